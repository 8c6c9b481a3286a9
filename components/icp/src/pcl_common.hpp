// Conversions shared by the PCL back ends (pcl_*.cpp only): draco clouds as PCL clouds with
// z = 0, planar poses as 4x4 transforms and back (the SE(2) projection of backends.hpp).
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>
#include <cmath>

#include "backends.hpp"

namespace draco::icp::detail {

using PclCloud = pcl::PointCloud<pcl::PointXYZ>;

inline PclCloud::Ptr ToPcl(const Cloud2& points) {
  auto cloud = std::make_shared<PclCloud>();
  cloud->reserve(points.size());
  for (const auto& p : points) {
    cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f));
  }
  return cloud;
}

template <typename Scalar>
Eigen::Matrix<Scalar, 4, 4> ToMatrix(const msgs::Pose2& T) {
  Eigen::Matrix<Scalar, 4, 4> m = Eigen::Matrix<Scalar, 4, 4>::Identity();
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  m(0, 0) = static_cast<Scalar>(c);
  m(0, 1) = static_cast<Scalar>(-s);
  m(1, 0) = static_cast<Scalar>(s);
  m(1, 1) = static_cast<Scalar>(c);
  m(0, 3) = static_cast<Scalar>(T.x_m);
  m(1, 3) = static_cast<Scalar>(T.y_m);
  return m;
}

// SE(2) projection of a 3D rigid transform: x, y of its translation and the yaw of the
// planar rotation closest (Frobenius) to its xy block, atan2(r10 - r01, r00 + r11).
// Answers valid = false when the matrix is not finite.
template <typename Derived>
BackendAnswer Project(const Eigen::MatrixBase<Derived>& m, int iterations, bool converged,
                      int max_iterations) {
  BackendAnswer a;
  a.iterations = iterations;
  a.converged = converged && iterations < max_iterations;
  if (!m.allFinite()) return a;
  a.valid = true;
  a.T_target_source.x_m = static_cast<double>(m(0, 3));
  a.T_target_source.y_m = static_cast<double>(m(1, 3));
  a.T_target_source.yaw_rad =
      std::atan2(static_cast<double>(m(1, 0) - m(0, 1)), static_cast<double>(m(0, 0) + m(1, 1)));
  return a;
}

// Exposes Registration's iteration count (protected in PCL).
template <typename Base>
class Counted : public Base {
 public:
  int iterations() const { return this->nr_iterations_; }
};

}  // namespace draco::icp::detail
