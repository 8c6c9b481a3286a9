// slam.IcpOdometry: the runtime adapter of SequentialScanMatcher (sequential.hpp).
#include <string>

#include "draco/graph/component.hpp"
#include "draco/icp/sequential.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::icp {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;

class IcpOdometryComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Sequential scan matching: ICP of each keyframe against the last keyframes, "
        "seeded and gated by dead reckoning, falling back to it.");
    keyframe_ = spec.Input<msgs::Keyframe>("keyframe", {.depth = 64, .doc = "keyframes"});
    factor_ = spec.Output<msgs::SequentialFactor>(
        "factor", "previous keyframe to this one, stamped with the keyframe time");
    spec.Param("num_previous_keyframes", &o_.num_previous_keyframes,
               {"keyframes in the target cloud", "", 1.0, 100.0, {}});
    spec.Param("min_points", &o_.min_points,
               {"points needed in source and target", "", 0.0, 1e6, {}});
    spec.Param("max_translation_from_seed_m", &o_.max_translation_from_seed_m,
               {"gate around the dead-reckoning seed", "m", 0.0, {}, {}});
    spec.Param("max_rotation_from_seed_rad", &o_.max_rotation_from_seed_rad,
               {"gate around the dead-reckoning seed", "rad", 0.0, 3.2, {}});
    spec.Param("min_overlap_ratio", &o_.min_overlap_ratio,
               {"reject matches with less overlap", "", 0.0, 1.0, {}});
    spec.Param("covariance_scale", &o_.covariance_scale,
               {.doc = "ICP covariance multiplied by this (the library's default: 1)",
                .min = 1e-6,
                .origin = "25: ICP's own covariance is 15-45x too confident in variance; "
                          "calibrated against ground truth on the marina and airplane missions: "
                          "docs/local-slam.md, \"Factor calibration\""});
    spec.Param(
        "max_anisotropy", &o_.max_anisotropy,
        {"fall back when the ICP xy covariance is more elongated (0: off)", "", 0.0, {}, {}});
    spec.Param("max_dr_mahalanobis2", &o_.max_dr_mahalanobis2,
               {.doc = "fall back when ICP and dead reckoning disagree beyond this chi2 (0: off; "
                       "the library's default)",
                .min = 0.0,
                .origin = "11.34, chi2(3) at 0.99; calibrated against ground truth on the marina "
                          "and airplane missions: docs/local-slam.md, \"Factor calibration\""});
    spec.Param("metric", &metric_,
               {"ICP error metric", "", {}, {}, {"point_to_point", "point_to_line"}});
    spec.Param("max_correspondence_distance_m", &o_.icp.max_correspondence_distance_m,
               {"ICP pairs further apart are dropped", "m", 0.0, {}, {}});
    spec.Param("trim_fraction", &o_.icp.trim_fraction,
               {"ICP keeps this fraction of the closest pairs", "", 0.01, 1.0, {}});
    spec.Param("max_iterations", &o_.icp.max_iterations, {"ICP iterations", "", 1.0, 1000.0, {}});
    spec.Param("backend", &backend_,
               {.doc = "registration back end: draco's 2D ICP, PCL's ICP (2D), GICP or NDT "
                       "(3D with z = 0, projected to SE(2)), or MRPT's 2D ICP; docs/benchmarks.md "
                       "compares them",
                .choices = BackendNames()});
    spec.Param("ndt_resolution_m", &o_.icp.ndt_resolution_m,
               {.doc = "pcl_ndt: voxel size", .unit = "m", .min = 0.05});
  }
  Status Start(Context&) override {
    o_.icp.metric = metric_ == "point_to_line" ? Metric::kPointToLine : Metric::kPointToPoint;
    o_.icp.backend = ParseBackend(backend_);
    matcher_ = SequentialScanMatcher(o_);
    return Status::Ok();
  }
  Status Process(Context&) override {
    while (auto m = keyframe_.Take()) {
      if (auto f = matcher_.AddKeyframe(**m)) factor_.PublishAt(m->stamp, std::move(*f));
    }
    return Status::Ok();
  }

 private:
  // The runtime's defaults are the calibrated ones (see their origin); the library keeps the
  // reference's.
  SequentialOptions o_ = [] {
    SequentialOptions o;
    o.covariance_scale = 25.0;
    o.max_dr_mahalanobis2 = 11.34;
    return o;
  }();
  std::string metric_ = "point_to_point";
  std::string backend_ = "draco";
  SequentialScanMatcher matcher_;
  graph::In<msgs::Keyframe> keyframe_;
  graph::Out<msgs::SequentialFactor> factor_;
};
DRACO_REGISTER_COMPONENT(IcpOdometryComponent, "slam.IcpOdometry")

}  // namespace
}  // namespace draco::icp
