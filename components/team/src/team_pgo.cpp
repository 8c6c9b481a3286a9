#include "draco/team/team_pgo.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>

#include "draco/msgs/rigid_fit.hpp"

namespace draco::team {
namespace {

using pose_graph::Between;
using pose_graph::Compose;
using pose_graph::FactorKind;
using pose_graph::InformationFromSigmas;
using pose_graph::Inverse;
using pose_graph::PoseGraph2d;
using pose_graph::PoseId;

PoseId Id(int robot, int keyframe) {
  return (static_cast<PoseId>(robot) << 32) |
         static_cast<PoseId>(static_cast<std::uint32_t>(keyframe));
}

double Seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Pose2 ToPose(const msgs::Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }

// Inverse of a symmetric positive definite 3x3 covariance.
Matrix3 InverseCovariance(const msgs::Covariance3& c) {
  const double a = c[0], b = c[1], d = c[2], e = c[4], f = c[5], i = c[8];
  const double c00 = e * i - f * f, c01 = -(b * i - d * f), c02 = b * f - d * e;
  const double det = a * c00 + b * c01 + d * c02;
  if (!(det > 0.0) || !std::isfinite(det)) {
    throw std::invalid_argument("team: a loop covariance is not positive definite");
  }
  const double c11 = a * i - d * d, c12 = -(a * f - d * b), c22 = a * e - b * b;
  return {c00 / det, c01 / det, c02 / det, c01 / det, c11 / det,
          c12 / det, c02 / det, c12 / det, c22 / det};
}

Matrix3 LoopInformation(const msgs::InterRobotLoop& loop, bool from_covariance, double sigma_xy,
                        double sigma_yaw) {
  if (from_covariance) return InverseCovariance(loop.covariance);
  return InformationFromSigmas(sigma_xy, sigma_xy, sigma_yaw);
}

const RobotGraph& Robot(const TeamProblem& problem, int robot) {
  const auto it = problem.robots.find(robot);
  if (it == problem.robots.end()) {
    throw std::invalid_argument("team: robot " + std::to_string(robot) + " is not in the problem");
  }
  return it->second;
}

void CheckKeyframe(const RobotGraph& graph, int robot, int keyframe) {
  if (keyframe < 0 || keyframe >= static_cast<int>(graph.poses.size())) {
    throw std::invalid_argument("team: robot " + std::to_string(robot) + " has no keyframe " +
                                std::to_string(keyframe));
  }
}

void CheckLoop(const TeamProblem& problem, const msgs::InterRobotLoop& loop) {
  CheckKeyframe(Robot(problem, loop.own_robot), loop.own_robot, loop.own_keyframe);
  CheckKeyframe(Robot(problem, loop.teammate_robot), loop.teammate_robot, loop.teammate_keyframe);
}

Pose2 RequireGuess(const TeamProblem& problem, int a, int b) {
  Pose2 T_a_b;
  if (!MapGuess(problem, a, b, &T_a_b)) {
    throw std::invalid_argument("team: no map guess from robot " + std::to_string(a) +
                                " to robot " + std::to_string(b));
  }
  return T_a_b;
}

// Where keyframe k of a robot starts: from the problem's warm start when it has one for the
// robot, else at T_own_robot * poses[k].
Pose2 Initial(const TeamProblem& problem, int robot, const RobotGraph& rg, std::size_t k,
              const Pose2& T_own_robot) {
  const auto it = problem.warm.find(robot);
  if (it != problem.warm.end()) {
    const WarmStart& w = it->second;
    const std::size_t m = std::min(w.input.size(), w.solution.size());
    if (m > 0) {
      if (k < m) return Compose(w.solution[k], Between(w.input[k], rg.poses[k]));
      return Compose(Compose(w.solution[m - 1], Between(w.input[m - 1], rg.poses[m - 1])),
                     Between(rg.poses[m - 1], rg.poses[k]));
    }
  }
  return Compose(T_own_robot, rg.poses[k]);
}

void AddRobot(PoseGraph2d& graph, const TeamProblem& problem, int robot, const RobotGraph& rg,
              const Pose2& T_own_robot) {
  for (std::size_t k = 0; k < rg.poses.size(); ++k) {
    graph.AddPose(Id(robot, static_cast<int>(k)), Initial(problem, robot, rg, k, T_own_robot));
  }
  for (const ChainFactor& f : rg.factors) {
    graph.AddBetween(Id(robot, f.from), Id(robot, f.to), f.T_from_to, f.information,
                     FactorKind::kOdometry);
  }
}

// Rigid SE(2) transform T with T * source[k] ~ target[k] (positions, least squares); a single
// pair gives the full pose alignment.
Pose2 FitRigid(const std::vector<Pose2>& source, const std::vector<Pose2>& target) {
  if (source.size() >= 2) {
    if (const auto T = msgs::FitRigid2d(source, target)) return {T->x_m, T->y_m, T->yaw_rad};
  }
  return Compose(target[0], Inverse(source[0]));  // one pair: the full pose alignment
}

}  // namespace

RobotGraph FromPoseGraph(const PoseGraph2d& graph) {
  RobotGraph out;
  std::map<PoseId, int> index;
  for (const PoseId id : graph.PoseIds()) {
    index[id] = static_cast<int>(out.poses.size());
    out.poses.push_back(graph.Pose(id));
  }
  for (const pose_graph::Factor& f : graph.Factors()) {
    if (f.kind == FactorKind::kPrior) continue;
    out.factors.push_back({index.at(f.i), index.at(f.j), f.measurement, f.information});
  }
  return out;
}

bool MapGuess(const TeamProblem& problem, int a, int b, Pose2* T_a_b) {
  if (a == b) {
    *T_a_b = {};
    return true;
  }
  std::map<int, std::vector<std::pair<int, Pose2>>> edges;
  for (const auto& [pair, T] : problem.maps) {
    edges[pair.first].push_back({pair.second, T});
    edges[pair.second].push_back({pair.first, Inverse(T)});
  }
  std::map<int, Pose2> reached{{a, Pose2{}}};
  std::deque<int> queue{a};
  while (!queue.empty()) {
    const int r = queue.front();
    queue.pop_front();
    for (const auto& [next, T_r_next] : edges[r]) {
      if (reached.contains(next)) continue;
      reached[next] = Compose(reached[r], T_r_next);
      if (next == b) {
        *T_a_b = reached[next];
        return true;
      }
      queue.push_back(next);
    }
  }
  return false;
}

TeamEstimate TwoStepPgo(const TeamProblem& problem, int own_robot, const TwoStepOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const RobotGraph& own = Robot(problem, own_robot);
  TeamEstimate est;
  est.own_robot = own_robot;

  // Step 1: own graph + robust loops to the touched teammate poses.
  PoseGraph2d local;
  AddRobot(local, problem, own_robot, own, Pose2{});
  if (!own.poses.empty()) {
    local.SetPose(Id(own_robot, 0), own.poses[0]);  // the gauge, whatever the warm start
    local.SetPoseConstant(Id(own_robot, 0));
  }
  std::map<int, Pose2> guesses;          // teammate -> T_own_teammate
  std::map<int, std::set<int>> touched;  // teammate -> keyframes
  std::map<int, const msgs::InterRobotLoop*> first_loop;
  for (const msgs::InterRobotLoop& loop : problem.loops) {
    if ((loop.own_robot == own_robot) == (loop.teammate_robot == own_robot)) continue;
    CheckLoop(problem, loop);
    const bool forward = loop.own_robot == own_robot;
    const int mate = forward ? loop.teammate_robot : loop.own_robot;
    const int mate_kf = forward ? loop.teammate_keyframe : loop.own_keyframe;
    if (!guesses.contains(mate)) guesses[mate] = RequireGuess(problem, own_robot, mate);
    const PoseId mate_id = Id(mate, mate_kf);
    if (!local.HasPose(mate_id)) {
      const RobotGraph& mate_graph = Robot(problem, mate);
      Pose2 initial =
          Initial(problem, mate, mate_graph, static_cast<std::size_t>(mate_kf), guesses[mate]);
      if (const auto w = problem.warm.find(mate); w != problem.warm.end()) {
        const auto it = w->second.local.find(mate_kf);
        if (it != w->second.local.end() && mate_kf < static_cast<int>(w->second.input.size())) {
          initial =
              Compose(it->second, Between(w->second.input[static_cast<std::size_t>(mate_kf)],
                                          mate_graph.poses[static_cast<std::size_t>(mate_kf)]));
        }
      }
      local.AddPose(mate_id, initial);
      touched[mate].insert(mate_kf);
    }
    first_loop.try_emplace(mate, &loop);
    local.AddBetween(Id(loop.own_robot, loop.own_keyframe),
                     Id(loop.teammate_robot, loop.teammate_keyframe),
                     ToPose(loop.T_ownkf_teammatekf),
                     LoopInformation(loop, options.loop_information_from_covariance,
                                     options.loop_sigma_xy_m, options.loop_sigma_yaw_rad),
                     FactorKind::kInterRobot, options.loop_loss);
    ++est.loops_used;
  }
  for (const auto& [mate, kfs] : touched)
    est.touched_teammate_poses += static_cast<int>(kfs.size());
  est.local = local.Optimize(options.solver);
  for (const auto& [mate, kfs] : touched) {
    auto& poses = est.local_teammate_poses[mate];
    for (const int kf : kfs) poses[kf] = local.Pose(Id(mate, kf));
  }
  auto& own_traj = est.trajectories[own_robot];
  for (std::size_t k = 0; k < own.poses.size(); ++k) {
    own_traj.push_back(local.Pose(Id(own_robot, static_cast<int>(k))));
  }
  est.local_time_s = Seconds(start);

  // Step 2: each teammate's trajectory from the poses it shared.
  const auto global_start = std::chrono::steady_clock::now();
  for (const auto& [robot, rg] : problem.robots) {
    if (robot == own_robot) continue;
    auto& traj = est.trajectories[robot];
    if (!touched.contains(robot)) {
      Pose2 T_own_robot;
      if (!MapGuess(problem, own_robot, robot, &T_own_robot)) {
        est.trajectories.erase(robot);
        continue;
      }
      for (const Pose2& p : rg.poses) traj.push_back(Compose(T_own_robot, p));
      continue;
    }
    if (options.anchor == GlobalAnchor::kFirstLoop) {
      const msgs::InterRobotLoop& loop = *first_loop.at(robot);
      const bool forward = loop.own_robot == own_robot;
      const Pose2 T_ownkf_matekf =
          forward ? ToPose(loop.T_ownkf_teammatekf) : Inverse(ToPose(loop.T_ownkf_teammatekf));
      const int own_kf = forward ? loop.own_keyframe : loop.teammate_keyframe;
      const int mate_kf = forward ? loop.teammate_keyframe : loop.own_keyframe;
      const Pose2 T_own_matekf =
          Compose(own_traj[static_cast<std::size_t>(own_kf)], T_ownkf_matekf);
      const Pose2 T_own_robot =
          Compose(T_own_matekf, Inverse(rg.poses[static_cast<std::size_t>(mate_kf)]));
      for (const Pose2& p : rg.poses) traj.push_back(Compose(T_own_robot, p));
      continue;
    }
    // Initial placement: the rigid fit of the touched poses to their step-1 estimates.
    std::vector<Pose2> source, target;
    for (const int kf : touched[robot]) {
      source.push_back(rg.poses[static_cast<std::size_t>(kf)]);
      target.push_back(local.Pose(Id(robot, kf)));
    }
    const Pose2 T_own_robot = FitRigid(source, target);
    if (options.anchor == GlobalAnchor::kRigid) {
      for (const Pose2& p : rg.poses) traj.push_back(Compose(T_own_robot, p));
      continue;
    }
    PoseGraph2d global;
    for (std::size_t k = 0; k < rg.poses.size(); ++k) {
      global.AddPose(Id(robot, static_cast<int>(k)), Initial(problem, robot, rg, k, T_own_robot));
    }
    const Matrix3 chain_info = InformationFromSigmas(
        options.chain_sigma_xy_m, options.chain_sigma_xy_m, options.chain_sigma_yaw_rad);
    for (const ChainFactor& f : rg.factors) {
      global.AddBetween(Id(robot, f.from), Id(robot, f.to), f.T_from_to,
                        options.teammate_chain_from_factors ? f.information : chain_info,
                        FactorKind::kOdometry);
    }
    const Matrix3 anchor_info = InformationFromSigmas(
        options.anchor_sigma_xy_m, options.anchor_sigma_xy_m, options.anchor_sigma_yaw_rad);
    for (std::size_t q = 0; q < source.size(); ++q) {
      global.AddPrior(Id(robot, *std::next(touched[robot].begin(), static_cast<long>(q))),
                      target[q], anchor_info, options.anchor_loss);
    }
    est.global[robot] = global.Optimize(options.solver);
    for (std::size_t k = 0; k < rg.poses.size(); ++k) {
      traj.push_back(global.Pose(Id(robot, static_cast<int>(k))));
    }
  }
  est.global_time_s = Seconds(global_start);
  return est;
}

TeamEstimate FullPgo(const TeamProblem& problem, int own_robot, const FullOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const RobotGraph& own = Robot(problem, own_robot);
  TeamEstimate est;
  est.own_robot = own_robot;
  PoseGraph2d graph;
  std::vector<int> robots;
  for (const auto& [robot, rg] : problem.robots) {
    Pose2 T_own_robot;
    if (robot != own_robot && !MapGuess(problem, own_robot, robot, &T_own_robot)) continue;
    AddRobot(graph, problem, robot, rg, T_own_robot);
    robots.push_back(robot);
  }
  if (!own.poses.empty()) {
    graph.SetPose(Id(own_robot, 0), own.poses[0]);  // the gauge, whatever the warm start
    graph.SetPoseConstant(Id(own_robot, 0));
  }
  for (const msgs::InterRobotLoop& loop : problem.loops) {
    CheckLoop(problem, loop);
    const PoseId i = Id(loop.own_robot, loop.own_keyframe);
    const PoseId j = Id(loop.teammate_robot, loop.teammate_keyframe);
    if (!graph.HasPose(i) || !graph.HasPose(j)) {
      RequireGuess(problem, own_robot, graph.HasPose(i) ? loop.teammate_robot : loop.own_robot);
    }
    graph.AddBetween(i, j, ToPose(loop.T_ownkf_teammatekf),
                     LoopInformation(loop, options.loop_information_from_covariance,
                                     options.loop_sigma_xy_m, options.loop_sigma_yaw_rad),
                     FactorKind::kInterRobot, options.loop_loss);
    ++est.loops_used;
  }
  est.local = graph.Optimize(options.solver);
  for (const int robot : robots) {
    auto& traj = est.trajectories[robot];
    const std::size_t n = problem.robots.at(robot).poses.size();
    for (std::size_t k = 0; k < n; ++k) traj.push_back(graph.Pose(Id(robot, static_cast<int>(k))));
  }
  est.local_time_s = Seconds(start);
  return est;
}

}  // namespace draco::team
