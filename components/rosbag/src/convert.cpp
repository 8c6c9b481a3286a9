#include "draco/rosbag/convert.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace draco::rosbag {
namespace {

constexpr double kPi = 3.14159265358979323846;

double Required(const RosValue& msg, const std::string& path) {
  auto v = msg.Number(path);
  if (!v) throw DecodeError("field '" + path + "' is missing or not a number");
  return *v;
}

double RequiredFinite(const RosValue& msg, const std::string& path) {
  const double v = Required(msg, path);
  if (!std::isfinite(v)) throw DecodeError("field '" + path + "' is not a finite number");
  return v;
}

std::uint32_t BigEndian16(const std::uint8_t* p) { return (std::uint32_t{p[0]} << 8) | p[1]; }
std::uint32_t BigEndian32(const std::uint8_t* p) {
  return (BigEndian16(p) << 16) | BigEndian16(p + 2);
}

// Deflate (PNG) expands at most 1032:1, and baseline JPEG codes an 8 x 8 block in 2 bits at
// the least (256 pixels a byte): an image may announce at most this many pixels per byte.
constexpr std::uint64_t kMaxPixelsPerByte = 1032;
constexpr std::uint64_t kMaxPixels = 64ull << 20;  // as sonar.drs (recording format)

// "" when data is a JPEG or PNG whose header announces a plausible size; else the problem.
// Checked before OpenCV decodes (and allocates what the header announces).
std::string CheckCompressedImage(const std::vector<std::uint8_t>& data) {
  const std::uint8_t* p = data.data();
  const std::size_t n = data.size();
  std::uint64_t width = 0, height = 0;
  static constexpr std::uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n >= 8 && std::equal(kPng, kPng + 8, p)) {
    if (n < 33 || std::string(reinterpret_cast<const char*>(p + 12), 4) != "IHDR") {
      return "PNG without its IHDR header";
    }
    width = BigEndian32(p + 16);
    height = BigEndian32(p + 20);
    if (p[24] != 8 && p[24] != 16) {
      return "PNG of bit depth " + std::to_string(p[24]) + " (8 or 16 expected)";
    }
  } else if (n >= 4 && p[0] == 0xFF && p[1] == 0xD8) {
    // JPEG: segments up to the frame header (SOF0 to SOF15 but DHT, JPG and DAC).
    std::size_t at = 2;
    while (true) {
      if (at + 4 > n || p[at] != 0xFF) return "JPEG without a frame header (SOF)";
      const std::uint8_t marker = p[at + 1];
      if (marker == 0xFF) {  // fill byte
        ++at;
        continue;
      }
      if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {  // no length
        at += 2;
        continue;
      }
      if (marker == 0xDA || marker == 0xD9) return "JPEG without a frame header (SOF)";
      const std::size_t length = BigEndian16(p + at + 2);
      if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
        if (length < 8 || at + 2 + 7 > n) return "JPEG frame header (SOF) cut short";
        height = BigEndian16(p + at + 5);
        width = BigEndian16(p + at + 7);
        break;
      }
      if (length < 2) return "JPEG segment of length " + std::to_string(length);
      at += 2 + length;
    }
  } else {
    return "neither JPEG nor PNG";
  }
  const std::uint64_t pixels = width * height;
  if (pixels == 0 || pixels > kMaxPixels || pixels > kMaxPixelsPerByte * n) {
    return "the " + std::to_string(n) + "-byte image announces " + std::to_string(height) + " x " +
           std::to_string(width) + " pixels (implausible: at most " +
           std::to_string(kMaxPixelsPerByte) + " per byte, and 64 Mi)";
  }
  return "";
}

// Decodes the ping image into rows (range bins) x cols (beams) of 8-bit intensity.
cv::Mat PingImage(const RosValue& msg) {
  const RosValue* ping = msg.Find("ping");
  if (ping == nullptr || !ping->IsMessage()) throw DecodeError("field 'ping' is missing");
  const RosValue::Bytes* data = ping->Find("data") ? ping->Find("data")->AsBytes() : nullptr;
  if (data == nullptr) throw DecodeError("field 'ping.data' is missing or not a byte array");
  if (ping->Find("encoding") == nullptr) {
    // sensor_msgs/CompressedImage: JPEG (or PNG) bytes.
    if (data->empty()) throw DecodeError("field 'ping.data': empty compressed image");
    if (const std::string problem = CheckCompressedImage(*data); !problem.empty()) {
      throw DecodeError("field 'ping.data': " + problem);
    }
    cv::Mat image;
    try {
      cv::Mat buffer(1, static_cast<int>(data->size()), CV_8UC1,
                     const_cast<std::uint8_t*>(data->data()));
      image = cv::imdecode(buffer, cv::IMREAD_GRAYSCALE);
    } catch (const cv::Exception& e) {
      throw DecodeError("field 'ping.data': cannot decode image (" + std::string(e.what()) + ")");
    }
    if (image.empty() || image.type() != CV_8UC1) {
      const std::string* format = ping->Find("format") ? ping->Find("format")->AsString() : nullptr;
      throw DecodeError("field 'ping.data': cannot decode the " + std::to_string(data->size()) +
                        "-byte image (format '" + (format ? *format : std::string()) + "')");
    }
    return image;
  }
  // sensor_msgs/Image.
  const std::string* encoding = ping->Find("encoding")->AsString();
  std::string enc = encoding ? *encoding : std::string();
  if (enc != "mono8" && enc != "8UC1") {
    throw DecodeError("field 'ping.encoding': unsupported encoding '" + enc +
                      "' (expected mono8 or 8UC1)");
  }
  double height = ping->NumberOr("height", -1.0);
  double width = ping->NumberOr("width", -1.0);
  double step = ping->NumberOr("step", width);
  if (height <= 0 || width <= 0 || height > 1e5 || width > 1e5 || step < width) {
    throw DecodeError("field 'ping': bad image size " + std::to_string(height) + " x " +
                      std::to_string(width) + " (step " + std::to_string(step) + ")");
  }
  if (static_cast<double>(data->size()) < step * height) {
    throw DecodeError("field 'ping.data': " + std::to_string(data->size()) +
                      " bytes, image needs " + std::to_string(step * height));
  }
  cv::Mat view(static_cast<int>(height), static_cast<int>(width), CV_8UC1,
               const_cast<std::uint8_t*>(data->data()), static_cast<std::size_t>(step));
  return view.clone();
}

std::array<std::uint8_t, 256> GammaTable(double gamma) {
  std::array<std::uint8_t, 256> table{};
  for (int i = 0; i < 256; ++i) {
    double v = std::pow(i / 255.0, 255.0 / gamma) * 255.0;
    table[static_cast<std::size_t>(i)] =
        static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
  }
  return table;
}

}  // namespace

Euler EulerFromQuaternion(double x, double y, double z, double w, const std::string& field) {
  double norm = std::sqrt(x * x + y * y + z * z + w * w);
  if (!(norm > 1e-9) || !std::isfinite(norm)) {
    throw DecodeError("field '" + field + "': zero or invalid quaternion");
  }
  x /= norm;
  y /= norm;
  z /= norm;
  w /= norm;
  Euler e;
  e.roll_rad = std::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
  e.pitch_rad = std::asin(std::clamp(2.0 * (w * y - z * x), -1.0, 1.0));
  e.yaw_rad = std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
  return e;
}

msgs::SonarPing ToSonarPing(const RosValue& msg, double time_s, const ConvertOptions& options) {
  cv::Mat image = PingImage(msg);
  auto bearings = msg.Numbers("bearings");
  if (!bearings) throw DecodeError("field 'bearings' is missing or not numeric");
  if (static_cast<int>(bearings->size()) != image.cols) {
    throw DecodeError("field 'bearings': " + std::to_string(bearings->size()) +
                      " entries, but the image has " + std::to_string(image.cols) +
                      " beams (columns)");
  }
  double resolution = Required(msg, "range_resolution");
  if (!(resolution > 0.0) || !std::isfinite(resolution)) {
    throw DecodeError("field 'range_resolution': must be positive, got " +
                      std::to_string(resolution));
  }

  msgs::SonarPing ping;
  ping.time_s = time_s;
  const double ping_id = msg.NumberOr("ping_id", 0.0);
  if (!(ping_id >= 0.0 && ping_id <= 4294967295.0)) {
    throw DecodeError("field 'ping_id': " + std::to_string(ping_id) +
                      " is not a 32-bit unsigned integer");
  }
  ping.ping_id = static_cast<std::uint32_t>(ping_id);
  ping.num_ranges = image.rows;
  ping.num_beams = image.cols;
  ping.range_resolution_m = resolution;
  ping.vertical_aperture_rad = options.vertical_aperture_rad;

  const double sign = options.frd_to_flu ? -1.0 : 1.0;
  std::vector<float> rad(bearings->size());
  for (std::size_t i = 0; i < bearings->size(); ++i) {
    rad[i] = static_cast<float>(sign * (*bearings)[i] * 0.01 * kPi / 180.0);
  }
  bool reverse = rad.size() > 1 && rad.front() > rad.back();
  if (reverse) std::reverse(rad.begin(), rad.end());
  for (std::size_t i = 1; i < rad.size(); ++i) {
    if (!(rad[i] > rad[i - 1])) {
      throw DecodeError("field 'bearings': not strictly monotonic at beam " + std::to_string(i));
    }
  }
  ping.bearings_rad = std::move(rad);

  double gamma = msg.NumberOr("fire_msg.gamma", 0.0);
  bool linearize = options.linearize_gamma && gamma > 0.0 && gamma < 255.0;
  std::array<std::uint8_t, 256> table{};
  if (linearize) table = GammaTable(gamma);

  ping.intensity.resize(static_cast<std::size_t>(image.rows) * image.cols);
  for (int r = 0; r < image.rows; ++r) {
    const std::uint8_t* src = image.ptr<std::uint8_t>(r);
    std::uint8_t* dst = ping.intensity.data() + static_cast<std::size_t>(r) * image.cols;
    for (int c = 0; c < image.cols; ++c) {
      std::uint8_t v = src[reverse ? image.cols - 1 - c : c];
      dst[c] = linearize ? table[v] : v;
    }
  }
  return ping;
}

msgs::Ahrs ToAhrs(const RosValue& msg, double time_s, const ConvertOptions& options) {
  Euler e = EulerFromQuaternion(Required(msg, "orientation.x"), Required(msg, "orientation.y"),
                                Required(msg, "orientation.z"), Required(msg, "orientation.w"),
                                "orientation");
  const double sign = options.frd_to_flu ? -1.0 : 1.0;
  msgs::Ahrs ahrs;
  ahrs.time_s = time_s;
  ahrs.roll_rad = e.roll_rad;
  ahrs.pitch_rad = sign * e.pitch_rad;
  ahrs.yaw_rad = sign * e.yaw_rad;
  ahrs.yaw_rate_radps = sign * msg.NumberOr("angular_velocity.z", 0.0);
  if (!std::isfinite(ahrs.yaw_rate_radps)) {
    throw DecodeError("field 'angular_velocity.z' is not a finite number");
  }
  return ahrs;
}

msgs::DvlVelocity ToDvlVelocity(const RosValue& msg, double time_s, const ConvertOptions& options) {
  const double sign = options.frd_to_flu ? -1.0 : 1.0;
  msgs::DvlVelocity dvl;
  dvl.time_s = time_s;
  dvl.velocity_body_mps = {Required(msg, "velocity.x"), sign * Required(msg, "velocity.y"),
                           sign * Required(msg, "velocity.z")};
  dvl.valid = true;
  for (double v : dvl.velocity_body_mps) {
    if (!std::isfinite(v) || std::abs(v) > options.dvl_max_valid_speed_mps) dvl.valid = false;
  }
  double altitude = msg.NumberOr("altitude", -1.0);
  dvl.altitude_m = std::isfinite(altitude) && altitude > 0.0 ? altitude : -1.0;
  return dvl;
}

msgs::Depth ToDepth(const RosValue& msg, double time_s) {
  msgs::Depth depth;
  depth.time_s = time_s;
  depth.depth_m = RequiredFinite(msg, "depth");
  return depth;
}

msgs::GroundTruthPose ToGroundTruthPose(const RosValue& msg, double time_s,
                                        const ConvertOptions& options) {
  const double sign = options.frd_to_flu ? -1.0 : 1.0;
  Euler e = EulerFromQuaternion(
      Required(msg, "pose.orientation.x"), Required(msg, "pose.orientation.y"),
      Required(msg, "pose.orientation.z"), Required(msg, "pose.orientation.w"), "pose.orientation");
  msgs::GroundTruthPose pose;
  pose.time_s = time_s;
  pose.position_m = {RequiredFinite(msg, "pose.position.x"),
                     sign * RequiredFinite(msg, "pose.position.y"),
                     sign * RequiredFinite(msg, "pose.position.z")};
  pose.roll_rad = e.roll_rad;
  pose.pitch_rad = sign * e.pitch_rad;
  pose.yaw_rad = sign * e.yaw_rad;
  return pose;
}

}  // namespace draco::rosbag
