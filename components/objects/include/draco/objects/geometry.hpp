// Planar geometry for the object map and the matcher: convex hull, rotated minimum-area
// rectangle, and the least-squares rigid SE(2) fit between matched points.
#pragma once

#include <cstddef>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::objects {

using msgs::Point2;
using msgs::Pose2;

// Convex hull, counter-clockwise, no collinear points (Andrew's monotone chain).
// Fewer than 3 distinct points: the distinct points.
std::vector<Point2> ConvexHull(std::vector<Point2> points);

struct Rectangle {
  Point2 center;
  double length_m = 0.0;   // long side
  double breadth_m = 0.0;  // short side
  double yaw_rad = 0.0;    // direction of the long side, in [0, pi)
};

// Minimum-area enclosing rectangle: one side lies on a hull edge (Freeman and Shapira);
// rotating calipers over the hull edges. One point: zero size; collinear points: breadth 0.
Rectangle MinAreaRectangle(const std::vector<Point2>& points);

// p_a = T_a_b * p_b
Point2 Transform(const Pose2& T_a_b, const Point2& p_b);

// Least-squares rigid transform T_a_b with a[i] ~ T_a_b * b[i] (closed form, 2D Kabsch).
// Needs at least 2 pairs (1 pair: translation only).
Pose2 FitRigid(const std::vector<Point2>& a, const std::vector<Point2>& b);

double NormalizeAngle(double angle_rad);  // to (-pi, pi]

}  // namespace draco::objects
