// SE(2) helpers on msgs::Pose2 (x, y, yaw): composition, inverse, interpolation and
// first-order covariance propagation. T_a_b maps frame-b coordinates into frame a.
#pragma once

#include <cmath>

#include "draco/msgs/slam.hpp"

namespace draco::se2 {

using msgs::Covariance3;
using msgs::Point2;
using msgs::Pose2;

inline double WrapAngle(double a) { return std::remainder(a, 2.0 * M_PI); }

// T_a_c = T_a_b * T_b_c.
inline Pose2 Compose(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
  return Pose2{a.x_m + c * b.x_m - s * b.y_m, a.y_m + s * b.x_m + c * b.y_m,
               WrapAngle(a.yaw_rad + b.yaw_rad)};
}

inline Pose2 Inverse(const Pose2& a) {
  const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
  return Pose2{-c * a.x_m - s * a.y_m, s * a.x_m - c * a.y_m, WrapAngle(-a.yaw_rad)};
}

// T_a_b from T_w_a and T_w_b.
inline Pose2 Between(const Pose2& w_a, const Pose2& w_b) { return Compose(Inverse(w_a), w_b); }

inline Point2 Apply(const Pose2& T, const Point2& p) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return Point2{T.x_m + c * p.x_m - s * p.y_m, T.y_m + s * p.x_m + c * p.y_m};
}

// Linear in translation, shortest way in yaw; f in [0, 1].
inline Pose2 Interpolate(const Pose2& a, const Pose2& b, double f) {
  return Pose2{a.x_m + f * (b.x_m - a.x_m), a.y_m + f * (b.y_m - a.y_m),
               WrapAngle(a.yaw_rad + f * WrapAngle(b.yaw_rad - a.yaw_rad))};
}

inline double Translation(const Pose2& a) { return std::hypot(a.x_m, a.y_m); }

// Covariance of T_a_c = T_a_b * T_b_c from independent covariances of its factors
// (first order, perturbations in the local frame of each pose):
// Covariances are of a right perturbation T = T_hat * Exp(delta), delta = (x, y, yaw) in the
// pose's own frame. T_a_b Exp(d1) T_b_c Exp(d2) = T_a_c Exp(Ad(T_b_c^-1) d1 + d2), so
//   S_ac = J S_ab J^T + S_bc,  J = Ad(T_c_b) = [R^T, (s x - c y, c x + s y)^T; 0, 1]
// with (x, y) and R = R(yaw) = [c -s; s c] of T_b_c.
inline Covariance3 ComposeCovariance(const Covariance3& s_ab, const Pose2& b_c,
                                     const Covariance3& s_bc) {
  const double c = std::cos(b_c.yaw_rad), s = std::sin(b_c.yaw_rad);
  const double x = b_c.x_m, y = b_c.y_m;
  const double j1[9] = {c, s, s * x - c * y, -s, c, c * x + s * y, 0, 0, 1};
  double out[9] = {0};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double v = 0.0;
      for (int k = 0; k < 3; ++k) {
        for (int l = 0; l < 3; ++l) v += j1[i * 3 + k] * s_ab[k * 3 + l] * j1[j * 3 + l];
      }
      out[i * 3 + j] = v + s_bc[i * 3 + j];
    }
  }
  Covariance3 r;
  for (int i = 0; i < 9; ++i) r[i] = out[i];
  return r;
}

}  // namespace draco::se2
