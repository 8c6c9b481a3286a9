// Runs one robot of a mission: true trajectory, sonar pings and navigation sensors, emitted
// in time order to a sink (the app writes them with the recording library).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <vector>

#include "draco/msgs/sensors.hpp"
#include "draco/sim/mission.hpp"
#include "draco/sim/random.hpp"
#include "draco/sim/sonar_model.hpp"
#include "draco/sim/trajectory.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim {

class RobotSink {
 public:
  virtual ~RobotSink() = default;
  virtual void OnPing(const msgs::SonarPing& ping, const TrajectorySample& truth) = 0;
  virtual void OnDvl(const msgs::DvlVelocity& dvl) = 0;
  virtual void OnAhrs(const msgs::Ahrs& ahrs) = 0;
  virtual void OnDepth(const msgs::Depth& depth) = 0;
  virtual void OnGroundTruth(const msgs::GroundTruthPose& pose) = 0;
};

// Pose of the sonar head for a body pose (mount: tilt down by tilt_rad, at the body origin).
SonarPose SonarPoseAt(const TrajectorySample& body, double tilt_rad);

// Navigation sensor models with per-run errors (DVL scale and misalignment, AHRS yaw drift).
class NavigationSensors {
 public:
  NavigationSensors(const NavigationOptions& options, const World& world, std::uint64_t seed);

  msgs::DvlVelocity Dvl(const TrajectorySample& truth);
  // Advances the yaw drift to truth.time_s (call in time order).
  msgs::Ahrs Ahrs(const TrajectorySample& truth);
  msgs::Depth Depth(const TrajectorySample& truth);

  double dvl_scale() const { return dvl_scale_; }
  double dvl_misalignment_rad() const { return dvl_misalignment_rad_; }
  double yaw_drift_rad() const { return yaw_drift_rad_; }
  // Magnetic heading anomaly at a position (sum over steel objects).
  double HeadingAnomaly(double x_m, double y_m) const;

 private:
  NavigationOptions options_;
  const World& world_;
  Rng rng_;
  struct Anomaly {
    double x_m, y_m, amplitude_rad;
  };
  std::vector<Anomaly> anomalies_;
  double dvl_scale_ = 1.0;
  double dvl_misalignment_rad_ = 0.0;
  double yaw_drift_rad_ = 0.0;
  double drift_time_s_ = -1.0;
};

struct RobotRunStats {
  std::uint64_t pings = 0;
  double distance_m = 0.0;
  double duration_s = 0.0;
};

// Progress: robot's pings done so far (written by the simulator, read by any thread).
struct RobotProgress {
  std::atomic<std::uint64_t> pings_done{0};
  std::atomic<std::uint64_t> pings_total{0};
  std::atomic<double> mission_time_s{0.0};
};

// Simulates robot `robot_index` of the mission. Streams are emitted in time order (ties:
// AHRS, DVL, depth, sonar, ground truth). Ground truth comes at ground_truth_rate_hz and at
// every ping time. Deterministic in (mission.seed, robot_index). With sonar == nullptr no
// pings are rendered (navigation and ground truth only, fast; the same navigation and ground
// truth as with pings). An exception thrown by the sink leaves the simulation.
RobotRunStats SimulateRobot(const World& world, const Mission& mission, int robot_index,
                            const SonarModel* sonar, RobotSink& sink,
                            RobotProgress* progress = nullptr);

// Time of the robot's last AHRS sample (the last record SimulateRobot emits on that stream;
// a recording's replay length, recording::RobotReplayLengthS). Generates the trajectory only.
double LastAhrsTimeS(const Mission& mission, int robot_index);

// The reference dead reckoning (DVL + AHRS yaw relative to its first reading, trapezoidal
// velocity at the DVL rate), in the robot's start frame.
class DeadReckoning {
 public:
  void AddAhrs(const msgs::Ahrs& ahrs);
  void AddDvl(const msgs::DvlVelocity& dvl);
  double x_m() const { return x_; }
  double y_m() const { return y_; }
  double yaw_rad() const { return yaw_; }
  double max_speed_mps = 0.9;  // faster readings hold the last good velocity

 private:
  bool have_yaw0_ = false;
  double yaw0_ = 0.0;
  double yaw_ = 0.0;
  bool have_prev_ = false;
  double prev_t_ = 0.0;
  double prev_vx_ = 0.0;
  double prev_vy_ = 0.0;
  double x_ = 0.0;
  double y_ = 0.0;
};

}  // namespace draco::sim
