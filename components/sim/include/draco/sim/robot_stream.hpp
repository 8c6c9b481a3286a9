// One robot of a mission simulated on a thread of its own and taken record by record, in
// the order a recording of the same mission gives them back (sim.LiveRobot streams it into a
// graph in place of a recorded mission; docs/simulator.md, "Live").
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <variant>

#include "draco/msgs/sensors.hpp"
#include "draco/sim/mission.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim {

// One record of a robot's merged stream (the same alternatives as recording::Record).
using StreamRecord = std::variant<msgs::SonarPing, msgs::DvlVelocity, msgs::Ahrs, msgs::Depth,
                                  msgs::GroundTruthPose>;

double StreamRecordTime(const StreamRecord& record);

// SimulateRobot(world, mission, robot_index, sonar, ...) on a producer thread into a queue of
// at most `depth` records. Next() gives the records in the simulator's order (time, ties:
// AHRS, DVL, depth, sonar, ground truth), the same records as a RobotReader of the recorded
// mission. The destructor stops the producer at its next record (within one ping's render).
class RobotStream {
 public:
  // Starts the producer. with_sonar false: navigation and ground truth only.
  RobotStream(World world, Mission mission, int robot_index, std::size_t depth,
              bool with_sonar = true);
  RobotStream(const RobotStream&) = delete;
  RobotStream& operator=(const RobotStream&) = delete;
  ~RobotStream();

  // Waits for the next record; std::nullopt at the end. Rethrows the simulator's error.
  std::optional<StreamRecord> Next();

  // Stops and joins the producer (records not taken are dropped); Next() then returns
  // std::nullopt. Idempotent.
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace draco::sim
