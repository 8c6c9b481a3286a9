// 2D ray intersections used by the sonar ray caster.
//
// The world is 2.5D: every primitive is a vertical prism (a footprint in the horizontal
// plane and a height range), so a 3D ray's hits follow from the 2D intersection of its
// horizontal direction with the footprint (an interval of horizontal distance s) and the
// ray's height z(s) = z0 + s * tan(elevation), handled analytically.
#pragma once

#include <cmath>
#include <vector>

namespace draco::sim {

struct Vec2 {
  double x = 0.0;
  double y = 0.0;
};

inline Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
inline Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
inline Vec2 operator*(double k, Vec2 a) { return {k * a.x, k * a.y}; }
inline double Dot(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
inline double Cross(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }
inline double Norm(Vec2 a) { return std::hypot(a.x, a.y); }

// Angle wrapped to (-pi, pi].
double WrapAngle(double angle_rad);

// Where a ray origin + s * dir (dir unit length) is inside a footprint: s in [s_in, s_out],
// with normal_in the outward unit normal of the boundary at s_in. s_in may be negative when
// the origin is inside the footprint.
struct RayInterval {
  double s_in = 0.0;
  double s_out = 0.0;
  Vec2 normal_in;
};

// Circle (a pile). False when the ray's line misses the circle or the circle is behind.
bool IntersectRayCircle(Vec2 origin, Vec2 dir, Vec2 center, double radius, RayInterval* out);

// Segment a-b (a wall of zero thickness, hit from either side): s_in == s_out, the normal
// faces the ray. False when missed or behind.
bool IntersectRaySegment(Vec2 origin, Vec2 dir, Vec2 a, Vec2 b, RayInterval* out);

// Convex polygon, vertices counter-clockwise (Cyrus-Beck clipping). False when missed or
// behind.
bool IntersectRayConvexPolygon(Vec2 origin, Vec2 dir, const std::vector<Vec2>& vertices_ccw,
                               RayInterval* out);

// Oriented box as 4 counter-clockwise vertices.
std::vector<Vec2> BoxVertices(Vec2 center, double length_m, double width_m, double yaw_rad);

// Signed area (positive when counter-clockwise).
double SignedArea(const std::vector<Vec2>& polygon);
bool IsConvex(const std::vector<Vec2>& polygon);

}  // namespace draco::sim
