// sonar.RecordingReader: replays one robot of a recorded mission (docs/recording-format.md)
// as typed messages stamped in mission time. A thin adapter over draco_recording.
#include <memory>
#include <string>

#include "draco/graph/component.hpp"
#include "draco/msgs/sensors.hpp"
#include "draco/recording/recording.hpp"
#include "draco/sensor_outputs/sensor_outputs.hpp"

namespace draco::recording {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;
using graph::Time;

class RecordingReaderComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Source(
        "Replays one robot of a recorded mission (sonar pings, DVL, AHRS, depth, ground "
        "truth) in mission-time order. A missing, truncated or corrupt file stops the run "
        "with an error naming the file and the place.");
    outputs_.Declare(spec, "true body pose in the world frame (only when the mission has it)");
    spec.Param("recording", &recording_,
               {"mission directory (the folder holding mission.yaml)", "", {}, {}, {}});
    spec.Param(
        "robot", &robot_,
        {"robot name in the mission; may be empty when the mission has one robot", "", {}, {}, {}});
    spec.Param("prefetch_records", &prefetch_records_,
               {"records read ahead on a thread of the reader's own (decompressing pings beside "
                "the graph; the same records in the same order); 0 reads on the executor's thread",
                "",
                0.0,
                65536.0,
                {}});
  }

  Status Start(Context& ctx) override {
    if (recording_.empty()) return Status::Fatal("parameter 'recording' is not set");
    try {
      std::string robot = robot_;
      if (robot.empty()) {
        const MissionInfo info = LoadMissionInfo(recording_);
        if (info.robots.size() != 1) {
          return Status::Fatal("parameter 'robot' is not set and mission '" + recording_ +
                               "' has " + std::to_string(info.robots.size()) + " robots");
        }
        robot = info.robots[0].name;
      }
      RobotReader reader = RobotReader::Open(recording_, robot);
      const std::string mission_name = reader.Mission().name;
      if (prefetch_records_ > 0) {
        prefetch_ = std::make_unique<PrefetchingReader>(
            std::move(reader), static_cast<std::size_t>(prefetch_records_));
      } else {
        reader_.emplace(std::move(reader));
      }
      end_s_ = RobotReplayLengthS(recording_, robot);
      next_ = NextRecord();
      ctx.Log("replaying robot '" + robot + "' of mission '" + mission_name + "' from " +
              recording_);
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    return Status::Ok();
  }

  std::optional<Time> NextSourceTime() override {
    if (!next_) return std::nullopt;
    return Time::FromSeconds(RecordTime(*next_));
  }

  // The recording's last AHRS stamp (the mission's length; docs/recording-format.md).
  std::optional<Time> SourceEndTime() const override {
    if (!(end_s_ > 0.0)) return std::nullopt;
    return Time::FromSeconds(end_s_);
  }

  Status Process(Context& ctx) override {
    if (!next_) return Status::Ok();
    const Time stamp = Time::FromSeconds(RecordTime(*next_));
    Record record = std::move(*next_);
    next_.reset();
    outputs_.Publish(stamp, std::move(record));
    ++published_;
    try {
      next_ = NextRecord();
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    if (!next_) ctx.Log("end of recording after " + std::to_string(published_) + " messages");
    return Status::Ok();
  }

 private:
  std::optional<Record> NextRecord() { return prefetch_ ? prefetch_->Next() : reader_->Next(); }

  std::string recording_;
  std::string robot_;
  int prefetch_records_ = 256;
  std::optional<RobotReader> reader_;
  std::unique_ptr<PrefetchingReader> prefetch_;
  std::optional<Record> next_;
  std::uint64_t published_ = 0;
  double end_s_ = 0.0;  // 0: unknown
  sensor_outputs::SensorOutputs outputs_;
};
DRACO_REGISTER_COMPONENT(RecordingReaderComponent, "sonar.RecordingReader")

}  // namespace
}  // namespace draco::recording
