// Navigation CSV files and the TUM ground-truth file: line-by-line readers.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <string_view>

#include "internal.hpp"

namespace draco::recording::internal {
namespace {

// Reads lines, counting them; a last line without '\n' means the file was cut short.
class LineReader {
 public:
  LineReader(const fs::path& path, const std::string& what) : path_(path), file_(path) {
    std::error_code error;
    if (!fs::is_regular_file(path, error) || !file_) {
      throw RecordingError(path_.string() + ": missing or unreadable (expected " + what + ")");
    }
  }

  bool Next(std::string& line) {
    if (!std::getline(file_, line)) return false;
    ++line_number_;
    if (file_.eof()) Fail("truncated: the last line has no end-of-line (file cut short?)");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw RecordingError(path_.string() + ":" + std::to_string(line_number_) + ": " + what);
  }

  const fs::path& Path() const { return path_; }

 private:
  fs::path path_;
  std::ifstream file_;
  std::size_t line_number_ = 0;
};

// Splits line at separator (or at runs of blanks when separator is ' ') into exactly n fields.
template <std::size_t N>
bool Split(std::string_view line, char separator, std::array<std::string_view, N>& fields,
           std::size_t& found) {
  found = 0;
  std::size_t pos = 0;
  if (separator == ' ') {
    while (true) {
      pos = line.find_first_not_of(" \t", pos);
      if (pos == std::string_view::npos) break;
      const std::size_t end = std::min(line.find_first_of(" \t", pos), line.size());
      if (found < N) fields[found] = line.substr(pos, end - pos);
      ++found;
      pos = end;
    }
    return found == N;
  }
  while (true) {
    const std::size_t end = std::min(line.find(separator, pos), line.size());
    if (found < N) fields[found] = line.substr(pos, end - pos);
    ++found;
    if (end == line.size()) break;
    pos = end + 1;
  }
  return found == N;
}

std::optional<double> ParseField(std::string_view text) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return std::nullopt;
  double value = 0.0;
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  if (result.ec != std::errc() || result.ptr != text.data() + text.size() ||
      !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

// A CSV file with one fixed header line and N numeric columns per row.
template <std::size_t N>
class CsvStream : public Stream {
 public:
  CsvStream(const fs::path& path, const char* header, const char* what)
      : lines_(path, what), header_(header) {
    std::string line;
    if (!lines_.Next(line)) {
      lines_.Fail("empty file, expected the header line '" + header_ + "'");
    }
    if (line != header_) lines_.Fail("header is '" + line + "', expected '" + header_ + "'");
    // Column names, for error messages.
    std::size_t found = 0;
    Split<N>(header_, ',', names_, found);
  }

 protected:
  // Reads the next row into values; false at the end of the file.
  bool NextRow(std::array<double, N>& values) {
    if (!lines_.Next(line_)) return false;
    std::array<std::string_view, N> fields;
    std::size_t found = 0;
    if (!Split<N>(line_, ',', fields, found)) {
      lines_.Fail("expected " + std::to_string(N) + " comma-separated fields (" + header_ +
                  "), found " + std::to_string(found));
    }
    for (std::size_t i = 0; i < N; ++i) {
      const std::optional<double> value = ParseField(fields[i]);
      if (!value) {
        lines_.Fail("column '" + std::string(names_[i]) + "': expected a finite number, found '" +
                    std::string(fields[i]) + "'");
      }
      values[i] = *value;
    }
    if (values[0] < last_time_) {
      lines_.Fail("time " + FormatDouble(values[0]) + " s is before the previous line's " +
                  FormatDouble(last_time_) + " s (times must not decrease)");
    }
    last_time_ = values[0];
    return true;
  }

  LineReader lines_;

 private:
  std::string header_;
  std::array<std::string_view, N> names_;
  std::string line_;
  double last_time_ = -INFINITY;
};

class DvlStream final : public CsvStream<6> {
 public:
  explicit DvlStream(const fs::path& path) : CsvStream(path, kDvlHeader, "DVL velocities") {}

  std::optional<Record> Next() override {
    std::array<double, 6> v;
    if (!NextRow(v)) return std::nullopt;
    msgs::DvlVelocity dvl;
    dvl.time_s = v[0];
    dvl.velocity_body_mps = {v[1], v[2], v[3]};
    dvl.altitude_m = v[4];
    if (v[5] != 0.0 && v[5] != 1.0) lines_.Fail("column 'valid': expected 0 or 1");
    dvl.valid = v[5] == 1.0;
    return dvl;
  }
};

class AhrsStream final : public CsvStream<5> {
 public:
  explicit AhrsStream(const fs::path& path) : CsvStream(path, kAhrsHeader, "AHRS attitude") {}

  std::optional<Record> Next() override {
    std::array<double, 5> v;
    if (!NextRow(v)) return std::nullopt;
    msgs::Ahrs ahrs;
    ahrs.time_s = v[0];
    ahrs.roll_rad = v[1];
    ahrs.pitch_rad = v[2];
    ahrs.yaw_rad = v[3];
    ahrs.yaw_rate_radps = v[4];
    return ahrs;
  }
};

class DepthStream final : public CsvStream<2> {
 public:
  explicit DepthStream(const fs::path& path) : CsvStream(path, kDepthHeader, "depth") {}

  std::optional<Record> Next() override {
    std::array<double, 2> v;
    if (!NextRow(v)) return std::nullopt;
    msgs::Depth depth;
    depth.time_s = v[0];
    depth.depth_m = v[1];
    return depth;
  }
};

// TUM: "t x y z qx qy qz qw" separated by blanks; '#' lines are comments.
class GroundTruthStream final : public Stream {
 public:
  explicit GroundTruthStream(const fs::path& path) : lines_(path, "ground truth in TUM format") {}

  std::optional<Record> Next() override {
    while (lines_.Next(line_)) {
      const std::size_t first = line_.find_first_not_of(" \t");
      if (first == std::string::npos) lines_.Fail("empty line, expected 't x y z qx qy qz qw'");
      if (line_[first] == '#') continue;
      std::array<std::string_view, 8> fields;
      std::size_t found = 0;
      if (!Split<8>(line_, ' ', fields, found)) {
        lines_.Fail("expected 8 blank-separated fields 't x y z qx qy qz qw', found " +
                    std::to_string(found));
      }
      std::array<double, 8> v;
      static const char* const kNames[8] = {"t", "x", "y", "z", "qx", "qy", "qz", "qw"};
      for (std::size_t i = 0; i < 8; ++i) {
        const std::optional<double> value = ParseField(fields[i]);
        if (!value) {
          lines_.Fail(std::string("field '") + kNames[i] + "': expected a finite number, found '" +
                      std::string(fields[i]) + "'");
        }
        v[i] = *value;
      }
      if (v[0] < last_time_) {
        lines_.Fail("time " + FormatDouble(v[0]) + " s is before the previous line's " +
                    FormatDouble(last_time_) + " s (times must not decrease)");
      }
      last_time_ = v[0];
      std::array<double, 4> q{v[4], v[5], v[6], v[7]};
      const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (std::abs(norm - 1.0) > 1e-3) {
        lines_.Fail("quaternion norm " + FormatDouble(norm) + ", expected 1");
      }
      for (double& c : q) c /= norm;
      msgs::GroundTruthPose pose;
      pose.time_s = v[0];
      pose.position_m = {v[1], v[2], v[3]};
      RpyFromQuaternion(q, pose.roll_rad, pose.pitch_rad, pose.yaw_rad);
      return pose;
    }
    return std::nullopt;
  }

 private:
  LineReader lines_;
  std::string line_;
  double last_time_ = -INFINITY;
};

}  // namespace

std::unique_ptr<Stream> OpenDvlStream(const fs::path& path) {
  return std::make_unique<DvlStream>(path);
}
std::unique_ptr<Stream> OpenAhrsStream(const fs::path& path) {
  return std::make_unique<AhrsStream>(path);
}
std::unique_ptr<Stream> OpenDepthStream(const fs::path& path) {
  return std::make_unique<DepthStream>(path);
}
std::unique_ptr<Stream> OpenGroundTruthStream(const fs::path& path) {
  return std::make_unique<GroundTruthStream>(path);
}

}  // namespace draco::recording::internal

namespace draco::recording {

double RobotReplayLengthS(const std::filesystem::path& mission_dir, const std::string& robot) {
  std::ifstream f(mission_dir / robot / "ahrs.csv", std::ios::binary | std::ios::ate);
  if (!f) return 0.0;
  const std::streamoff size = f.tellg();
  const std::streamoff start = std::max<std::streamoff>(0, size - 4096);
  f.seekg(start);
  std::string tail(static_cast<std::size_t>(size - start), '\0');
  f.read(tail.data(), static_cast<std::streamsize>(tail.size()));
  while (!tail.empty() && (tail.back() == '\n' || tail.back() == '\r')) tail.pop_back();
  const auto nl = tail.rfind('\n');
  const std::string last = tail.substr(nl == std::string::npos ? 0 : nl + 1);
  double t = 0.0;
  const auto [ptr, ec] = std::from_chars(last.data(), last.data() + last.size(), t);
  (void)ptr;
  return ec == std::errc() && std::isfinite(t) ? t : 0.0;
}

}  // namespace draco::recording
