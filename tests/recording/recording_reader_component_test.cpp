// sonar.RecordingReader through the runtime's one-component harness.
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "draco/graph/testing/harness.hpp"
#include "draco/recording/recording.hpp"

namespace draco::recording {
namespace {

namespace fs = std::filesystem;
using graph::Seconds;
using graph::testing::Harness;

class RecordingReaderComponentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("draco-recording-component-" + std::to_string(::getpid()) + "-" + info->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Robot "alpha": pings at 0, 0.2, ... 0.8 s; DVL, depth and ground truth at 0.1 s steps.
  void WriteMission(std::vector<RobotInfo> robots = {{"alpha", 0, true}, {"bravo", 1, false}}) {
    MissionInfo info;
    info.name = "component test";
    info.world = "none";
    info.robots = robots;
    MissionWriter mission = MissionWriter::Create(dir_, info);
    for (const RobotInfo& robot : robots) {
      RobotWriter w = mission.OpenRobot(robot.name);
      for (int i = 0; i < 5; ++i) {
        msgs::SonarPing ping;
        ping.time_s = 0.2 * i;
        ping.ping_id = static_cast<std::uint32_t>(i);
        ping.num_ranges = 8;
        ping.num_beams = 4;
        ping.range_resolution_m = 0.5;
        ping.bearings_rad = {-0.3f, -0.1f, 0.1f, 0.3f};
        ping.intensity.assign(32, static_cast<std::uint8_t>(10 * i));
        w.WritePing(ping);
      }
      for (int i = 0; i < 10; ++i) {
        msgs::DvlVelocity dvl;
        dvl.time_s = 0.1 * i;
        dvl.velocity_body_mps = {0.3, 0.0, 0.0};
        w.WriteDvl(dvl);
        msgs::Ahrs ahrs;
        ahrs.time_s = 0.1 * i;
        ahrs.yaw_rad = 0.01 * i;
        w.WriteAhrs(ahrs);
        w.WriteDepth({0.1 * i, 1.0});
        if (robot.has_ground_truth) {
          msgs::GroundTruthPose pose;
          pose.time_s = 0.1 * i;
          pose.position_m = {0.03 * i, 0.0, -1.0};
          w.WriteGroundTruth(pose);
        }
      }
      w.Close();
    }
    mission.Close();
  }

  std::string Params(const std::string& robot) const {
    return "recording: \"" + dir_.string() + "\"\nrobot: \"" + robot + "\"\n";
  }

  fs::path dir_;
};

TEST_F(RecordingReaderComponentTest, ReplaysEveryStreamStampedInMissionTime) {
  WriteMission();
  Harness h("sonar.RecordingReader", Params("alpha"));
  h.RunUntilIdle();
  EXPECT_EQ(h.error(), "");
  const auto pings = h.Outputs<msgs::SonarPing>("ping");
  ASSERT_EQ(pings.size(), 5u);
  for (std::size_t i = 0; i < pings.size(); ++i) {
    EXPECT_EQ(pings[i].stamp, Seconds(0.2 * i));
    EXPECT_EQ(pings[i]->ping_id, i);
    EXPECT_EQ(pings[i]->intensity, std::vector<std::uint8_t>(32, 10 * i));
    EXPECT_EQ(pings[i]->bearings_rad.size(), 4u);
  }
  const auto dvl = h.Outputs<msgs::DvlVelocity>("dvl");
  ASSERT_EQ(dvl.size(), 10u);
  EXPECT_EQ(dvl[3].stamp, Seconds(0.1 * 3));
  EXPECT_EQ(dvl[3]->velocity_body_mps[0], 0.3);
  EXPECT_EQ(h.Outputs<msgs::Ahrs>("ahrs").size(), 10u);
  EXPECT_EQ(h.Outputs<msgs::Ahrs>("ahrs")[7]->yaw_rad, 0.01 * 7);
  EXPECT_EQ(h.Outputs<msgs::Depth>("depth").size(), 10u);
  const auto truth = h.Outputs<msgs::GroundTruthPose>("ground_truth");
  ASSERT_EQ(truth.size(), 10u);
  EXPECT_EQ(truth[9]->position_m[0], 0.03 * 9);
}

TEST_F(RecordingReaderComponentTest, RobotWithoutGroundTruthEmitsNone) {
  WriteMission();
  Harness h("sonar.RecordingReader", Params("bravo"));
  h.RunUntilIdle();
  EXPECT_EQ(h.error(), "");
  EXPECT_EQ(h.Outputs<msgs::SonarPing>("ping").size(), 5u);
  EXPECT_TRUE(h.Outputs<msgs::GroundTruthPose>("ground_truth").empty());
}

TEST_F(RecordingReaderComponentTest, RobotMayBeOmittedWhenTheMissionHasOne) {
  WriteMission({{"solo", 3, true}});
  Harness h("sonar.RecordingReader", Params(""));
  h.RunUntilIdle();
  EXPECT_EQ(h.Outputs<msgs::SonarPing>("ping").size(), 5u);
}

TEST_F(RecordingReaderComponentTest, StartFailsNamingTheProblem) {
  WriteMission();
  auto start_error = [&](const std::string& params) -> std::string {
    try {
      Harness h("sonar.RecordingReader", params);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(start_error(Params("charlie")).find("no robot 'charlie'"), std::string::npos);
  EXPECT_NE(start_error(Params("")).find("'robot' is not set"), std::string::npos);
  EXPECT_NE(start_error("robot: alpha\n").find("'recording' is not set"), std::string::npos);
  fs::remove(dir_ / "alpha" / "dvl.csv");
  const std::string missing = start_error(Params("alpha"));
  EXPECT_NE(missing.find("alpha/dvl.csv: missing"), std::string::npos) << missing;
}

TEST_F(RecordingReaderComponentTest, CorruptDataMidRunStopsWithError) {
  WriteMission();
  // Cut the sonar file inside the fourth ping: the first three replay, then a fatal error.
  const fs::path sonar = dir_ / "alpha" / "sonar.drs";
  std::string bytes;
  {
    std::ifstream in(sonar, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::size_t at = 16;
  for (int i = 0; i < 3; ++i) {
    std::uint32_t length = 0;
    for (int k = 3; k >= 0; --k)
      length = (length << 8) | static_cast<std::uint8_t>(bytes[at + 8 + k]);
    at += 12 + length + 4;
  }
  {
    std::ofstream out(sonar, std::ios::binary | std::ios::trunc);
    out << bytes.substr(0, at + 20);
  }
  Harness h("sonar.RecordingReader", Params("alpha"));
  h.RunUntilIdle();
  EXPECT_NE(h.error().find("alpha/sonar.drs: record 3"), std::string::npos) << h.error();
  EXPECT_NE(h.error().find("truncated record"), std::string::npos) << h.error();
  EXPECT_LE(h.Outputs<msgs::SonarPing>("ping").size(), 3u);
}

}  // namespace
}  // namespace draco::recording
