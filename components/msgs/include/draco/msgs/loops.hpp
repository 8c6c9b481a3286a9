// Inter-robot loop closures: a registration between one of the own robot's keyframes and
// one of a teammate's, as proposed by inter-robot registration and judged by the
// consistency filter (PCM / GCM). Plain structs (no Eigen fixed-size members).
//
// T_ownkf_teammatekf is the teammate keyframe's pose in the own keyframe's body frame
// (p_ownkf = T * p_teammatekf); its covariance is of (x_m, y_m, yaw_rad) as additive
// perturbations of the three parameters, row-major.
#pragma once

#include <cstdint>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::msgs {

// Bits of InterRobotLoop::flags.
enum LoopFlags : std::uint32_t {
  kLoopAccepted = 1u << 0,  // passed the consistency filter
  kLoopRejected = 1u << 1,  // judged and not accepted
  kLoopInjected = 1u << 2,  // synthetic (tests, robustness experiments)
};

struct InterRobotLoop {
  std::uint64_t id = 0;  // unique per own robot (the sender's running count)
  int own_robot = 0;
  int own_keyframe = 0;
  int teammate_robot = 0;
  int teammate_keyframe = 0;
  Pose2 T_ownkf_teammatekf;
  Covariance3 covariance{};
  double overlap = 0.0;  // registration overlap ratio in [0, 1]
  std::uint32_t flags = 0;
};

struct InterRobotLoops {
  double time_s = 0.0;
  std::vector<InterRobotLoop> loops;
};

}  // namespace draco::msgs
