// RobotReader: merges one robot's streams by time, one pending record per stream.
#include "internal.hpp"

namespace draco::recording {

namespace fs = std::filesystem;

struct RobotReader::Impl {
  MissionInfo mission;
  RobotInfo robot;
  // In tie-break order: on equal times the earlier stream goes first.
  std::vector<std::unique_ptr<internal::Stream>> streams;
  std::vector<std::optional<Record>> heads;
};

RobotReader::RobotReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
RobotReader::RobotReader(RobotReader&&) noexcept = default;
RobotReader& RobotReader::operator=(RobotReader&&) noexcept = default;
RobotReader::~RobotReader() = default;

RobotReader RobotReader::Open(const fs::path& mission_dir, const std::string& robot_name,
                              const ReadOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->mission = LoadMissionInfo(mission_dir);
  const RobotInfo* robot = impl->mission.FindRobot(robot_name);
  if (robot == nullptr) {
    std::string names;
    for (const RobotInfo& r : impl->mission.robots) names += (names.empty() ? "" : ", ") + r.name;
    throw RecordingError((mission_dir / internal::kMissionFile).string() + ": no robot '" +
                         robot_name + "' (the mission has: " + names + ")");
  }
  impl->robot = *robot;
  const fs::path dir = mission_dir / robot_name;
  if (options.ahrs) impl->streams.push_back(internal::OpenAhrsStream(dir / internal::kAhrsFile));
  if (options.dvl) impl->streams.push_back(internal::OpenDvlStream(dir / internal::kDvlFile));
  if (options.depth) {
    impl->streams.push_back(internal::OpenDepthStream(dir / internal::kDepthFile));
  }
  if (options.sonar) {
    impl->streams.push_back(internal::OpenSonarStream(dir / internal::kSonarFile));
  }
  if (options.ground_truth && robot->has_ground_truth) {
    impl->streams.push_back(internal::OpenGroundTruthStream(dir / internal::kGroundTruthFile));
  }
  for (auto& stream : impl->streams) impl->heads.push_back(stream->Next());
  return RobotReader(std::move(impl));
}

std::optional<Record> RobotReader::Next() {
  Impl& d = *impl_;
  std::size_t best = d.heads.size();
  double best_time = 0.0;
  for (std::size_t i = 0; i < d.heads.size(); ++i) {
    if (!d.heads[i]) continue;
    const double t = RecordTime(*d.heads[i]);
    if (best == d.heads.size() || t < best_time) {
      best = i;
      best_time = t;
    }
  }
  if (best == d.heads.size()) return std::nullopt;
  std::optional<Record> result = std::move(d.heads[best]);
  d.heads[best] = d.streams[best]->Next();
  return result;
}

const MissionInfo& RobotReader::Mission() const { return impl_->mission; }
const RobotInfo& RobotReader::Robot() const { return impl_->robot; }

}  // namespace draco::recording
