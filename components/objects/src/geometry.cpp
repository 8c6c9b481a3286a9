// Convex hull, minimum-area rectangle and rigid fit (see geometry.hpp).
#include "draco/objects/geometry.hpp"

#include "draco/msgs/rigid_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace draco::objects {
namespace {

double Cross(const Point2& o, const Point2& a, const Point2& b) {
  return (a.x_m - o.x_m) * (b.y_m - o.y_m) - (a.y_m - o.y_m) * (b.x_m - o.x_m);
}

}  // namespace

std::vector<Point2> ConvexHull(std::vector<Point2> points) {
  std::sort(points.begin(), points.end(), [](const Point2& a, const Point2& b) {
    return a.x_m < b.x_m || (a.x_m == b.x_m && a.y_m < b.y_m);
  });
  points.erase(std::unique(points.begin(), points.end(),
                           [](const Point2& a, const Point2& b) {
                             return a.x_m == b.x_m && a.y_m == b.y_m;
                           }),
               points.end());
  const std::size_t n = points.size();
  if (n < 3) return points;
  std::vector<Point2> hull(2 * n);
  std::size_t k = 0;
  for (std::size_t i = 0; i < n; ++i) {  // lower chain
    while (k >= 2 && Cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  for (std::size_t i = n - 1, lower = k + 1; i-- > 0;) {  // upper chain
    while (k >= lower && Cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);  // the last point repeats the first
  return hull;
}

Rectangle MinAreaRectangle(const std::vector<Point2>& points) {
  Rectangle best;
  if (points.empty()) return best;
  const std::vector<Point2> hull = ConvexHull(points);
  const std::size_t h = hull.size();
  if (h == 1) {
    best.center = hull[0];
    return best;
  }
  // For each hull edge direction u (normal v), the extents of the hull along u and v; the
  // extreme vertices advance monotonically around the hull (rotating calipers), so each
  // edge costs amortised O(1). For simplicity and robustness with h <= a few hundred, the
  // extents are found with the calipers' pointers and verified against neighbours.
  double best_area = std::numeric_limits<double>::infinity();
  std::size_t i_max_u = 0, i_min_u = 0, i_max_v = 0;
  auto dot = [&](std::size_t i, double ux, double uy) {
    return hull[i].x_m * ux + hull[i].y_m * uy;
  };
  auto advance = [&](std::size_t* idx, double ux, double uy, bool maximise) {
    // Move while the next vertex is better; the function along a convex polygon is unimodal.
    for (std::size_t steps = 0; steps < h; ++steps) {
      const std::size_t next = (*idx + 1) % h;
      const double d_next = dot(next, ux, uy), d_cur = dot(*idx, ux, uy);
      if (maximise ? d_next > d_cur : d_next < d_cur) {
        *idx = next;
      } else {
        break;
      }
    }
  };
  const std::size_t edges = h == 2 ? 1 : h;
  for (std::size_t e = 0; e < edges; ++e) {
    const Point2& p0 = hull[e];
    const Point2& p1 = hull[(e + 1) % h];
    const double dx = p1.x_m - p0.x_m, dy = p1.y_m - p0.y_m;
    const double len = std::hypot(dx, dy);
    if (len == 0.0) continue;
    const double ux = dx / len, uy = dy / len;  // along the edge
    const double vx = -uy, vy = ux;             // inward normal (hull is counter-clockwise)
    if (e == 0) {
      i_max_u = i_min_u = i_max_v = 0;
      for (std::size_t i = 0; i < h; ++i) {
        if (dot(i, ux, uy) > dot(i_max_u, ux, uy)) i_max_u = i;
        if (dot(i, ux, uy) < dot(i_min_u, ux, uy)) i_min_u = i;
        if (dot(i, vx, vy) > dot(i_max_v, vx, vy)) i_max_v = i;
      }
    } else {
      advance(&i_max_u, ux, uy, true);
      advance(&i_min_u, ux, uy, false);
      advance(&i_max_v, vx, vy, true);
    }
    const double u_min = dot(i_min_u, ux, uy), u_max = dot(i_max_u, ux, uy);
    const double v_min = dot(e, vx, vy), v_max = dot(i_max_v, vx, vy);
    const double su = u_max - u_min, sv = v_max - v_min;
    const double area = su * sv;
    // Equal areas (a triangle has up to three minimal rectangles): the squarer one, so
    // that the result does not depend on where the hull starts.
    const double tol = 1e-9 * area;
    const bool tie = std::abs(area - best_area) <= tol;
    if ((!tie && area < best_area) || (tie && std::max(su, sv) < best.length_m * (1.0 - 1e-9))) {
      best_area = area;
      const double cu = 0.5 * (u_min + u_max), cv = 0.5 * (v_min + v_max);
      best.center = {cu * ux + cv * vx, cu * uy + cv * vy};
      if (su >= sv) {
        best.length_m = su;
        best.breadth_m = sv;
        best.yaw_rad = std::atan2(uy, ux);
      } else {
        best.length_m = sv;
        best.breadth_m = su;
        best.yaw_rad = std::atan2(vy, vx);
      }
    }
  }
  // Direction of a line: fold into [0, pi).
  best.yaw_rad = std::fmod(best.yaw_rad + 2.0 * M_PI, M_PI);
  if (best.yaw_rad >= M_PI) best.yaw_rad -= M_PI;
  return best;
}

Point2 Transform(const Pose2& T, const Point2& p) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {T.x_m + c * p.x_m - s * p.y_m, T.y_m + s * p.x_m + c * p.y_m};
}

Pose2 FitRigid(const std::vector<Point2>& a, const std::vector<Point2>& b) {
  if (const auto T = msgs::FitRigid2d(b, a)) return *T;
  // One pair (or every point at one place): the translation between the centres.
  const std::size_t n = std::min(a.size(), b.size());
  if (n == 0) return {};
  double dx = 0, dy = 0;
  for (std::size_t i = 0; i < n; ++i) dx += a[i].x_m - b[i].x_m, dy += a[i].y_m - b[i].y_m;
  return {dx / double(n), dy / double(n), 0.0};
}

double NormalizeAngle(double a) {
  a = std::remainder(a, 2.0 * M_PI);
  if (a <= -M_PI) a += 2.0 * M_PI;
  return a;
}

}  // namespace draco::objects
