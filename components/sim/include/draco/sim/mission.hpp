// A simulated mission: world, robots with survey patterns, sensor and vehicle options.
// Missions are YAML files (config/missions/*.yaml, format in docs/simulator.md).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "draco/sim/geometry.hpp"
#include "draco/sim/sonar_model.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim {

// One survey leg. The vehicle steers along the leg's path (pure pursuit), so corners are
// rounded and the motion is smooth.
struct PatternSpec {
  enum class Type { kWaypoints, kLoop, kLawnmower, kFigureEight, kOrbit };
  Type type = Type::kWaypoints;
  std::vector<Vec2> waypoints_m;  // waypoints, loop (closed, repeated `laps` times)
  int laps = 1;                   // loop, figure_eight, orbit
  // lawnmower: lanes of lane_length_m along heading_rad, lane_spacing_m apart, starting at
  // origin_m and stepping to the left of the heading.
  Vec2 origin_m;
  double heading_rad = 0.0;
  double lane_length_m = 40.0;
  double lane_spacing_m = 10.0;
  int lanes = 4;
  // figure_eight (two lobes of radius_m either side of center_m along heading_rad) and orbit
  // (circle of radius_m around center_m).
  Vec2 center_m;
  double radius_m = 10.0;
  bool clockwise = false;  // orbit
};

struct RobotSpec {
  std::string name;
  Vec2 start_m;
  double start_yaw_rad = 0.0;
  double depth_m = 1.0;
  double speed_mps = 0.35;
  double start_time_s = 0.0;
  std::vector<PatternSpec> patterns;
};

struct VehicleOptions {
  double lookahead_m = 3.0;
  double max_yaw_rate_radps = 0.15;
  double heading_gain_per_s = 0.6;
  double yaw_rate_lag_s = 1.0;
  double accel_mps2 = 0.05;
  double roll_amplitude_rad = 1.0 * M_PI / 180.0;
  double pitch_amplitude_rad = 0.8 * M_PI / 180.0;
  double heave_amplitude_m = 0.05;
  Vec2 current_mps;  // water current over ground, world frame
  double sample_dt_s = 0.01;
};

struct DvlOptions {
  double rate_hz = 5.0;
  double noise_sigma_mps = 0.02;
  double scale_sigma = 0.005;  // per-run scale factor N(1, sigma)
  double misalignment_sigma_rad = 0.5 * M_PI / 180.0;
  double dropout_probability = 0.01;
  double max_altitude_m = 10.0;
  double altitude_noise_sigma_m = 0.05;
};

struct AhrsOptions {
  double rate_hz = 100.0;
  double yaw_drift_sigma_rad = 3.0 * M_PI / 180.0;  // Gauss-Markov, stationary sigma
  double yaw_drift_tau_s = 120.0;
  double yaw_noise_sigma_rad = 0.2 * M_PI / 180.0;
  double roll_pitch_noise_sigma_rad = 0.5 * M_PI / 180.0;
  double yaw_rate_noise_sigma_radps = 0.002;
  // Local magnetic heading anomaly near steel objects: +-amplitude (sign per object) with a
  // Gaussian fall-off of the given length.
  double steel_anomaly_rad = 5.0 * M_PI / 180.0;
  double steel_anomaly_length_m = 8.0;
};

struct DepthOptions {
  double rate_hz = 5.0;
  double noise_sigma_m = 0.02;
};

struct NavigationOptions {
  DvlOptions dvl;
  AhrsOptions ahrs;
  DepthOptions depth;
  double ground_truth_rate_hz = 20.0;
};

struct Mission {
  std::string name;
  std::string source;                // file it was loaded from
  std::filesystem::path world_path;  // resolved against the mission file's folder
  std::uint64_t seed = 1;
  double duration_s = 0.0;  // cap per robot; 0 = until its patterns end
  SonarOptions sonar;
  double sonar_tilt_rad = 10.0 * M_PI / 180.0;  // mount pitch, positive down
  NavigationOptions navigation;
  VehicleOptions vehicle;
  std::vector<RobotSpec> robots;
};

// Throws ConfigError naming file, line and what was expected.
Mission LoadMission(const std::filesystem::path& path);
Mission ParseMission(const std::string& yaml_text, const std::string& source_name,
                     const std::filesystem::path& base_dir);

}  // namespace draco::sim
