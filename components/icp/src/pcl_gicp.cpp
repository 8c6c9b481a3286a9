// Back end kPclGicp (icp.hpp): pcl::GeneralizedIterativeClosestPoint in 3D with z = 0, each
// point's covariance that of a vertical wall through its local 2D line, answer projected to
// SE(2).
#include <pcl/console/print.h>
#include <pcl/registration/gicp.h>

#include <algorithm>

#include "pcl_common.hpp"

namespace draco::icp::detail {
namespace {

using Gicp = Counted<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ, double>>;
using Covariances = Gicp::MatricesVector;

// GICP's covariance flattening (Segal et al. 2009, section III-B; PCL's gicp_epsilon_):
// unit variance within the surface, epsilon across it. The surface of a planar sonar return
// is a vertical wall along the line its neighbours form: unit along the line and along z,
// epsilon along the line's normal in the plane.
constexpr double kEpsilon = 0.001;

std::shared_ptr<Covariances> WallCovariances(const Cloud2& points, const KdTree2& tree,
                                             int neighbors) {
  auto out = std::make_shared<Covariances>();
  out->reserve(points.size());
  std::vector<int> near;
  for (const auto& p : points) {
    tree.KNearest(p, std::max(neighbors, 2), &near);
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const int j : near) mean += points[j];
    mean /= static_cast<double>(near.size());
    Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
    for (const int j : near) C += (points[j] - mean) * (points[j] - mean).transpose();
    const double major = 0.5 * std::atan2(2.0 * C(0, 1), C(0, 0) - C(1, 1));
    const Eigen::Vector3d along(std::cos(major), std::sin(major), 0.0);
    const Eigen::Vector3d across(-std::sin(major), std::cos(major), 0.0);
    const Eigen::Vector3d up(0.0, 0.0, 1.0);
    out->push_back(along * along.transpose() + up * up.transpose() +
                   kEpsilon * across * across.transpose());
  }
  return out;
}

// A name of its own in each back end: the caches of all back ends share one slot and are told
// apart by dynamic_cast, and clang compares the type_info of classes in anonymous namespaces
// by name, so equal names in two files made one back end take the other's cache (ASan:
// heap-use-after-free in Backends.PreparedTargetServesManySourcesAndBackEnds).
struct PclGicpPrepared final : IcpTarget::BackendCache {
  Gicp gicp;
  std::shared_ptr<Covariances> target_covariances;
  int neighbors = -1;
};

PclGicpPrepared& Prepare(IcpTarget& target, int neighbors) {
  auto& slot = target.backend_cache();
  auto* p = dynamic_cast<PclGicpPrepared*>(slot.get());
  if (p == nullptr) {
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
    auto fresh = std::make_unique<PclGicpPrepared>();
    p = fresh.get();
    slot = std::move(fresh);
  }
  if (p->neighbors != neighbors) {
    p->gicp.setInputTarget(ToPcl(target.points()));  // resets the target covariances
    p->target_covariances = WallCovariances(target.points(), target.tree(), neighbors);
    p->gicp.setTargetCovariances(p->target_covariances);
    p->neighbors = neighbors;
  }
  return *p;
}

}  // namespace

BackendAnswer AlignPclGicp(const Cloud2& source, IcpTarget& target, const msgs::Pose2& initial,
                           const IcpOptions& o) {
  Gicp& gicp = Prepare(target, o.gicp_neighbors).gicp;
  gicp.setMaxCorrespondenceDistance(o.max_correspondence_distance_m);
  gicp.setMaximumIterations(o.max_iterations);
  // GICP stops when no translation entry moved by this and no rotation entry by the next.
  gicp.setTransformationEpsilon(o.convergence_translation_m);
  gicp.setRotationEpsilon(o.convergence_rotation_rad);
  gicp.setInputSource(ToPcl(source));  // resets the source covariances
  const KdTree2 source_tree(source);
  gicp.setSourceCovariances(WallCovariances(source, source_tree, o.gicp_neighbors));
  PclCloud aligned;
  gicp.align(aligned, ToMatrix<double>(initial));
  return Project(gicp.getFinalTransformation(), gicp.iterations(), gicp.hasConverged(),
                 o.max_iterations);
}

}  // namespace draco::icp::detail
