// True vehicle motion: a unicycle with a rate-limited, lagged yaw rate steering along the
// survey path by pure pursuit, at fixed depth with small roll, pitch and heave.
#pragma once

#include <vector>

#include "draco/sim/mission.hpp"

namespace draco::sim {

// True state at one time. Pose of "body" in "world" (x forward, y left, z up); velocities
// are over ground, expressed in the body frame (what a DVL measures).
struct TrajectorySample {
  double time_s = 0.0;
  double x_m = 0.0;
  double y_m = 0.0;
  double z_m = 0.0;
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;
  double yaw_rate_radps = 0.0;
  double vx_body_mps = 0.0;
  double vy_body_mps = 0.0;
  double vz_body_mps = 0.0;
  double distance_m = 0.0;  // path length travelled since the start
};

class Trajectory {
 public:
  Trajectory() = default;
  explicit Trajectory(std::vector<TrajectorySample> samples) : samples_(std::move(samples)) {}

  const std::vector<TrajectorySample>& samples() const { return samples_; }
  double StartTime() const { return samples_.empty() ? 0.0 : samples_.front().time_s; }
  double EndTime() const { return samples_.empty() ? 0.0 : samples_.back().time_s; }
  double Length() const { return samples_.empty() ? 0.0 : samples_.back().distance_m; }
  // Linear interpolation (yaw on the circle), clamped to the ends.
  TrajectorySample At(double time_s) const;

 private:
  std::vector<TrajectorySample> samples_;
};

// The dense path (0.25 m spacing) the vehicle follows: start point, then each pattern.
std::vector<Vec2> PatternPath(const RobotSpec& robot);

// Integrates the vehicle along its path until the path ends or duration_cap_s (> 0) passes.
Trajectory GenerateTrajectory(const RobotSpec& robot, const VehicleOptions& vehicle,
                              double duration_cap_s);

}  // namespace draco::sim
