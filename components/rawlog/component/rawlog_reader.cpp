// sonar.RawlogReader: replays an MRPT rawlog (odometry and 2D range scans, rawlog.hpp) as
// the dead reckoning and sonar features of the local-SLAM graph (import.hpp), stamped with the
// rawlog's times. A thin adapter over draco_rawlog; config/graphs/local-slam-rawlog.yaml.
#include <optional>
#include <string>
#include <vector>

#include "draco/graph/component.hpp"
#include "draco/msgs/slam.hpp"
#include "draco/rawlog/import.hpp"
#include "draco/rawlog/rawlog.hpp"

namespace draco::rawlog {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;
using graph::Time;

class RawlogReaderComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Source(
        "Replays an MRPT rawlog (observations only, or action / sensory-frame pairs) as "
        "dead reckoning (CObservationOdometry or CActionRobotMovement2D) and sonar features "
        "(CObservation2DRangeScan returns in the sensor frame). A missing or damaged file "
        "stops the run with an error naming it.");
    odometry_ = spec.Output<msgs::DeadReckoning>(
        "odometry", "the rawlog's odometry, with increments and their covariance");
    features_ = spec.Output<msgs::SonarFeatures>(
        "features", "returns of each range scan's valid beams, sensor frame");
    spec.Param("rawlog", &path_, {"MRPT rawlog file", "", {}, {}, {}});
    spec.Param("velocity_sigma_mps", &o_.velocity_sigma_mps,
               {.doc = "odometry increment noise per axis", .unit = "m/s", .min = 0.0});
    spec.Param("yaw_random_walk_rad_per_sqrt_s", &o_.yaw_random_walk_rad_per_sqrt_s,
               {.doc = "odometry heading random walk", .unit = "rad/sqrt(s)", .min = 0.0});
  }

  Status Start(Context& ctx) override {
    if (path_.empty()) return Status::Fatal("parameter 'rawlog' is not set");
    try {
      ReadStats stats;
      messages_ = ToMessages(ReadRawlog(path_, &stats), o_);
      ctx.Log("replaying " + std::to_string(messages_.size()) + " messages of " + path_ +
              (stats.skipped > 0
                   ? " (" + std::to_string(stats.skipped) + " observations of other types skipped)"
                   : std::string()));
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    return Status::Ok();
  }

  std::optional<Time> NextSourceTime() override {
    if (next_ >= messages_.size()) return std::nullopt;
    return Time::FromSeconds(MessageTime(messages_[next_]));
  }

  Status Process(Context&) override {
    if (next_ >= messages_.size()) return Status::Ok();
    Message& m = messages_[next_++];
    const Time stamp = Time::FromSeconds(MessageTime(m));
    if (auto* d = std::get_if<msgs::DeadReckoning>(&m)) {
      odometry_.PublishAt(stamp, std::move(*d));
    } else {
      features_.PublishAt(stamp, std::move(std::get<msgs::SonarFeatures>(m)));
    }
    return Status::Ok();
  }

 private:
  std::string path_;
  ImportOptions o_;
  std::vector<Message> messages_;
  std::size_t next_ = 0;
  graph::Out<msgs::DeadReckoning> odometry_;
  graph::Out<msgs::SonarFeatures> features_;
};
DRACO_REGISTER_COMPONENT(RawlogReaderComponent, "sonar.RawlogReader")

}  // namespace
}  // namespace draco::rawlog
