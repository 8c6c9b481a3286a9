// SE(2) helpers for the consistency filters: composition, inverse and the error of a pose
// as (dx, dy, dtheta), with their Jacobians and first-order covariance propagation.
//
// Poses are msgs::Pose2 (x_m, y_m, yaw_rad). T_a_b maps frame b to frame a; Compose(T_a_b,
// T_b_c) = T_a_c. Covariances are of the three parameters as additive perturbations
// (x + dx, y + dy, yaw + dyaw), the same convention as the Ceres pose_graph_2d example, so a
// pose graph's marginals can be passed unchanged. Jacobians are d(output params) /
// d(input params) in that convention.
#pragma once

#include <Eigen/Core>

#include "draco/msgs/slam.hpp"

namespace draco::consistency {

using msgs::Pose2;

// Angle wrapped to (-pi, pi].
double WrapAngle(double angle_rad);

// T_a_c = T_a_b * T_b_c; optional Jacobians with respect to a and b.
Pose2 Compose(const Pose2& a, const Pose2& b, Eigen::Matrix3d* J_a = nullptr,
              Eigen::Matrix3d* J_b = nullptr);

// T_b_a from T_a_b; optional Jacobian.
Pose2 Inverse(const Pose2& a, Eigen::Matrix3d* J = nullptr);

// inv(a) * b, the pose of b in a's frame.
Pose2 Between(const Pose2& a, const Pose2& b);

// Error vector of a pose that should be the identity: (x, y, wrapped yaw). This is the
// reference's error (not the exact SE(2) logarithm; the two agree to first order).
Eigen::Vector3d ErrorVector(const Pose2& e);

// Row-major 3x3 <-> Eigen.
Eigen::Matrix3d ToMatrix(const msgs::Covariance3& c);
msgs::Covariance3 FromMatrix(const Eigen::Matrix3d& m);

// A pose with the covariance of its parameters.
struct UncertainPose {
  Pose2 pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

// First-order propagation; the operands are assumed independent.
UncertainPose Compose(const UncertainPose& a, const UncertainPose& b);
UncertainPose Inverse(const UncertainPose& a);

}  // namespace draco::consistency
