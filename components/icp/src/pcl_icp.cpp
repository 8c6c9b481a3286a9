// Back end kPclIcp (icp.hpp): pcl::IterativeClosestPoint constrained to the plane by
// pcl::registration::TransformationEstimation2D, trimmed as draco's ICP.
#include <pcl/console/print.h>
#include <pcl/registration/correspondence_rejection_trimmed.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/transformation_estimation_2D.h>

#include "pcl_common.hpp"

namespace draco::icp::detail {
namespace {

using Icp = Counted<pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ, double>>;

// The target's PCL cloud and an ICP object holding it (its kd-tree is built on the first
// alignment and kept).
// A name of its own in each back end: the caches of all back ends share one slot and are told
// apart by dynamic_cast, and clang compares the type_info of classes in anonymous namespaces
// by name, so equal names in two files made one back end take the other's cache (ASan:
// heap-use-after-free in Backends.PreparedTargetServesManySourcesAndBackEnds).
struct PclIcpPrepared final : IcpTarget::BackendCache {
  Icp icp;
};

PclIcpPrepared& Prepare(IcpTarget& target) {
  auto& slot = target.backend_cache();
  if (auto* p = dynamic_cast<PclIcpPrepared*>(slot.get())) return *p;
  // Expected failures (too few correspondences) are answers here, not console messages.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  auto p = std::make_unique<PclIcpPrepared>();
  p->icp.setInputTarget(ToPcl(target.points()));
  p->icp.setTransformationEstimation(
      std::make_shared<
          pcl::registration::TransformationEstimation2D<pcl::PointXYZ, pcl::PointXYZ, double>>());
  PclIcpPrepared& out = *p;
  slot = std::move(p);
  return out;
}

}  // namespace

BackendAnswer AlignPclIcp(const Cloud2& source, IcpTarget& target, const msgs::Pose2& initial,
                          const IcpOptions& o) {
  Icp& icp = Prepare(target).icp;
  icp.setMaxCorrespondenceDistance(o.max_correspondence_distance_m);
  icp.setMaximumIterations(o.max_iterations);
  // PCL compares the squared translation and the cosine of the rotation of one step.
  icp.setTransformationEpsilon(o.convergence_translation_m * o.convergence_translation_m);
  icp.setTransformationRotationEpsilon(std::cos(o.convergence_rotation_rad));
  icp.clearCorrespondenceRejectors();
  auto trim = std::make_shared<pcl::registration::CorrespondenceRejectorTrimmed>();
  trim->setOverlapRatio(static_cast<float>(o.trim_fraction));
  trim->setMinCorrespondences(static_cast<unsigned>(std::max(o.min_correspondences, 0)));
  icp.addCorrespondenceRejector(trim);
  icp.setInputSource(ToPcl(source));
  PclCloud aligned;
  icp.align(aligned, ToMatrix<double>(initial));
  return Project(icp.getFinalTransformation(), icp.iterations(), icp.hasConverged(),
                 o.max_iterations);
}

}  // namespace draco::icp::detail
