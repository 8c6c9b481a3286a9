#include "mission_output.hpp"

#include <mutex>
#include <sstream>

#include "draco/recording/recording.hpp"

namespace draco::sim_app {

namespace {

class RobotRecording : public RecordingSink {
 public:
  explicit RobotRecording(recording::RobotWriter writer) : writer_(std::move(writer)) {}
  void OnPing(const msgs::SonarPing& ping, const sim::TrajectorySample&) override {
    writer_.WritePing(ping);
  }
  void OnDvl(const msgs::DvlVelocity& dvl) override { writer_.WriteDvl(dvl); }
  void OnAhrs(const msgs::Ahrs& ahrs) override { writer_.WriteAhrs(ahrs); }
  void OnDepth(const msgs::Depth& depth) override { writer_.WriteDepth(depth); }
  void OnGroundTruth(const msgs::GroundTruthPose& pose) override { writer_.WriteGroundTruth(pose); }
  void Close() override { writer_.Close(); }

 private:
  recording::RobotWriter writer_;
};

recording::MissionInfo MakeInfo(const sim::Mission& mission,
                                const std::vector<int>& robot_indices) {
  recording::MissionInfo info;
  info.name = mission.name;
  info.world = mission.world_path.stem().string();
  info.seed = mission.seed;
  const sim::SonarOptions& s = mission.sonar;
  info.sonar.num_beams = s.num_beams;
  info.sonar.num_ranges = s.num_ranges;
  info.sonar.range_resolution_m = s.range_max_m / s.num_ranges;
  info.sonar.horizontal_aperture_rad = s.horizontal_aperture_rad;
  info.sonar.vertical_aperture_rad = s.vertical_aperture_rad;
  info.sonar.rate_hz = s.rate_hz;
  info.sonar.mount.pitch_rad = mission.sonar_tilt_rad;
  info.navigation.dvl_hz = mission.navigation.dvl.rate_hz;
  info.navigation.ahrs_hz = mission.navigation.ahrs.rate_hz;
  info.navigation.depth_hz = mission.navigation.depth.rate_hz;
  info.navigation.ground_truth_hz = mission.navigation.ground_truth_rate_hz;
  for (int index : robot_indices) {
    recording::RobotInfo robot;
    robot.name = mission.robots.at(static_cast<std::size_t>(index)).name;
    robot.id = index;
    robot.has_ground_truth = true;
    info.robots.push_back(robot);
  }
  std::ostringstream notes;
  notes << "Simulated by draco-sim from " << mission.source << " (world "
        << mission.world_path.string() << ", seed " << mission.seed << ").\n"
        << "Ground truth is the body pose in the world frame (x east, y north, z up); robots "
           "start at unknown relative poses.";
  info.notes = notes.str();
  return info;
}

}  // namespace

struct MissionOutput::Impl {
  recording::MissionWriter writer;
  std::mutex mutex;
  std::vector<std::pair<int, std::string>> names;
};

MissionOutput::MissionOutput(const std::filesystem::path& dir, const sim::Mission& mission,
                             const std::vector<int>& robot_indices,
                             const recording::WriterOptions& options)
    : impl_(
          new Impl{recording::MissionWriter::Create(dir, MakeInfo(mission, robot_indices), options),
                   {},
                   {}}) {
  for (int index : robot_indices) {
    impl_->names.push_back({index, mission.robots.at(static_cast<std::size_t>(index)).name});
  }
}

MissionOutput::~MissionOutput() = default;

std::unique_ptr<RecordingSink> MissionOutput::OpenRobot(int robot_index) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  for (const auto& [index, name] : impl_->names) {
    if (index == robot_index) {
      return std::make_unique<RobotRecording>(impl_->writer.OpenRobot(name));
    }
  }
  throw std::invalid_argument("robot " + std::to_string(robot_index) + " is not in the output");
}

void MissionOutput::Close() { impl_->writer.Close(); }

}  // namespace draco::sim_app
