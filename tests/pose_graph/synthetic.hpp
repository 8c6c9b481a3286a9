// Synthetic 2D pose graphs with known ground truth, for tests and benchmarks: a walk on a
// 1 m grid (forward steps, 90-degree turns) so it revisits places, noisy odometry between
// consecutive poses and noisy loop closures to earlier poses within loop_radius_m.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "draco/pose_graph/pose2.hpp"

namespace draco::pose_graph::testing {

struct SyntheticEdge {
  int i = 0;
  int j = 0;
  Pose2 T_i_j;  // noisy measurement
  bool loop = false;
};

struct SyntheticGraph {
  std::vector<Pose2> truth;  // T_world_pose
  std::vector<SyntheticEdge> edges;
  double sigma_xy_m = 0.05;
  double sigma_yaw_rad = 0.01;
  Matrix3 Information() const {
    return InformationFromSigmas(sigma_xy_m, sigma_xy_m, sigma_yaw_rad);
  }
};

struct SyntheticOptions {
  int num_poses = 200;
  double sigma_xy_m = 0.05;
  double sigma_yaw_rad = 0.01;
  double loop_radius_m = 1.1;
  int min_loop_gap = 10;  // poses between the ends of a loop
  int loop_every = 1;     // at most one loop per this many poses
  std::uint32_t seed = 42;
};

inline SyntheticGraph MakeGridWalk(const SyntheticOptions& o) {
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  SyntheticGraph g;
  g.sigma_xy_m = o.sigma_xy_m;
  g.sigma_yaw_rad = o.sigma_yaw_rad;
  auto noisy = [&](const Pose2& T) {
    return Pose2{T.x_m + o.sigma_xy_m * n01(rng), T.y_m + o.sigma_xy_m * n01(rng),
                 NormalizeAngle(T.yaw_rad + o.sigma_yaw_rad * n01(rng))};
  };
  g.truth.push_back({0.0, 0.0, 0.0});
  int last_loop = -o.loop_every;
  for (int k = 1; k < o.num_poses; ++k) {
    // Turn left or right now and then, staying inside a 10 x 10 m box so the walk revisits.
    const Pose2 prev = g.truth.back();  // a copy: truth grows below
    double turn = 0.0;
    const double r = u01(rng);
    if (r < 0.15) turn = std::numbers::pi / 2;
    if (r > 0.85) turn = -std::numbers::pi / 2;
    Pose2 step{1.0, 0.0, turn};
    Pose2 next = Compose(prev, step);
    if (std::abs(next.x_m) > 5.0 || std::abs(next.y_m) > 5.0) {
      step = {1.0, 0.0, 0.0};
      next = Compose(prev, {0.0, 0.0, std::numbers::pi / 2});  // turn in place
      step = Between(prev, next);
    }
    g.truth.push_back(next);
    g.edges.push_back({k - 1, k, noisy(Between(prev, next)), false});
    if (k - last_loop < o.loop_every) continue;
    for (int m = 0; m + o.min_loop_gap < k; ++m) {
      const double dx = g.truth[m].x_m - next.x_m, dy = g.truth[m].y_m - next.y_m;
      if (std::hypot(dx, dy) <= o.loop_radius_m) {
        g.edges.push_back({m, k, noisy(Between(g.truth[m], next)), true});
        last_loop = k;
        break;
      }
    }
  }
  return g;
}

}  // namespace draco::pose_graph::testing
