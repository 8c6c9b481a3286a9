// sonar.BagReader: replays the sonar and navigation streams of a ROS 1 bag recorded on a
// vehicle (docs/rosbag.md) as typed messages stamped in mission time. A thin adapter over
// draco_rosbag; its outputs are those of sonar.RecordingReader, so either can feed a graph.
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "draco/graph/component.hpp"
#include "draco/msgs/sensors.hpp"
#include "draco/rosbag/bag_reader.hpp"
#include "draco/sensor_outputs/sensor_outputs.hpp"

namespace draco::rosbag {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;
using graph::Time;

double MessageTime(const Message& message) {
  return std::visit([](const auto& m) { return m.time_s; }, message);
}

class BagReaderComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Source(
        "Replays a ROS 1 bag from a vehicle (Oculus pings, RTI DVL, IMU, Bar30 depth, ground "
        "truth when present) in bag order, converted to draco messages. Envelopes are stamped "
        "in mission time (header stamp - bag start), clamped to be non-negative and "
        "non-decreasing; each message keeps its own time_s. A missing, truncated or corrupt "
        "bag stops the run with an error naming the file, topic, message and field.");
    outputs_.Declare(spec, "true body pose (only when the bag has the ground-truth topic)");
    spec.Param("bag", &bag_, {"path of the ROS 1 bag", "", {}, {}, {}});
    spec.Param("sonar_topics", &options_.sonar_topics,
               {"sonar topics, the first present in the bag is read", "", {}, {}, {}});
    spec.Param("dvl_topic", &options_.dvl_topic,
               {"rti_dvl/DVL topic (empty: none)", "", {}, {}, {}});
    spec.Param("imu_topic", &options_.imu_topic,
               {"sensor_msgs/Imu topic (empty: none)", "", {}, {}, {}});
    spec.Param("depth_topic", &options_.depth_topic,
               {"bar30_depth/Depth topic (empty: none)", "", {}, {}, {}});
    spec.Param("ground_truth_topic", &options_.ground_truth_topic,
               {"geometry_msgs/PoseStamped topic (empty: none)", "", {}, {}, {}});
    spec.Param("use_header_stamp", &options_.use_header_stamp,
               {"time messages by header.stamp (false: by receipt time)", "", {}, {}, {}});
    spec.Param("linearize_gamma", &options_.convert.linearize_gamma,
               {"undo the driver's gamma on sonar intensities", "", {}, {}, {}});
    spec.Param(
        "frd_to_flu", &options_.convert.frd_to_flu,
        {"convert the vehicle's x-fwd/y-right/z-down data to x-fwd/y-left/z-up", "", {}, {}, {}});
    spec.Param("vertical_aperture_rad", &options_.convert.vertical_aperture_rad,
               {"sonar vertical aperture (not in the bag)", "rad", 0.0, 3.2, {}});
    spec.Param("dvl_max_valid_speed_mps", &options_.convert.dvl_max_valid_speed_mps,
               {"DVL samples faster than this are marked invalid", "m/s", 0.0, {}, {}});
    spec.Param(
        "skip_bad_messages", &skip_bad_messages_,
        {"log and skip a message that cannot be decoded instead of stopping", "", {}, {}, {}});
  }

  Status Start(Context& ctx) override {
    if (bag_.empty()) return Status::Fatal("parameter 'bag' is not set");
    try {
      reader_.emplace(BagReader::Open(bag_, options_));
      ctx.Log("replaying " + bag_ + " (" + std::to_string(reader_->selected_message_count()) +
              " messages; sonar topic '" + reader_->sonar_topic() + "')");
      return Advance(ctx);
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
  }

  std::optional<Time> NextSourceTime() override {
    if (!next_) return std::nullopt;
    return Stamp(*next_);
  }

  // Mission time is relative to the bag's start; its end is in the bag's index.
  std::optional<Time> SourceEndTime() const override {
    if (!reader_) return std::nullopt;
    const double end_s = reader_->end_time_s() - reader_->start_time_s();
    if (!(end_s > 0.0)) return std::nullopt;
    return Time::FromSeconds(end_s);
  }

  Status Process(Context& ctx) override {
    if (!next_) return Status::Ok();
    const Time stamp = Stamp(*next_);
    last_stamp_ = stamp;
    Record record = std::move(*next_);
    next_.reset();
    outputs_.Publish(stamp, std::move(record.message));
    ++published_;
    Status status = Advance(ctx);
    if (status.ok() && !next_) {
      ctx.Log("end of bag after " + std::to_string(published_) + " messages" +
              (skipped_ > 0 ? ", " + std::to_string(skipped_) + " skipped" : std::string()));
    }
    return status;
  }

 private:
  // Reads the next record into next_, skipping bad messages when asked to.
  Status Advance(Context& ctx) {
    while (true) {
      try {
        next_ = reader_->Next();
        return Status::Ok();
      } catch (const BagError& e) {
        if (!skip_bad_messages_ || !e.bad_message()) return Status::Fatal(e.what());
        ++skipped_;
        ctx.Log(log::Level::kWarn, std::string("skipped: ") + e.what());
      }
    }
  }

  Time Stamp(const Record& record) const {
    return std::max(last_stamp_, Time::FromSeconds(std::max(0.0, MessageTime(record.message))));
  }

  std::string bag_;
  Options options_;
  bool skip_bad_messages_ = false;
  std::optional<BagReader> reader_;
  std::optional<Record> next_;
  Time last_stamp_;
  std::uint64_t published_ = 0;
  std::uint64_t skipped_ = 0;
  sensor_outputs::SensorOutputs outputs_;
};
DRACO_REGISTER_COMPONENT(BagReaderComponent, "sonar.BagReader")

}  // namespace
}  // namespace draco::rosbag
