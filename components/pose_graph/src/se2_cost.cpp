#include "se2_cost.hpp"

#include <algorithm>
#include <cmath>

#include <ceres/autodiff_cost_function.h>
#include <stdexcept>

namespace draco::pose_graph::internal {

std::array<double, 9> SqrtInformation(const Matrix3& m) {
  const double asym = std::abs(m[1] - m[3]) + std::abs(m[2] - m[6]) + std::abs(m[5] - m[7]);
  const double scale = std::abs(m[0]) + std::abs(m[4]) + std::abs(m[8]);
  if (!(asym <= 1e-9 * scale)) throw std::invalid_argument("information matrix is not symmetric");
  // Omega = L^T L with L upper triangular: L = U where Omega = U^T U (Cholesky, upper form).
  const double u00_sq = m[0];
  if (!(u00_sq > 0.0)) throw std::invalid_argument("information matrix is not positive definite");
  const double u00 = std::sqrt(u00_sq);
  const double u01 = m[1] / u00;
  const double u02 = m[2] / u00;
  const double u11_sq = m[4] - u01 * u01;
  if (!(u11_sq > 0.0)) throw std::invalid_argument("information matrix is not positive definite");
  const double u11 = std::sqrt(u11_sq);
  const double u12 = (m[5] - u01 * u02) / u11;
  const double u22_sq = m[8] - u02 * u02 - u12 * u12;
  if (!(u22_sq > 0.0)) throw std::invalid_argument("information matrix is not positive definite");
  return {u00, u01, u02, 0.0, u11, u12, 0.0, 0.0, std::sqrt(u22_sq)};
}

bool Pose2Manifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  x_plus_delta[0] = x[0] + delta[0];
  x_plus_delta[1] = x[1] + delta[1];
  x_plus_delta[2] = NormalizeAngle(x[2] + delta[2]);
  return true;
}

bool Pose2Manifold::PlusJacobian(const double*, double* jacobian) const {
  for (int k = 0; k < 9; ++k) jacobian[k] = (k % 4 == 0) ? 1.0 : 0.0;
  return true;
}

bool Pose2Manifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  y_minus_x[0] = y[0] - x[0];
  y_minus_x[1] = y[1] - x[1];
  y_minus_x[2] = NormalizeAngle(y[2] - x[2]);
  return true;
}

bool Pose2Manifold::MinusJacobian(const double*, double* jacobian) const {
  for (int k = 0; k < 9; ++k) jacobian[k] = (k % 4 == 0) ? 1.0 : 0.0;
  return true;
}

namespace {

// out = L * in for the upper-triangular L (row-major).
inline void ApplyUpper(const std::array<double, 9>& L, const double* in, double* out) {
  out[0] = L[0] * in[0] + L[1] * in[1] + L[2] * in[2];
  out[1] = L[4] * in[1] + L[5] * in[2];
  out[2] = L[8] * in[2];
}

// jacobian (3x3 row-major) = L * J.
inline void WhitenJacobian(const std::array<double, 9>& L, const double* J, double* out) {
  for (int c = 0; c < 3; ++c) {
    const double col[3] = {J[c], J[3 + c], J[6 + c]};
    double w[3];
    ApplyUpper(L, col, w);
    out[c] = w[0];
    out[3 + c] = w[1];
    out[6 + c] = w[2];
  }
}

}  // namespace

BetweenCost::BetweenCost(const Pose2& z, const Matrix3& information, ErrorConvention convention)
    : zyaw_(z.yaw_rad),
      frame_yaw_(convention == ErrorConvention::kG2o ? z.yaw_rad : 0.0),
      sqrt_info_(SqrtInformation(information)) {
  const double c = std::cos(frame_yaw_), s = std::sin(frame_yaw_);
  zt_rot_ = {c * z.x_m + s * z.y_m, -s * z.x_m + c * z.y_m};
}

bool BetweenCost::Evaluate(double const* const* parameters, double* residuals,
                           double** jacobians) const {
  const double* a = parameters[0];
  const double* b = parameters[1];
  const double phi = a[2] + frame_yaw_;
  const double c = std::cos(phi), s = std::sin(phi);
  const double dx = b[0] - a[0], dy = b[1] - a[1];
  const double e[3] = {c * dx + s * dy - zt_rot_[0], -s * dx + c * dy - zt_rot_[1],
                       NormalizeAngle(b[2] - a[2] - zyaw_)};
  ApplyUpper(sqrt_info_, e, residuals);
  if (jacobians == nullptr) return true;
  if (jacobians[0] != nullptr) {
    const double J[9] = {-c, -s, -s * dx + c * dy,  //
                         s,  -c, -c * dx - s * dy,  //
                         0,  0,  -1};
    WhitenJacobian(sqrt_info_, J, jacobians[0]);
  }
  if (jacobians[1] != nullptr) {
    const double J[9] = {c, s, 0, -s, c, 0, 0, 0, 1};
    WhitenJacobian(sqrt_info_, J, jacobians[1]);
  }
  return true;
}

PriorCost::PriorCost(const Pose2& z, const Matrix3& information, ErrorConvention convention)
    : z_(z),
      frame_yaw_(convention == ErrorConvention::kG2o ? z.yaw_rad : 0.0),
      sqrt_info_(SqrtInformation(information)) {}

bool PriorCost::Evaluate(double const* const* parameters, double* residuals,
                         double** jacobians) const {
  const double* a = parameters[0];
  const double c = std::cos(frame_yaw_), s = std::sin(frame_yaw_);
  const double dx = a[0] - z_.x_m, dy = a[1] - z_.y_m;
  const double e[3] = {c * dx + s * dy, -s * dx + c * dy, NormalizeAngle(a[2] - z_.yaw_rad)};
  ApplyUpper(sqrt_info_, e, residuals);
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    const double J[9] = {c, s, 0, -s, c, 0, 0, 0, 1};
    WhitenJacobian(sqrt_info_, J, jacobians[0]);
  }
  return true;
}

YawGaussMarkovCost::YawGaussMarkovCost(double phi, double sigma_rad)
    : phi_(phi), inv_sigma_(1.0 / sigma_rad) {
  if (!(std::abs(phi) <= 1.0)) throw std::invalid_argument("yaw Gauss-Markov: |phi| must be <= 1");
  if (!(sigma_rad > 0.0)) throw std::invalid_argument("yaw Gauss-Markov: sigma must be positive");
}

bool YawGaussMarkovCost::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const double* m = parameters[0];
  const double* b = parameters[1];
  const double* c = parameters[2];
  residuals[0] = inv_sigma_ * (NormalizeAngle(c[2] - m[2]) - phi_ * NormalizeAngle(b[2] - m[2]));
  if (jacobians == nullptr) return true;
  const double d[3] = {(phi_ - 1.0) * inv_sigma_, -phi_ * inv_sigma_, inv_sigma_};
  for (int block = 0; block < 3; ++block) {
    if (jacobians[block] == nullptr) continue;
    jacobians[block][0] = 0.0;
    jacobians[block][1] = 0.0;
    jacobians[block][2] = d[block];
  }
  return true;
}

double YawGaussMarkovError(const Pose2& m, const Pose2& b, const Pose2& c, double phi) {
  return NormalizeAngle(c.yaw_rad - m.yaw_rad) - phi * NormalizeAngle(b.yaw_rad - m.yaw_rad);
}

std::array<double, 3> BetweenError(const Pose2& a, const Pose2& b, const Pose2& z,
                                   ErrorConvention convention) {
  const double frame_yaw = convention == ErrorConvention::kG2o ? z.yaw_rad : 0.0;
  const double phi = a.yaw_rad + frame_yaw;
  const double c = std::cos(phi), s = std::sin(phi);
  const double cz = std::cos(frame_yaw), sz = std::sin(frame_yaw);
  const double dx = b.x_m - a.x_m, dy = b.y_m - a.y_m;
  return {c * dx + s * dy - (cz * z.x_m + sz * z.y_m),
          -s * dx + c * dy - (-sz * z.x_m + cz * z.y_m),
          NormalizeAngle(b.yaw_rad - a.yaw_rad - z.yaw_rad)};
}

std::array<double, 3> PriorError(const Pose2& a, const Pose2& z, ErrorConvention convention) {
  const double frame_yaw = convention == ErrorConvention::kG2o ? z.yaw_rad : 0.0;
  const double c = std::cos(frame_yaw), s = std::sin(frame_yaw);
  const double dx = a.x_m - z.x_m, dy = a.y_m - z.y_m;
  return {c * dx + s * dy, -s * dx + c * dy, NormalizeAngle(a.yaw_rad - z.yaw_rad)};
}

std::array<double, 3> SqrtInformation2(const Matrix2& m) {
  const double scale = std::abs(m[0]) + std::abs(m[3]);
  if (!(std::abs(m[1] - m[2]) <= 1e-9 * scale)) {
    throw std::invalid_argument("information matrix is not symmetric");
  }
  if (!(m[0] > 0.0)) throw std::invalid_argument("information matrix is not positive definite");
  const double l0 = std::sqrt(m[0]);
  const double l1 = m[1] / l0;
  const double l2_sq = m[3] - l1 * l1;
  if (!(l2_sq > 0.0)) throw std::invalid_argument("information matrix is not positive definite");
  return {l0, l1, std::sqrt(l2_sq)};
}

PointObservationCost::PointObservationCost(const Point2& p_i, const Matrix2& information)
    : z_(p_i), sqrt_info_(SqrtInformation2(information)) {}

bool PointObservationCost::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const double* a = parameters[0];
  const double* l = parameters[1];
  const double c = std::cos(a[2]), s = std::sin(a[2]);
  const double dx = l[0] - a[0], dy = l[1] - a[1];
  const double e[2] = {c * dx + s * dy - z_.x_m, -s * dx + c * dy - z_.y_m};
  const auto& L = sqrt_info_;
  residuals[0] = L[0] * e[0] + L[1] * e[1];
  residuals[1] = L[2] * e[1];
  if (jacobians == nullptr) return true;
  // Whitens a 2 x cols row-major Jacobian in place into out.
  auto whiten = [&](const double* J, int cols, double* out) {
    for (int col = 0; col < cols; ++col) {
      out[col] = L[0] * J[col] + L[1] * J[cols + col];
      out[cols + col] = L[2] * J[cols + col];
    }
  };
  if (jacobians[0] != nullptr) {
    const double J[6] = {-c, -s, -s * dx + c * dy,  //
                         s,  -c, -c * dx - s * dy};
    whiten(J, 3, jacobians[0]);
  }
  if (jacobians[1] != nullptr) {
    const double J[4] = {c, s, -s, c};
    whiten(J, 2, jacobians[1]);
  }
  return true;
}

namespace {

struct PointRadiusResidual {
  template <typename T>
  bool operator()(const T* a, const T* l, const T* rho, T* r) const {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const T c = cos(a[2]), s = sin(a[2]);
    const T dx = l[0] - a[0], dy = l[1] - a[1];
    const T cx = c * dx + s * dy, cy = -s * dx + c * dy;
    T norm = sqrt(cx * cx + cy * cy);
    if (norm < T(1e-6)) norm = T(1e-6);
    const T scale = T(1.0) - rho[0] / norm;
    const T e0 = cx * scale - T(z.x_m), e1 = cy * scale - T(z.y_m);
    r[0] = T(L[0]) * e0 + T(L[1]) * e1;
    r[1] = T(L[2]) * e1;
    return true;
  }
  Point2 z;
  std::array<double, 3> L;
};

struct RadiusPriorResidual {
  template <typename T>
  bool operator()(const T* rho, T* r) const {
    r[0] = (rho[0] - T(prior_m)) / T(sigma_m);
    return true;
  }
  double prior_m;
  double sigma_m;
};

}  // namespace

ceres::CostFunction* NewPointRadiusObservationCost(const Point2& p_i, const Matrix2& information) {
  return new ceres::AutoDiffCostFunction<PointRadiusResidual, 2, 3, 2, 1>(
      new PointRadiusResidual{p_i, SqrtInformation2(information)});
}

ceres::CostFunction* NewRadiusPriorCost(double prior_m, double sigma_m) {
  if (!(sigma_m > 0.0)) throw std::invalid_argument("radius prior sigma must be positive");
  return new ceres::AutoDiffCostFunction<RadiusPriorResidual, 1, 1>(
      new RadiusPriorResidual{prior_m, sigma_m});
}

std::array<double, 2> PointRadiusError(const Pose2& a, const Point2& l, double rho,
                                       const Point2& z) {
  const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
  const double dx = l.x_m - a.x_m, dy = l.y_m - a.y_m;
  const double cx = c * dx + s * dy, cy = -s * dx + c * dy;
  const double scale = 1.0 - rho / std::max(std::hypot(cx, cy), 1e-6);
  return {cx * scale - z.x_m, cy * scale - z.y_m};
}

std::array<double, 2> PointError(const Pose2& a, const Point2& l, const Point2& z) {
  const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
  const double dx = l.x_m - a.x_m, dy = l.y_m - a.y_m;
  return {c * dx + s * dy - z.x_m, -s * dx + c * dy - z.y_m};
}

double Chi2(const std::array<double, 2>& e, const Matrix2& m) {
  return e[0] * (m[0] * e[0] + m[1] * e[1]) + e[1] * (m[2] * e[0] + m[3] * e[1]);
}

double Chi2(const std::array<double, 3>& e, const Matrix3& m) {
  double sum = 0.0;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) sum += e[r] * m[3 * r + c] * e[c];
  return sum;
}

}  // namespace draco::pose_graph::internal
