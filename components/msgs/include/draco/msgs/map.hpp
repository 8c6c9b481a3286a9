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

struct KeyframeTrajectory {
  double time_s = 0.0;  // time of the newest keyframe
  std::vector<KeyframePose> keyframes;
  int loops_accepted = 0;  // intra-robot loop closures in the graph so far
};

}  // namespace draco::msgs
