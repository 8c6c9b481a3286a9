// Ceres pieces of the SE(2) pose graph (internal; tests include it for the gradient checker).
//
// Parameter block: (x, y, yaw) of T_world_pose. The manifold is R^2 x SO(2) with yaw kept
// in [-pi, pi): Plus(x, d) = (x + dx, y + dy, wrap(yaw + dyaw)), so the tangent space is the
// ambient one and both Jacobians are the identity.
//
// Between factor, measurement Z = (zx, zy, zyaw) = T_i_j, poses a = T_w_i, b = T_w_j
// (g2o EDGE_SE2):
//   e_t   = R(zyaw)^T * (R(a.yaw)^T * (b.p - a.p) - z.p) = R(a.yaw + zyaw)^T (b.p - a.p) -
//   R(zyaw)^T z.p e_yaw = wrap(b.yaw - a.yaw - zyaw) r = L * e, with Omega = L^T L (L upper
//   triangular, from the Cholesky factor of Omega).
// With phi = a.yaw + zyaw and d = b.p - a.p:
//   de_t/da.p = -R(phi)^T, de_t/db.p = R(phi)^T, de_t/da.yaw = dR(phi)^T/dphi * d,
//   de_yaw/da.yaw = -1, de_yaw/db.yaw = 1.
// Prior, measurement Z = T_w_i: e_t = R(zyaw)^T (a.p - z.p), e_yaw = wrap(a.yaw - zyaw).
//
// With ErrorConvention::kCeresExample the translation error is not rotated into Z's frame
// (zyaw is replaced by 0 in the rotations above): e_t = R(a.yaw)^T (b.p - a.p) - z.p for a
// between factor, a.p - z.p for a prior.
#pragma once

#include <array>

#include <ceres/cost_function.h>
#include <ceres/manifold.h>
#include <ceres/sized_cost_function.h>

#include "draco/pose_graph/pose_graph_2d.hpp"

namespace draco::pose_graph::internal {

// Upper-triangular L with L^T L = information; throws std::invalid_argument when the matrix is
// not symmetric positive definite.
std::array<double, 9> SqrtInformation(const Matrix3& information);

class Pose2Manifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 3; }
  int TangentSize() const override { return 3; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

class BetweenCost final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  BetweenCost(const Pose2& T_i_j, const Matrix3& information,
              ErrorConvention convention = ErrorConvention::kG2o);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double zyaw_;
  double frame_yaw_;              // zyaw (g2o) or 0 (Ceres example)
  std::array<double, 2> zt_rot_;  // R(frame_yaw)^T * z.p
  std::array<double, 9> sqrt_info_;
};

class PriorCost final : public ceres::SizedCostFunction<3, 3> {
 public:
  PriorCost(const Pose2& T_w_i, const Matrix3& information,
            ErrorConvention convention = ErrorConvention::kG2o);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Pose2 z_;
  double frame_yaw_;
  std::array<double, 9> sqrt_info_;
};

// Yaw Gauss-Markov factor on poses m (mean), b (previous), c (current):
//   r = (wrap(c.yaw - m.yaw) - phi * wrap(b.yaw - m.yaw)) / sigma,
//   dr/dm.yaw = (phi - 1) / sigma, dr/db.yaw = -phi / sigma, dr/dc.yaw = 1 / sigma, and 0 for
// every x, y.
class YawGaussMarkovCost final : public ceres::SizedCostFunction<1, 3, 3, 3> {
 public:
  YawGaussMarkovCost(double phi, double sigma_rad);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double phi_;
  double inv_sigma_;
};
// Its unwhitened error (wrap(c.yaw - m.yaw) - phi * wrap(b.yaw - m.yaw)).
double YawGaussMarkovError(const Pose2& m, const Pose2& b, const Pose2& c, double phi);

// Point observation: pose a = T_w_i, landmark l (world frame), measurement z = the landmark in
// frame i: e = R(a.yaw)^T (l - a.p) - z, r = L * e with Omega = L^T L (2x2).
//   de/da.p = -R^T, de/da.yaw = dR(a.yaw)^T/dyaw (l - a.p), de/dl = R^T.
class PointObservationCost final : public ceres::SizedCostFunction<2, 3, 2> {
 public:
  PointObservationCost(const Point2& p_i, const Matrix2& information);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Point2 z_;
  std::array<double, 3> sqrt_info_;  // L = [[l0, l1], [0, l2]]
};

// Point observation with a radius state rho (PointRadiusPrior): parameters a (3), l (2),
// rho (1); c = R(a.yaw)^T (l - a.p), e = c (1 - rho / |c|) - z, r = L * e. Automatic
// derivatives. |c| is floored at 1e-6 m.
ceres::CostFunction* NewPointRadiusObservationCost(const Point2& p_i, const Matrix2& information);
// Gaussian prior on rho: r = (rho - prior_m) / sigma_m.
ceres::CostFunction* NewRadiusPriorCost(double prior_m, double sigma_m);
std::array<double, 2> PointRadiusError(const Pose2& T_w_i, const Point2& l_w, double rho_m,
                                       const Point2& p_i);

// Upper-triangular L with L^T L = information (2x2, as l0, l1, l2 above); throws
// std::invalid_argument when the matrix is not symmetric positive definite.
std::array<double, 3> SqrtInformation2(const Matrix2& information);

// Unwhitened point-observation error R(a.yaw)^T (l - a.p) - z, and its chi2.
std::array<double, 2> PointError(const Pose2& T_w_i, const Point2& l_w, const Point2& p_i);
double Chi2(const std::array<double, 2>& e, const Matrix2& information);

// Unwhitened g2o errors (no Ceres), for chi2.
std::array<double, 3> BetweenError(const Pose2& T_w_i, const Pose2& T_w_j, const Pose2& T_i_j,
                                   ErrorConvention convention = ErrorConvention::kG2o);
std::array<double, 3> PriorError(const Pose2& T_w_i, const Pose2& z,
                                 ErrorConvention convention = ErrorConvention::kG2o);
double Chi2(const std::array<double, 3>& e, const Matrix3& information);

}  // namespace draco::pose_graph::internal
