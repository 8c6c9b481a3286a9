// Back end kPclNdt (icp.hpp): pcl::NormalDistributionsTransform in 3D with z = 0, answer
// projected to SE(2).
#include <pcl/console/print.h>
#include <pcl/registration/ndt.h>

#include "pcl_common.hpp"

namespace draco::icp::detail {
namespace {

using Ndt = Counted<pcl::NormalDistributionsTransform<pcl::PointXYZ, pcl::PointXYZ, double>>;

// The target's voxel grid (built by setInputTarget, rebuilt when the resolution changes).
// A name of its own in each back end: the caches of all back ends share one slot and are told
// apart by dynamic_cast, and clang compares the type_info of classes in anonymous namespaces
// by name, so equal names in two files made one back end take the other's cache (ASan:
// heap-use-after-free in Backends.PreparedTargetServesManySourcesAndBackEnds).
struct PclNdtPrepared final : IcpTarget::BackendCache {
  Ndt ndt;
  double resolution_m = -1.0;
};

PclNdtPrepared& Prepare(IcpTarget& target, double resolution_m) {
  auto& slot = target.backend_cache();
  auto* p = dynamic_cast<PclNdtPrepared*>(slot.get());
  if (p == nullptr) {
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
    auto fresh = std::make_unique<PclNdtPrepared>();
    p = fresh.get();
    slot = std::move(fresh);
  }
  if (p->resolution_m != resolution_m) {
    p->ndt.setResolution(static_cast<float>(resolution_m));
    p->ndt.setInputTarget(ToPcl(target.points()));
    p->resolution_m = resolution_m;
  }
  return *p;
}

}  // namespace

BackendAnswer AlignPclNdt(const Cloud2& source, IcpTarget& target, const msgs::Pose2& initial,
                          const IcpOptions& o) {
  Ndt& ndt = Prepare(target, o.ndt_resolution_m).ndt;
  ndt.setMaximumIterations(o.max_iterations);
  // As ICP: squared translation and cosine of the rotation of one step.
  ndt.setTransformationEpsilon(o.convergence_translation_m * o.convergence_translation_m);
  ndt.setTransformationRotationEpsilon(std::cos(o.convergence_rotation_rad));
  ndt.setInputSource(ToPcl(source));
  PclCloud aligned;
  ndt.align(aligned, ToMatrix<double>(initial));
  return Project(ndt.getFinalTransformation(), ndt.iterations(), ndt.hasConverged(),
                 o.max_iterations);
}

}  // namespace draco::icp::detail
