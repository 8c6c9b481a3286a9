// Object pairs under a known map-to-map transform (graph_matcher.hpp).
#include <algorithm>
#include <array>
#include <cmath>

#include "draco/msgs/rigid_fit.hpp"
#include "draco/objects/graph_matcher.hpp"

namespace draco::objects {
namespace {

msgs::Point2 Apply(const Pose2& T, const msgs::Point2& p) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {T.x_m + c * p.x_m - s * p.y_m, T.y_m + s * p.x_m + c * p.y_m};
}

// Corners of an object's rectangle grown by margin_m on every side, placed by T.
std::array<msgs::Point2, 4> Corners(const msgs::Object& o, const Pose2& T, double margin_m) {
  const double c = std::cos(o.yaw_rad), s = std::sin(o.yaw_rad);
  const double hl = 0.5 * o.length_m + margin_m, hb = 0.5 * o.breadth_m + margin_m;
  std::array<msgs::Point2, 4> out;
  const double sx[4] = {1, -1, -1, 1}, sy[4] = {1, 1, -1, -1};
  for (int k = 0; k < 4; ++k) {
    const msgs::Point2 p{o.rect_center.x_m + c * hl * sx[k] - s * hb * sy[k],
                         o.rect_center.y_m + s * hl * sx[k] + c * hb * sy[k]};
    out[static_cast<std::size_t>(k)] = Apply(T, p);
  }
  return out;
}

// Separating-axis test of two convex quadrilaterals.
bool Intersect(const std::array<msgs::Point2, 4>& a, const std::array<msgs::Point2, 4>& b) {
  for (const auto* poly : {&a, &b}) {
    for (std::size_t k = 0; k < 4; ++k) {
      const auto& p = (*poly)[k];
      const auto& q = (*poly)[(k + 1) % 4];
      const double nx = q.y_m - p.y_m, ny = p.x_m - q.x_m;
      double amin = 1e300, amax = -1e300, bmin = 1e300, bmax = -1e300;
      for (const auto& v : a) {
        const double d = nx * v.x_m + ny * v.y_m;
        amin = std::min(amin, d);
        amax = std::max(amax, d);
      }
      for (const auto& v : b) {
        const double d = nx * v.x_m + ny * v.y_m;
        bmin = std::min(bmin, d);
        bmax = std::max(bmax, d);
      }
      if (amax < bmin || bmax < amin) return false;
    }
  }
  return true;
}

}  // namespace

std::vector<msgs::ObjectPair> PairsUnderTransform(const msgs::ObjectMap& a,
                                                  const msgs::ObjectMap& b, const Pose2& T_a_b,
                                                  double margin_m) {
  std::vector<msgs::ObjectPair> pairs;
  std::vector<std::array<msgs::Point2, 4>> rect_a;
  for (const auto& oa : a.objects) rect_a.push_back(Corners(oa, Pose2{}, margin_m));
  for (const auto& ob : b.objects) {
    if (ob.landmark) continue;
    const auto rb = Corners(ob, T_a_b, margin_m);
    const auto cb = Apply(T_a_b, ob.center);
    int best = -1;
    double best_d = 1e300;
    for (std::size_t i = 0; i < a.objects.size(); ++i) {
      if (a.objects[i].landmark || !Intersect(rect_a[i], rb)) continue;
      const double d =
          std::hypot(a.objects[i].center.x_m - cb.x_m, a.objects[i].center.y_m - cb.y_m);
      if (d < best_d) {
        best_d = d;
        best = static_cast<int>(i);
      }
    }
    if (best >= 0) pairs.push_back({a.objects[static_cast<std::size_t>(best)].id, ob.id, best_d});
  }
  return pairs;
}

std::optional<Pose2> RefineUnderTransform(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                                          const Pose2& T_a_b, const RefineOptions& options,
                                          int* pairs) {
  if (pairs != nullptr) *pairs = 0;
  const auto small = [&](const msgs::Object& o) { return o.length_m <= options.max_length_m; };
  std::vector<msgs::Point2> own;
  for (const auto& oa : a.objects) {
    if (small(oa)) own.push_back(oa.center);
  }
  Pose2 T = T_a_b;
  int n = 0;
  for (int it = 0; it < std::max(1, options.iterations); ++it) {
    std::vector<msgs::Point2> source, target;
    for (const auto& ob : b.objects) {
      if (!small(ob)) continue;
      const auto p = Apply(T, ob.center);
      const msgs::Point2* best = nullptr;
      double best_d = options.gate_m;
      for (const auto& q : own) {
        const double d = std::hypot(q.x_m - p.x_m, q.y_m - p.y_m);
        if (d <= best_d) {
          best_d = d;
          best = &q;
        }
      }
      if (best == nullptr) continue;
      source.push_back(ob.center);
      target.push_back(*best);
    }
    n = static_cast<int>(source.size());
    if (n < std::max(2, options.min_pairs)) return std::nullopt;
    if (options.rotate) {
      const auto fit = msgs::FitRigid2d(source, target);
      if (!fit) return std::nullopt;
      T = *fit;
      continue;
    }
    double dx = 0.0, dy = 0.0;
    for (std::size_t i = 0; i < source.size(); ++i) {
      const auto p = Apply(T, source[i]);
      dx += target[i].x_m - p.x_m;
      dy += target[i].y_m - p.y_m;
    }
    T.x_m += dx / n;
    T.y_m += dy / n;
  }
  if (pairs != nullptr) *pairs = n;
  return T;
}

MapAgreement CompareObjectMaps(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                               const Pose2& T_a_b, const Coverage& coverage_a,
                               const Coverage& coverage_b, double margin_m) {
  const Pose2 T_b_a = [&] {
    const double c = std::cos(T_a_b.yaw_rad), s = std::sin(T_a_b.yaw_rad);
    return Pose2{-(c * T_a_b.x_m + s * T_a_b.y_m), -(-s * T_a_b.x_m + c * T_a_b.y_m),
                 -T_a_b.yaw_rad};
  }();
  std::vector<std::array<msgs::Point2, 4>> rect_a, grown_b;  // both in a's frame
  for (const auto& oa : a.objects) rect_a.push_back(Corners(oa, Pose2{}, 0.0));
  for (const auto& ob : b.objects) grown_b.push_back(Corners(ob, T_a_b, margin_m));
  const auto meets = [&](std::size_t i, std::size_t k) {
    return !a.objects[i].landmark && !b.objects[k].landmark && Intersect(rect_a[i], grown_b[k]);
  };
  // Objects of `from` inside `coverage` (placed by T_cov_from) and those meeting one of the
  // other map's (of `others` objects), counted into *expected / *met.
  const auto count = [&](const msgs::ObjectMap& from, const Coverage& coverage,
                         const Pose2& T_cov_from, std::size_t others, bool from_is_a, int* expected,
                         int* met) {
    for (std::size_t x = 0; x < from.objects.size(); ++x) {
      if (from.objects[x].landmark || !coverage.Observed(Apply(T_cov_from, from.objects[x].center)))
        continue;
      ++*expected;
      for (std::size_t y = 0; y < others; ++y) {
        if (from_is_a ? meets(x, y) : meets(y, x)) {
          ++*met;
          break;
        }
      }
    }
  };
  MapAgreement out;
  count(b, coverage_a, T_a_b, a.objects.size(), false, &out.b_expected, &out.b_met);
  count(a, coverage_b, T_b_a, b.objects.size(), true, &out.a_expected, &out.a_met);
  return out;
}

PointCounts::PointCounts(const std::vector<Point2>& points, double cell_m) : cell_m_(cell_m) {
  if (points.empty() || !(cell_m > 0.0)) return;
  double x1 = points[0].x_m, y1 = points[0].y_m;
  x0_ = x1, y0_ = y1;
  for (const auto& p : points) {
    x0_ = std::min(x0_, p.x_m), x1 = std::max(x1, p.x_m);
    y0_ = std::min(y0_, p.y_m), y1 = std::max(y1, p.y_m);
  }
  nx_ = static_cast<int>((x1 - x0_) / cell_m_) + 1;
  ny_ = static_cast<int>((y1 - y0_) / cell_m_) + 1;
  counts_.assign(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_), 0);
  for (const auto& p : points) {
    const int ix = std::min(nx_ - 1, static_cast<int>((p.x_m - x0_) / cell_m_));
    const int iy = std::min(ny_ - 1, static_cast<int>((p.y_m - y0_) / cell_m_));
    ++counts_[static_cast<std::size_t>(iy) * static_cast<std::size_t>(nx_) +
              static_cast<std::size_t>(ix)];
  }
}

int PointCounts::CountInRectangle(const Point2& c, double yaw_rad, double hl, double hb) const {
  if (counts_.empty()) return 0;
  const double cy = std::cos(yaw_rad), sy = std::sin(yaw_rad), r = std::hypot(hl, hb);
  const int ix0 = std::max(0, static_cast<int>(std::floor((c.x_m - r - x0_) / cell_m_)));
  const int iy0 = std::max(0, static_cast<int>(std::floor((c.y_m - r - y0_) / cell_m_)));
  const int ix1 = std::min(nx_ - 1, static_cast<int>(std::floor((c.x_m + r - x0_) / cell_m_)));
  const int iy1 = std::min(ny_ - 1, static_cast<int>(std::floor((c.y_m + r - y0_) / cell_m_)));
  int n = 0;
  for (int iy = iy0; iy <= iy1; ++iy) {
    for (int ix = ix0; ix <= ix1; ++ix) {
      const double dx = x0_ + (ix + 0.5) * cell_m_ - c.x_m, dy = y0_ + (iy + 0.5) * cell_m_ - c.y_m;
      if (std::abs(cy * dx + sy * dy) <= hl && std::abs(-sy * dx + cy * dy) <= hb) {
        n += counts_[static_cast<std::size_t>(iy) * static_cast<std::size_t>(nx_) +
                     static_cast<std::size_t>(ix)];
      }
    }
  }
  return n;
}

PointSupport SupportByPoints(const msgs::ObjectMap& b, const Pose2& T_a_b,
                             const PointCounts& a_points, const Coverage& coverage_a,
                             double margin_m, int min_points) {
  PointSupport out;
  for (const auto& o : b.objects) {
    if (o.landmark) continue;
    if (!coverage_a.Observed(Apply(T_a_b, o.center))) continue;
    ++out.expected;
    const int n =
        a_points.CountInRectangle(Apply(T_a_b, o.rect_center), o.yaw_rad + T_a_b.yaw_rad,
                                  0.5 * o.length_m + margin_m, 0.5 * o.breadth_m + margin_m);
    out.met += n >= min_points;
  }
  return out;
}

}  // namespace draco::objects
