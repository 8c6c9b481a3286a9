// Covariances of a solved PoseGraph2d (pose_graph_2d.hpp): relative covariances of pose pairs
// (propagated from Ceres' marginals into the relative pose's local frame) and the marginal
// covariance of one pose.
#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <utility>
#include <vector>

#include <ceres/covariance.h>
#include <Eigen/Core>

#include "draco/pose_graph/pose_graph_2d.hpp"
#include "pose_graph_impl.hpp"

namespace draco::pose_graph {
namespace {

using Mat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

}  // namespace

std::vector<Matrix3> PoseGraph2d::RelativeCovariances(
    std::span<const std::pair<PoseId, PoseId>> pairs) {
  auto& m = *impl_;
  m.SyncProblem();
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::SPARSE_QR;
  co.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  co.num_threads = 2;
  ceres::Covariance covariance(co);
  std::vector<std::pair<const double*, const double*>> blocks;
  auto add_block = [&](const double* a, const double* b) {
    const std::pair<const double*, const double*> key = a <= b ? std::pair{a, b} : std::pair{b, a};
    if (std::find(blocks.begin(), blocks.end(), key) == blocks.end()) blocks.push_back(key);
  };
  for (const auto& [i, j] : pairs) {
    m.RequireFactors(i);
    m.RequireFactors(j);
    const double* a = m.nodes[m.Index(i)].x.data();
    const double* b = m.nodes[m.Index(j)].x.data();
    add_block(a, a);
    add_block(b, b);
    if (a != b) add_block(a, b);
  }
  if (!covariance.Compute(blocks, m.problem.get())) {
    throw std::runtime_error("covariance: the pose graph is rank-deficient (unconstrained poses?)");
  }
  std::vector<Matrix3> result;
  result.reserve(pairs.size());
  for (const auto& [i, j] : pairs) {
    const double* a = m.nodes[m.Index(i)].x.data();
    const double* b = m.nodes[m.Index(j)].x.data();
    Mat3 saa, sbb, sab;
    covariance.GetCovarianceBlock(a, a, saa.data());
    covariance.GetCovarianceBlock(b, b, sbb.data());
    covariance.GetCovarianceBlock(a, b, sab.data());
    // T_i_j = (R_a^T (p_b - p_a), yaw_b - yaw_a); local frame: rotate by R_b^T = R_ij^T R_a^T.
    const double ca = std::cos(a[2]), sa = std::sin(a[2]);
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    // Jacobians of the parameters of T_i_j w.r.t. a and b.
    Mat3 Ja, Jb;
    Ja << -ca, -sa, -sa * dx + ca * dy,  //
        sa, -ca, -ca * dx - sa * dy,     //
        0, 0, -1;
    Jb << ca, sa, 0,  //
        -sa, ca, 0,   //
        0, 0, 1;
    // Right perturbation of T_i_j: d_t = R_ij^T * (change of its translation).
    const double yij = b[2] - a[2];
    const double cij = std::cos(yij), sij = std::sin(yij);
    Mat3 G;
    G << cij, sij, 0, -sij, cij, 0, 0, 0, 1;
    const Mat3 A = G * Ja, B = G * Jb;
    const Mat3 cov = A * saa * A.transpose() + A * sab * B.transpose() +
                     B * sab.transpose() * A.transpose() + B * sbb * B.transpose();
    Matrix3 out;
    for (int k = 0; k < 9; ++k) out[k] = 0.5 * (cov(k / 3, k % 3) + cov(k % 3, k / 3));
    result.push_back(out);
  }
  return result;
}

Matrix3 PoseGraph2d::RelativeCovariance(PoseId i, PoseId j) {
  const std::pair<PoseId, PoseId> pair{i, j};
  return RelativeCovariances(std::span(&pair, 1)).front();
}

Matrix3 PoseGraph2d::MarginalCovariance(PoseId id) {
  auto& m = *impl_;
  m.RequireFactors(id);
  m.SyncProblem();
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::SPARSE_QR;
  co.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  ceres::Covariance covariance(co);
  const double* x = m.nodes[m.Index(id)].x.data();
  const std::vector<std::pair<const double*, const double*>> blocks{{x, x}};
  if (!covariance.Compute(blocks, m.problem.get())) {
    throw std::runtime_error("covariance: the pose graph is rank-deficient (unconstrained poses?)");
  }
  Matrix3 out;
  covariance.GetCovarianceBlock(x, x, out.data());
  return out;
}

}  // namespace draco::pose_graph
