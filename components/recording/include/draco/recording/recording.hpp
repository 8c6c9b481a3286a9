// Recorded missions: write and stream-read the on-disk format described in
// docs/recording-format.md (format "draco-mission", version 1).
//
// A mission is a directory:
//   mission.yaml            metadata (MissionInfo): sonar geometry, robots, rates, world, seed
//   <robot>/sonar.drs       binary sonar pings (compressed polar images, CRC-checked)
//   <robot>/dvl.csv         DVL body velocity
//   <robot>/ahrs.csv        attitude and heading
//   <robot>/depth.csv       depth
//   <robot>/groundtruth.tum ground truth in TUM format (only when the robot has ground truth)
//
// Writing is atomic per file: data goes to "<file>.partial", renamed on Close(). A writer
// destroyed without Close() removes its partial files, so an interrupted run never leaves a
// file that looks whole. mission.yaml is renamed last, by MissionWriter::Close().
//
// Reading is streaming: RobotReader merges one robot's streams in time order and holds at
// most one decoded record per stream in memory.
//
// Errors in files (missing, truncated, corrupt, wrong version, malformed metadata) throw
// RecordingError whose message names the file, the record index or line, and what was
// expected. Misuse of the writer API (time going backwards, wrong image size, unknown robot
// name) throws std::invalid_argument.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "draco/msgs/sensors.hpp"

namespace draco::recording {

inline constexpr const char* kFormatName = "draco-mission";
inline constexpr int kFormatVersion = 1;

// Thrown for any problem with a recorded file; what() names the file and the place.
class RecordingError : public std::runtime_error {
 public:
  explicit RecordingError(const std::string& message) : std::runtime_error(message) {}
};

// Pose of the sonar frame in the body frame (body: x forward, y left, z up).
// Rotation R = Rz(yaw) * Ry(pitch) * Rx(roll); a sonar tilted down has positive pitch.
struct SonarMount {
  std::array<double, 3> position_m{0.0, 0.0, 0.0};
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;
};

// Nominal sonar geometry of the mission. Every ping also carries its own geometry and
// bearing table; these values describe the device and are what a consumer can size for.
struct SonarInfo {
  int num_beams = 512;
  int num_ranges = 512;
  double range_resolution_m = 30.0 / 512.0;
  double horizontal_aperture_rad = 2.2689280275926285;  // 130 deg
  double vertical_aperture_rad = 0.3490658503988659;    // 20 deg
  double rate_hz = 5.0;
  SonarMount mount;
};

// Nominal rates of the navigation streams (0 when a stream is absent).
struct NavigationRates {
  double dvl_hz = 5.0;
  double ahrs_hz = 200.0;
  double depth_hz = 5.0;
  double ground_truth_hz = 20.0;
};

struct RobotInfo {
  std::string name;  // folder name: letters, digits, '_' and '-' only
  int id = 0;        // unique, >= 0
  bool has_ground_truth = true;
};

struct MissionInfo {
  std::string name;
  std::string world;
  std::uint64_t seed = 0;
  SonarInfo sonar;
  NavigationRates navigation;
  std::vector<RobotInfo> robots;
  std::string notes;  // free-form, may be multi-line

  // nullptr when no robot has that name.
  const RobotInfo* FindRobot(const std::string& robot_name) const;
};

// Reads and validates <dir>/mission.yaml (format name, version, every key known and present).
MissionInfo LoadMissionInfo(const std::filesystem::path& mission_dir);

// One record of a robot's merged stream.
using Record = std::variant<msgs::SonarPing, msgs::DvlVelocity, msgs::Ahrs, msgs::Depth,
                            msgs::GroundTruthPose>;

double RecordTime(const Record& record);

enum class ImageCompression : std::uint8_t {
  kRaw = 0,   // uncompressed rows (fastest, largest)
  kPng = 1,   // lossless PNG, 8-bit grey: any image tool opens it
  kZlib = 2,  // lossless zlib stream of the raw rows (Huffman-only at level 1)
  kZstd = 3,  // lossless zstd frame of the raw rows (default: as small as zlib level 1 and
              // several times faster to read; docs/recording-format.md section 10)
};

struct WriterOptions {
  ImageCompression compression = ImageCompression::kZstd;
  // kPng and kZlib: zlib level 1-9, 1 the fastest. kZstd: zstd level -131072..22; negative
  // levels are the fastest and store literals uncompressed (speckle then barely shrinks), 0
  // means zstd's default (3). Ignored for kRaw.
  int compression_level = 1;
  // Lossy option: each intensity v is stored as the nearest multiple of Q =
  // ping_quantization_step, min(255, Q * floor((v + floor(Q / 2)) / Q)), before the encoding:
  // no return (0) stays 0, and the entropy coder needs about log2(Q) bits less per cell
  // (speckle's low bits are noise). The step is written in the ping record
  // (docs/recording-format.md). 1 (default): the exact image; 1..128.
  int ping_quantization_step = 1;
};

// Writes one robot's files. Obtained from MissionWriter::OpenRobot; movable, not copyable.
// Independent RobotWriters may be used from different threads.
// Each stream's times must be non-decreasing (std::invalid_argument otherwise).
class RobotWriter {
 public:
  RobotWriter(RobotWriter&&) noexcept;
  RobotWriter& operator=(RobotWriter&&) noexcept;
  RobotWriter(const RobotWriter&) = delete;
  RobotWriter& operator=(const RobotWriter&) = delete;
  ~RobotWriter();  // without Close(): removes the partial files

  // ping.intensity must hold num_ranges * num_beams bytes and bearings_rad num_beams values.
  void WritePing(const msgs::SonarPing& ping);
  void WriteDvl(const msgs::DvlVelocity& dvl);
  void WriteAhrs(const msgs::Ahrs& ahrs);
  void WriteDepth(const msgs::Depth& depth);
  // std::invalid_argument when the robot was declared without ground truth.
  void WriteGroundTruth(const msgs::GroundTruthPose& pose);

  // Flushes, writes the sonar end record and renames every file to its final name.
  void Close();
  bool IsClosed() const;

  std::uint64_t PingCount() const;

 private:
  struct Impl;
  explicit RobotWriter(std::unique_ptr<Impl> impl);
  friend class MissionWriter;
  std::unique_ptr<Impl> impl_;
};

class MissionWriter {
 public:
  // Creates the mission directory (and parents). An existing mission there is replaced: its
  // mission.yaml and the named robots' files are removed first. A non-empty directory that
  // is not a mission is refused (RecordingError). Validates info (std::invalid_argument).
  static MissionWriter Create(const std::filesystem::path& mission_dir, const MissionInfo& info,
                              const WriterOptions& options = {});

  MissionWriter(MissionWriter&&) noexcept;
  MissionWriter& operator=(MissionWriter&&) noexcept;
  MissionWriter(const MissionWriter&) = delete;
  MissionWriter& operator=(const MissionWriter&) = delete;
  ~MissionWriter();  // without Close(): removes mission.yaml.partial

  // At most once per robot named in the MissionInfo.
  RobotWriter OpenRobot(const std::string& robot_name);

  // Renames mission.yaml into place. Every robot must have been opened and closed
  // (RecordingError naming the robot otherwise).
  void Close();

  const MissionInfo& Info() const;
  const std::filesystem::path& Directory() const;

 private:
  struct Impl;
  explicit MissionWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Which streams a RobotReader opens; skipped streams are never read (nor required).
struct ReadOptions {
  bool sonar = true;
  bool dvl = true;
  bool ahrs = true;
  bool depth = true;
  bool ground_truth = true;  // ignored when the robot has no ground truth
};

// Streams one robot's records merged by time. Records with equal times come out in a fixed
// stream order: AHRS, DVL, depth, sonar, ground truth (navigation before the ping it
// belongs to); within a stream, in file order. Deterministic across runs.
class RobotReader {
 public:
  // RecordingError when mission.yaml or a required file is missing or bad, or the robot is
  // not in the mission.
  static RobotReader Open(const std::filesystem::path& mission_dir, const std::string& robot_name,
                          const ReadOptions& options = {});

  RobotReader(RobotReader&&) noexcept;
  RobotReader& operator=(RobotReader&&) noexcept;
  RobotReader(const RobotReader&) = delete;
  RobotReader& operator=(const RobotReader&) = delete;
  ~RobotReader();

  // The next record in time order; std::nullopt once every stream is exhausted.
  // Throws RecordingError on corrupt or truncated data as soon as it is reached.
  std::optional<Record> Next();

  const MissionInfo& Mission() const;
  const RobotInfo& Robot() const;

 private:
  struct Impl;
  explicit RobotReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// A RobotReader read ahead on a thread of its own, up to `depth` records waiting (and one in
// the reader's hands): Next() gives the same records in the same order as the reader's Next()
// (and throws its RecordingError where the reader would have), so a replay's outputs do not
// change, while decompressing pings runs beside the consumer (on 2 cores the team replay's
// readers leave the executor's thread).
class PrefetchingReader {
 public:
  PrefetchingReader(RobotReader reader, std::size_t depth);
  PrefetchingReader(const PrefetchingReader&) = delete;
  PrefetchingReader& operator=(const PrefetchingReader&) = delete;
  ~PrefetchingReader();  // stops the thread (records not taken are dropped)

  // Waits for the next record; std::nullopt at the end. Rethrows the reader's error.
  std::optional<Record> Next();

  const MissionInfo& Mission() const;
  const RobotInfo& Robot() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Mission time of a robot's replay: the time of the last AHRS sample (the last line of
// <mission>/<robot>/ahrs.csv; read from the file's end, cheap), 0 when unknown. For progress
// lines and for running a team to its longest replay.
double RobotReplayLengthS(const std::filesystem::path& mission_dir, const std::string& robot);

}  // namespace draco::recording
