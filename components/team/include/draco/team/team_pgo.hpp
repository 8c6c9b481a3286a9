// Inter-robot pose-graph optimisation for one robot of a team (paper Sec. III-F):
//
// Two-step PGO, for own robot a:
//  1. Local step: a's keyframe poses with a's own factors, plus one robust between factor per
//     inter-robot loop to the teammate keyframe it touches. Only the touched teammate poses are
//     variables (initialised through the map-to-map guess T_a_b); they are tied to nothing but
//     their loops. a's first pose is held at its input value (a's map frame is the gauge).
//  2. Global step, per teammate b with loops: a throw-away problem with b's whole trajectory
//     (initialised through T_a_b), b's chain as between factors (the reference's sigmas
//     0.1 m, 0.1 m, 0.01 rad by default) and a robust prior on each touched pose at its step-1
//     estimate (or, GlobalAnchor::kFirstLoop, b placed rigidly through its first loop;
//     GlobalAnchor::kRigid, b placed rigidly by the fit of all its touched poses).
//     a's poses are not variables here.
//  Teammates without loops are placed by their map-to-map guess alone.
//
// Full PGO (the baseline): every robot's graph and every loop solved jointly, initialised
// through the guesses, a's first pose held at its input value.
//
// Output: a's trajectory and each teammate's, all in a's map frame.
//
// Loops: a loop (own_robot o, own_keyframe i, teammate_robot t, teammate_keyframe k, T) is the
// between factor T_{o,i}_{t,k} = T with information = covariance^-1; the two-step uses the
// loops with a on either side (all of them are taken as accepted: pass the filter's output).
#pragma once

#include <map>
#include <vector>

#include "draco/msgs/loops.hpp"
#include "draco/pose_graph/pose_graph_2d.hpp"

namespace draco::team {

using pose_graph::Matrix3;
using pose_graph::Pose2;

// A factor of one robot's own graph between two of its keyframes (indices).
struct ChainFactor {
  int from = 0;
  int to = 0;
  Pose2 T_from_to;
  Matrix3 information = pose_graph::Diagonal3(1.0, 1.0, 1.0);
};

// One robot's optimised local SLAM: keyframe poses in its map frame, index = keyframe number,
// and its between factors (sequential / odometry and intra-robot loops).
struct RobotGraph {
  std::vector<Pose2> poses;
  std::vector<ChainFactor> factors;
};

// From a robot's PoseGraph2d: keyframe k is the k-th pose in insertion order (PoseIds());
// its between factors are kept, priors dropped.
RobotGraph FromPoseGraph(const pose_graph::PoseGraph2d& graph);

// A previous solve of one robot to start the next from (TwoStepPgo): its poses then (its own
// map frame, RobotGraph::poses) and the trajectory the solve gave them (the own map frame).
struct WarmStart {
  std::vector<Pose2> input;
  std::vector<Pose2> solution;
  std::map<int, Pose2> local;  // a teammate's keyframes in the local step then (its estimate)
};

struct TeamProblem {
  std::map<int, RobotGraph> robots;           // by robot id
  std::vector<msgs::InterRobotLoop> loops;    // accepted inter-robot loops, any direction
  std::map<std::pair<int, int>, Pose2> maps;  // {a, b} -> T_a_b map-to-map guess
  // Optional: initial values from a previous solve instead of the own poses and the map
  // guesses. Keyframe k starts at solution[k] (a teammate's local-step pose at local[k]) moved
  // as its input moved since (* Between(input[k], poses[k])); keyframes past the previous
  // solve follow the last one by their chain. The own keyframe 0 (the gauge) stays at its
  // pose. Fewer iterations when little changed; the same solution to the solver's tolerance
  // where the robust cost has one minimum, else possibly another (the one nearer the start).
  std::map<int, WarmStart> warm;
};

// T_a_b from the guesses: direct, inverted, or chained through other robots (breadth-first).
// Returns false when b is not connected to a.
bool MapGuess(const TeamProblem& problem, int a, int b, Pose2* T_a_b);

enum class GlobalAnchor {
  kTouchedPoses,  // a robust prior on every touched teammate pose at its step-1 estimate
  kFirstLoop,     // the reference's: the teammate placed through its first loop (rigidly)
  kRigid,         // the teammate placed rigidly by the least-squares fit of its touched poses
                  // to their step-1 estimates (its own trajectory is not deformed)
};

struct TwoStepOptions {
  pose_graph::RobustLoss loop_loss{pose_graph::LossKind::kCauchy, 1.0};
  // Loop information: from each loop's covariance (true) or the fixed loop sigmas below.
  bool loop_information_from_covariance = true;
  double loop_sigma_xy_m = 0.1;
  double loop_sigma_yaw_rad = 0.01;
  // Global step: teammate chain information (the reference's sigmas) or the teammate's own.
  bool teammate_chain_from_factors = false;
  double chain_sigma_xy_m = 0.1;
  double chain_sigma_yaw_rad = 0.01;
  GlobalAnchor anchor = GlobalAnchor::kTouchedPoses;
  double anchor_sigma_xy_m = 0.1;
  double anchor_sigma_yaw_rad = 0.01;
  pose_graph::RobustLoss anchor_loss{pose_graph::LossKind::kCauchy, 1.0};
  pose_graph::SolverOptions solver{};
};

struct FullOptions {
  pose_graph::RobustLoss loop_loss{pose_graph::LossKind::kCauchy, 1.0};
  bool loop_information_from_covariance = true;
  double loop_sigma_xy_m = 0.1;
  double loop_sigma_yaw_rad = 0.01;
  pose_graph::SolverOptions solver{};
};

struct TeamEstimate {
  int own_robot = 0;
  std::map<int, std::vector<Pose2>> trajectories;  // by robot id, in own_robot's map frame
  // Two-step: the local step, and one global step per teammate with loops. Full: `local` is
  // the joint solve, `global` empty.
  pose_graph::SolveSummary local;
  std::map<int, pose_graph::SolveSummary> global;
  int touched_teammate_poses = 0;  // two-step: teammate variables of the local step
  // Two-step: the local step's estimate of those poses, by teammate and keyframe.
  std::map<int, std::map<int, Pose2>> local_teammate_poses;
  int loops_used = 0;
  double local_time_s = 0.0;   // building + solving
  double global_time_s = 0.0;  // all teammates
};

// Throws std::invalid_argument when own_robot is missing, a loop names a missing robot or
// keyframe, or a teammate has no map guess to own_robot.
TeamEstimate TwoStepPgo(const TeamProblem& problem, int own_robot,
                        const TwoStepOptions& options = {});
TeamEstimate FullPgo(const TeamProblem& problem, int own_robot, const FullOptions& options = {});

}  // namespace draco::team
