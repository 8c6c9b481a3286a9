// MRPT rawlogs: draco data as the files MRPT's RawLogViewer and its SLAM apps (icp-slam,
// rbpf-slam) open. The "observations only" rawlog format: a gzip-compressed sequence of
// serialized MRPT observations, in time order:
//   Odometry     -> mrpt::obs::CObservationOdometry (label "ODOMETRY"): dead reckoning's
//                   T_odom_body as a 2D pose.
//   RangeScan    -> mrpt::obs::CObservation2DRangeScan (label "SONAR"): the sonar's first
//                   return per beam, as a planar range finder (the type MRPT's scan-matching
//                   SLAM and grid mapping consume; a forward-looking sonar's beams are evenly
//                   spaced over its aperture as a laser's rays).
//   PoseEstimate -> mrpt::obs::CObservationRobotPose (label "ESTIMATE"): a run's estimated
//                   trajectory (x, y, yaw; no covariance).
// Timestamps are the mission seconds as MRPT time (seconds since 1970-01-01). MRPT is used in
// src/rawlog.cpp only; this header is plain C++.
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::rawlog {

struct Odometry {
  double time_s = 0.0;
  msgs::Pose2 T_odom_body;
};

// Beams evenly spaced over aperture_rad, counter-clockwise from -aperture_rad / 2 (MRPT's
// rightToLeft): beam i at -aperture_rad / 2 + i * aperture_rad / (n - 1) in the sensor frame.
struct RangeScan {
  double time_s = 0.0;
  msgs::Pose2 T_body_sensor;
  double aperture_rad = 0.0;
  double max_range_m = 0.0;
  std::vector<float> ranges_m;
  std::vector<char> valid;  // 0: no return on that beam
};

struct PoseEstimate {
  double time_s = 0.0;
  msgs::Pose2 T_map_body;
};

using Entry = std::variant<Odometry, RangeScan, PoseEstimate>;
double EntryTime(const Entry& entry);

// The first return per beam of sonar points in the sensor frame (the features of a ping):
// each point goes to the beam nearest its bearing; points outside the aperture or beyond
// max_range_m are dropped. Throws std::invalid_argument when beams < 2 or the aperture or
// range is not positive.
RangeScan ScanFromPoints(double time_s, const std::vector<msgs::Point2>& points_sensor, int beams,
                         double aperture_rad, double max_range_m);
// The returns of the valid beams as points in the sensor frame.
std::vector<msgs::Point2> ScanPoints(const RangeScan& scan);

// Writes the entries (in the order given) as a gzip-compressed observations-only rawlog.
// Throws std::runtime_error naming the file when it cannot be written, std::invalid_argument
// when a scan's ranges and valid flags differ in size.
void WriteRawlog(const std::string& path, const std::vector<Entry>& entries);

struct ReadStats {
  int skipped = 0;  // observations of other types (images, IMU, ...), not returned
};
// Reads a rawlog in either MRPT format (observations only, or action / sensory-frame pairs,
// gzip or not): odometry (CObservationOdometry, and CActionRobotMovement2D in the pair
// format, accumulated), 2D range scans and robot poses, in file order. Throws
// std::runtime_error naming the file when it is missing or not a rawlog.
std::vector<Entry> ReadRawlog(const std::string& path, ReadStats* stats = nullptr);

}  // namespace draco::rawlog
