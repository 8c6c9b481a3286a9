// Negative evidence for the object-graph matcher (graph_matcher.hpp): the area a robot's sonar
// has seen (Coverage) and the objects a transform puts there that the map lacks (CountMisses).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "draco/objects/geometry.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "graph_matcher_internal.hpp"

namespace draco::objects {
namespace {

using detail::Distance;
using msgs::ObjectMap;

}  // namespace

Coverage::Coverage(const std::vector<Pose2>& poses, const CoverageOptions& o)
    : Coverage(poses, {}, o) {}

Coverage::Coverage(const std::vector<Pose2>& poses, const std::vector<Point2>& returns_map,
                   const CoverageOptions& o) {
  if (poses.empty()) return;
  cell_m_ = o.cell_m;
  double x0 = poses[0].x_m, x1 = x0, y0 = poses[0].y_m, y1 = y0;
  for (const auto& p : poses) {
    x0 = std::min(x0, p.x_m), x1 = std::max(x1, p.x_m);
    y0 = std::min(y0, p.y_m), y1 = std::max(y1, p.y_m);
  }
  x0_ = x0 - o.range_m;
  y0_ = y0 - o.range_m;
  nx_ = static_cast<int>(std::ceil((x1 - x0 + 2 * o.range_m) / cell_m_)) + 1;
  ny_ = static_cast<int>(std::ceil((y1 - y0 + 2 * o.range_m) / cell_m_)) + 1;
  cells_.assign(std::size_t(nx_) * ny_, 0);
  const double half = std::min(o.half_aperture_rad, M_PI);
  const double cos_half = std::cos(half);
  const double r2 = o.range_m * o.range_m;
  // Shadows: the cells holding shadow_min_points returns, on this grid.
  const bool shadows = o.shadow_margin_m > 0.0 && o.shadow_bin_rad > 0.0 && !returns_map.empty();
  const int bins = shadows ? static_cast<int>(std::ceil(2.0 * half / o.shadow_bin_rad)) : 0;
  const auto bin_of = [&](double bearing_rad) {  // bearing from the heading
    return std::clamp(static_cast<int>((bearing_rad + half) / o.shadow_bin_rad), 0, bins - 1);
  };
  std::vector<std::uint8_t> solid;
  if (shadows) {
    std::vector<int> counts(cells_.size(), 0);
    for (const auto& q : returns_map) {
      const double fx = (q.x_m - x0_) / cell_m_, fy = (q.y_m - y0_) / cell_m_;
      if (fx < 0 || fy < 0 || fx >= nx_ || fy >= ny_) continue;
      ++counts[std::size_t(fy) * nx_ + std::size_t(fx)];
    }
    solid.resize(counts.size());
    for (std::size_t i = 0; i < counts.size(); ++i)
      solid[i] = counts[i] >= std::max(1, o.shadow_min_points);
  }
  std::vector<double> seen_m;  // per bearing bin: how far the keyframe saw
  for (const auto& p : poses) {
    const double hx = std::cos(p.yaw_rad), hy = std::sin(p.yaw_rad);
    // The sector's bounding box: the apex, the arc's ends and the circle's axis points on the
    // arc. Cells outside it cannot pass the test below; one cell of margin for rounding.
    double bx0 = p.x_m, bx1 = p.x_m, by0 = p.y_m, by1 = p.y_m;
    const auto extend = [&](double angle) {
      const double x = p.x_m + o.range_m * std::cos(angle), y = p.y_m + o.range_m * std::sin(angle);
      bx0 = std::min(bx0, x);
      bx1 = std::max(bx1, x);
      by0 = std::min(by0, y);
      by1 = std::max(by1, y);
    };
    extend(p.yaw_rad - half);
    extend(p.yaw_rad + half);
    for (int q = 0; q < 4; ++q) {
      const double axis = q * M_PI / 2.0;
      if (std::abs(std::remainder(axis - p.yaw_rad, 2.0 * M_PI)) <= half) extend(axis);
    }
    const int iy0 = std::max(0, static_cast<int>(std::floor((by0 - y0_) / cell_m_)) - 1);
    const int iy1 = std::min(ny_ - 1, static_cast<int>(std::floor((by1 - y0_) / cell_m_)) + 1);
    const int bix0 = std::max(0, static_cast<int>(std::floor((bx0 - x0_) / cell_m_)) - 1);
    const int bix1 = std::min(nx_ - 1, static_cast<int>(std::floor((bx1 - x0_) / cell_m_)) + 1);
    if (shadows) {  // per bearing bin, the nearest solid cell (every bin its width covers)
      seen_m.assign(static_cast<std::size_t>(bins), o.range_m);
      for (int iy = iy0; iy <= iy1; ++iy) {
        for (int ix = bix0; ix <= bix1; ++ix) {
          if (!solid[std::size_t(iy) * nx_ + ix]) continue;
          const double dx = x0_ + (ix + 0.5) * cell_m_ - p.x_m;
          const double dy = y0_ + (iy + 0.5) * cell_m_ - p.y_m;
          const double r = std::hypot(dx, dy);
          if (r > o.range_m || r < cell_m_) continue;
          const double bearing = std::atan2(hx * dy - hy * dx, hx * dx + hy * dy);
          const double width = std::atan(0.5 * cell_m_ / r);
          if (std::abs(bearing) - width > half) continue;
          const int b0 = bin_of(bearing - width), b1 = bin_of(bearing + width);
          for (int b = b0; b <= b1; ++b) {
            auto& seen = seen_m[static_cast<std::size_t>(b)];
            seen = std::min(seen, r + o.shadow_margin_m);
          }
        }
      }
    }
    for (int iy = iy0; iy <= iy1; ++iy) {
      const double dy = y0_ + (iy + 0.5) * cell_m_ - p.y_m;
      const double s2 = r2 - dy * dy;
      if (s2 < 0.0) continue;
      // The row's cells within range: centre x within p.x +- sqrt(r^2 - dy^2), one cell of
      // margin.
      const double sx = std::sqrt(s2);
      const int ix0 =
          std::max(bix0, static_cast<int>(std::floor((p.x_m - sx - x0_) / cell_m_)) - 1);
      const int ix1 =
          std::min(bix1, static_cast<int>(std::floor((p.x_m + sx - x0_) / cell_m_)) + 1);
      std::uint8_t* row = cells_.data() + std::size_t(iy) * nx_;
      for (int ix = ix0; ix <= ix1; ++ix) {
        std::uint8_t& cell = row[ix];
        if (cell) continue;
        const double dx = x0_ + (ix + 0.5) * cell_m_ - p.x_m;
        const double d2 = dx * dx + dy * dy;
        if (d2 > r2) continue;
        // Within half_aperture of the heading: cos(bearing - yaw) >= cos(half_aperture).
        if (hx * dx + hy * dy < std::sqrt(d2) * cos_half) continue;
        if (shadows) {
          const double bearing = std::atan2(hx * dy - hy * dx, hx * dx + hy * dy);
          const double seen = seen_m[static_cast<std::size_t>(bin_of(bearing))];
          if (d2 > seen * seen) continue;
        }
        cell = 1;
      }
    }
  }
}

bool Coverage::Observed(const Point2& p) const {
  if (cells_.empty()) return false;
  const double fx = (p.x_m - x0_) / cell_m_, fy = (p.y_m - y0_) / cell_m_;
  if (fx < 0 || fy < 0 || fx >= nx_ || fy >= ny_) return false;
  return cells_[std::size_t(fy) * nx_ + std::size_t(fx)] != 0;
}

double Coverage::ObservedFraction() const {
  if (cells_.empty()) return 0.0;
  std::size_t n = 0;
  for (const auto c : cells_) n += c;
  return double(n) / double(cells_.size());
}

int CountMisses(const ObjectMap& from, const ObjectMap& to, const Pose2& T_to_from,
                const Coverage& to_coverage, double distance_m) {
  int misses = 0;
  for (const auto& o : from.objects) {
    const Point2 q = Transform(T_to_from, o.center);
    if (!to_coverage.Observed(q)) continue;
    bool near = false;
    for (const auto& t : to.objects) {
      if (Distance(t.center, q) < distance_m) {
        near = true;
        break;
      }
    }
    misses += !near;
  }
  return misses;
}

}  // namespace draco::objects
