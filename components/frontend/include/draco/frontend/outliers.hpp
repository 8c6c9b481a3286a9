// Wrong inter-robot loop closures injected into a real candidate stream (issue 6's
// robustness test). Every wrong loop is a copy of a real candidate (same keyframes,
// covariance and overlap, so it looks like what registration emits) with a wrong relative
// pose:
//   kRandom      each loop on its own: translated 2-10 m in a random direction, turned by up
//                to +-30 deg;
//   kCorrelated  groups of `group_size` loops of one teammate over consecutive own
//                keyframes share one offset of `offset_m` in the own map frame (one pile-bent
//                spacing by default: the aliasing a row of pier pilings causes); the
//                direction is uniform (`directions` 0) or one of `directions` evenly spaced
//                ones (4: +-x, +-y, groups with equal offsets then agree with each other).
// Deterministic for a seed.
#pragma once

#include <cstdint>
#include <vector>

#include "draco/msgs/loops.hpp"

namespace draco::frontend {

enum class OutlierKind { kRandom, kCorrelated };

struct OutlierOptions {
  OutlierKind kind = OutlierKind::kRandom;
  double fraction = 0.3;  // wrong / (wrong + real candidates), in [0, 1)
  int group_size = 6;
  double offset_m = 2.4;  // the marina's pile-bent spacing
  int directions = 0;
  double random_min_m = 2.0;
  double random_max_m = 10.0;
  double random_max_yaw_rad = 0.5236;
  std::uint64_t seed = 1;
};

// Returns the wrong loops (ids first_id, first_id + 1, ...) for `candidates` (one own
// robot's). own_poses[k]: T_ownmap_ownkf of own keyframe index k (for the map-frame offset).
// Throws std::invalid_argument on a fraction outside [0, 1) or a candidate whose own
// keyframe has no pose.
std::vector<msgs::InterRobotLoop> InjectOutliers(
    const std::vector<msgs::InterRobotLoop>& candidates, const std::vector<msgs::Pose2>& own_poses,
    const OutlierOptions& options, std::uint64_t first_id);

}  // namespace draco::frontend
