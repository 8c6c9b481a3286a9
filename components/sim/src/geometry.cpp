#include "draco/sim/geometry.hpp"

#include <algorithm>
#include <limits>

namespace draco::sim {

double WrapAngle(double angle_rad) {
  double a = std::fmod(angle_rad + M_PI, 2.0 * M_PI);
  if (a <= 0.0) a += 2.0 * M_PI;
  return a - M_PI;
}

bool IntersectRayCircle(Vec2 origin, Vec2 dir, Vec2 center, double radius, RayInterval* out) {
  // |o + s d - c|^2 = r^2  ->  s^2 + 2 b s + c0 = 0 with b = d.(o - c).
  const Vec2 oc = origin - center;
  const double b = Dot(dir, oc);
  const double c0 = Dot(oc, oc) - radius * radius;
  const double disc = b * b - c0;
  if (disc < 0.0) return false;
  const double root = std::sqrt(disc);
  const double s_out = -b + root;
  if (s_out <= 0.0) return false;
  out->s_in = -b - root;
  out->s_out = s_out;
  const Vec2 hit = origin + out->s_in * dir;
  const Vec2 n = hit - center;
  const double len = Norm(n);
  out->normal_in = len > 0.0 ? (1.0 / len) * n : Vec2{-dir.x, -dir.y};
  return true;
}

bool IntersectRaySegment(Vec2 origin, Vec2 dir, Vec2 a, Vec2 b, RayInterval* out) {
  // origin + s dir = a + u (b - a), u in [0, 1].
  const Vec2 e = b - a;
  const double denom = Cross(dir, e);
  if (std::abs(denom) < 1e-12) return false;
  const Vec2 ao = a - origin;
  const double s = Cross(ao, e) / denom;
  const double u = Cross(ao, dir) / denom;
  if (s <= 0.0 || u < 0.0 || u > 1.0) return false;
  out->s_in = s;
  out->s_out = s;
  const double len = Norm(e);
  Vec2 n{e.y / len, -e.x / len};
  if (Dot(n, dir) > 0.0) n = -1.0 * n;
  out->normal_in = n;
  return true;
}

bool IntersectRayConvexPolygon(Vec2 origin, Vec2 dir, const std::vector<Vec2>& vertices_ccw,
                               RayInterval* out) {
  double s_enter = -std::numeric_limits<double>::infinity();
  double s_exit = std::numeric_limits<double>::infinity();
  Vec2 normal_enter{-dir.x, -dir.y};
  const std::size_t n = vertices_ccw.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 a = vertices_ccw[i];
    const Vec2 e = vertices_ccw[(i + 1) % n] - a;
    const double len = Norm(e);
    if (len <= 0.0) continue;
    const Vec2 normal{e.y / len, -e.x / len};  // outward for counter-clockwise order
    // Inside half-plane: normal . (p - a) <= 0 with p = origin + s dir.
    const double dist = Dot(normal, origin - a);
    const double rate = Dot(normal, dir);
    if (std::abs(rate) < 1e-15) {
      if (dist > 0.0) return false;
      continue;
    }
    const double s = -dist / rate;
    if (rate < 0.0) {
      if (s > s_enter) {
        s_enter = s;
        normal_enter = normal;
      }
    } else {
      s_exit = std::min(s_exit, s);
    }
    if (s_enter > s_exit) return false;
  }
  if (s_exit <= 0.0) return false;
  out->s_in = s_enter;
  out->s_out = s_exit;
  out->normal_in = normal_enter;
  return true;
}

std::vector<Vec2> BoxVertices(Vec2 center, double length_m, double width_m, double yaw_rad) {
  const Vec2 ax{std::cos(yaw_rad) * 0.5 * length_m, std::sin(yaw_rad) * 0.5 * length_m};
  const Vec2 ay{-std::sin(yaw_rad) * 0.5 * width_m, std::cos(yaw_rad) * 0.5 * width_m};
  return {center - ax - ay, center + ax - ay, center + ax + ay, center - ax + ay};
}

double SignedArea(const std::vector<Vec2>& polygon) {
  double area = 0.0;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    area += Cross(polygon[i], polygon[(i + 1) % polygon.size()]);
  }
  return 0.5 * area;
}

bool IsConvex(const std::vector<Vec2>& polygon) {
  const std::size_t n = polygon.size();
  if (n < 3) return false;
  int sign = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 e1 = polygon[(i + 1) % n] - polygon[i];
    const Vec2 e2 = polygon[(i + 2) % n] - polygon[(i + 1) % n];
    const double c = Cross(e1, e2);
    if (std::abs(c) < 1e-12) continue;
    const int s = c > 0 ? 1 : -1;
    if (sign == 0) sign = s;
    if (s != sign) return false;
  }
  return sign != 0;
}

}  // namespace draco::sim
