// Synthetic inter-robot loop-closure streams for the consistency tests, the robustness
// experiment and the benchmark: three robots surveying the same 60 x 40 m area (robot 0 and 1
// in rows along x, in opposite order; robot 2 in columns along y), odometry chains with
// drift, noisy map-to-map transforms, true loops and injected wrong ones (random, or
// correlated groups of nearby loops sharing one wrong offset).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "draco/consistency/pairwise.hpp"
#include "draco/msgs/loops.hpp"

namespace draco::consistency::synthetic {

enum class OutlierKind { kRandom, kCorrelated };

struct MissionOptions {
  int keyframes_per_robot = 160;
  double keyframe_step_m = 2.0;
  double odom_sigma_xy_m = 0.02;  // per keyframe step (scan-matched local SLAM)
  double odom_sigma_yaw_rad = 0.001;
  double loop_sigma_xy_m = 0.1;
  double loop_sigma_yaw_rad = 0.01;
  double map_sigma_xy_m = 0.1;
  double map_sigma_yaw_rad = 0.005;
  int inliers = 60;  // over both teammates
  double outlier_fraction = 0.0;
  OutlierKind outliers = OutlierKind::kRandom;
  int group_size = 6;
  double group_offset_m = 2.0;      // one pile spacing
  bool shared_offset_axis = false;  // every group shifted +-offset along x or y (else random)
  double max_loop_distance_m = 8.0;
  std::uint32_t seed = 1;
};

struct Mission {
  ChainPoseSource poses;  // own and teammate odometry chains, map transforms (estimates)
  std::vector<msgs::InterRobotLoop> loops;  // in arrival order, id = position
  std::vector<bool> inlier;                 // by id
  std::vector<int> arrival;                 // keyframe step at which each loop exists
};

inline std::vector<Pose2> Survey(int robot, int n, double step) {
  std::vector<std::pair<double, double>> waypoints;
  if (robot == 2) {
    for (int c = 0; c <= 4; ++c) {
      const double x = 15.0 * c;
      const bool up = c % 2 == 0;
      waypoints.push_back({x, up ? 0.0 : 40.0});
      waypoints.push_back({x, up ? 40.0 : 0.0});
    }
  } else {
    for (int r = 0; r <= 4; ++r) {
      const double y = robot == 0 ? 10.0 * r : 40.0 - 10.0 * r;
      const bool right = (r % 2 == 0) == (robot == 0);
      waypoints.push_back({right ? 0.0 : 60.0, y});
      waypoints.push_back({right ? 60.0 : 0.0, y});
    }
  }
  std::vector<Pose2> poses;
  std::size_t seg = 0;
  double along = 0.0;
  while (static_cast<int>(poses.size()) < n) {
    const auto [x0, y0] = waypoints[seg % waypoints.size()];
    const auto [x1, y1] = waypoints[(seg + 1) % waypoints.size()];
    const double len = std::hypot(x1 - x0, y1 - y0);
    if (along > len) {
      along -= len;
      ++seg;
      continue;
    }
    const double yaw = std::atan2(y1 - y0, x1 - x0);
    poses.push_back({x0 + along * std::cos(yaw), y0 + along * std::sin(yaw), yaw});
    along += step;
  }
  return poses;
}

inline Mission MakeMission(const MissionOptions& o) {
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const int n = o.keyframes_per_robot;
  std::vector<std::vector<Pose2>> world;
  for (int r = 0; r < 3; ++r) world.push_back(Survey(r, n, o.keyframe_step_m));
  Mission m;
  // Odometry chains in each robot's map frame (its first keyframe), with drift.
  const Eigen::Matrix3d step_cov =
      Eigen::Vector3d(o.odom_sigma_xy_m * o.odom_sigma_xy_m, o.odom_sigma_xy_m * o.odom_sigma_xy_m,
                      o.odom_sigma_yaw_rad * o.odom_sigma_yaw_rad)
          .asDiagonal();
  for (int r = 0; r < 3; ++r) {
    Pose2 est{};
    for (int k = 0; k < n; ++k) {
      if (k > 0) {
        Pose2 step = Between(world[r][k - 1], world[r][k]);
        step.x_m += o.odom_sigma_xy_m * gauss(rng);
        step.y_m += o.odom_sigma_xy_m * gauss(rng);
        step.yaw_rad += o.odom_sigma_yaw_rad * gauss(rng);
        est = Compose(est, step);
      }
      m.poses.AddKeyframe(r, est, step_cov);
    }
  }
  for (int b = 1; b < 3; ++b) {
    UncertainPose t;
    t.pose = Between(world[0][0], world[b][0]);
    t.pose.x_m += o.map_sigma_xy_m * gauss(rng);
    t.pose.y_m += o.map_sigma_xy_m * gauss(rng);
    t.pose.yaw_rad += o.map_sigma_yaw_rad * gauss(rng);
    t.covariance =
        Eigen::Vector3d(o.map_sigma_xy_m * o.map_sigma_xy_m, o.map_sigma_xy_m * o.map_sigma_xy_m,
                        o.map_sigma_yaw_rad * o.map_sigma_yaw_rad)
            .asDiagonal();
    m.poses.SetMapTransform(0, b, t);
  }
  // Candidate pairs: own keyframe i, teammate b keyframe k, close in the world.
  struct Pair {
    int b, i, k;
  };
  std::vector<Pair> pairs;
  for (int b = 1; b < 3; ++b) {
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < n; ++k) {
        if (std::hypot(world[0][i].x_m - world[b][k].x_m, world[0][i].y_m - world[b][k].y_m) <
            o.max_loop_distance_m) {
          pairs.push_back({b, i, k});
        }
      }
    }
  }
  const msgs::Covariance3 loop_cov{o.loop_sigma_xy_m * o.loop_sigma_xy_m,      0, 0, 0,
                                   o.loop_sigma_xy_m * o.loop_sigma_xy_m,      0, 0, 0,
                                   o.loop_sigma_yaw_rad * o.loop_sigma_yaw_rad};
  struct Raw {
    msgs::InterRobotLoop loop;
    bool inlier;
  };
  std::vector<Raw> raw;
  auto make = [&](const Pair& p, const Pose2& world_shift, double extra_yaw, bool inlier) {
    Pose2 target = world[p.b][p.k];
    target.x_m += world_shift.x_m;
    target.y_m += world_shift.y_m;
    target.yaw_rad += extra_yaw;
    Pose2 z = Between(world[0][p.i], target);
    z.x_m += o.loop_sigma_xy_m * gauss(rng);
    z.y_m += o.loop_sigma_xy_m * gauss(rng);
    z.yaw_rad += o.loop_sigma_yaw_rad * gauss(rng);
    msgs::InterRobotLoop loop;
    loop.own_robot = 0;
    loop.own_keyframe = p.i;
    loop.teammate_robot = p.b;
    loop.teammate_keyframe = p.k;
    loop.T_ownkf_teammatekf = z;
    loop.covariance = loop_cov;
    loop.overlap = 0.9;
    if (!inlier) loop.flags |= msgs::kLoopInjected;
    raw.push_back({loop, inlier});
  };
  auto pick = [&]() {
    return pairs[static_cast<std::size_t>(uni(rng) * pairs.size()) % pairs.size()];
  };
  for (int q = 0; q < o.inliers; ++q) make(pick(), {}, 0.0, true);
  const int outliers = static_cast<int>(
      std::lround(o.inliers * o.outlier_fraction / std::max(1e-9, 1.0 - o.outlier_fraction)));
  int made = 0;
  while (made < outliers) {
    const Pair c = pick();
    if (o.outliers == OutlierKind::kRandom) {
      const double dx = -6.0 + 12.0 * uni(rng);
      const double dy = -6.0 + 12.0 * uni(rng);
      const double dyaw = -0.6 + 1.2 * uni(rng);
      if (std::hypot(dx, dy) < 1.5 && std::abs(dyaw) < 15.0 * std::numbers::pi / 180.0) continue;
      make(c, {dx, dy, 0.0}, dyaw, false);
      ++made;
      continue;
    }
    // A group of nearby loops (consecutive keyframes on both sides) with one wrong offset.
    double angle = 2.0 * std::numbers::pi * uni(rng);
    if (o.shared_offset_axis) angle = 0.5 * std::numbers::pi * std::floor(4.0 * uni(rng));
    const Pose2 shift{o.group_offset_m * std::cos(angle), o.group_offset_m * std::sin(angle), 0};
    for (int g = 0; g < o.group_size && made < outliers; ++g) {
      Pair p = c;
      p.i = std::clamp(c.i + g / 2, 0, n - 1);
      p.k = std::clamp(c.k + (g + 1) / 2, 0, n - 1);
      make(p, shift, 0.0, false);
      ++made;
    }
  }
  // Arrival: when both keyframes exist; stable order, ids in arrival order.
  std::stable_sort(raw.begin(), raw.end(), [](const Raw& a, const Raw& b) {
    return std::max(a.loop.own_keyframe, a.loop.teammate_keyframe) <
           std::max(b.loop.own_keyframe, b.loop.teammate_keyframe);
  });
  for (std::size_t id = 0; id < raw.size(); ++id) {
    raw[id].loop.id = id;
    m.loops.push_back(raw[id].loop);
    m.inlier.push_back(raw[id].inlier);
    m.arrival.push_back(std::max(raw[id].loop.own_keyframe, raw[id].loop.teammate_keyframe));
  }
  return m;
}

}  // namespace draco::consistency::synthetic
