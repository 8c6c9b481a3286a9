// nav.DeadReckoning and slam.KeyframeSelector: runtime adapters of dead_reckoning.hpp and
// keyframes.hpp.
#include <deque>
#include <string>
#include <vector>

#include "draco/graph/component.hpp"
#include "draco/msgs/sensors.hpp"
#include "draco/msgs/slam.hpp"
#include "draco/navigation/dead_reckoning.hpp"
#include "draco/navigation/keyframes.hpp"

namespace draco::navigation {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;

class DeadReckoningComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc("DVL + AHRS (+ depth) dead reckoning: one pose and increment per DVL sample.");
    dvl_ = spec.Input<msgs::DvlVelocity>("dvl", {.depth = 256, .doc = "body velocity"});
    ahrs_ = spec.Input<msgs::Ahrs>("ahrs", {.trigger = false,
                                            .depth = 4096,
                                            .doc = "heading; readings up to each DVL "
                                                   "sample are applied before it"});
    depth_ = spec.Input<msgs::Depth>("depth", {.trigger = false,
                                               .delivery = graph::Delivery::kLatest,
                                               .required = false,
                                               .doc = "latest depth"});
    out_ = spec.Output<msgs::DeadReckoning>("odometry", "pose in the odom frame per DVL sample");
    spec.Param("yaw_relative_to_first", &o_.yaw_relative_to_first,
               {"odom yaw 0 = the first AHRS reading", "", {}, {}, {}});
    spec.Param("absolute_heading", &o_.absolute_heading,
               {"the AHRS yaw has an absolute reference (magnetometer, gyrocompass): the odom "
                "frame's heading goes with the map to teammates",
                "",
                {},
                {},
                {}});
    spec.Param(
        "max_speed_mps", &o_.max_speed_mps,
        {"faster DVL samples are spikes (the last good velocity is held)", "m/s", 0.0, {}, {}});
    spec.Param("hold_time_s", &o_.hold_time_s,
               {"hold the last good velocity this long in a dropout", "s", 0.0, {}, {}});
    spec.Param("decay_time_s", &o_.decay_time_s,
               {"then decay it with this time constant", "s", 1e-6, {}, {}});
    spec.Param("velocity_sigma_mps", &o_.velocity_sigma_mps,
               {"per-axis sigma of a good DVL velocity", "m/s", 0.0, {}, {}});
    spec.Param("held_sigma_growth_mps_per_s", &o_.held_sigma_growth_mps_per_s,
               {"sigma added per second without a good DVL sample", "m/s^2", 0.0, {}, {}});
    spec.Param("max_gap_s", &o_.max_gap_s,
               {"DVL samples further apart count as a dropout", "s", 0.0, {}, {}});
    spec.Param("yaw_random_walk_rad_per_sqrt_s", &o_.yaw_random_walk_rad_per_sqrt_s,
               {"relative heading uncertainty growth", "rad/sqrt(s)", 0.0, {}, {}});
  }
  Status Start(Context&) override {
    dr_ = DeadReckoner(o_);
    return Status::Ok();
  }
  Status Process(Context&) override {
    if (auto d = depth_.Take()) dr_.AddDepth(**d);
    while (auto v = dvl_.Take()) {
      while (auto a = ahrs_.Peek()) {
        if (a->stamp > v->stamp) break;
        dr_.AddAhrs(**a);
        ahrs_.Take();
      }
      if (auto out = dr_.AddDvl(**v)) out_.PublishAt(v->stamp, std::move(*out));
    }
    return Status::Ok();
  }

 private:
  DeadReckoningOptions o_;
  DeadReckoner dr_;
  graph::In<msgs::DvlVelocity> dvl_;
  graph::In<msgs::Ahrs> ahrs_;
  graph::In<msgs::Depth> depth_;
  graph::Out<msgs::DeadReckoning> out_;
};
DRACO_REGISTER_COMPONENT(DeadReckoningComponent, "nav.DeadReckoning")

// The keyframe rule's parameters, declared alike by slam.KeyframeSelector and
// slam.KeyframePings.
void DeclareKeyframeRule(Spec& spec, KeyframeOptions* o) {
  spec.Param("min_interval_s", &o->min_interval_s,
             {"minimum time between keyframes", "s", 0.0, {}, {}});
  spec.Param("min_translation_m", &o->min_translation_m,
             {"translation that makes a keyframe", "m", 0.0, {}, {}});
  spec.Param("min_rotation_rad", &o->min_rotation_rad,
             {"rotation that makes a keyframe", "rad", 0.0, 3.2, {}});
}

class KeyframeSelectorComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Pairs sonar features with dead reckoning at the ping time and emits keyframes "
        "(min interval, and min translation or rotation).");
    features_ = spec.Input<msgs::SonarFeatures>("features", {.depth = 64, .doc = "CFAR points"});
    odometry_ =
        spec.Input<msgs::DeadReckoning>("odometry", {.depth = 1024, .doc = "dead reckoning"});
    keyframe_ = spec.Output<msgs::Keyframe>("keyframe", "stamped with the ping time");
    DeclareKeyframeRule(spec, &o_);
    spec.Param("T_body_sensor", &T_body_sensor_,
               {"sonar mounting [x_m, y_m, yaw_rad]", "", {}, {}, {}});
  }
  Status Start(Context&) override {
    if (T_body_sensor_.size() != 3) return Status::Fatal("T_body_sensor needs 3 values");
    selector_ =
        KeyframeSelector(o_, msgs::Pose2{T_body_sensor_[0], T_body_sensor_[1], T_body_sensor_[2]});
    return Status::Ok();
  }
  Status Process(Context&) override {
    for (const auto& m : odometry_.TakeAll()) selector_.AddDeadReckoning(*m);
    for (const auto& m : features_.TakeAll()) selector_.AddFeatures(*m);
    for (auto& kf : selector_.Poll()) {
      const graph::Time stamp = graph::Time::FromSeconds(kf.time_s);
      keyframe_.PublishAt(stamp, std::move(kf));
    }
    return Status::Ok();
  }

 private:
  KeyframeOptions o_;
  std::vector<double> T_body_sensor_{0.0, 0.0, 0.0};
  KeyframeSelector selector_;
  graph::In<msgs::SonarFeatures> features_;
  graph::In<msgs::DeadReckoning> odometry_;
  graph::Out<msgs::Keyframe> keyframe_;
};
DRACO_REGISTER_COMPONENT(KeyframeSelectorComponent, "slam.KeyframeSelector")

// Passes on only the pings slam.KeyframeSelector will make keyframes (KeyframeGate), so that
// the feature extractor between them runs on those alone. Its three parameters (declared by
// the same DeclareKeyframeRule) must be set to the selector's: with a looser gate the
// selector picks among fewer pings, with a stricter one it takes every ping it is given.
class KeyframePingsComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Passes on only the sonar pings that will become keyframes (slam.KeyframeSelector's "
        "rule on dead reckoning at the ping time), so CFAR runs on those alone.");
    ping_ = spec.Input<msgs::SonarPing>("ping", {.depth = 64, .doc = "sonar pings"});
    odometry_ =
        spec.Input<msgs::DeadReckoning>("odometry", {.depth = 1024, .doc = "dead reckoning"});
    out_ = spec.Output<msgs::SonarPing>("keyframe_ping", "the pings of keyframes, unchanged");
    DeclareKeyframeRule(spec, &o_);
  }
  Status Start(Context&) override {
    gate_ = KeyframeGate(o_);
    waiting_.clear();
    return Status::Ok();
  }
  Status Process(Context&) override {
    for (const auto& m : odometry_.TakeAll()) gate_.AddDeadReckoning(*m);
    for (auto& m : ping_.TakeAll()) waiting_.push_back(std::move(m));
    while (!waiting_.empty()) {
      const auto verdict = gate_.Decide(waiting_.front()->time_s);
      if (verdict == KeyframeGate::Verdict::kUndecided) break;
      if (verdict == KeyframeGate::Verdict::kKeyframe) {
        out_.PublishAt(waiting_.front().stamp, waiting_.front().value);
      }
      waiting_.pop_front();
    }
    return Status::Ok();
  }

 private:
  KeyframeOptions o_;
  KeyframeGate gate_;
  std::deque<graph::Stamped<msgs::SonarPing>> waiting_;
  graph::In<msgs::SonarPing> ping_;
  graph::In<msgs::DeadReckoning> odometry_;
  graph::Out<msgs::SonarPing> out_;
};
DRACO_REGISTER_COMPONENT(KeyframePingsComponent, "slam.KeyframePings")

}  // namespace
}  // namespace draco::navigation
