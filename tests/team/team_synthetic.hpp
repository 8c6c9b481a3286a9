// Synthetic 3-robot team for the team PGO tests and benchmark: lawnmower surveys of one
// 60 x 40 m area (robot 0 and 1 in rows along x in opposite order, robot 2 in columns, the
// layout of tests/consistency/synthetic.hpp), odometry chains with noise and a yaw bias
// (drift), noisy map-to-map guesses, correct inter-robot loops between every pair of robots
// and optional wrong loops sharing a teammate keyframe with a correct loop.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "../consistency/synthetic.hpp"
#include "draco/team/team_pgo.hpp"

namespace draco::team::synthetic {

struct Options {
  int keyframes = 150;
  double step_m = 2.0;
  double odom_sigma_xy_m = 0.03;
  double odom_sigma_yaw_rad = 0.002;
  double odom_yaw_bias_rad = 0.0;  // per step, sign alternates by robot
  double loop_sigma_xy_m = 0.1;
  double loop_sigma_yaw_rad = 0.01;
  double map_sigma_xy_m = 1.5;
  double map_sigma_yaw_rad = 0.05;
  int loops_per_pair = 15;
  int wrong_loops_per_pair = 0;
  double wrong_offset_m = 5.0;
  double wrong_yaw_rad = 0.3;
  double max_loop_distance_m = 8.0;
  std::uint32_t seed = 1;
};

struct Mission {
  TeamProblem problem;
  std::vector<std::vector<Pose2>> world;  // ground truth per robot
  std::vector<bool> inlier;               // per loop
};

// The consistency tests' survey layout (tests/consistency/synthetic.hpp), as pose-graph poses.
inline std::vector<Pose2> Survey(int robot, int n, double step) {
  std::vector<Pose2> poses;
  for (const auto& p : consistency::synthetic::Survey(robot, n, step)) {
    poses.push_back({p.x_m, p.y_m, p.yaw_rad});
  }
  return poses;
}

inline Mission MakeMission(const Options& o) {
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Mission m;
  const int n = o.keyframes;
  const Matrix3 odom_info =
      pose_graph::InformationFromSigmas(o.odom_sigma_xy_m, o.odom_sigma_xy_m, o.odom_sigma_yaw_rad);
  for (int r = 0; r < 3; ++r) {
    m.world.push_back(Survey(r, n, o.step_m));
    RobotGraph g;
    Pose2 est{};
    g.poses.push_back(est);
    const double bias = (r % 2 == 0 ? 1.0 : -1.0) * o.odom_yaw_bias_rad;
    for (int k = 1; k < n; ++k) {
      Pose2 z = pose_graph::Between(m.world[r][k - 1], m.world[r][k]);
      z.x_m += o.odom_sigma_xy_m * gauss(rng);
      z.y_m += o.odom_sigma_xy_m * gauss(rng);
      z.yaw_rad += o.odom_sigma_yaw_rad * gauss(rng) + bias;
      est = pose_graph::Compose(est, z);
      g.poses.push_back(est);
      g.factors.push_back({k - 1, k, z, odom_info});
    }
    m.problem.robots[r] = std::move(g);
  }
  for (int a = 0; a < 3; ++a) {
    for (int b = a + 1; b < 3; ++b) {
      Pose2 t = pose_graph::Between(m.world[a][0], m.world[b][0]);
      t.x_m += o.map_sigma_xy_m * gauss(rng);
      t.y_m += o.map_sigma_xy_m * gauss(rng);
      t.yaw_rad += o.map_sigma_yaw_rad * gauss(rng);
      m.problem.maps[{a, b}] = t;
    }
  }
  const double sxy2 = o.loop_sigma_xy_m * o.loop_sigma_xy_m;
  const msgs::Covariance3 cov{
      sxy2, 0, 0, 0, sxy2, 0, 0, 0, o.loop_sigma_yaw_rad * o.loop_sigma_yaw_rad};
  std::uint64_t id = 0;
  for (int a = 0; a < 3; ++a) {
    for (int b = a + 1; b < 3; ++b) {
      std::vector<std::pair<int, int>> pairs;
      for (int i = 0; i < n; ++i) {
        for (int k = 0; k < n; ++k) {
          if (std::hypot(m.world[a][i].x_m - m.world[b][k].x_m,
                         m.world[a][i].y_m - m.world[b][k].y_m) < o.max_loop_distance_m) {
            pairs.push_back({i, k});
          }
        }
      }
      std::shuffle(pairs.begin(), pairs.end(), rng);
      const int count = std::min<int>(o.loops_per_pair, static_cast<int>(pairs.size()));
      auto add = [&](int i, int k, const Pose2& z, bool inlier) {
        msgs::InterRobotLoop loop;
        loop.id = id++;
        loop.own_robot = a;
        loop.own_keyframe = i;
        loop.teammate_robot = b;
        loop.teammate_keyframe = k;
        loop.T_ownkf_teammatekf = {z.x_m, z.y_m, z.yaw_rad};
        loop.covariance = cov;
        loop.flags = msgs::kLoopAccepted | (inlier ? 0u : msgs::kLoopInjected);
        m.problem.loops.push_back(loop);
        m.inlier.push_back(inlier);
      };
      for (int q = 0; q < count; ++q) {
        const auto [i, k] = pairs[static_cast<std::size_t>(q)];
        Pose2 z = pose_graph::Between(m.world[a][i], m.world[b][k]);
        z.x_m += o.loop_sigma_xy_m * gauss(rng);
        z.y_m += o.loop_sigma_xy_m * gauss(rng);
        z.yaw_rad += o.loop_sigma_yaw_rad * gauss(rng);
        add(i, k, z, true);
      }
      // Wrong loops: another own keyframe to a teammate keyframe a correct loop touches.
      for (int q = 0; q < o.wrong_loops_per_pair && q < count; ++q) {
        const auto [i, k] = pairs[static_cast<std::size_t>(q)];
        const int i2 = std::clamp(i + 3, 0, n - 1);
        Pose2 target = m.world[b][k];
        target.x_m += o.wrong_offset_m * (q % 2 == 0 ? 1.0 : -0.6);
        target.y_m += o.wrong_offset_m * (q % 2 == 0 ? 0.5 : 0.8);
        target.yaw_rad += o.wrong_yaw_rad;
        add(i2, k, pose_graph::Between(m.world[a][i2], target), false);
      }
    }
  }
  return m;
}

// Ground truth of robot r in robot own's map frame.
inline std::vector<Pose2> TruthInFrame(const Mission& m, int own, int r) {
  std::vector<Pose2> out;
  for (const Pose2& p : m.world[static_cast<std::size_t>(r)]) {
    out.push_back(pose_graph::Between(m.world[static_cast<std::size_t>(own)][0], p));
  }
  return out;
}

// Position RMSE without alignment (both in the same frame).
inline double Ate(const std::vector<Pose2>& est, const std::vector<Pose2>& truth) {
  double sum = 0.0;
  for (std::size_t k = 0; k < est.size(); ++k) {
    sum += std::pow(est[k].x_m - truth[k].x_m, 2) + std::pow(est[k].y_m - truth[k].y_m, 2);
  }
  return est.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(est.size()));
}

}  // namespace draco::team::synthetic
