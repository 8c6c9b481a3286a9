// sonar.Cfar: the runtime adapter of the CFAR feature extractor (draco/cfar/cfar.hpp).
#include <memory>
#include <string>

#include "draco/cfar/cfar.hpp"
#include "draco/graph/component.hpp"
#include "draco/msgs/sensors.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::cfar {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;

class CfarComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Extracts sonar feature points: CFAR along range, intensity threshold, polar to "
        "Cartesian, voxel downsampling, radius outlier filter.");
    ping_ = spec.Input<msgs::SonarPing>("ping", {.doc = "sonar pings"});
    features_ = spec.Output<msgs::SonarFeatures>(
        "features", "feature points in the sensor frame, stamped with the ping time");
    spec.Param("method", &method_, {"CFAR variant", "", {}, {}, {"SOCA", "CA", "GOCA", "OS"}});
    spec.Param("train_cells", &train_cells_,
               {"training cells, both sides together (even)", "", 2.0, 4096.0, {}});
    spec.Param("guard_cells", &guard_cells_,
               {"guard cells, both sides together (even)", "", 0.0, 4096.0, {}});
    spec.Param("false_alarm_probability", &pfa_,
               {"CFAR false-alarm probability", "", 1e-12, 0.999, {}});
    spec.Param(
        "os_rank", &os_rank_,
        {"OS only: rank of the order statistic (0 = 3/4 of train_cells)", "", 0.0, 4096.0, {}});
    spec.Param("edge_mode", &edge_mode_,
               {"cells whose window leaves the column: none = never detections, one_sided = "
                "CA on the complete side",
                "",
                {},
                {},
                {"none", "one_sided"}});
    spec.Param("min_intensity", &opts_.min_intensity,
               {"absolute threshold on the (linearised) intensity", "", 0.0, 255.0, {}});
    spec.Param("linearize_gamma", &opts_.linearize_gamma,
               {"apply v = 255 (u / 255)^(255 / gamma) before detection", "", {}, {}, {}});
    spec.Param("gamma", &opts_.gamma, {"the sonar driver's gamma byte", "", 1.0, 255.0, {}});
    spec.Param("min_range_m", &opts_.min_range_m, {"drop closer points", "m", 0.0, {}, {}});
    spec.Param("max_range_m", &opts_.max_range_m, {"drop farther points", "m", 0.0, {}, {}});
    spec.Param("downsample", &downsample_,
               {"representative per voxel", "", {}, {}, {"medoid", "centroid", "none"}});
    spec.Param("voxel_size_m", &opts_.voxel_size_m, {"downsampling grid", "m", 0.0, {}, {}});
    spec.Param("outlier_radius_m", &opts_.outlier_radius_m,
               {"radius outlier filter (0 = off)", "m", 0.0, {}, {}});
    spec.Param("outlier_min_neighbors", &opts_.outlier_min_neighbors,
               {"other points needed within the radius", "", 0.0, 1e6, {}});
  }

  Status Start(Context&) override {
    FeatureOptions o = opts_;
    ParseMethod(method_, &o.cfar.method);
    o.cfar.train_cells = train_cells_;
    o.cfar.guard_cells = guard_cells_;
    o.cfar.false_alarm_probability = pfa_;
    o.cfar.os_rank = os_rank_;
    o.cfar.edge_mode = edge_mode_ == "one_sided" ? EdgeMode::kOneSided : EdgeMode::kNone;
    o.downsample = downsample_ == "medoid"     ? Downsample::kMedoid
                   : downsample_ == "centroid" ? Downsample::kCentroid
                                               : Downsample::kNone;
    try {
      extractor_ = std::make_unique<FeatureExtractor>(o);
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    return Status::Ok();
  }

  Status Process(Context&) override {
    while (auto m = ping_.Take()) {
      const msgs::SonarPing& ping = **m;
      msgs::SonarFeatures out;
      out.time_s = ping.time_s;
      out.ping_id = ping.ping_id;
      FeatureStats stats;
      try {
        out.points_sensor = extractor_->Extract(ping, &stats);
      } catch (const std::exception& e) {
        return Status::Error(e.what());
      }
      out.num_detections = stats.detections;
      features_.PublishAt(m->stamp, std::move(out));
    }
    return Status::Ok();
  }

 private:
  FeatureOptions opts_;
  std::string method_ = MethodName(CfarOptions{}.method);
  int train_cells_ = CfarOptions{}.train_cells;
  int guard_cells_ = CfarOptions{}.guard_cells;
  double pfa_ = CfarOptions{}.false_alarm_probability;
  int os_rank_ = 0;
  std::string edge_mode_ = "none";
  std::string downsample_ = "medoid";
  std::unique_ptr<FeatureExtractor> extractor_;
  graph::In<msgs::SonarPing> ping_;
  graph::Out<msgs::SonarFeatures> features_;
};
DRACO_REGISTER_COMPONENT(CfarComponent, "sonar.Cfar")

}  // namespace
}  // namespace draco::cfar
