// The one place the simulator app talks to the recording library (recorded-mission format,
// docs/recording-format.md).
#pragma once

#include <filesystem>
#include <memory>
#include <vector>

#include "draco/recording/recording.hpp"
#include "draco/sim/mission.hpp"
#include "draco/sim/simulator.hpp"

namespace draco::sim_app {

// A sink that writes one robot's streams; Close() finishes its files.
class RecordingSink : public sim::RobotSink {
 public:
  ~RecordingSink() override = default;
  virtual void Close() = 0;
};

class MissionOutput {
 public:
  // Creates (or replaces) the mission directory for the given robots of the mission.
  MissionOutput(const std::filesystem::path& dir, const sim::Mission& mission,
                const std::vector<int>& robot_indices,
                const recording::WriterOptions& options = {});
  ~MissionOutput();
  MissionOutput(const MissionOutput&) = delete;
  MissionOutput& operator=(const MissionOutput&) = delete;

  // One sink per robot; sinks of different robots may be used from different threads.
  std::unique_ptr<RecordingSink> OpenRobot(int robot_index);
  // After every robot's sink was closed: puts mission.yaml in place.
  void Close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace draco::sim_app
