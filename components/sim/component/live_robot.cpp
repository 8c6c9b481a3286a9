// sim.LiveRobot: simulates one robot of a mission while the graph runs and publishes its
// sensors as sonar.RecordingReader publishes a recording of the same mission (same ports,
// messages and stamps), so a graph swaps one for the other. A thin adapter over
// draco::sim::RobotStream (docs/simulator.md, "Live").
#include <memory>
#include <string>

#include "draco/graph/component.hpp"
#include "draco/sensor_outputs/sensor_outputs.hpp"
#include "draco/sim/mission.hpp"
#include "draco/sim/robot_stream.hpp"
#include "draco/sim/simulator.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;
using graph::Time;

class LiveRobotComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Source(
        "Simulates one robot of a mission (sonar pings, DVL, AHRS, depth, ground truth) on a "
        "thread of its own while the graph runs, and publishes the records in mission-time "
        "order: the messages a recording of the same mission (draco-sim) replays, nothing "
        "written to disk.");
    outputs_.Declare(spec, "true body pose in the world frame");
    spec.Param("mission", &mission_file_,
               {.doc = "mission YAML (config/missions/*.yaml); its world is found from it"});
    spec.Param("robot", &robot_,
               {.doc = "robot name in the mission; may be empty when the mission has one robot"});
    spec.Param("duration_s", &duration_s_,
               {.doc = "cap of the robot's duration, as draco-sim --duration-s (0: the mission's)",
                .unit = "s",
                .min = 0.0});
    spec.Param("seed", &seed_,
               {.doc = "mission seed, as draco-sim --seed (-1: the mission's)",
                .min = -1.0,
                .max = 2147483647.0});
    spec.Param("queue_records", &queue_records_,
               {.doc = "records simulated ahead of the graph on the component's own thread (the "
                       "simulator waits while the queue is full)",
                .min = 1.0,
                .max = 65536.0});
  }

  Status Start(Context& ctx) override {
    if (mission_file_.empty()) return Status::Fatal("parameter 'mission' is not set");
    try {
      Mission mission = LoadMission(mission_file_);
      if (duration_s_ > 0.0) mission.duration_s = duration_s_;
      if (seed_ >= 0) mission.seed = static_cast<std::uint64_t>(seed_);
      int index = -1;
      if (robot_.empty()) {
        if (mission.robots.size() != 1) {
          return Status::Fatal("parameter 'robot' is not set and mission '" + mission_file_ +
                               "' has " + std::to_string(mission.robots.size()) + " robots");
        }
        index = 0;
      } else {
        for (std::size_t i = 0; i < mission.robots.size(); ++i) {
          if (mission.robots[i].name == robot_) index = static_cast<int>(i);
        }
        if (index < 0) {
          return Status::Fatal("robot '" + robot_ + "' is not in mission '" + mission_file_ + "'");
        }
      }
      end_s_ = LastAhrsTimeS(mission, index);
      World world = LoadWorld(mission.world_path);
      const std::string line = "simulating robot '" + mission.robots[index].name +
                               "' of mission '" + mission.name + "' (seed " +
                               std::to_string(mission.seed) + ") live from " + mission_file_;
      stream_ = std::make_unique<RobotStream>(std::move(world), std::move(mission), index,
                                              static_cast<std::size_t>(queue_records_));
      next_ = stream_->Next();
      ctx.Log(line);
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    return Status::Ok();
  }

  std::optional<Time> NextSourceTime() override {
    if (!next_) return std::nullopt;
    return Time::FromSeconds(StreamRecordTime(*next_));
  }

  // The time of the robot's last AHRS sample, as the recording's replay length.
  std::optional<Time> SourceEndTime() const override {
    if (!(end_s_ > 0.0)) return std::nullopt;
    return Time::FromSeconds(end_s_);
  }

  Status Process(Context& ctx) override {
    if (!next_) return Status::Ok();
    const Time stamp = Time::FromSeconds(StreamRecordTime(*next_));
    StreamRecord record = std::move(*next_);
    next_.reset();
    outputs_.Publish(stamp, std::move(record));
    ++published_;
    try {
      next_ = stream_->Next();
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    if (!next_) ctx.Log("end of the simulation after " + std::to_string(published_) + " messages");
    return Status::Ok();
  }

  // The graph may end before the simulation: the producer leaves at its next record.
  Status Stop(Context&) override {
    if (stream_) stream_->Stop();
    next_.reset();
    return Status::Ok();
  }

 private:
  std::string mission_file_;
  std::string robot_;
  double duration_s_ = 0.0;
  int seed_ = -1;
  int queue_records_ = 256;
  std::unique_ptr<RobotStream> stream_;
  std::optional<StreamRecord> next_;
  std::uint64_t published_ = 0;
  double end_s_ = 0.0;
  sensor_outputs::SensorOutputs outputs_;
};
DRACO_REGISTER_COMPONENT(LiveRobotComponent, "sim.LiveRobot")

}  // namespace
}  // namespace draco::sim
