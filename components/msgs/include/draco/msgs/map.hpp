// A robot's optimised keyframe trajectory, as published after every local-SLAM update.
#pragma once

#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::msgs {

struct KeyframePose {
  int index = 0;
  double time_s = 0.0;
  Pose2 T_map_kf;
};

// A point landmark of the local SLAM (components/slam): an object centre in the map frame.
struct LandmarkEstimate {
  int id = 0;
  Point2 p_map;
  double radius_m = 0.0;
  std::vector<int> keyframes;  // that saw it, ascending
};

inline bool operator==(const LandmarkEstimate& a, const LandmarkEstimate& b) {
  return a.id == b.id && a.p_map.x_m == b.p_map.x_m && a.p_map.y_m == b.p_map.y_m &&
         a.radius_m == b.radius_m && a.keyframes == b.keyframes;
}

struct KeyframeTrajectory {
  double time_s = 0.0;  // time of the newest keyframe
  std::vector<KeyframePose> keyframes;
  int loops_accepted = 0;                   // intra-robot loop closures in the graph so far
  std::vector<LandmarkEstimate> landmarks;  // empty when the local SLAM has none
};

}  // namespace draco::msgs
