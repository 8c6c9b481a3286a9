// The output ports of a sensor source (ping, dvl, ahrs, depth, ground_truth), declared and
// published the same way by every source, so graphs can swap a recorded mission for a ROS bag.
#pragma once

#include <string>
#include <utility>
#include <variant>

#include "draco/graph/component.hpp"
#include "draco/msgs/sensors.hpp"

namespace draco::sensor_outputs {

class SensorOutputs {
 public:
  void Declare(graph::Spec& spec, const std::string& ground_truth_doc) {
    ping_ = spec.Output<msgs::SonarPing>("ping", "sonar pings (polar image, bearing table)");
    dvl_ = spec.Output<msgs::DvlVelocity>("dvl", "DVL body velocity");
    ahrs_ = spec.Output<msgs::Ahrs>("ahrs", "attitude and heading");
    depth_ = spec.Output<msgs::Depth>("depth", "depth, positive down");
    ground_truth_ = spec.Output<msgs::GroundTruthPose>("ground_truth", ground_truth_doc);
  }

  // Publishes whichever message a std::variant of the sensor messages holds.
  template <class Variant>
  void Publish(graph::Time stamp, Variant&& message) {
    std::visit([&](auto& m) { PublishOne(stamp, std::move(m)); }, message);
  }

 private:
  void PublishOne(graph::Time t, msgs::SonarPing&& m) { ping_.PublishAt(t, std::move(m)); }
  void PublishOne(graph::Time t, msgs::DvlVelocity&& m) { dvl_.PublishAt(t, std::move(m)); }
  void PublishOne(graph::Time t, msgs::Ahrs&& m) { ahrs_.PublishAt(t, std::move(m)); }
  void PublishOne(graph::Time t, msgs::Depth&& m) { depth_.PublishAt(t, std::move(m)); }
  void PublishOne(graph::Time t, msgs::GroundTruthPose&& m) {
    ground_truth_.PublishAt(t, std::move(m));
  }

  graph::Out<msgs::SonarPing> ping_;
  graph::Out<msgs::DvlVelocity> dvl_;
  graph::Out<msgs::Ahrs> ahrs_;
  graph::Out<msgs::Depth> depth_;
  graph::Out<msgs::GroundTruthPose> ground_truth_;
};

}  // namespace draco::sensor_outputs
