// A synthetic seabed for registration tests and benchmarks: random piles (small clusters)
// and wall segments in a world frame; a keyframe sees the points within range in its frame.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "draco/registration/registration.hpp"

namespace draco::registration::synthetic {

inline std::vector<Point2> World(unsigned seed, double size_m = 120.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-size_m / 2, size_m / 2);
  std::normal_distribution<double> n(0.0, 0.3);
  std::vector<Point2> w;
  for (int pile = 0; pile < 80; ++pile) {  // piles: 12 points in a 0.3 m blob
    const double cx = u(rng), cy = u(rng);
    for (int i = 0; i < 12; ++i) w.push_back({cx + n(rng), cy + n(rng)});
  }
  for (int wall = 0; wall < 10; ++wall) {  // walls: 15 m long, a point every 0.4 m
    const double cx = u(rng), cy = u(rng), a = u(rng);
    for (double t = -7.5; t <= 7.5; t += 0.4) {
      w.push_back({cx + t * std::cos(a), cy + t * std::sin(a)});
    }
  }
  return w;
}

// Points of `world` within range_m in front (|bearing| <= 65 deg) of T_world_kf, in the
// keyframe frame.
inline std::vector<Point2> See(const std::vector<Point2>& world, const Pose2& T_world_kf,
                               double range_m = 30.0) {
  std::vector<Point2> out;
  const Pose2 T_kf_world = Inverse(T_world_kf);
  for (const auto& p : world) {
    const Point2 q = Apply(T_kf_world, p);
    const double r = std::hypot(q.x_m, q.y_m);
    if (r > range_m || r < 1.0 || std::abs(std::atan2(q.y_m, q.x_m)) > 65.0 * M_PI / 180.0) {
      continue;
    }
    out.push_back(q);
  }
  return out;
}

// Keyframes every 2 m along a straight line from `start` in its heading; the map frame is
// the world frame moved by T_world_map.
inline std::vector<KeyframeScan> Survey(const std::vector<Point2>& world, const Pose2& start, int n,
                                        const Pose2& T_world_map = {}) {
  std::vector<KeyframeScan> out;
  const Pose2 T_map_world = Inverse(T_world_map);
  for (int i = 0; i < n; ++i) {
    const Pose2 T_world_kf = Compose(start, Pose2{2.0 * i, 0.0, 0.0});
    out.push_back({i, 1.0 * i, Compose(T_map_world, T_world_kf), See(world, T_world_kf)});
  }
  return out;
}

}  // namespace draco::registration::synthetic
