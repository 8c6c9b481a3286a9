// MissionWriter and RobotWriter: every file goes through AtomicFile (".partial", renamed on
// close).
#include <cmath>
#include <set>

#include "internal.hpp"

namespace draco::recording {

using internal::AppendDouble;
using internal::AtomicFile;
namespace fs = std::filesystem;

namespace {

void CheckTime(double time_s, double& last_time_s, const char* stream) {
  if (!std::isfinite(time_s)) {
    throw std::invalid_argument(std::string(stream) + ": time is not finite");
  }
  if (time_s < last_time_s) {
    throw std::invalid_argument(std::string(stream) + ": time " + internal::FormatDouble(time_s) +
                                " s is before the previous " + internal::FormatDouble(last_time_s) +
                                " s");
  }
  last_time_s = time_s;
}

void CheckFinite(std::initializer_list<double> values, const char* stream) {
  for (double v : values) {
    if (!std::isfinite(v)) throw std::invalid_argument(std::string(stream) + ": non-finite value");
  }
}

std::vector<fs::path> RobotFiles(const fs::path& robot_dir, bool ground_truth) {
  std::vector<fs::path> files = {robot_dir / internal::kSonarFile, robot_dir / internal::kDvlFile,
                                 robot_dir / internal::kAhrsFile, robot_dir / internal::kDepthFile};
  if (ground_truth) files.push_back(robot_dir / internal::kGroundTruthFile);
  return files;
}

}  // namespace

// ---- RobotWriter ------------------------------------------------------------------------

struct RobotWriter::Impl {
  RobotInfo robot;
  std::unique_ptr<internal::PingEncoder> encoder;
  std::unique_ptr<AtomicFile> sonar, dvl, ahrs, depth, ground_truth;
  std::vector<float> last_bearings;
  std::vector<std::uint8_t> record;
  std::string line;
  std::uint64_t pings = 0;
  double last_ping = -INFINITY, last_dvl = -INFINITY, last_ahrs = -INFINITY, last_depth = -INFINITY,
         last_ground_truth = -INFINITY;
  bool closed = false;

  void CheckOpen() const {
    if (closed) throw std::logic_error("robot '" + robot.name + "': writer already closed");
  }

  void WriteLine(AtomicFile& file) {
    line += '\n';
    file.Write(line);
  }
};

RobotWriter::RobotWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
RobotWriter::RobotWriter(RobotWriter&&) noexcept = default;
RobotWriter& RobotWriter::operator=(RobotWriter&&) noexcept = default;
RobotWriter::~RobotWriter() = default;  // AtomicFile destructors remove unfinished files

void RobotWriter::WritePing(const msgs::SonarPing& ping) {
  Impl& d = *impl_;
  d.CheckOpen();
  CheckTime(ping.time_s, d.last_ping, "WritePing");
  if (ping.num_ranges <= 0 || ping.num_beams <= 0 ||
      static_cast<std::uint32_t>(ping.num_ranges) > internal::kMaxImageSide ||
      static_cast<std::uint32_t>(ping.num_beams) > internal::kMaxImageSide) {
    throw std::invalid_argument("WritePing: image size must be positive and at most 65536");
  }
  const std::size_t cells = static_cast<std::size_t>(ping.num_ranges) * ping.num_beams;
  if (ping.intensity.size() != cells) {
    throw std::invalid_argument("WritePing: intensity has " +
                                std::to_string(ping.intensity.size()) + " bytes, expected " +
                                std::to_string(cells));
  }
  if (ping.bearings_rad.size() != static_cast<std::size_t>(ping.num_beams)) {
    throw std::invalid_argument("WritePing: bearings_rad has " +
                                std::to_string(ping.bearings_rad.size()) + " values, expected " +
                                std::to_string(ping.num_beams));
  }
  for (float b : ping.bearings_rad) {
    if (!std::isfinite(b)) throw std::invalid_argument("WritePing: non-finite bearing");
  }
  if (!(std::isfinite(ping.range_resolution_m) && ping.range_resolution_m > 0)) {
    throw std::invalid_argument("WritePing: range_resolution_m must be > 0");
  }
  CheckFinite({ping.vertical_aperture_rad}, "WritePing");
  const bool include_bearings = ping.bearings_rad != d.last_bearings;
  d.record.clear();
  d.encoder->EncodePingRecord(ping, include_bearings, d.record);
  d.sonar->Write(d.record.data(), d.record.size());
  if (include_bearings) d.last_bearings = ping.bearings_rad;
  ++d.pings;
}

void RobotWriter::WriteDvl(const msgs::DvlVelocity& dvl) {
  Impl& d = *impl_;
  d.CheckOpen();
  CheckTime(dvl.time_s, d.last_dvl, "WriteDvl");
  const auto& v = dvl.velocity_body_mps;
  CheckFinite({v[0], v[1], v[2], dvl.altitude_m}, "WriteDvl");
  d.line.clear();
  for (double x : {dvl.time_s, v[0], v[1], v[2], dvl.altitude_m}) {
    AppendDouble(d.line, x);
    d.line += ',';
  }
  d.line += dvl.valid ? '1' : '0';
  d.WriteLine(*d.dvl);
}

void RobotWriter::WriteAhrs(const msgs::Ahrs& ahrs) {
  Impl& d = *impl_;
  d.CheckOpen();
  CheckTime(ahrs.time_s, d.last_ahrs, "WriteAhrs");
  CheckFinite({ahrs.roll_rad, ahrs.pitch_rad, ahrs.yaw_rad, ahrs.yaw_rate_radps}, "WriteAhrs");
  d.line.clear();
  AppendDouble(d.line, ahrs.time_s);
  for (double x : {ahrs.roll_rad, ahrs.pitch_rad, ahrs.yaw_rad, ahrs.yaw_rate_radps}) {
    d.line += ',';
    AppendDouble(d.line, x);
  }
  d.WriteLine(*d.ahrs);
}

void RobotWriter::WriteDepth(const msgs::Depth& depth) {
  Impl& d = *impl_;
  d.CheckOpen();
  CheckTime(depth.time_s, d.last_depth, "WriteDepth");
  CheckFinite({depth.depth_m}, "WriteDepth");
  d.line.clear();
  AppendDouble(d.line, depth.time_s);
  d.line += ',';
  AppendDouble(d.line, depth.depth_m);
  d.WriteLine(*d.depth);
}

void RobotWriter::WriteGroundTruth(const msgs::GroundTruthPose& pose) {
  Impl& d = *impl_;
  d.CheckOpen();
  if (!d.ground_truth) {
    throw std::invalid_argument("WriteGroundTruth: robot '" + d.robot.name +
                                "' was declared without ground truth");
  }
  CheckTime(pose.time_s, d.last_ground_truth, "WriteGroundTruth");
  const auto& p = pose.position_m;
  CheckFinite({p[0], p[1], p[2], pose.roll_rad, pose.pitch_rad, pose.yaw_rad}, "WriteGroundTruth");
  const std::array<double, 4> q =
      internal::QuaternionFromRpy(pose.roll_rad, pose.pitch_rad, pose.yaw_rad);
  d.line.clear();
  AppendDouble(d.line, pose.time_s);
  for (double x : {p[0], p[1], p[2], q[0], q[1], q[2], q[3]}) {
    d.line += ' ';
    AppendDouble(d.line, x);
  }
  d.WriteLine(*d.ground_truth);
}

void RobotWriter::Close() {
  Impl& d = *impl_;
  d.CheckOpen();
  d.record.clear();
  internal::EncodeEndRecord(d.pings, d.record);
  d.sonar->Write(d.record.data(), d.record.size());
  for (auto* file : {&d.sonar, &d.dvl, &d.ahrs, &d.depth, &d.ground_truth}) {
    if (*file) (*file)->Commit();
  }
  d.closed = true;
}

bool RobotWriter::IsClosed() const { return impl_->closed; }
std::uint64_t RobotWriter::PingCount() const { return impl_->pings; }

// ---- MissionWriter ----------------------------------------------------------------------

struct MissionWriter::Impl {
  fs::path dir;
  MissionInfo info;
  WriterOptions options;
  std::unique_ptr<AtomicFile> mission_file;
  std::set<std::string> opened;
};

MissionWriter::MissionWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
MissionWriter::MissionWriter(MissionWriter&&) noexcept = default;
MissionWriter& MissionWriter::operator=(MissionWriter&&) noexcept = default;
MissionWriter::~MissionWriter() = default;

MissionWriter MissionWriter::Create(const fs::path& mission_dir, const MissionInfo& info,
                                    const WriterOptions& options) {
  const std::string problem = internal::ValidateMissionInfo(info);
  if (!problem.empty()) throw std::invalid_argument("MissionInfo: " + problem);
  if (const std::string bad = internal::ValidateWriterOptions(options); !bad.empty()) {
    throw std::invalid_argument("WriterOptions: " + bad);
  }

  std::error_code error;
  const fs::path mission_file = mission_dir / internal::kMissionFile;
  fs::path partial_mission = mission_file;
  partial_mission += internal::kPartialSuffix;
  if (fs::exists(mission_dir, error)) {
    if (!fs::is_directory(mission_dir, error)) {
      throw RecordingError(mission_dir.string() + ": exists and is not a directory");
    }
    const bool is_mission = fs::exists(mission_file, error) || fs::exists(partial_mission, error);
    if (!is_mission && !fs::is_empty(mission_dir, error)) {
      throw RecordingError(mission_dir.string() +
                           ": not empty and not a draco mission; refusing to write into it");
    }
    // Replacing a mission: it must stop looking whole before any file changes.
    fs::remove(mission_file, error);
    for (const RobotInfo& robot : info.robots) {
      for (const fs::path& file : RobotFiles(mission_dir / robot.name, true)) {
        fs::remove(file, error);
      }
    }
  }
  fs::create_directories(mission_dir, error);
  if (error) {
    throw RecordingError(mission_dir.string() + ": cannot create directory: " + error.message());
  }

  auto impl = std::make_unique<Impl>();
  impl->dir = mission_dir;
  impl->info = info;
  impl->options = options;
  impl->mission_file = std::make_unique<AtomicFile>(mission_file);
  impl->mission_file->Write(internal::MissionYaml(info));
  return MissionWriter(std::move(impl));
}

RobotWriter MissionWriter::OpenRobot(const std::string& robot_name) {
  Impl& d = *impl_;
  const RobotInfo* robot = d.info.FindRobot(robot_name);
  if (robot == nullptr) {
    throw std::invalid_argument("OpenRobot: no robot '" + robot_name + "' in mission '" +
                                d.info.name + "'");
  }
  if (!d.opened.insert(robot_name).second) {
    throw std::invalid_argument("OpenRobot: robot '" + robot_name + "' was already opened");
  }
  const fs::path robot_dir = d.dir / robot_name;
  std::error_code error;
  fs::create_directories(robot_dir, error);
  if (error) {
    throw RecordingError(robot_dir.string() + ": cannot create directory: " + error.message());
  }

  auto impl = std::make_unique<RobotWriter::Impl>();
  impl->robot = *robot;
  impl->encoder = std::make_unique<internal::PingEncoder>(d.options);
  impl->sonar = std::make_unique<AtomicFile>(robot_dir / internal::kSonarFile);
  impl->dvl = std::make_unique<AtomicFile>(robot_dir / internal::kDvlFile);
  impl->ahrs = std::make_unique<AtomicFile>(robot_dir / internal::kAhrsFile);
  impl->depth = std::make_unique<AtomicFile>(robot_dir / internal::kDepthFile);
  if (robot->has_ground_truth) {
    impl->ground_truth = std::make_unique<AtomicFile>(robot_dir / internal::kGroundTruthFile);
    impl->ground_truth->Write(std::string(internal::kTumHeader) + "\n");
  }
  std::vector<std::uint8_t> header;
  internal::EncodeSonarFileHeader(header);
  impl->sonar->Write(header.data(), header.size());
  impl->dvl->Write(std::string(internal::kDvlHeader) + "\n");
  impl->ahrs->Write(std::string(internal::kAhrsHeader) + "\n");
  impl->depth->Write(std::string(internal::kDepthHeader) + "\n");
  return RobotWriter(std::move(impl));
}

void MissionWriter::Close() {
  Impl& d = *impl_;
  if (!d.mission_file) throw std::logic_error("MissionWriter: already closed");
  for (const RobotInfo& robot : d.info.robots) {
    for (const fs::path& file : RobotFiles(d.dir / robot.name, robot.has_ground_truth)) {
      std::error_code error;
      if (!fs::is_regular_file(file, error)) {
        throw RecordingError(file.string() + ": missing; robot '" + robot.name +
                             "' must be opened and closed before the mission is closed");
      }
    }
  }
  d.mission_file->Commit();
  d.mission_file.reset();
}

const MissionInfo& MissionWriter::Info() const { return impl_->info; }
const fs::path& MissionWriter::Directory() const { return impl_->dir; }

}  // namespace draco::recording
