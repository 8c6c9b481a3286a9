#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <set>
#include <system_error>

#include "internal.hpp"

namespace draco::recording {

const RobotInfo* MissionInfo::FindRobot(const std::string& robot_name) const {
  for (const RobotInfo& robot : robots) {
    if (robot.name == robot_name) return &robot;
  }
  return nullptr;
}

double RecordTime(const Record& record) {
  return std::visit([](const auto& message) { return message.time_s; }, record);
}

namespace internal {

std::uint32_t Crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc) {
  // zlib's CRC-32 (IEEE 802.3 polynomial, reflected, init and final xor 0xFFFFFFFF).
  uLong value = crc;
  while (size > 0) {
    const uInt chunk = static_cast<uInt>(std::min<std::size_t>(size, 1u << 30));
    value = crc32(value, data, chunk);
    data += chunk;
    size -= chunk;
  }
  return static_cast<std::uint32_t>(value);
}

void AppendDouble(std::string& out, double v) {
  char buffer[40];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  out.append(buffer, result.ptr);
}

std::string FormatDouble(double v) {
  std::string text;
  AppendDouble(text, v);
  return text;
}

std::optional<double> ParseDouble(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const char* begin = text.data();
  const char* end = begin + text.size();
  if (*begin == '+') ++begin;  // from_chars rejects a leading '+', other writers emit it
  double value = 0.0;
  const auto result = std::from_chars(begin, end, value);
  if (result.ec != std::errc() || result.ptr != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

bool IsValidRobotName(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-';
  });
}

std::string ValidateMissionInfo(const MissionInfo& info) {
  const SonarInfo& sonar = info.sonar;
  if (sonar.num_beams <= 0 || static_cast<std::uint32_t>(sonar.num_beams) > kMaxImageSide) {
    return "sonar.beams must be in 1.." + std::to_string(kMaxImageSide);
  }
  if (sonar.num_ranges <= 0 || static_cast<std::uint32_t>(sonar.num_ranges) > kMaxImageSide) {
    return "sonar.range_bins must be in 1.." + std::to_string(kMaxImageSide);
  }
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  auto non_negative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (!positive(sonar.range_resolution_m)) return "sonar.range_resolution_m must be > 0";
  if (!positive(sonar.horizontal_aperture_rad)) return "sonar.horizontal_aperture_rad must be > 0";
  if (!non_negative(sonar.vertical_aperture_rad)) return "sonar.vertical_aperture_rad must be >= 0";
  if (!positive(sonar.rate_hz)) return "sonar.rate_hz must be > 0";
  const SonarMount& mount = sonar.mount;
  for (double v : {mount.position_m[0], mount.position_m[1], mount.position_m[2], mount.roll_rad,
                   mount.pitch_rad, mount.yaw_rad}) {
    if (!std::isfinite(v)) return "sonar.mount values must be finite";
  }
  const NavigationRates& nav = info.navigation;
  for (double v : {nav.dvl_hz, nav.ahrs_hz, nav.depth_hz, nav.ground_truth_hz}) {
    if (!non_negative(v)) return "navigation rates must be >= 0";
  }
  if (info.robots.empty()) return "a mission needs at least one robot";
  std::set<std::string> names;
  std::set<int> ids;
  for (const RobotInfo& robot : info.robots) {
    if (!IsValidRobotName(robot.name)) {
      return "robot name '" + robot.name +
             "' must be 1-64 characters of letters, digits, '_' or '-'";
    }
    if (!names.insert(robot.name).second) return "robot name '" + robot.name + "' is repeated";
    if (robot.id < 0) return "robot '" + robot.name + "' has a negative id";
    if (!ids.insert(robot.id).second) {
      return "robot id " + std::to_string(robot.id) + " is repeated";
    }
  }
  return "";
}

std::array<double, 4> QuaternionFromRpy(double roll, double pitch, double yaw) {
  // q = q_z(yaw) * q_y(pitch) * q_x(roll), Hamilton convention.
  const double cr = std::cos(roll / 2), sr = std::sin(roll / 2);
  const double cp = std::cos(pitch / 2), sp = std::sin(pitch / 2);
  const double cy = std::cos(yaw / 2), sy = std::sin(yaw / 2);
  return {sr * cp * cy - cr * sp * sy,   // x
          cr * sp * cy + sr * cp * sy,   // y
          cr * cp * sy - sr * sp * cy,   // z
          cr * cp * cy + sr * sp * sy};  // w
}

void RpyFromQuaternion(const std::array<double, 4>& q, double& roll, double& pitch, double& yaw) {
  const double x = q[0], y = q[1], z = q[2], w = q[3];
  roll = std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  pitch = std::asin(std::clamp(2 * (w * y - z * x), -1.0, 1.0));
  yaw = std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
}

AtomicFile::AtomicFile(fs::path final_path) : final_path_(std::move(final_path)), buffer_(1 << 20) {
  partial_path_ = final_path_;
  partial_path_ += kPartialSuffix;
  file_ = std::fopen(partial_path_.c_str(), "wb");
  if (file_ == nullptr) {
    throw RecordingError(partial_path_.string() + ": cannot create: " + std::strerror(errno));
  }
  std::setvbuf(file_, buffer_.data(), _IOFBF, buffer_.size());
}

AtomicFile::~AtomicFile() { Abort(); }

void AtomicFile::Write(const void* data, std::size_t size) {
  if (file_ == nullptr) throw std::logic_error(final_path_.string() + ": write after close");
  if (size > 0 && std::fwrite(data, 1, size, file_) != size) {
    throw RecordingError(partial_path_.string() + ": write failed: " + std::strerror(errno));
  }
}

void AtomicFile::Commit() {
  if (file_ == nullptr) throw std::logic_error(final_path_.string() + ": already closed");
  std::FILE* file = file_;
  file_ = nullptr;
  if (std::fclose(file) != 0) {
    std::error_code ignored;
    fs::remove(partial_path_, ignored);
    throw RecordingError(partial_path_.string() + ": close failed: " + std::strerror(errno));
  }
  std::error_code error;
  fs::rename(partial_path_, final_path_, error);
  if (error) {
    throw RecordingError(partial_path_.string() + ": cannot rename to " + final_path_.string() +
                         ": " + error.message());
  }
}

void AtomicFile::Abort() {
  if (file_ == nullptr) return;
  std::fclose(file_);
  file_ = nullptr;
  std::error_code ignored;
  fs::remove(partial_path_, ignored);
}

}  // namespace internal
}  // namespace draco::recording
