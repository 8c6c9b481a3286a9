// SE(2) poses and 3x3 matrices as plain values (no Eigen in the public API, so these
// cross threads and headers freely). Transforms are named by frames: T_a_b maps
// coordinates in frame b to frame a, so T_a_c = Compose(T_a_b, T_b_c).
#pragma once

#include <array>
#include <cmath>
#include <numbers>

namespace draco::pose_graph {

// Wraps an angle to [-pi, pi).
inline double NormalizeAngle(double angle_rad) {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  return angle_rad - kTwoPi * std::floor((angle_rad + std::numbers::pi) / kTwoPi);
}

struct Pose2 {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

// T_a_c = T_a_b * T_b_c.
inline Pose2 Compose(const Pose2& T_a_b, const Pose2& T_b_c) {
  const double c = std::cos(T_a_b.yaw_rad), s = std::sin(T_a_b.yaw_rad);
  return {T_a_b.x_m + c * T_b_c.x_m - s * T_b_c.y_m, T_a_b.y_m + s * T_b_c.x_m + c * T_b_c.y_m,
          NormalizeAngle(T_a_b.yaw_rad + T_b_c.yaw_rad)};
}

// T_b_a from T_a_b.
inline Pose2 Inverse(const Pose2& T_a_b) {
  const double c = std::cos(T_a_b.yaw_rad), s = std::sin(T_a_b.yaw_rad);
  return {-c * T_a_b.x_m - s * T_a_b.y_m, s * T_a_b.x_m - c * T_a_b.y_m,
          NormalizeAngle(-T_a_b.yaw_rad)};
}

// T_a_b from T_w_a and T_w_b.
inline Pose2 Between(const Pose2& T_w_a, const Pose2& T_w_b) {
  return Compose(Inverse(T_w_a), T_w_b);
}

// A point (landmark) in the plane.
struct Point2 {
  double x_m = 0.0;
  double y_m = 0.0;
};

// p_a = T_a_b * p_b.
inline Point2 Transform(const Pose2& T_a_b, const Point2& p_b) {
  const double c = std::cos(T_a_b.yaw_rad), s = std::sin(T_a_b.yaw_rad);
  return {T_a_b.x_m + c * p_b.x_m - s * p_b.y_m, T_a_b.y_m + s * p_b.x_m + c * p_b.y_m};
}

// Row-major 2x2 matrix over (x, y).
using Matrix2 = std::array<double, 4>;

// Row-major 3x3 matrix over (x, y, yaw).
using Matrix3 = std::array<double, 9>;

inline Matrix3 Diagonal3(double a, double b, double c) { return {a, 0, 0, 0, b, 0, 0, 0, c}; }

// Information matrix diag(1/sigma^2) from standard deviations (x_m, y_m, yaw_rad).
inline Matrix3 InformationFromSigmas(double sigma_x_m, double sigma_y_m, double sigma_yaw_rad) {
  return Diagonal3(1.0 / (sigma_x_m * sigma_x_m), 1.0 / (sigma_y_m * sigma_y_m),
                   1.0 / (sigma_yaw_rad * sigma_yaw_rad));
}

}  // namespace draco::pose_graph
