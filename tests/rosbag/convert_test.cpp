// Conversions from decoded ROS messages to draco messages, on hand-built values.
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "draco/rosbag/convert.hpp"

namespace draco::rosbag {
namespace {

RosValue Msg(RosValue::Fields fields) { return RosValue(std::move(fields)); }
RosValue Num(double v) { return RosValue(v); }

RosValue Vec(double x, double y, double z) {
  return Msg({{"x", Num(x)}, {"y", Num(y)}, {"z", Num(z)}});
}

// An OculusPingUncompressed-like message: 2 ranges x 3 beams.
RosValue Ping(std::vector<double> bearings_hundredths, double gamma) {
  RosValue::Array bearings;
  for (double b : bearings_hundredths) bearings.emplace_back(static_cast<std::int64_t>(b));
  RosValue image = Msg({{"height", RosValue(std::uint64_t{2})},
                        {"width", RosValue(std::uint64_t{3})},
                        {"encoding", RosValue(std::string("mono8"))},
                        {"step", RosValue(std::uint64_t{3})},
                        {"data", RosValue(RosValue::Bytes{10, 20, 30, 40, 50, 255})}});
  return Msg({{"fire_msg", Msg({{"gamma", RosValue(static_cast<std::uint64_t>(gamma))}})},
              {"ping_id", RosValue(std::uint64_t{9})},
              {"bearings", RosValue(std::move(bearings))},
              {"range_resolution", Num(0.1)},
              {"ping", std::move(image)}});
}

TEST(Convert, SonarPingInVehicleFrameIsMirroredToCounterClockwiseBearings) {
  ConvertOptions options;
  options.linearize_gamma = false;
  auto ping = ToSonarPing(Ping({-1000, 0, 2000}, 255), 1.5, options);
  EXPECT_EQ(ping.num_ranges, 2);
  EXPECT_EQ(ping.num_beams, 3);
  EXPECT_EQ(ping.ping_id, 9u);
  EXPECT_DOUBLE_EQ(ping.time_s, 1.5);
  EXPECT_NEAR(ping.bearings_rad[0], -20.0 * M_PI / 180.0, 1e-6);
  EXPECT_NEAR(ping.bearings_rad[2], 10.0 * M_PI / 180.0, 1e-6);
  EXPECT_EQ(ping.intensity, (std::vector<std::uint8_t>{30, 20, 10, 255, 50, 40}));

  options.frd_to_flu = false;
  ping = ToSonarPing(Ping({-1000, 0, 2000}, 255), 1.5, options);
  EXPECT_NEAR(ping.bearings_rad[0], -10.0 * M_PI / 180.0, 1e-6);
  EXPECT_EQ(ping.intensity, (std::vector<std::uint8_t>{10, 20, 30, 40, 50, 255}));
}

TEST(Convert, GammaIsLinearised) {
  ConvertOptions options;
  options.frd_to_flu = false;
  auto ping = ToSonarPing(Ping({0, 1, 2}, 127), 0.0, options);
  const std::vector<int> in = {10, 20, 30, 40, 50, 255};
  for (std::size_t i = 0; i < in.size(); ++i) {
    double expected = std::pow(in[i] / 255.0, 255.0 / 127.0) * 255.0;
    EXPECT_NEAR(ping.intensity[i], expected, 0.5) << i;
  }
}

TEST(Convert, InconsistentPingsNameTheField) {
  ConvertOptions options;
  auto expect_error = [&](const RosValue& msg, const std::string& field) {
    try {
      ToSonarPing(msg, 0.0, options);
      ADD_FAILURE() << "no error for " << field;
    } catch (const DecodeError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  expect_error(Ping({0, 1}, 255), "bearings");
  expect_error(Ping({0, 5, 1}, 255), "bearings");
  expect_error(Msg({{"bearings", RosValue(RosValue::Array{})}}), "ping");
}

// A compressed ping (sensor_msgs/CompressedImage) of the given bytes, 3 beams.
RosValue CompressedPing(RosValue::Bytes data) {
  RosValue::Array bearings;
  for (int b : {0, 1, 2}) bearings.emplace_back(static_cast<std::int64_t>(b));
  return Msg({{"bearings", RosValue(std::move(bearings))},
              {"range_resolution", Num(0.1)},
              {"ping", Msg({{"format", RosValue(std::string("jpeg"))},
                            {"data", RosValue(std::move(data))}})}});
}

// Memory bound (docs/hardening.md): the image header is read before OpenCV decodes, and an
// image may announce at most 1032 pixels per byte (and 64 Mi): a 30-byte JPEG announcing
// 60000 x 60000 pixels made OpenCV try to allocate 3.6 GB.
TEST(Convert, CompressedImagesAnnouncingImplausibleSizesAreRefused) {
  ConvertOptions options;
  const auto error = [&](RosValue::Bytes data) {
    try {
      ToSonarPing(CompressedPing(std::move(data)), 0.0, options);
    } catch (const DecodeError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // SOI, then a baseline frame header (SOF0): 8 bits, 60000 x 60000, one component.
  const RosValue::Bytes jpeg = {0xFF, 0xD8, 0xFF, 0xC0, 0x00, 0x0B, 0x08, 0xEA, 0x60,
                                0xEA, 0x60, 0x01, 0x01, 0x11, 0x00, 0xFF, 0xD9};
  std::string e = error(jpeg);
  EXPECT_NE(e.find("field 'ping.data': the 17-byte image announces 60000 x 60000 pixels"),
            std::string::npos)
      << e;
  // PNG: signature and an IHDR of 100000 x 100000, 8-bit grey.
  RosValue::Bytes png = {0x89, 'P',  'N', 'G', '\r', '\n', 0x1a, '\n', 0,    0, 0,
                         13,   'I',  'H', 'D', 'R',  0,    1,    0x86, 0xA0, 0, 1,
                         0x86, 0xA0, 8,   0,   0,    0,    0,    0,    0,    0, 0};
  e = error(png);
  EXPECT_NE(e.find("announces 100000 x 100000 pixels"), std::string::npos) << e;
  png[24] = 1;  // 1-bit pixels: 8 a byte before compression
  e = error(png);
  EXPECT_NE(e.find("PNG of bit depth 1"), std::string::npos) << e;
  e = error({'G', 'I', 'F', '8', '9', 'a', 0, 0});
  EXPECT_NE(e.find("neither JPEG nor PNG"), std::string::npos) << e;
  e = error({0xFF, 0xD8, 0xFF, 0xDA, 0x00, 0x02});
  EXPECT_NE(e.find("JPEG without a frame header"), std::string::npos) << e;
}

// Bad input (docs/hardening.md): NaN where a number is used, and a ping id beyond 32 bits,
// are errors naming the field (before: a NaN depth was passed on; a float64 ping_id of 1e300
// was undefined behaviour).
TEST(Convert, NonFiniteValuesAreErrors) {
  ConvertOptions options;
  const double nan = std::nan("");
  EXPECT_THROW(ToDepth(Msg({{"depth", Num(nan)}}), 0.0), DecodeError);
  EXPECT_THROW(
      ToGroundTruthPose(
          Msg({{"pose",
                Msg({{"position", Vec(1, nan, 3)},
                     {"orientation",
                      Msg({{"x", Num(0)}, {"y", Num(0)}, {"z", Num(0)}, {"w", Num(1)}})}})}}),
          0.0, options),
      DecodeError);
  EXPECT_THROW(
      ToAhrs(
          Msg({{"orientation", Msg({{"x", Num(0)}, {"y", Num(0)}, {"z", Num(0)}, {"w", Num(1)}})},
               {"angular_velocity", Vec(0, 0, nan)}}),
          0.0, options),
      DecodeError);
  RosValue ping = Ping({0, 1, 2}, 255);
  RosValue::Fields fields = *ping.AsFields();
  for (auto& [name, value] : fields) {
    if (name == "ping_id") value = Num(1e300);
  }
  try {
    ToSonarPing(Msg(fields), 0.0, options);
    ADD_FAILURE() << "no error";
  } catch (const DecodeError& e) {
    EXPECT_NE(std::string(e.what()).find("field 'ping_id'"), std::string::npos) << e.what();
  }
  // A NaN DVL velocity stays a sample marked invalid (documented), not an error.
  EXPECT_FALSE(ToDvlVelocity(Msg({{"velocity", Vec(nan, 0, 0)}}), 0.0, options).valid);
}

TEST(Convert, ImuDvlDepthAndPose) {
  ConvertOptions options;
  // Quaternion of roll 0.1, pitch -0.2, yaw 1.0 (Z-Y-X).
  const double r = 0.1, p = -0.2, y = 1.0;
  const double cr = std::cos(r / 2), sr = std::sin(r / 2), cp = std::cos(p / 2),
               sp = std::sin(p / 2), cy = std::cos(y / 2), sy = std::sin(y / 2);
  RosValue q = Msg({{"x", Num(sr * cp * cy - cr * sp * sy)},
                    {"y", Num(cr * sp * cy + sr * cp * sy)},
                    {"z", Num(cr * cp * sy - sr * sp * cy)},
                    {"w", Num(cr * cp * cy + sr * sp * sy)}});
  auto ahrs =
      ToAhrs(Msg({{"orientation", q}, {"angular_velocity", Vec(0, 0, 0.05)}}), 2.0, options);
  EXPECT_NEAR(ahrs.roll_rad, 0.1, 1e-12);
  EXPECT_NEAR(ahrs.pitch_rad, 0.2, 1e-12);
  EXPECT_NEAR(ahrs.yaw_rad, -1.0, 1e-12);
  EXPECT_NEAR(ahrs.yaw_rate_radps, -0.05, 1e-12);

  auto dvl = ToDvlVelocity(Msg({{"velocity", Vec(0.5, -0.1, 0.02)}, {"altitude", Num(0.0)}}), 0.0,
                           options);
  EXPECT_EQ(dvl.velocity_body_mps, (std::array<double, 3>{0.5, 0.1, -0.02}));
  EXPECT_TRUE(dvl.valid);
  EXPECT_EQ(dvl.altitude_m, -1.0);
  dvl = ToDvlVelocity(Msg({{"velocity", Vec(88.888, 88.888, 88.888)}}), 0.0, options);
  EXPECT_FALSE(dvl.valid);

  EXPECT_EQ(ToDepth(Msg({{"depth", Num(2.5)}}), 0.0).depth_m, 2.5);
  EXPECT_THROW(ToDepth(Msg({{"pressure_abs", Num(2.5)}}), 0.0), DecodeError);

  auto pose = ToGroundTruthPose(
      Msg({{"pose", Msg({{"position", Vec(1, 2, -3)}, {"orientation", q}})}}), 0.0, options);
  EXPECT_EQ(pose.position_m, (std::array<double, 3>{1, -2, 3}));
  EXPECT_NEAR(pose.yaw_rad, -1.0, 1e-12);

  EXPECT_THROW(EulerFromQuaternion(0, 0, 0, 0, "orientation"), DecodeError);
}

}  // namespace
}  // namespace draco::rosbag
