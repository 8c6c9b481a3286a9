#include "draco/objects/landmark_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include "draco/msgs/rigid_fit.hpp"

namespace draco::objects {
namespace {

using msgs::Point2;
using msgs::Pose2;

double Wrap(double a) { return std::remainder(a, 2.0 * std::numbers::pi); }

Point2 Apply(const Pose2& T, const Point2& p) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {c * p.x_m - s * p.y_m + T.x_m, s * p.x_m + c * p.y_m + T.y_m};
}

// Points of map a in a dense grid of cell tolerance_m over their bounding box, for the
// nearest point within the tolerance.
class Grid {
 public:
  Grid(const std::vector<Point2>& points, double cell_m) : points_(points), cell_(cell_m) {
    double x1 = points[0].x_m, y1 = points[0].y_m;
    x0_ = x1, y0_ = y1;
    for (const auto& p : points) {
      x0_ = std::min(x0_, p.x_m), y0_ = std::min(y0_, p.y_m);
      x1 = std::max(x1, p.x_m), y1 = std::max(y1, p.y_m);
    }
    nx_ = static_cast<std::int64_t>((x1 - x0_) / cell_) + 1;
    ny_ = static_cast<std::int64_t>((y1 - y0_) / cell_) + 1;
    start_.assign(std::size_t(nx_ * ny_ + 1), 0);
    std::vector<std::int64_t> cell(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      cell[i] = CellX(points[i].x_m) * ny_ + CellY(points[i].y_m);
      ++start_[std::size_t(cell[i]) + 1];
    }
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    index_.resize(points.size());
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < points.size(); ++i)
      index_[std::size_t(fill[std::size_t(cell[i])]++)] = int(i);
  }
  // Index of the nearest point within r (r <= cell), -1 when none.
  int Nearest(const Point2& p, double r) const {
    const std::int64_t cx = CellX(p.x_m), cy = CellY(p.y_m);
    if (cx < -1 || cy < -1 || cx > nx_ || cy > ny_) return -1;
    int best = -1;
    double best_d2 = r * r;
    for (std::int64_t x = std::max<std::int64_t>(cx - 1, 0); x <= std::min(cx + 1, nx_ - 1); ++x) {
      for (std::int64_t y = std::max<std::int64_t>(cy - 1, 0); y <= std::min(cy + 1, ny_ - 1);
           ++y) {
        const std::size_t c = std::size_t(x * ny_ + y);
        for (int k = start_[c]; k < start_[c + 1]; ++k) {
          const int i = index_[std::size_t(k)];
          const double ex = points_[std::size_t(i)].x_m - p.x_m,
                       ey = points_[std::size_t(i)].y_m - p.y_m;
          const double d2 = ex * ex + ey * ey;
          if (d2 <= best_d2) best_d2 = d2, best = i;
        }
      }
    }
    return best;
  }

 private:
  std::int64_t CellX(double v) const {
    return static_cast<std::int64_t>(std::floor((v - x0_) / cell_));
  }
  std::int64_t CellY(double v) const {
    return static_cast<std::int64_t>(std::floor((v - y0_) / cell_));
  }
  const std::vector<Point2>& points_;
  double cell_;
  double x0_ = 0.0, y0_ = 0.0;
  std::int64_t nx_ = 1, ny_ = 1;
  std::vector<int> start_, index_;
};

// Inlier pairs of T_a_b: each b point to its nearest a point within r, an a point used once
// (the closer b point keeps it).
std::vector<std::pair<int, int>> Inliers(const Grid& grid, const std::vector<Point2>& a,
                                         const std::vector<Point2>& b, const Pose2& T, double r) {
  std::vector<int> owner(a.size(), -1);
  std::vector<double> owner_d2(a.size(), 0.0);
  for (std::size_t k = 0; k < b.size(); ++k) {
    const Point2 p = Apply(T, b[k]);
    const int i = grid.Nearest(p, r);
    if (i < 0) continue;
    const double ex = a[i].x_m - p.x_m, ey = a[i].y_m - p.y_m, d2 = ex * ex + ey * ey;
    if (owner[i] < 0 || d2 < owner_d2[i]) owner[i] = int(k), owner_d2[i] = d2;
  }
  std::vector<std::pair<int, int>> out;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (owner[i] >= 0) out.emplace_back(int(i), owner[i]);
  }
  return out;
}

// Support of T_a_b: b points with an a point within r, each a point counted once (stamp[i]
// holds the last hypothesis that used a point i).
// Stops early (returning a lower bound) once even every remaining b point could not bring it
// to `needed`.
int Support(const Grid& grid, const std::vector<Point2>& b, const Pose2& T, double r, int tag,
            std::vector<int>* stamp, int needed) {
  int n = 0;
  const int m = int(b.size());
  for (int k = 0; k < m; ++k) {
    if (n + (m - k) < needed) return n;
    const int i = grid.Nearest(Apply(T, b[std::size_t(k)]), r);
    if (i >= 0 && (*stamp)[std::size_t(i)] != tag) (*stamp)[std::size_t(i)] = tag, ++n;
  }
  return n;
}

struct Hypothesis {
  int support = 0;
  Pose2 T;
};

}  // namespace

LandmarkMatchResult MatchLandmarkPoints(const std::vector<Point2>& a_in,
                                        const std::vector<Point2>& b_in,
                                        const LandmarkMatchOptions& o) {
  LandmarkMatchResult out;
  const std::size_t cap = static_cast<std::size_t>(std::max(o.max_points, 2));
  const std::vector<Point2> a(a_in.begin(), a_in.begin() + std::min(a_in.size(), cap));
  const std::vector<Point2> b(b_in.begin(), b_in.begin() + std::min(b_in.size(), cap));
  if (a.size() < 2 || b.size() < 2 || !(o.tolerance_m > 0.0)) return out;
  const Grid grid(a, o.tolerance_m);
  // b's pairs sorted by distance, for the distance test by binary search.
  struct Pair {
    double d;
    int k, l;
  };
  std::vector<Pair> pairs_b;
  for (int k = 0; k < int(b.size()); ++k) {
    for (int l = k + 1; l < int(b.size()); ++l) {
      pairs_b.push_back({std::hypot(b[l].x_m - b[k].x_m, b[l].y_m - b[k].y_m), k, l});
    }
  }
  std::sort(pairs_b.begin(), pairs_b.end(), [](const Pair& x, const Pair& y) {
    return x.d < y.d || (x.d == y.d && (x.k < y.k || (x.k == y.k && x.l < y.l)));
  });
  const bool prior = o.yaw_prior_rad && o.max_yaw_gap_rad > 0.0;
  std::vector<Hypothesis> kept;  // support >= 3
  std::vector<int> stamp(a.size(), 0);
  Hypothesis best;
  for (int i = 0; i < int(a.size()); ++i) {
    for (int j = i + 1; j < int(a.size()); ++j) {
      const double ax = a[j].x_m - a[i].x_m, ay = a[j].y_m - a[i].y_m;
      const double d = std::hypot(ax, ay);
      if (d < o.min_pair_distance_m || d > o.max_pair_distance_m) continue;
      auto it = std::lower_bound(pairs_b.begin(), pairs_b.end(), d - o.tolerance_m,
                                 [](const Pair& p, double v) { return p.d < v; });
      for (; it != pairs_b.end() && it->d <= d + o.tolerance_m; ++it) {
        for (const bool flip : {false, true}) {  // k -> i, l -> j, or l -> i, k -> j
          const Point2& bk = b[flip ? it->l : it->k];
          const Point2& bl = b[flip ? it->k : it->l];
          const double yaw = std::atan2(ay, ax) - std::atan2(bl.y_m - bk.y_m, bl.x_m - bk.x_m);
          if (prior && std::abs(Wrap(yaw - *o.yaw_prior_rad)) > o.max_yaw_gap_rad) continue;
          const double c = std::cos(yaw), s = std::sin(yaw);
          const double mx = 0.5 * (bk.x_m + bl.x_m), my = 0.5 * (bk.y_m + bl.y_m);
          const Pose2 T{0.5 * (a[i].x_m + a[j].x_m) - (c * mx - s * my),
                        0.5 * (a[i].y_m + a[j].y_m) - (s * mx + c * my), Wrap(yaw)};
          // Hypotheses under half the best cannot matter (as the answer or as its runner-up
          // under any ambiguity limit >= 0.5): scored only far enough to know that.
          const int needed = std::max(3, best.support / 2);
          const int support = Support(grid, b, T, o.tolerance_m, ++out.hypotheses, &stamp, needed);
          if (support < 2) continue;
          if (support >= 3) kept.push_back({support, T});
          if (support > best.support) best = {support, T};
        }
      }
    }
  }
  if (best.support < 2) return out;
  // Refine: least squares on the inliers, re-scored (kept when it does not lose support).
  auto pairs = Inliers(grid, a, b, best.T, o.tolerance_m);
  std::vector<Point2> src, dst;
  for (const auto& [i, k] : pairs) src.push_back(b[k]), dst.push_back(a[i]);
  if (const auto fit = msgs::FitRigid2d(src, dst)) {
    const auto refined = Inliers(grid, a, b, *fit, o.tolerance_m);
    if (refined.size() >= pairs.size()) best.T = *fit, pairs = refined;
  }
  out.found = true;
  out.T_a_b = best.T;
  out.T_a_b.yaw_rad = Wrap(out.T_a_b.yaw_rad);
  out.pairs = pairs;
  out.support = int(pairs.size());
  double sum2 = 0.0;
  for (const auto& [i, k] : pairs) {
    const Point2 p = Apply(out.T_a_b, b[k]);
    sum2 += (p.x_m - a[i].x_m) * (p.x_m - a[i].x_m) + (p.y_m - a[i].y_m) * (p.y_m - a[i].y_m);
  }
  out.rmse_m = pairs.empty() ? 0.0 : std::sqrt(sum2 / double(pairs.size()));
  // Runner-up: the best hypothesis that places b's centroid elsewhere or turns it otherwise.
  Point2 cb{0.0, 0.0};
  for (const auto& p : b) cb.x_m += p.x_m / double(b.size()), cb.y_m += p.y_m / double(b.size());
  const Point2 at = Apply(out.T_a_b, cb);
  for (const Hypothesis& h : kept) {
    if (h.support <= out.runner_up_support) continue;
    const Point2 q = Apply(h.T, cb);
    const bool distinct = std::hypot(q.x_m - at.x_m, q.y_m - at.y_m) > o.distinct_m ||
                          std::abs(Wrap(h.T.yaw_rad - out.T_a_b.yaw_rad)) > o.distinct_rad;
    if (distinct) out.runner_up_support = h.support;
  }
  return out;
}

}  // namespace draco::objects
