#include "draco/consistency/se2.hpp"

#include <cmath>
#include <numbers>

namespace draco::consistency {

double WrapAngle(double angle_rad) {
  double a = std::remainder(angle_rad, 2.0 * std::numbers::pi);
  if (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

Pose2 Compose(const Pose2& a, const Pose2& b, Eigen::Matrix3d* J_a, Eigen::Matrix3d* J_b) {
  const double c = std::cos(a.yaw_rad);
  const double s = std::sin(a.yaw_rad);
  const double rx = c * b.x_m - s * b.y_m;  // R(a) * t(b)
  const double ry = s * b.x_m + c * b.y_m;
  if (J_a != nullptr) {
    *J_a << 1.0, 0.0, -ry,  //
        0.0, 1.0, rx,       //
        0.0, 0.0, 1.0;
  }
  if (J_b != nullptr) {
    *J_b << c, -s, 0.0,  //
        s, c, 0.0,       //
        0.0, 0.0, 1.0;
  }
  return {a.x_m + rx, a.y_m + ry, WrapAngle(a.yaw_rad + b.yaw_rad)};
}

Pose2 Inverse(const Pose2& a, Eigen::Matrix3d* J) {
  const double c = std::cos(a.yaw_rad);
  const double s = std::sin(a.yaw_rad);
  // inv(a) = (-R^T t, -yaw).
  const double ix = -c * a.x_m - s * a.y_m;
  const double iy = s * a.x_m - c * a.y_m;
  if (J != nullptr) {
    *J << -c, -s, iy,  //
        s, -c, -ix,    //
        0.0, 0.0, -1.0;
  }
  return {ix, iy, WrapAngle(-a.yaw_rad)};
}

Pose2 Between(const Pose2& a, const Pose2& b) { return Compose(Inverse(a), b); }

Eigen::Vector3d ErrorVector(const Pose2& e) { return {e.x_m, e.y_m, WrapAngle(e.yaw_rad)}; }

Eigen::Matrix3d ToMatrix(const msgs::Covariance3& c) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) m(r, k) = c[static_cast<std::size_t>(3 * r + k)];
  }
  return m;
}

msgs::Covariance3 FromMatrix(const Eigen::Matrix3d& m) {
  msgs::Covariance3 c{};
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) c[static_cast<std::size_t>(3 * r + k)] = m(r, k);
  }
  return c;
}

UncertainPose Compose(const UncertainPose& a, const UncertainPose& b) {
  Eigen::Matrix3d J_a;
  Eigen::Matrix3d J_b;
  UncertainPose out;
  out.pose = Compose(a.pose, b.pose, &J_a, &J_b);
  out.covariance = J_a * a.covariance * J_a.transpose() + J_b * b.covariance * J_b.transpose();
  return out;
}

UncertainPose Inverse(const UncertainPose& a) {
  Eigen::Matrix3d J;
  UncertainPose out;
  out.pose = Inverse(a.pose, &J);
  out.covariance = J * a.covariance * J.transpose();
  return out;
}

}  // namespace draco::consistency
