// Pieces shared by the recording writer and reader; not part of the public API.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "draco/recording/recording.hpp"

namespace draco::recording::internal {

namespace fs = std::filesystem;

// File names inside a robot folder.
inline constexpr const char* kMissionFile = "mission.yaml";
inline constexpr const char* kSonarFile = "sonar.drs";
inline constexpr const char* kDvlFile = "dvl.csv";
inline constexpr const char* kAhrsFile = "ahrs.csv";
inline constexpr const char* kDepthFile = "depth.csv";
inline constexpr const char* kGroundTruthFile = "groundtruth.tum";
inline constexpr const char* kPartialSuffix = ".partial";

// CSV header lines (column names carry the units).
inline constexpr const char* kDvlHeader = "time_s,vx_mps,vy_mps,vz_mps,altitude_m,valid";
inline constexpr const char* kAhrsHeader = "time_s,roll_rad,pitch_rad,yaw_rad,yaw_rate_radps";
inline constexpr const char* kDepthHeader = "time_s,depth_m";
inline constexpr const char* kTumHeader = "# timestamp_s x_m y_m z_m qx qy qz qw";

// sonar.drs constants (see docs/recording-format.md).
inline constexpr char kSonarFileMagic[8] = {'D', 'R', 'A', 'C', 'O', 'S', 'N', 'R'};
inline constexpr char kRecordMagic[4] = {'D', 'R', 'E', 'C'};
inline constexpr std::uint32_t kSonarFileVersion = 1;
inline constexpr std::uint16_t kRecordPing = 1;
inline constexpr std::uint16_t kRecordEnd = 2;
inline constexpr std::uint8_t kPingHasBearings = 0x01;
inline constexpr std::size_t kFileHeaderBytes = 16;
inline constexpr std::size_t kRecordHeaderBytes = 12;
inline constexpr std::size_t kPingFixedBytes = 40;
inline constexpr std::uint32_t kMaxPayloadBytes = 256u << 20;
inline constexpr std::uint32_t kMaxImageSide = 1u << 16;
inline constexpr std::uint64_t kMaxImageCells = 64ull << 20;
// Deflate's largest expansion (zlib's "maximum compression factor 1032:1"): a compressed image
// of n bytes holds at most 1032 n pixels. zstd can expand further (about 32768:1); the format
// holds zstd images to the same bound, and the writer stores a ping whose zstd frame would be
// smaller with encoding 2 instead (docs/recording-format.md section 4).
inline constexpr std::uint64_t kMaxDeflateRatio = 1032;
inline constexpr int kMaxQuantizationStep = 128;  // WriterOptions::ping_quantization_step

std::uint32_t Crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc = 0);

// Shortest text that reads back to exactly v (std::to_chars).
void AppendDouble(std::string& out, double v);
std::string FormatDouble(double v);
// Whole-string, finite-only parse; nullopt on anything else.
std::optional<double> ParseDouble(const std::string& text);

// "" when info is valid, else a description of the first problem.
std::string ValidateMissionInfo(const MissionInfo& info);
bool IsValidRobotName(const std::string& name);

std::string MissionYaml(const MissionInfo& info);

// Quaternion (x, y, z, w) of R = Rz(yaw) Ry(pitch) Rx(roll) and back.
std::array<double, 4> QuaternionFromRpy(double roll, double pitch, double yaw);
void RpyFromQuaternion(const std::array<double, 4>& q, double& roll, double& pitch, double& yaw);

// An output file written as "<path>.partial" and renamed to <path> by Commit().
class AtomicFile {
 public:
  explicit AtomicFile(fs::path final_path);
  ~AtomicFile();  // Abort() unless committed
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void Write(const void* data, std::size_t size);
  void Write(const std::string& text) { Write(text.data(), text.size()); }
  void Commit();
  void Abort();
  const fs::path& FinalPath() const { return final_path_; }

 private:
  fs::path final_path_;
  fs::path partial_path_;
  std::FILE* file_ = nullptr;
  std::vector<char> buffer_;
};

// Encodes ping records; holds the compression state reused from ping to ping (a zstd
// context). One per RobotWriter; not thread-safe.
class PingEncoder {
 public:
  explicit PingEncoder(const WriterOptions& options);
  ~PingEncoder();
  PingEncoder(const PingEncoder&) = delete;
  PingEncoder& operator=(const PingEncoder&) = delete;

  // Appends one ping record (header, payload, CRC) to out.
  void EncodePingRecord(const msgs::SonarPing& ping, bool include_bearings,
                        std::vector<std::uint8_t>& out);

 private:
  struct Zstd;
  WriterOptions options_;
  std::unique_ptr<Zstd> zstd_;
  std::vector<std::uint8_t> quantized_;  // the image after ping_quantization_step
};

// "" when options are valid, else a description of the first problem.
std::string ValidateWriterOptions(const WriterOptions& options);
void EncodeEndRecord(std::uint64_t ping_count, std::vector<std::uint8_t>& out);
void EncodeSonarFileHeader(std::vector<std::uint8_t>& out);

// A time-ordered source of records of one kind.
class Stream {
 public:
  virtual ~Stream() = default;
  virtual std::optional<Record> Next() = 0;
};

std::unique_ptr<Stream> OpenSonarStream(const fs::path& path);
std::unique_ptr<Stream> OpenDvlStream(const fs::path& path);
std::unique_ptr<Stream> OpenAhrsStream(const fs::path& path);
std::unique_ptr<Stream> OpenDepthStream(const fs::path& path);
std::unique_ptr<Stream> OpenGroundTruthStream(const fs::path& path);

}  // namespace draco::recording::internal
