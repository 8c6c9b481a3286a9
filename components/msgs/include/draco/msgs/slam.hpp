// Local-SLAM messages: sonar feature points, dead-reckoning state, keyframes and
// scan-matching factors. Plain structs (no Eigen fixed-size members: they cross threads
// inside shared_ptr<const T>), SI units in names, times in mission seconds.
//
// Frames: "sensor" is the sonar (x forward, y left), "body" the vehicle, "odom" the
// dead-reckoning frame (the body pose at the first DVL sample, yaw from the AHRS).
// T_a_b maps coordinates in frame b to frame a (p_a = T_a_b * p_b).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

namespace draco::msgs {

// A heading nobody knows (msgs::ObjectMap::map_heading_rad and its sources).
inline constexpr double kUnknownHeading = std::numeric_limits<double>::quiet_NaN();

struct Point2 {
  double x_m = 0.0;
  double y_m = 0.0;
};

// Planar rigid transform (x, y, yaw).
struct Pose2 {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

// 3x3 covariance of (x_m, y_m, yaw_rad), row-major.
using Covariance3 = std::array<double, 9>;

// Feature points extracted from one sonar ping (CFAR, downsampled, outliers removed).
struct SonarFeatures {
  double time_s = 0.0;  // the ping's time
  std::uint32_t ping_id = 0;
  std::vector<Point2> points_sensor;
  int num_detections = 0;  // CFAR detections before downsampling and filtering
};

// Dead reckoning at one DVL sample: the pose in the odometry frame, and the increment
// since the previous sample (in the previous body frame) with its covariance.
struct DeadReckoning {
  double time_s = 0.0;
  Pose2 T_odom_body;
  double depth_m = 0.0;  // 0 until a depth reading arrives
  Pose2 T_prev_body;     // increment since the previous message (identity for the first)
  Covariance3 covariance_prev_body{};
  std::array<double, 2> velocity_body_mps{0.0, 0.0};  // velocity used for this step
  bool dvl_ok = true;  // false while velocity is held or decayed (dropout or spike)
  // Absolute heading of the odom frame's x axis (the AHRS reading taken as odom yaw 0); NaN
  // when the AHRS has no absolute reference.
  double odom_heading_rad = kUnknownHeading;
};

// A keyframe: the feature points of one ping with the dead-reckoning pose at the ping time
// and the dead-reckoning increment from the previous keyframe.
struct Keyframe {
  int index = 0;  // 0, 1, 2, ... per robot
  double time_s = 0.0;
  Pose2 T_odom_body;  // dead reckoning, interpolated to time_s
  double depth_m = 0.0;
  std::vector<Point2> points_body;  // feature points in the body frame
  Pose2 T_prevkf_kf;                // dead-reckoning increment (identity for index 0)
  Covariance3 covariance_prevkf_kf{};
  double odom_heading_rad = kUnknownHeading;  // msgs::DeadReckoning::odom_heading_rad
};

// A relative-pose factor between two keyframes from sequential scan matching (or dead
// reckoning when scan matching fails or is rejected).
struct SequentialFactor {
  int from_index = 0;
  int to_index = 0;
  double time_s = 0.0;  // time of the `to` keyframe
  Pose2 T_from_to;
  Covariance3 covariance{};
  bool scan_matched = false;   // false: the dead-reckoning increment
  double overlap_ratio = 0.0;  // of the accepted scan match
  int iterations = 0;
};

}  // namespace draco::msgs
