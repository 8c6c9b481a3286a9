// Rawlog entries (rawlog.hpp) as the messages the local-SLAM graph consumes, so a rawlog of
// odometry and 2D range scans (MRPT's or draco's own) feeds slam.KeyframeSelector directly:
//   Odometry  -> msgs::DeadReckoning: the pose, the increment since the previous odometry
//                (identity for the first) and its covariance as navigation::DeadReckoner
//                models it (isotropic velocity noise over the interval, a yaw random walk);
//   RangeScan -> msgs::SonarFeatures: the returns of its valid beams in the sensor frame.
// PoseEstimates are not messages of the local-SLAM graph and are left out.
#pragma once

#include <variant>
#include <vector>

#include "draco/msgs/slam.hpp"
#include "draco/rawlog/rawlog.hpp"

namespace draco::rawlog {

struct ImportOptions {
  double velocity_sigma_mps = 0.02;                // DeadReckoningOptions' default
  double yaw_random_walk_rad_per_sqrt_s = 0.0035;  // idem
};

using Message = std::variant<msgs::DeadReckoning, msgs::SonarFeatures>;
double MessageTime(const Message& message);

// In entry order; scans numbered 0, 1, ... as ping ids.
std::vector<Message> ToMessages(const std::vector<Entry>& entries,
                                const ImportOptions& options = {});

}  // namespace draco::rawlog
