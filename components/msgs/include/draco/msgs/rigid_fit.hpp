// The closed-form planar rigid fit shared by object-graph matching (RANSAC over object
// centres), the two-step PGO (placing a teammate through its loops) and the team optimizer
// (map-to-map estimates): T minimising sum |target_i - T * source_i|^2 over positions.
#pragma once

#include <cmath>
#include <cstddef>
#include <optional>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::msgs {

// x_m / y_m of a Point2 or a Pose2.
template <class P>
std::optional<Pose2> FitRigid2d(const std::vector<P>& source, const std::vector<P>& target) {
  const std::size_t n = std::min(source.size(), target.size());
  if (n == 0) return std::nullopt;
  double sx = 0, sy = 0, tx = 0, ty = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sx += source[i].x_m, sy += source[i].y_m, tx += target[i].x_m, ty += target[i].y_m;
  }
  sx /= double(n), sy /= double(n), tx /= double(n), ty /= double(n);
  // Rotation maximising sum t'^T R s': yaw = atan2(sum(s'x t'y - s'y t'x), sum(s'.t')).
  double cos_sum = 0, sin_sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double ax = source[i].x_m - sx, ay = source[i].y_m - sy;
    const double bx = target[i].x_m - tx, by = target[i].y_m - ty;
    cos_sum += ax * bx + ay * by;
    sin_sum += ax * by - ay * bx;
  }
  if (std::hypot(cos_sum, sin_sum) < 1e-12) return std::nullopt;  // one point, or all at one
  const double yaw = std::atan2(sin_sum, cos_sum);
  const double c = std::cos(yaw), s = std::sin(yaw);
  return Pose2{tx - (c * sx - s * sy), ty - (s * sx + c * sy), yaw};
}

}  // namespace draco::msgs
