// Recorded missions: round trip, streaming, atomic writes, and one test per kind of damage.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>
#include <zstd.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "draco/recording/recording.hpp"
#include "largest_allocation.hpp"

namespace draco::recording {
namespace {

namespace fs = std::filesystem;

// ---- helpers ---------------------------------------------------------------------------

MissionInfo TwoRobotMission() {
  MissionInfo info;
  info.name = "unit-test mission";
  info.world = "marina";
  info.seed = 18446744073709551615ull;
  info.sonar.num_beams = 64;
  info.sonar.num_ranges = 48;
  info.sonar.range_resolution_m = 0.1;
  info.sonar.mount.position_m = {0.3, 0.0, -0.1};
  info.sonar.mount.pitch_rad = 0.1745;
  info.navigation.dvl_hz = 20.0;
  info.robots = {{"alpha", 0, true}, {"bravo", 7, false}};
  info.notes = "line one\nline two: with a colon\n";
  return info;
}

std::vector<float> Bearings(int beams, float half_width) {
  std::vector<float> bearings(beams);
  for (int i = 0; i < beams; ++i) {
    bearings[i] = -half_width + 2 * half_width * static_cast<float>(i) / (beams - 1);
  }
  return bearings;
}

msgs::SonarPing MakePing(double t, std::uint32_t id, int ranges, int beams, std::mt19937& rng,
                         float half_width = 1.1345f) {
  msgs::SonarPing ping;
  ping.time_s = t;
  ping.ping_id = id;
  ping.num_ranges = ranges;
  ping.num_beams = beams;
  ping.range_resolution_m = 0.1;
  ping.vertical_aperture_rad = 0.349;
  ping.bearings_rad = Bearings(beams, half_width);
  ping.intensity.resize(static_cast<std::size_t>(ranges) * beams);
  std::uniform_int_distribution<int> noise(0, 40);
  for (int r = 0; r < ranges; ++r) {
    for (int b = 0; b < beams; ++b) {
      const int structure = (r == (static_cast<int>(id) * 3 + b) % ranges) ? 200 : 0;
      ping.intensity[static_cast<std::size_t>(r) * beams + b] =
          static_cast<std::uint8_t>(std::min(255, structure + noise(rng)));
    }
  }
  return ping;
}

// Everything a robot wrote, in write order per stream.
struct Written {
  std::vector<msgs::SonarPing> pings;
  std::vector<msgs::DvlVelocity> dvl;
  std::vector<msgs::Ahrs> ahrs;
  std::vector<msgs::Depth> depth;
  std::vector<msgs::GroundTruthPose> ground_truth;
};

Written WriteRobot(RobotWriter& writer, bool ground_truth, int pings, std::mt19937& rng,
                   int ranges = 48, int beams = 64) {
  Written w;
  std::normal_distribution<double> n(0.0, 1.0);
  for (int i = 0; i < pings; ++i) {
    // The bearing table changes halfway through, and the image size once.
    const bool wide = i >= pings / 2;
    w.pings.push_back(
        MakePing(0.2 * i, 100 + i, ranges, wide ? beams + 8 : beams, rng, wide ? 1.2f : 1.1345f));
    writer.WritePing(w.pings.back());
  }
  const double duration = 0.2 * pings;
  for (int i = 0; 0.05 * i < duration; ++i) {
    msgs::DvlVelocity dvl;
    dvl.time_s = 0.05 * i;
    dvl.velocity_body_mps = {0.3 + 0.01 * n(rng), 0.01 * n(rng), 1e-17 * n(rng)};
    dvl.altitude_m = i % 7 == 0 ? -1.0 : 4.0 + n(rng);
    dvl.valid = i % 13 != 0;
    w.dvl.push_back(dvl);
    writer.WriteDvl(dvl);
  }
  for (int i = 0; 0.01 * i < duration; ++i) {
    msgs::Ahrs ahrs;
    ahrs.time_s = 0.01 * i;
    ahrs.roll_rad = 0.01 * n(rng);
    ahrs.pitch_rad = 0.01 * n(rng);
    ahrs.yaw_rad = 3.0 * n(rng);
    ahrs.yaw_rate_radps = 0.1 * n(rng);
    w.ahrs.push_back(ahrs);
    writer.WriteAhrs(ahrs);
  }
  for (int i = 0; 0.2 * i < duration; ++i) {
    msgs::Depth depth;
    depth.time_s = 0.2 * i;
    depth.depth_m = 1.0 + 0.02 * n(rng);
    w.depth.push_back(depth);
    writer.WriteDepth(depth);
  }
  if (ground_truth) {
    for (int i = 0; 0.05 * i < duration; ++i) {
      msgs::GroundTruthPose pose;
      pose.time_s = 0.05 * i;
      pose.position_m = {100 * n(rng), 100 * n(rng), -1.0 + n(rng)};
      pose.roll_rad = 0.05 * n(rng);
      pose.pitch_rad = 0.05 * n(rng);
      pose.yaw_rad = std::remainder(2.0 * n(rng), 2 * M_PI);
      w.ground_truth.push_back(pose);
      writer.WriteGroundTruth(pose);
    }
  }
  writer.Close();
  return w;
}

std::vector<Record> ReadAll(const fs::path& dir, const std::string& robot,
                            const ReadOptions& options = {}) {
  RobotReader reader = RobotReader::Open(dir, robot, options);
  std::vector<Record> records;
  while (auto record = reader.Next()) records.push_back(std::move(*record));
  return records;
}

template <typename F>
std::string RecordingErrorOf(F&& f) {
  try {
    f();
  } catch (const RecordingError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected RecordingError, got another exception: " << e.what();
    return "";
  }
  ADD_FAILURE() << "expected RecordingError, nothing was thrown";
  return "";
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteFileBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << bytes;
}

std::uint32_t GetU32(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(s[at + i]);
  return v;
}

void SetU32(std::string& s, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s[at + i] = static_cast<char>(v >> (8 * i));
}

// Byte offsets of the records of a sonar.drs (file header is 16 bytes; record = 12-byte
// header + payload + 4-byte CRC).
std::vector<std::size_t> RecordOffsets(const std::string& file) {
  std::vector<std::size_t> offsets;
  for (std::size_t at = 16; at + 12 <= file.size(); at += 12 + GetU32(file, at + 8) + 4) {
    offsets.push_back(at);
  }
  return offsets;
}

// Recomputes the CRC of the record at offset (after a deliberate edit).
void FixCrc(std::string& file, std::size_t at) {
  const std::uint32_t length = GetU32(file, at + 8);
  const auto* data = reinterpret_cast<const Bytef*>(file.data() + at + 4);
  SetU32(file, at + 12 + length, static_cast<std::uint32_t>(crc32(0, data, 8 + length)));
}

class RecordingTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("draco-recording-" + std::to_string(::getpid()) + "-" + info->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A complete two-robot mission; alpha has ground truth, bravo not.
  void WriteMission(int pings = 6) {
    std::mt19937 rng(7);
    MissionWriter mission = MissionWriter::Create(dir_, TwoRobotMission());
    RobotWriter alpha = mission.OpenRobot("alpha");
    RobotWriter bravo = mission.OpenRobot("bravo");
    alpha_ = WriteRobot(alpha, true, pings, rng);
    bravo_ = WriteRobot(bravo, false, pings, rng);
    mission.Close();
  }

  fs::path Alpha(const char* file) const { return dir_ / "alpha" / file; }

  fs::path dir_;
  Written alpha_, bravo_;
};

// ---- round trip ------------------------------------------------------------------------

TEST_F(RecordingTest, MissionInfoRoundTrips) {
  WriteMission(2);
  const MissionInfo expected = TwoRobotMission();
  const MissionInfo info = LoadMissionInfo(dir_);
  EXPECT_EQ(info.name, expected.name);
  EXPECT_EQ(info.world, expected.world);
  EXPECT_EQ(info.seed, expected.seed);
  EXPECT_EQ(info.notes, expected.notes);
  EXPECT_EQ(info.sonar.num_beams, 64);
  EXPECT_EQ(info.sonar.num_ranges, 48);
  EXPECT_EQ(info.sonar.range_resolution_m, 0.1);
  EXPECT_EQ(info.sonar.horizontal_aperture_rad, expected.sonar.horizontal_aperture_rad);
  EXPECT_EQ(info.sonar.vertical_aperture_rad, expected.sonar.vertical_aperture_rad);
  EXPECT_EQ(info.sonar.rate_hz, expected.sonar.rate_hz);
  EXPECT_EQ(info.sonar.mount.position_m, expected.sonar.mount.position_m);
  EXPECT_EQ(info.sonar.mount.pitch_rad, expected.sonar.mount.pitch_rad);
  EXPECT_EQ(info.navigation.dvl_hz, 20.0);
  EXPECT_EQ(info.navigation.ahrs_hz, expected.navigation.ahrs_hz);
  EXPECT_EQ(info.navigation.ground_truth_hz, expected.navigation.ground_truth_hz);
  ASSERT_EQ(info.robots.size(), 2u);
  EXPECT_EQ(info.robots[1].name, "bravo");
  EXPECT_EQ(info.robots[1].id, 7);
  EXPECT_TRUE(info.robots[0].has_ground_truth);
  EXPECT_FALSE(info.robots[1].has_ground_truth);
}

TEST_F(RecordingTest, RobotStreamsRoundTripInTimeOrder) {
  WriteMission(10);
  for (const auto& [name, written] : {std::pair{"alpha", &alpha_}, std::pair{"bravo", &bravo_}}) {
    SCOPED_TRACE(name);
    const std::vector<Record> records = ReadAll(dir_, name);
    Written read;
    double last_time = -1.0;
    for (const Record& record : records) {
      EXPECT_GE(RecordTime(record), last_time);
      last_time = RecordTime(record);
      std::visit(
          [&](const auto& m) {
            using T = std::decay_t<decltype(m)>;
            if constexpr (std::is_same_v<T, msgs::SonarPing>) read.pings.push_back(m);
            if constexpr (std::is_same_v<T, msgs::DvlVelocity>) read.dvl.push_back(m);
            if constexpr (std::is_same_v<T, msgs::Ahrs>) read.ahrs.push_back(m);
            if constexpr (std::is_same_v<T, msgs::Depth>) read.depth.push_back(m);
            if constexpr (std::is_same_v<T, msgs::GroundTruthPose>) read.ground_truth.push_back(m);
          },
          record);
    }
    ASSERT_EQ(read.pings.size(), written->pings.size());
    for (std::size_t i = 0; i < read.pings.size(); ++i) {
      const msgs::SonarPing& a = read.pings[i];
      const msgs::SonarPing& b = written->pings[i];
      EXPECT_EQ(a.time_s, b.time_s);
      EXPECT_EQ(a.ping_id, b.ping_id);
      EXPECT_EQ(a.num_ranges, b.num_ranges);
      EXPECT_EQ(a.num_beams, b.num_beams);
      EXPECT_EQ(a.range_resolution_m, b.range_resolution_m);
      EXPECT_EQ(a.vertical_aperture_rad, b.vertical_aperture_rad);
      EXPECT_EQ(a.bearings_rad, b.bearings_rad);
      EXPECT_EQ(a.intensity, b.intensity);  // lossless
    }
    ASSERT_EQ(read.dvl.size(), written->dvl.size());
    for (std::size_t i = 0; i < read.dvl.size(); ++i) {
      EXPECT_EQ(read.dvl[i].time_s, written->dvl[i].time_s);
      EXPECT_EQ(read.dvl[i].velocity_body_mps, written->dvl[i].velocity_body_mps);
      EXPECT_EQ(read.dvl[i].altitude_m, written->dvl[i].altitude_m);
      EXPECT_EQ(read.dvl[i].valid, written->dvl[i].valid);
    }
    ASSERT_EQ(read.ahrs.size(), written->ahrs.size());
    for (std::size_t i = 0; i < read.ahrs.size(); ++i) {
      EXPECT_EQ(read.ahrs[i].time_s, written->ahrs[i].time_s);
      EXPECT_EQ(read.ahrs[i].roll_rad, written->ahrs[i].roll_rad);
      EXPECT_EQ(read.ahrs[i].pitch_rad, written->ahrs[i].pitch_rad);
      EXPECT_EQ(read.ahrs[i].yaw_rad, written->ahrs[i].yaw_rad);
      EXPECT_EQ(read.ahrs[i].yaw_rate_radps, written->ahrs[i].yaw_rate_radps);
    }
    ASSERT_EQ(read.depth.size(), written->depth.size());
    for (std::size_t i = 0; i < read.depth.size(); ++i) {
      EXPECT_EQ(read.depth[i].time_s, written->depth[i].time_s);
      EXPECT_EQ(read.depth[i].depth_m, written->depth[i].depth_m);
    }
    ASSERT_EQ(read.ground_truth.size(), written->ground_truth.size());
    for (std::size_t i = 0; i < read.ground_truth.size(); ++i) {
      const msgs::GroundTruthPose& a = read.ground_truth[i];
      const msgs::GroundTruthPose& b = written->ground_truth[i];
      EXPECT_EQ(a.time_s, b.time_s);
      EXPECT_EQ(a.position_m, b.position_m);
      // Attitude goes through a quaternion: equal to rounding.
      EXPECT_NEAR(a.roll_rad, b.roll_rad, 1e-12);
      EXPECT_NEAR(a.pitch_rad, b.pitch_rad, 1e-12);
      EXPECT_NEAR(a.yaw_rad, b.yaw_rad, 1e-12);
    }
  }
}

TEST_F(RecordingTest, EveryImageEncodingRoundTrips) {
  MissionInfo info = TwoRobotMission();
  info.robots.resize(1);
  for (ImageCompression compression : {ImageCompression::kRaw, ImageCompression::kPng,
                                       ImageCompression::kZlib, ImageCompression::kZstd}) {
    SCOPED_TRACE(static_cast<int>(compression));
    WriterOptions options;
    options.compression = compression;
    MissionWriter mission = MissionWriter::Create(dir_, info, options);
    RobotWriter alpha = mission.OpenRobot("alpha");
    std::mt19937 rng(3);
    const msgs::SonarPing ping = MakePing(1.0, 1, 48, 64, rng);
    alpha.WritePing(ping);
    alpha.Close();
    mission.Close();
    const auto records = ReadAll(dir_, "alpha");
    ASSERT_EQ(records.size(), 1u);
    EXPECT_EQ(std::get<msgs::SonarPing>(records[0]).intensity, ping.intensity);
    const std::uintmax_t size = fs::file_size(Alpha("sonar.drs"));
    // file header, ping record (header, fixed part, bearings, image size, image, CRC), end record
    const std::uintmax_t fixed = 16u + 12 + 40 + 64 * 4 + 4 + 4 + 12 + 8 + 4;
    if (compression == ImageCompression::kRaw) {
      EXPECT_EQ(size, fixed + 48 * 64);
    } else {
      EXPECT_LT(size, fixed + 48 * 64);
    }
  }
}

// The byte of the first ping record that holds its image encoding.
int FirstPingEncoding(const fs::path& sonar_file) {
  const std::string bytes = ReadFile(sonar_file);
  return static_cast<std::uint8_t>(bytes.at(16 + 12 + 37));
}

TEST_F(RecordingTest, ZstdIsTheDefaultAndEveryLevelRoundTripsBitExact) {
  EXPECT_EQ(WriterOptions{}.compression, ImageCompression::kZstd);
  MissionInfo info = TwoRobotMission();
  info.robots.resize(1);
  for (int level : {-5, -1, 0, 1, 3, 19}) {
    SCOPED_TRACE(level);
    WriterOptions options;
    options.compression_level = level;
    MissionWriter mission = MissionWriter::Create(dir_, info, options);
    RobotWriter alpha = mission.OpenRobot("alpha");
    std::mt19937 rng(5);
    std::vector<msgs::SonarPing> pings;
    for (int i = 0; i < 3; ++i) {
      pings.push_back(MakePing(0.2 * i, i, 512, 256 + 64 * i, rng));
      alpha.WritePing(pings.back());
    }
    alpha.Close();
    mission.Close();
    EXPECT_EQ(FirstPingEncoding(Alpha("sonar.drs")), 3);
    const auto records = ReadAll(dir_, "alpha");
    ASSERT_EQ(records.size(), pings.size());
    for (std::size_t i = 0; i < pings.size(); ++i) {
      const auto& read = std::get<msgs::SonarPing>(records[i]);
      EXPECT_EQ(read.num_ranges, pings[i].num_ranges);
      EXPECT_EQ(read.num_beams, pings[i].num_beams);
      EXPECT_TRUE(read.intensity == pings[i].intensity) << "ping " << i;
    }
  }
}

TEST_F(RecordingTest, NearConstantZstdPingIsStoredAsZlibWithinTheFormatsExpansionBound) {
  // 512 x 512 zeros make a zstd frame of a few dozen bytes, beyond the 1032:1 the format allows
  // a compressed image: the writer stores that ping with encoding 2, the others with 3.
  MissionInfo info = TwoRobotMission();
  info.robots.resize(1);
  MissionWriter mission = MissionWriter::Create(dir_, info);
  RobotWriter alpha = mission.OpenRobot("alpha");
  std::mt19937 rng(2);
  msgs::SonarPing blank = MakePing(0.0, 0, 512, 512, rng);
  std::fill(blank.intensity.begin(), blank.intensity.end(), 0);
  const msgs::SonarPing speckle = MakePing(0.2, 1, 512, 512, rng);
  alpha.WritePing(blank);
  alpha.WritePing(speckle);
  alpha.Close();
  mission.Close();
  const std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::vector<std::size_t> records = RecordOffsets(bytes);
  ASSERT_EQ(records.size(), 3u);  // two pings and the end record
  EXPECT_EQ(bytes[records[0] + 12 + 37], 2);
  EXPECT_EQ(bytes[records[1] + 12 + 37], 3);
  const auto read = ReadAll(dir_, "alpha");
  ASSERT_EQ(read.size(), 2u);
  EXPECT_TRUE(std::get<msgs::SonarPing>(read[0]).intensity == blank.intensity);
  EXPECT_TRUE(std::get<msgs::SonarPing>(read[1]).intensity == speckle.intensity);
}

TEST_F(RecordingTest, WriterRefusesCompressionLevelsOutsideTheCodecsRange) {
  MissionInfo info = TwoRobotMission();
  for (const WriterOptions& options :
       {WriterOptions{ImageCompression::kZlib, 0}, WriterOptions{ImageCompression::kPng, 10},
        WriterOptions{ImageCompression::kZstd, 23},
        WriterOptions{static_cast<ImageCompression>(4), 1}}) {
    EXPECT_THROW(MissionWriter::Create(dir_, info, options), std::invalid_argument);
  }
  EXPECT_NO_THROW(MissionWriter::Create(dir_, info, {ImageCompression::kRaw, 0}));
}

TEST_F(RecordingTest, QuantizedPingsReadBackAsTheNearestMultipleOfTheStepAndAreSmaller) {
  MissionInfo info = TwoRobotMission();
  info.robots.resize(1);
  std::mt19937 rng(7);
  msgs::SonarPing ping = MakePing(1.0, 1, 256, 128, rng);
  std::fill(ping.intensity.begin(), ping.intensity.begin() + 100, 0);  // no return: stays 0
  std::fill(ping.intensity.begin() + 100, ping.intensity.begin() + 110, 255);
  std::uintmax_t exact_size = 0;
  for (const int step : {1, 8, 16}) {
    SCOPED_TRACE(step);
    WriterOptions options;
    options.ping_quantization_step = step;
    MissionWriter mission = MissionWriter::Create(dir_, info, options);
    RobotWriter alpha = mission.OpenRobot("alpha");
    alpha.WritePing(ping);
    alpha.Close();
    mission.Close();
    const std::string bytes = ReadFile(Alpha("sonar.drs"));
    const std::size_t at = RecordOffsets(bytes).at(0) + 12 + 38;  // the ping's step (u16)
    const int stored =
        static_cast<std::uint8_t>(bytes[at]) | (static_cast<std::uint8_t>(bytes[at + 1]) << 8);
    EXPECT_EQ(stored, step > 1 ? step : 0);
    const auto records = ReadAll(dir_, "alpha");
    ASSERT_EQ(records.size(), 1u);
    const auto& read = std::get<msgs::SonarPing>(records[0]).intensity;
    ASSERT_EQ(read.size(), ping.intensity.size());
    for (std::size_t i = 0; i < read.size(); ++i) {
      const int v = ping.intensity[i];
      ASSERT_EQ(read[i], std::min(255, step * ((v + step / 2) / step))) << i;
      if (step > 1) {
        ASSERT_LE(std::abs(read[i] - v), step / 2) << i;
      }
      if (v == 0) {
        ASSERT_EQ(read[i], 0) << i;
      }
    }
    const std::uintmax_t size = fs::file_size(Alpha("sonar.drs"));
    if (step == 1) {
      exact_size = size;
    } else {
      EXPECT_LT(size, exact_size);
    }
  }
}

TEST_F(RecordingTest, WriterRefusesQuantizationStepsOutsideOneTo128) {
  MissionInfo info = TwoRobotMission();
  for (const int step : {0, -1, 129}) {
    WriterOptions options;
    options.ping_quantization_step = step;
    EXPECT_THROW(MissionWriter::Create(dir_, info, options), std::invalid_argument) << step;
  }
  WriterOptions options;
  options.ping_quantization_step = 128;
  EXPECT_NO_THROW(MissionWriter::Create(dir_, info, options));
}

TEST_F(RecordingTest, EqualTimesComeOutInFixedStreamOrder) {
  MissionInfo info = TwoRobotMission();
  info.robots.resize(1);
  MissionWriter mission = MissionWriter::Create(dir_, info);
  RobotWriter w = mission.OpenRobot("alpha");
  std::mt19937 rng(1);
  for (double t : {1.0, 2.0}) {
    msgs::GroundTruthPose gt;
    gt.time_s = t;
    w.WriteGroundTruth(gt);
    w.WritePing(MakePing(t, 0, 48, 64, rng));
    w.WriteDepth({t, 1.0});
    msgs::DvlVelocity dvl;
    dvl.time_s = t;
    w.WriteDvl(dvl);
    msgs::Ahrs ahrs;
    ahrs.time_s = t;
    w.WriteAhrs(ahrs);
  }
  w.Close();
  mission.Close();
  std::vector<std::size_t> kinds;
  for (const Record& r : ReadAll(dir_, "alpha")) kinds.push_back(r.index());
  // variant indices: 0 ping, 1 dvl, 2 ahrs, 3 depth, 4 ground truth
  EXPECT_EQ(kinds, (std::vector<std::size_t>{2, 1, 3, 0, 4, 2, 1, 3, 0, 4}));
}

TEST_F(RecordingTest, ReadOptionsSkipStreams) {
  WriteMission(4);
  fs::remove(Alpha("ahrs.csv"));  // not needed when AHRS is not read
  ReadOptions options;
  options.ahrs = false;
  options.sonar = false;
  for (const Record& r : ReadAll(dir_, "alpha", options)) {
    EXPECT_FALSE(std::holds_alternative<msgs::SonarPing>(r));
    EXPECT_FALSE(std::holds_alternative<msgs::Ahrs>(r));
  }
}

// Same kind, time and (for pings) image, record by record.
void ExpectSameRecords(const std::vector<Record>& got, const std::vector<Record>& expected) {
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].index(), expected[i].index()) << i;
    EXPECT_EQ(RecordTime(got[i]), RecordTime(expected[i])) << i;
    if (const auto* ping = std::get_if<msgs::SonarPing>(&got[i])) {
      EXPECT_EQ(ping->intensity, std::get<msgs::SonarPing>(expected[i]).intensity) << i;
    }
  }
}

TEST_F(RecordingTest, PrefetchingReaderGivesTheReadersRecordsInOrder) {
  WriteMission(10);
  const std::vector<Record> expected = ReadAll(dir_, "alpha");
  ASSERT_GT(expected.size(), 20u);
  for (std::size_t depth : {1u, 3u, 1000u}) {
    SCOPED_TRACE(depth);
    PrefetchingReader reader(RobotReader::Open(dir_, "alpha"), depth);
    EXPECT_EQ(reader.Robot().name, "alpha");
    std::vector<Record> got;
    while (auto record = reader.Next()) got.push_back(std::move(*record));
    EXPECT_FALSE(reader.Next().has_value());  // the end stays the end
    ExpectSameRecords(got, expected);
  }
  // Destroyed with records not taken (its thread waiting for room): returns.
  PrefetchingReader early(RobotReader::Open(dir_, "alpha"), 2);
  EXPECT_TRUE(early.Next().has_value());
}

TEST_F(RecordingTest, TumFileIsPlainTum) {
  WriteMission(2);
  std::ifstream in(Alpha("groundtruth.tum"));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line[0], '#');
  std::getline(in, line);
  std::istringstream fields(line);
  double t, x, y, z, qx, qy, qz, qw;
  ASSERT_TRUE(fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw);
  EXPECT_EQ(t, alpha_.ground_truth[0].time_s);
  EXPECT_EQ(x, alpha_.ground_truth[0].position_m[0]);
  EXPECT_NEAR(qx * qx + qy * qy + qz * qz + qw * qw, 1.0, 1e-12);
  const double yaw = std::atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz));
  EXPECT_NEAR(yaw, alpha_.ground_truth[0].yaw_rad, 1e-12);
}

// ---- streaming -------------------------------------------------------------------------

TEST_F(RecordingTest, ReaderStreamsRecordByRecord) {
  // Incompressible 256 x 256 pings (about 64 KiB each, 3 MiB in all): damage to the last
  // ping is only noticed when it is reached, so nothing was read ahead.
  MissionInfo info = TwoRobotMission();
  info.robots.resize(1);
  MissionWriter mission = MissionWriter::Create(dir_, info);
  RobotWriter w = mission.OpenRobot("alpha");
  std::mt19937 rng(5);
  const int kPings = 50;
  for (int i = 0; i < kPings; ++i) {
    msgs::SonarPing ping = MakePing(0.2 * i, i, 256, 256, rng);
    for (auto& px : ping.intensity) px = static_cast<std::uint8_t>(rng());
    w.WritePing(ping);
  }
  w.Close();
  mission.Close();

  ReadOptions sonar_only;
  sonar_only.dvl = sonar_only.ahrs = sonar_only.depth = sonar_only.ground_truth = false;
  RobotReader reader = RobotReader::Open(dir_, "alpha", sonar_only);
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(reader.Next());

  std::string bytes = ReadFile(Alpha("sonar.drs"));
  EXPECT_GT(bytes.size(), 50u * 65536);
  const std::vector<std::size_t> offsets = RecordOffsets(bytes);
  ASSERT_EQ(offsets.size(), static_cast<std::size_t>(kPings) + 1);
  std::fstream file(Alpha("sonar.drs"), std::ios::in | std::ios::out | std::ios::binary);
  file.seekp(static_cast<std::streamoff>(offsets[kPings - 1] + 100));
  file.put(static_cast<char>(bytes[offsets[kPings - 1] + 100] ^ 0x5a));
  file.close();

  // The reader keeps one record of look-ahead per stream: returning ping 48 reads ping 49.
  for (int i = 10; i < kPings - 2; ++i) ASSERT_TRUE(reader.Next()) << i;
  const std::string error = RecordingErrorOf([&] { reader.Next(); });
  EXPECT_NE(error.find("record 49"), std::string::npos) << error;
  EXPECT_NE(error.find("bad CRC"), std::string::npos) << error;
}

// ---- atomic writing --------------------------------------------------------------------

TEST_F(RecordingTest, WriterWithoutCloseLeavesNoFile) {
  {
    MissionWriter mission = MissionWriter::Create(dir_, TwoRobotMission());
    RobotWriter alpha = mission.OpenRobot("alpha");
    std::mt19937 rng(1);
    alpha.WritePing(MakePing(0.0, 0, 48, 64, rng));
    alpha.WriteDepth({0.0, 1.0});
    EXPECT_TRUE(fs::exists(dir_ / "alpha" / "sonar.drs.partial"));
  }
  EXPECT_TRUE(fs::is_directory(dir_ / "alpha"));
  EXPECT_TRUE(fs::is_empty(dir_ / "alpha"));
  EXPECT_FALSE(fs::exists(dir_ / "mission.yaml"));
  EXPECT_FALSE(fs::exists(dir_ / "mission.yaml.partial"));
  const std::string error = RecordingErrorOf([&] { RobotReader::Open(dir_, "alpha"); });
  EXPECT_NE(error.find("mission.yaml: missing"), std::string::npos) << error;
}

TEST_F(RecordingTest, MissionCloseNeedsEveryRobotClosed) {
  MissionWriter mission = MissionWriter::Create(dir_, TwoRobotMission());
  RobotWriter alpha = mission.OpenRobot("alpha");
  alpha.Close();
  const std::string error = RecordingErrorOf([&] { mission.Close(); });
  EXPECT_NE(error.find("robot 'bravo' must be opened and closed"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(dir_ / "mission.yaml"));
}

TEST_F(RecordingTest, CreateReplacesAMissionButRefusesOtherData) {
  WriteMission(2);
  {
    MissionWriter again = MissionWriter::Create(dir_, TwoRobotMission());
    EXPECT_FALSE(fs::exists(dir_ / "mission.yaml"));  // no longer looks whole
    EXPECT_FALSE(fs::exists(Alpha("sonar.drs")));
  }
  const fs::path other = dir_ / "other";
  fs::create_directories(other);
  WriteFileBytes(other / "precious.txt", "keep me\n");
  const std::string error =
      RecordingErrorOf([&] { MissionWriter::Create(other, TwoRobotMission()); });
  EXPECT_NE(error.find("not empty and not a draco mission"), std::string::npos) << error;
  EXPECT_TRUE(fs::exists(other / "precious.txt"));
}

TEST_F(RecordingTest, WriterRejectsMisuse) {
  MissionInfo bad = TwoRobotMission();
  bad.robots[1].name = "../escape";
  EXPECT_THROW(MissionWriter::Create(dir_, bad), std::invalid_argument);
  bad = TwoRobotMission();
  bad.robots[1].id = 0;
  EXPECT_THROW(MissionWriter::Create(dir_, bad), std::invalid_argument);

  MissionWriter mission = MissionWriter::Create(dir_, TwoRobotMission());
  EXPECT_THROW(mission.OpenRobot("charlie"), std::invalid_argument);
  RobotWriter bravo = mission.OpenRobot("bravo");
  EXPECT_THROW(mission.OpenRobot("bravo"), std::invalid_argument);
  EXPECT_THROW(bravo.WriteGroundTruth({}), std::invalid_argument);  // declared without
  std::mt19937 rng(1);
  msgs::SonarPing ping = MakePing(1.0, 0, 48, 64, rng);
  bravo.WritePing(ping);
  ping.time_s = 0.5;
  EXPECT_THROW(bravo.WritePing(ping), std::invalid_argument);  // time going backwards
  ping.time_s = 2.0;
  ping.intensity.pop_back();
  EXPECT_THROW(bravo.WritePing(ping), std::invalid_argument);
  bravo.WriteDepth({1.0, 2.0});
  EXPECT_THROW(bravo.WriteDepth({0.9, 2.0}), std::invalid_argument);
  EXPECT_THROW(bravo.WriteDepth({1.1, NAN}), std::invalid_argument);
}

// ---- damaged files: each names the file, the place and what was expected -----------------

class DamagedMissionTest : public RecordingTest {
 protected:
  void SetUp() override {
    RecordingTest::SetUp();
    WriteMission(4);
  }

  // Reads alpha to the end and returns the error.
  std::string ReadError() {
    return RecordingErrorOf([&] { ReadAll(dir_, "alpha"); });
  }

  void EditMissionYaml(const std::string& from, const std::string& to) {
    std::string text = ReadFile(dir_ / "mission.yaml");
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    WriteFileBytes(dir_ / "mission.yaml", text);
  }

  void ExpectError(const std::string& error, std::initializer_list<std::string> parts) {
    for (const std::string& part : parts) {
      EXPECT_NE(error.find(part), std::string::npos) << "'" << part << "' not in: " << error;
    }
  }
};

TEST_F(DamagedMissionTest, UnknownRobot) {
  const std::string error = RecordingErrorOf([&] { RobotReader::Open(dir_, "charlie"); });
  ExpectError(error, {"mission.yaml", "no robot 'charlie'", "alpha, bravo"});
}

TEST_F(DamagedMissionTest, MissionYamlMalformed) {
  WriteFileBytes(dir_ / "mission.yaml", "format: draco-mission\nversion: [1\n");
  ExpectError(ReadError(), {"mission.yaml:", "malformed YAML"});
}

TEST_F(DamagedMissionTest, MissionYamlUnknownKey) {
  EditMissionYaml("  rate_hz:", "  rate_hzz: 1\n  rate_hz:");
  ExpectError(ReadError(), {"mission.yaml:", "unknown key 'sonar.rate_hzz'"});
}

TEST_F(DamagedMissionTest, MissionYamlMissingKey) {
  EditMissionYaml("  range_bins:", "  # range_bins:");
  ExpectError(ReadError(), {"mission.yaml:", "missing key 'sonar.range_bins'"});
}

TEST_F(DamagedMissionTest, MissionYamlBadValue) {
  EditMissionYaml("beams: 64", "beams: sixty-four");
  ExpectError(ReadError(), {"mission.yaml:", "'sonar.beams': expected an integer"});
}

TEST_F(DamagedMissionTest, MissionYamlWrongVersion) {
  EditMissionYaml("version: 1", "version: 2");
  ExpectError(ReadError(), {"mission.yaml:3:", "unsupported format version 2", "reads version 1"});
}

TEST_F(DamagedMissionTest, MissionYamlWrongFormat) {
  EditMissionYaml("format: draco-mission", "format: rosbag");
  ExpectError(ReadError(), {"mission.yaml:", "format is 'rosbag', expected 'draco-mission'"});
}

TEST_F(DamagedMissionTest, MissingFiles) {
  for (const char* file : {"sonar.drs", "dvl.csv", "ahrs.csv", "depth.csv", "groundtruth.tum"}) {
    SCOPED_TRACE(file);
    const std::string saved = ReadFile(Alpha(file));
    fs::remove(Alpha(file));
    ExpectError(ReadError(), {std::string("alpha/") + file, "missing"});
    WriteFileBytes(Alpha(file), saved);
  }
  EXPECT_EQ(ReadAll(dir_, "alpha").size(), ReadAll(dir_, "alpha").size());
}

TEST_F(DamagedMissionTest, SonarBadFileMagic) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  bytes.replace(0, 8, "PNGFILE!");
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(), {"alpha/sonar.drs", "bad file magic 'PNGFILE!'", "expected 'DRACOSNR'"});
}

TEST_F(DamagedMissionTest, SonarWrongVersion) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  SetU32(bytes, 8, 9);
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(), {"alpha/sonar.drs", "unsupported sonar file version 9"});
}

TEST_F(DamagedMissionTest, SonarTruncatedFileHeader) {
  WriteFileBytes(Alpha("sonar.drs"), ReadFile(Alpha("sonar.drs")).substr(0, 10));
  ExpectError(ReadError(), {"alpha/sonar.drs", "truncated file header: 10 of 16 bytes"});
}

TEST_F(DamagedMissionTest, SonarBadRecordMagic) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[2];
  bytes[at] = 'X';
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 2 (byte offset " + std::to_string(at) + ")",
                            "bad record magic 'XREC', expected 'DREC'"});
}

TEST_F(DamagedMissionTest, SonarBadCrc) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[1];
  bytes[at + 12 + 50] ^= 0x01;  // one bit of the image
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(),
              {"alpha/sonar.drs", "record 1 (byte offset", "bad CRC: stored 0x", ", computed 0x"});
}

TEST_F(DamagedMissionTest, SonarTruncatedRecord) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[3];
  WriteFileBytes(Alpha("sonar.drs"), bytes.substr(0, at + 100));
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 3", "truncated record"});
  WriteFileBytes(Alpha("sonar.drs"), bytes.substr(0, at + 5));
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 3", "truncated record header: 5 of 12"});
}

TEST_F(DamagedMissionTest, PrefetchingReaderThrowsWhereTheReaderWould) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  WriteFileBytes(Alpha("sonar.drs"), bytes.substr(0, RecordOffsets(bytes)[3] + 100));
  std::vector<Record> before_plain, before_prefetched;
  const std::string plain = RecordingErrorOf([&] {
    RobotReader reader = RobotReader::Open(dir_, "alpha");
    while (auto record = reader.Next()) before_plain.push_back(std::move(*record));
  });
  const std::string prefetched = RecordingErrorOf([&] {
    PrefetchingReader reader(RobotReader::Open(dir_, "alpha"), 4);
    while (auto record = reader.Next()) before_prefetched.push_back(std::move(*record));
  });
  ExpectError(prefetched, {"alpha/sonar.drs", "record 3", "truncated record"});
  EXPECT_EQ(prefetched, plain);
  ExpectSameRecords(before_prefetched, before_plain);
}

TEST_F(DamagedMissionTest, SonarCutAtARecordBoundary) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t end_record = RecordOffsets(bytes).back();
  WriteFileBytes(Alpha("sonar.drs"), bytes.substr(0, end_record));
  ExpectError(ReadError(),
              {"alpha/sonar.drs", "record 4", "ends after 4 pings without the end record"});
}

TEST_F(DamagedMissionTest, SonarDataAfterEnd) {
  WriteFileBytes(Alpha("sonar.drs"), ReadFile(Alpha("sonar.drs")) + "junk");
  ExpectError(ReadError(), {"alpha/sonar.drs", "unexpected data after the end record"});
}

TEST_F(DamagedMissionTest, SonarEndCountMismatch) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes).back();
  SetU32(bytes, at + 12, 99);
  FixCrc(bytes, at);
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(), {"alpha/sonar.drs", "end record counts 99 pings, file holds 4"});
}

TEST_F(DamagedMissionTest, SonarUnknownRecordType) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[1];
  bytes[at + 4] = 7;
  FixCrc(bytes, at);
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 1", "unknown record type 7"});
}

TEST_F(DamagedMissionTest, SonarFirstPingWithoutBearings) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[0];
  bytes[at + 12 + 36] = 0;  // clear the bearing-table flag
  FixCrc(bytes, at);
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0", "first ping must carry one"});
}

TEST_F(DamagedMissionTest, SonarImplausibleQuantizationStep) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[0];
  bytes[at + 12 + 38] = static_cast<char>(200);  // step 200: beyond 128
  FixCrc(bytes, at);
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0", "quantization step 200"});
}

TEST_F(DamagedMissionTest, SonarUndecodableImage) {
  for (ImageCompression compression : {ImageCompression::kZlib, ImageCompression::kPng}) {
    SCOPED_TRACE(static_cast<int>(compression));
    WriterOptions options;
    options.compression = compression;
    {
      MissionWriter mission = MissionWriter::Create(dir_, TwoRobotMission(), options);
      std::mt19937 rng(1);
      for (const char* name : {"alpha", "bravo"}) {
        RobotWriter w = mission.OpenRobot(name);
        WriteRobot(w, std::string(name) == "alpha", 2, rng);
      }
      mission.Close();
    }
    std::string bytes = ReadFile(Alpha("sonar.drs"));
    const std::size_t at = RecordOffsets(bytes)[0];
    const std::size_t image = at + 12 + 40 + 64 * 4 + 4;
    // PNG: inside the first chunk after the header (IHDR is 33 bytes with the signature).
    const std::size_t damage = compression == ImageCompression::kPng ? image + 41 : image;
    bytes.replace(damage, 8, "NOTIMAGE");
    FixCrc(bytes, at);
    WriteFileBytes(Alpha("sonar.drs"), bytes);
    ExpectError(ReadError(),
                {"alpha/sonar.drs", "record 0",
                 compression == ImageCompression::kPng ? "PNG image does not decode to 48 x 64"
                                                       : "zlib image does not inflate to 48 x 64"});
    if (compression == ImageCompression::kPng) {
      bytes.replace(image, 8, "NOTIMAGE");
      FixCrc(bytes, at);
      WriteFileBytes(Alpha("sonar.drs"), bytes);
      ExpectError(ReadError(), {"alpha/sonar.drs", "record 0", "no PNG signature and header"});
    }
  }
}

// ---- memory bounds: sizes in a corrupt file are checked before anything is allocated ------
// The reader allocates at most the file's size for a record and, for a compressed image, at
// most 1032 times its bytes (deflate's largest expansion); docs/hardening.md.

TEST_F(DamagedMissionTest, SonarRecordLongerThanTheFileIsRefusedBeforeAllocating) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[1];
  SetU32(bytes, at + 8, 200u << 20);  // a 200 MiB payload claimed in a file of a few kB
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  const test_support::LargestAllocation largest;
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 1",
                            "truncated record: payload and CRC need 209715204 bytes, file has " +
                                std::to_string(bytes.size() - at - 12)});
  if (test_support::LargestAllocation::Supported()) {
    EXPECT_LT(largest.bytes(), 1u << 20);
  }
}

TEST_F(DamagedMissionTest, SonarImageLargerThanItsCompressedBytesCanHoldIsRefused) {
  // 60000 x 64 pixels claimed for a compressed image of a few kB (deflate expands at most
  // 1032:1, and the format holds zstd images to the same bound).
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[0];
  SetU32(bytes, at + 12 + 12, 60000);
  FixCrc(bytes, at);
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  const test_support::LargestAllocation largest;
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0",
                            "compressed image cannot hold 60000 x 64", "at most 1032:1"});
  if (test_support::LargestAllocation::Supported()) {
    EXPECT_LT(largest.bytes(), 1u << 20);
  }
}

TEST_F(DamagedMissionTest, SonarPngHeaderMustAnnounceThePingSize) {
  {
    MissionWriter mission =
        MissionWriter::Create(dir_, TwoRobotMission(), {ImageCompression::kPng, 1});
    std::mt19937 rng(1);
    for (const char* name : {"alpha", "bravo"}) {
      RobotWriter w = mission.OpenRobot(name);
      WriteRobot(w, std::string(name) == "alpha", 2, rng);
    }
    mission.Close();
  }
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[0];
  SetU32(bytes, at + 12 + 12, 47);  // the record says 47 range bins, the PNG 48
  FixCrc(bytes, at);
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0",
                            "PNG header announces 48 x 64 pixels of bit depth 8, colour type 0; "
                            "expected 47 x 64 8-bit grey"});
}

// zstd images (encoding 3): DamagedMissionTest writes with the default, zstd level 1.
class DamagedZstdImageTest : public DamagedMissionTest {
 protected:
  void SetUp() override {
    DamagedMissionTest::SetUp();
    bytes_ = ReadFile(Alpha("sonar.drs"));
    at_ = RecordOffsets(bytes_)[0];
    ASSERT_EQ(bytes_[at_ + 12 + 37], 3);
    size_at_ = at_ + 12 + 40 + 64 * 4;  // the first ping carries its bearing table
    image_at_ = size_at_ + 4;
  }

  // Replaces the first ping's image by image (the record's lengths and CRC follow).
  void SetImage(const std::string& image) {
    const std::uint32_t old_size = GetU32(bytes_, size_at_);
    bytes_.replace(image_at_, old_size, image);
    SetU32(bytes_, size_at_, static_cast<std::uint32_t>(image.size()));
    SetU32(bytes_, at_ + 8,
           GetU32(bytes_, at_ + 8) - old_size + static_cast<std::uint32_t>(image.size()));
    FixCrc(bytes_, at_);
    WriteFileBytes(Alpha("sonar.drs"), bytes_);
  }
  std::string Image() const { return bytes_.substr(image_at_, GetU32(bytes_, size_at_)); }

  std::string bytes_;
  std::size_t at_ = 0, size_at_ = 0, image_at_ = 0;
};

TEST_F(DamagedZstdImageTest, TruncatedFrame) {
  const std::string image = Image();
  SetImage(image.substr(0, image.size() - 10));
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0", "zstd frame is truncated or corrupt"});
}

TEST_F(DamagedZstdImageTest, CorruptBlockHeader) {
  // The frame header of a 3072-byte image is 7 bytes (magic, descriptor, 2-byte content size);
  // the first block header follows: block type 3 is reserved.
  std::string image = Image();
  image[7] = static_cast<char>(image[7] | 0x06);
  SetImage(image);
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0", "zstd frame is truncated or corrupt"});
}

TEST_F(DamagedZstdImageTest, FrameDecodesToFewerBytesThanItStates) {
  // A well-formed frame stating 3072 bytes whose one (raw) block holds 3000. zstd has no way
  // to see other damage inside a block without its checksum: the record's CRC-32 covers that.
  std::string frame = "\x28\xb5\x2f\xfd";        // magic
  frame += '\x60';                               // single segment, 2-byte content size
  frame += std::string("\x00\x0b", 2);           // 3072 - 256
  const std::uint32_t block = 1 | (3000u << 3);  // last block, raw, 3000 bytes
  for (int i = 0; i < 3; ++i) frame += static_cast<char>(block >> (8 * i));
  frame += std::string(3000, 'x');
  SetImage(frame);
  ExpectError(ReadError(),
              {"alpha/sonar.drs", "record 0", "zstd frame does not decompress to 48 x 64 = 3072"});
}

TEST_F(DamagedZstdImageTest, NotAFrame) {
  std::string image = Image();
  image.replace(0, 4, "NOPE");
  SetImage(image);
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0", "zstd image is not a zstd frame"});
}

TEST_F(DamagedZstdImageTest, BytesAfterTheFrame) {
  SetImage(Image() + "tail");
  ExpectError(ReadError(),
              {"alpha/sonar.drs", "record 0", "zstd image has 4 bytes after its frame"});
}

TEST_F(DamagedZstdImageTest, ContentSizeIsNotThePingsSize) {
  // The record says 47 range bins, the frame holds 48 x 64 bytes.
  SetU32(bytes_, at_ + 12 + 12, 47);
  FixCrc(bytes_, at_);
  WriteFileBytes(Alpha("sonar.drs"), bytes_);
  const test_support::LargestAllocation largest;
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0",
                            "zstd frame holds 3072 bytes, expected 47 x 64 = 3008"});
  if (test_support::LargestAllocation::Supported()) {
    EXPECT_LT(largest.bytes(), 1u << 20);
  }
}

TEST_F(DamagedZstdImageTest, FrameWithoutContentSize) {
  // A frame of the same bytes whose header leaves the content size out.
  const std::string raw(48 * 64, 'x');
  std::string frame(ZSTD_compressBound(raw.size()), '\0');
  ZSTD_CCtx* context = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(context, ZSTD_c_contentSizeFlag, 0);
  ZSTD_CCtx_setParameter(context, ZSTD_c_compressionLevel, -1);
  ZSTD_inBuffer in{raw.data(), raw.size(), 0};
  ZSTD_outBuffer out{frame.data(), frame.size(), 0};
  ASSERT_EQ(ZSTD_compressStream2(context, &out, &in, ZSTD_e_end), 0u);
  ZSTD_freeCCtx(context);
  frame.resize(out.pos);
  SetImage(frame);
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0",
                            "zstd frame header does not state its content size (expected 48 x "
                            "64 = 3072 bytes)"});
}

TEST_F(DamagedMissionTest, SonarUnknownImageEncoding) {
  std::string bytes = ReadFile(Alpha("sonar.drs"));
  const std::size_t at = RecordOffsets(bytes)[0];
  bytes[at + 12 + 37] = 5;
  FixCrc(bytes, at);
  WriteFileBytes(Alpha("sonar.drs"), bytes);
  ExpectError(ReadError(), {"alpha/sonar.drs", "record 0", "unknown image encoding 5",
                            "expected 0 (raw), 1 (PNG), 2 (zlib) or 3 (zstd)"});
}

TEST_F(DamagedMissionTest, CsvBadHeader) {
  WriteFileBytes(Alpha("dvl.csv"), "t,vx,vy,vz\n0,0,0,0\n");
  ExpectError(ReadError(), {"alpha/dvl.csv:1:", "header is 't,vx,vy,vz'",
                            "expected 'time_s,vx_mps,vy_mps,vz_mps,altitude_m,valid'"});
}

TEST_F(DamagedMissionTest, CsvEmptyFile) {
  WriteFileBytes(Alpha("depth.csv"), "");
  ExpectError(ReadError(), {"alpha/depth.csv", "empty file", "'time_s,depth_m'"});
}

TEST_F(DamagedMissionTest, CsvWrongFieldCount) {
  WriteFileBytes(Alpha("depth.csv"), "time_s,depth_m\n0,1\n0.2,1,5\n");
  ExpectError(ReadError(), {"alpha/depth.csv:3:", "expected 2 comma-separated fields", "found 3"});
}

TEST_F(DamagedMissionTest, CsvNotANumber) {
  WriteFileBytes(Alpha("ahrs.csv"),
                 std::string("time_s,roll_rad,pitch_rad,yaw_rad,yaw_rate_radps\n") +
                     "0,0,0,0,0\n0.01,0,north,0,0\n");
  ExpectError(ReadError(), {"alpha/ahrs.csv:3:", "column 'pitch_rad'",
                            "expected a finite number, found 'north'"});
}

TEST_F(DamagedMissionTest, CsvNonFinite) {
  WriteFileBytes(Alpha("depth.csv"), "time_s,depth_m\n0,nan\n");
  ExpectError(ReadError(), {"alpha/depth.csv:2:", "column 'depth_m'", "found 'nan'"});
}

TEST_F(DamagedMissionTest, CsvTimeGoesBackwards) {
  WriteFileBytes(Alpha("depth.csv"), "time_s,depth_m\n0,1\n0.4,1\n0.2,1\n");
  ExpectError(ReadError(), {"alpha/depth.csv:4:", "time 0.2 s is before the previous line's 0.4"});
}

TEST_F(DamagedMissionTest, CsvCutMidLine) {
  const std::string text = ReadFile(Alpha("dvl.csv"));
  WriteFileBytes(Alpha("dvl.csv"), text.substr(0, text.size() - 5));
  ExpectError(ReadError(), {"alpha/dvl.csv:", "truncated: the last line has no end-of-line"});
}

TEST_F(DamagedMissionTest, CsvBadValidFlag) {
  WriteFileBytes(Alpha("dvl.csv"), "time_s,vx_mps,vy_mps,vz_mps,altitude_m,valid\n0,0.3,0,0,4,2\n");
  ExpectError(ReadError(), {"alpha/dvl.csv:2:", "column 'valid': expected 0 or 1"});
}

TEST_F(DamagedMissionTest, TumWrongFieldCount) {
  WriteFileBytes(Alpha("groundtruth.tum"), "# t x y z qx qy qz qw\n0 1 2 3 0 0 0\n");
  ExpectError(ReadError(),
              {"alpha/groundtruth.tum:2:", "expected 8 blank-separated fields", "found 7"});
}

TEST_F(DamagedMissionTest, TumBadQuaternion) {
  WriteFileBytes(Alpha("groundtruth.tum"), "0 1 2 3 0 0 0 0.5\n");
  ExpectError(ReadError(), {"alpha/groundtruth.tum:1:", "quaternion norm 0.5, expected 1"});
}

TEST_F(DamagedMissionTest, CrlfAndForeignTumAreAccepted) {
  // Converters written in Python emit "\r\n" and "+" signs; TUM from other tools uses blanks.
  WriteFileBytes(Alpha("depth.csv"), "time_s,depth_m\r\n0,+1.5\r\n");
  WriteFileBytes(Alpha("groundtruth.tum"), "0.0   1 2 3\t0 0 0 1\n");
  const auto records = ReadAll(dir_, "alpha");
  int depths = 0, poses = 0;
  for (const Record& r : records) {
    if (const auto* d = std::get_if<msgs::Depth>(&r)) {
      EXPECT_EQ(d->depth_m, 1.5);
      ++depths;
    }
    if (const auto* p = std::get_if<msgs::GroundTruthPose>(&r)) {
      EXPECT_EQ(p->position_m[2], 3.0);
      ++poses;
    }
  }
  EXPECT_EQ(depths, 1);
  EXPECT_EQ(poses, 1);
}

}  // namespace
}  // namespace draco::recording
