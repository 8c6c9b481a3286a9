// Back end kMrptIcp (icp.hpp): mrpt::slam::CICP, MRPT's classic 2D ICP (icpClassic) on two
// mrpt::maps::CSimplePointsMap with z = 0, every source point matched (no decimation).
// MRPT anneals its correspondence distance: it starts at max_correspondence_distance_m and
// is scaled by 0.5 each time the steps fall below the convergence thresholds, until it is
// below 0.1 m (MRPT's defaults for ALFA and smallestThresholdDist).
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPosePDF.h>
#include <mrpt/poses/CPosePDFGaussian.h>
#include <mrpt/slam/CICP.h>

#include <cmath>
#include <exception>
#include <memory>

#include "backends.hpp"

namespace draco::icp::detail {
namespace {

mrpt::maps::CSimplePointsMap ToMrpt(const Cloud2& points) {
  mrpt::maps::CSimplePointsMap map;
  map.reserve(points.size());
  for (const auto& p : points) {
    map.insertPointFast(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
  }
  // insertPointFast leaves MRPT's derived data (kd-tree, bounding box) to be rebuilt.
  map.mark_as_modified();
  return map;
}

// The target's MRPT point map (its kd-tree is built on the first alignment and kept).
struct Prepared final : IcpTarget::BackendCache {
  mrpt::maps::CSimplePointsMap map;
};

Prepared& Prepare(IcpTarget& target) {
  auto& slot = target.backend_cache();
  if (auto* p = dynamic_cast<Prepared*>(slot.get())) return *p;
  auto p = std::make_unique<Prepared>();
  p->map = ToMrpt(target.points());
  Prepared& out = *p;
  slot = std::move(p);
  return out;
}

}  // namespace

BackendAnswer AlignMrptIcp(const Cloud2& source, IcpTarget& target, const msgs::Pose2& initial,
                           const IcpOptions& o) {
  BackendAnswer a;
  const Prepared& prepared = Prepare(target);
  const mrpt::maps::CSimplePointsMap source_map = ToMrpt(source);

  mrpt::slam::CICP icp;
  auto& p = icp.options;
  p.ICP_algorithm = mrpt::slam::icpClassic;
  p.maxIterations = static_cast<unsigned>(std::max(o.max_iterations, 1));
  p.minAbsStep_trans = o.convergence_translation_m;
  p.minAbsStep_rot = o.convergence_rotation_rad;
  p.thresholdDist = o.max_correspondence_distance_m;
  p.thresholdAng = 0.0;  // no range-dependent widening: the distance alone, as the others
  p.corresponding_points_decimation = 1;
  p.skip_cov_calculation = true;  // draco computes the covariance (AlignIcp)
  p.skip_quality_calculation = true;

  mrpt::slam::CICP::TReturnInfo info;
  mrpt::poses::CPosePDF::Ptr pdf;
  try {
    // AlignPDF(reference, to_align): the pose of to_align's frame in reference's frame,
    // i.e. T_target_source.
    pdf = icp.AlignPDF(&prepared.map, &source_map,
                       mrpt::poses::CPosePDFGaussian(
                           mrpt::poses::CPose2D(initial.x_m, initial.y_m, initial.yaw_rad)),
                       info);
  } catch (const std::exception&) {
    return a;  // MRPT refuses (e.g. empty maps): no answer, as a failed alignment
  }
  if (!pdf) return a;
  const mrpt::poses::CPose2D T = pdf->getMeanVal();
  a.iterations = static_cast<int>(info.nIterations);
  // MRPT reports no convergence flag: it stopped before max_iterations.
  a.converged = a.iterations < o.max_iterations;
  if (!std::isfinite(T.x()) || !std::isfinite(T.y()) || !std::isfinite(T.phi())) return a;
  // No correspondence at all leaves the seed unchanged with goodness 0: not an answer.
  if (info.goodness <= 0.0) return a;
  a.valid = true;
  a.T_target_source = {T.x(), T.y(), T.phi()};
  return a;
}

}  // namespace draco::icp::detail
