// Forward-looking sonar image formation (docs/simulator.md, "Sonar model").
//
// Per ping: first-hit ray casting with elevation rays over the vertical aperture (shadows
// for free), energy mu * cos^2(incidence) * vertical pattern * two-way absorption, seabed
// backscatter splatted over each elevation ray's range footprint, streaks, surface
// multipath ghosts, Gaussian beam/range blur, Gamma(L) speckle, a range-dependent noise
// floor and near-field clutter; output u8 = 255 * sqrt(clamp(gain * E)).
#pragma once

#include <cstdint>
#include <vector>

#include "draco/msgs/sensors.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim {

struct SonarOptions {
  int num_beams = 512;
  int num_ranges = 512;
  double range_max_m = 30.0;
  double horizontal_aperture_rad = 130.0 * M_PI / 180.0;
  double vertical_aperture_rad = 20.0 * M_PI / 180.0;
  double rate_hz = 5.0;
  // Oculus bearing tables are not uniform: bearing = a * (u + k u^3), u in [-1, 1].
  double bearing_nonuniformity = 0.08;
  int elevation_rays = 24;           // per beam; jittered within equal slices
  double absorption_db_per_m = 0.1;  // one way; applied twice
  double beam_blur_fwhm_rad = 1.0 * M_PI / 180.0;
  double range_blur_sigma_bins = 0.8;
  double range_jitter_sigma_m = 0.02;  // per object hit
  double speckle_looks = 2.0;          // L of Gamma(L, 1/L)
  double noise_sigma = 0.04;           // Rayleigh amplitude at max range, scaled (r/r_max)^2
  double noise_floor_sigma = 0.018;    // Rayleigh amplitude everywhere
  double near_field_amplitude = 0.25;  // A * exp(-r / near_field_length_m)
  double near_field_length_m = 0.5;
  double streak_fraction = 0.08;  // fraction of beams with near-normal hits in a row
  double streak_level = 0.04;     // added across the row, times the row maximum
  double ghost_amplitude = 0.15;  // surface multipath ghost, 0 disables
  double gain = 20.0;             // g in u8 = 255 * sqrt(clamp(g * E))
  double object_gain = 1.5;       // energy scale of object hits (all elevation rays)
  double seabed_gain = 0.8;  // seabed resolution-cell area factor on mu      // energy scale of one
                             // object hit per elevation ray
};

// Pose of the sonar head in the world (z up). Positive tilt points the sonar down.
struct SonarPose {
  double x_m = 0.0;
  double y_m = 0.0;
  double z_m = 0.0;
  double yaw_rad = 0.0;
  double tilt_rad = 0.0;
};

// Optional per-pixel truth the tests use: which cells an object (not the seabed) lit.
struct SonarTruth {
  std::vector<std::uint8_t> object_mask;  // num_ranges * num_beams, 1 where objects hit
  std::vector<float> object_energy;       // geometric energy from objects before noise
  std::vector<float> seabed_energy;       // geometric energy from the seabed before noise
};

class SonarModel {
 public:
  SonarModel(const World& world, const SonarOptions& options);

  const SonarOptions& options() const { return options_; }
  const std::vector<float>& bearings_rad() const { return bearings_rad_; }
  double range_resolution_m() const { return options_.range_max_m / options_.num_ranges; }

  // One ping. Deterministic in (pose, seed). Thread-safe (const, scratch is local).
  msgs::SonarPing Render(const SonarPose& pose, double time_s, std::uint32_t ping_id,
                         std::uint64_t seed, SonarTruth* truth = nullptr) const;

 private:
  const World& world_;
  SonarOptions options_;
  std::vector<float> bearings_rad_;
  std::vector<float> speckle_table_;         // Gamma(L, 1/L) samples
  std::vector<float> exp_table_;             // Exponential(1) samples
  std::vector<std::uint8_t> amplitude_lut_;  // intensity -> u8
};

}  // namespace draco::sim
