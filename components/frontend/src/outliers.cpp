#include "draco/frontend/outliers.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>

namespace draco::frontend {
namespace {

using msgs::InterRobotLoop;
using msgs::Pose2;

// The teammate keyframe moved by d (own map frame) as seen from own keyframe pose T_map_k.
Pose2 ShiftInMap(const Pose2& T_k_t, const Pose2& T_map_k, double dx_m, double dy_m) {
  const double c = std::cos(T_map_k.yaw_rad), s = std::sin(T_map_k.yaw_rad);
  return {T_k_t.x_m + c * dx_m + s * dy_m, T_k_t.y_m - s * dx_m + c * dy_m, T_k_t.yaw_rad};
}

}  // namespace

std::vector<InterRobotLoop> InjectOutliers(const std::vector<InterRobotLoop>& candidates,
                                           const std::vector<Pose2>& own_poses,
                                           const OutlierOptions& options, std::uint64_t first_id) {
  if (!(options.fraction >= 0.0 && options.fraction < 1.0)) {
    throw std::invalid_argument("outlier fraction " + std::to_string(options.fraction) +
                                " is outside [0, 1)");
  }
  std::vector<InterRobotLoop> out;
  if (candidates.empty() || options.fraction == 0.0) return out;
  for (const auto& l : candidates) {
    if (l.own_keyframe < 0 || l.own_keyframe >= static_cast<int>(own_poses.size())) {
      throw std::invalid_argument("candidate loop " + std::to_string(l.id) + ": own keyframe " +
                                  std::to_string(l.own_keyframe) + " has no pose (" +
                                  std::to_string(own_poses.size()) + " keyframes)");
    }
  }
  const int wanted = static_cast<int>(std::lround(options.fraction / (1.0 - options.fraction) *
                                                  static_cast<double>(candidates.size())));
  // Candidates of each teammate in own-keyframe order: groups are taken from these runs.
  std::vector<InterRobotLoop> sorted = candidates;
  std::stable_sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) {
    return std::tie(a.teammate_robot, a.own_keyframe, a.teammate_keyframe) <
           std::tie(b.teammate_robot, b.own_keyframe, b.teammate_keyframe);
  });
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<std::size_t> pick(0, sorted.size() - 1);
  auto emit = [&](const InterRobotLoop& from, const Pose2& T) {
    InterRobotLoop w = from;
    w.id = first_id + out.size();
    w.T_ownkf_teammatekf = T;
    out.push_back(w);
  };
  while (static_cast<int>(out.size()) < wanted) {
    if (options.kind == OutlierKind::kRandom) {
      const auto& t = sorted[pick(rng)];
      const double r =
          options.random_min_m + (options.random_max_m - options.random_min_m) * unit(rng);
      const double a = 2.0 * std::numbers::pi * unit(rng);
      const double dyaw = options.random_max_yaw_rad * (2.0 * unit(rng) - 1.0);
      Pose2 T = ShiftInMap(t.T_ownkf_teammatekf, own_poses[t.own_keyframe], r * std::cos(a),
                           r * std::sin(a));
      T.yaw_rad = std::remainder(T.yaw_rad + dyaw, 2.0 * std::numbers::pi);
      emit(t, T);
      continue;
    }
    const std::size_t start = pick(rng);
    double angle = 2.0 * std::numbers::pi * unit(rng);
    if (options.directions > 0) {
      std::uniform_int_distribution<int> dir(0, options.directions - 1);
      angle = 2.0 * std::numbers::pi * dir(rng) / options.directions;
    }
    const double dx = options.offset_m * std::cos(angle), dy = options.offset_m * std::sin(angle);
    const int teammate = sorted[start].teammate_robot;
    for (std::size_t i = start, n = 0;
         i < sorted.size() && static_cast<int>(n) < std::max(1, options.group_size) &&
         static_cast<int>(out.size()) < wanted && sorted[i].teammate_robot == teammate;
         ++i, ++n) {
      const auto& t = sorted[i];
      emit(t, ShiftInMap(t.T_ownkf_teammatekf, own_poses[t.own_keyframe], dx, dy));
    }
  }
  return out;
}

}  // namespace draco::frontend
