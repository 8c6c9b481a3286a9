// A recorded mission (docs/recording-format.md) and a run's estimated trajectory as rawlog
// entries (rawlog.hpp): one robot's dead reckoning (navigation::DeadReckoner on its DVL and
// AHRS, one Odometry per DVL sample) and, per sonar ping, the first return per beam of its
// feature points (cfar::FeatureExtractor as config/graphs/local-slam.yaml sets it: 0.25 m
// voxel medoids, no radius filter) as a RangeScan over the ping's bearing span, mounted as
// mission.yaml's sonar mount; plus, when given, the estimated trajectory as PoseEstimates.
// Everything in time order.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "draco/rawlog/rawlog.hpp"

namespace draco::rawlog {

struct ExportStats {
  int odometry = 0;
  int scans = 0;
  int valid_beams = 0;  // over every scan
  int poses = 0;
};

// Throws what the mission reader throws (recording::RecordingError naming the file) for a
// missing or bad mission or an unknown robot.
std::vector<Entry> MissionEntries(const std::filesystem::path& mission_dir,
                                  const std::string& robot, ExportStats* stats = nullptr);

// A TUM trajectory (eval::ReadTum) as PoseEstimates; throws naming the file and line.
std::vector<Entry> TrajectoryEntries(const std::string& tum_path);

// Merges entry lists by time (stable: equal times keep list order, then the first list first).
std::vector<Entry> MergeByTime(std::vector<Entry> a, const std::vector<Entry>& b);

}  // namespace draco::rawlog
