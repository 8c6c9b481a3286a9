// sim.LiveRobot against sonar.RecordingReader on a recording of the same mission written by
// draco-sim, both through the one-component harness: the same messages with the same stamps
// on every port. Pings, DVL, AHRS and depth are bit-identical (the recording stores pings
// losslessly and CSV numbers as the shortest text that reads back as the same double); ground
// truth positions and times too, its angles to 1e-12 rad (groundtruth.tum stores the attitude
// as a quaternion, read back into roll, pitch and yaw).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string>

#include "draco/graph/testing/harness.hpp"
#include "draco/msgs/sensors.hpp"

namespace {

namespace fs = std::filesystem;
using draco::graph::testing::Harness;

const std::string kMission = std::string(DRACO_SOURCE_DIR) + "/config/missions/marina.yaml";
constexpr const char* kDuration = "20";

double AngleDiff(double a, double b) {
  return std::abs(std::remainder(a - b, 2.0 * std::numbers::pi));
}

class LiveRobotTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("draco-live-robot-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    const std::string command = std::string(DRACO_SIM_EXE) + " " + kMission + " --out " +
                                dir_.string() + " --duration-s " + kDuration +
                                " --robots 2 --no-pictures > " + dir_.string() + ".log 2>&1";
    status_ = std::system(command.c_str());
  }
  static void TearDownTestSuite() {
    fs::remove_all(dir_);
    fs::remove(dir_.string() + ".log");
  }
  void SetUp() override { ASSERT_EQ(status_, 0) << "draco-sim failed, see " << dir_ << ".log"; }

  static std::string LiveParams(const std::string& robot, int queue_records) {
    return "mission: " + kMission + "\nrobot: " + robot + "\nduration_s: " + kDuration +
           "\nqueue_records: " + std::to_string(queue_records);
  }
  static std::string RecordedParams(const std::string& robot) {
    return "recording: " + dir_.string() + "\nrobot: " + robot;
  }

  static inline fs::path dir_;
  static inline int status_ = -1;
};

template <class T>
void ExpectSameStamps(const Harness& recorded, const Harness& live, const std::string& port,
                      std::size_t* count) {
  const auto a = recorded.Outputs<T>(port);
  const auto b = live.Outputs<T>(port);
  ASSERT_EQ(a.size(), b.size()) << port;
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].stamp, b[i].stamp) << port << " " << i;
    ASSERT_EQ(a[i]->time_s, b[i]->time_s) << port << " " << i;
  }
  *count = a.size();
}

TEST_F(LiveRobotTest, PublishesWhatTheRecordingReplays) {
  for (const std::string robot : {"alpha", "bravo"}) {
    SCOPED_TRACE(robot);
    Harness recorded("sonar.RecordingReader", RecordedParams(robot));
    recorded.RunUntilIdle();
    Harness live("sim.LiveRobot", LiveParams(robot, 16));  // a small queue: the producer waits
    live.RunUntilIdle();
    ASSERT_EQ(recorded.error(), "");
    ASSERT_EQ(live.error(), "");

    std::size_t n = 0;
    ExpectSameStamps<draco::msgs::SonarPing>(recorded, live, "ping", &n);
    EXPECT_EQ(n, 101u);  // 20 s at 5 Hz, both ends
    const auto pa = recorded.Outputs<draco::msgs::SonarPing>("ping");
    const auto pb = live.Outputs<draco::msgs::SonarPing>("ping");
    for (std::size_t i = 0; i < n; ++i) {
      const auto& a = *pa[i];
      const auto& b = *pb[i];
      ASSERT_EQ(a.ping_id, b.ping_id);
      ASSERT_EQ(a.num_ranges, b.num_ranges);
      ASSERT_EQ(a.num_beams, b.num_beams);
      ASSERT_EQ(a.range_resolution_m, b.range_resolution_m);
      ASSERT_EQ(a.vertical_aperture_rad, b.vertical_aperture_rad);
      ASSERT_EQ(a.bearings_rad, b.bearings_rad);
      ASSERT_EQ(a.intensity, b.intensity) << "ping " << i;
    }

    ExpectSameStamps<draco::msgs::DvlVelocity>(recorded, live, "dvl", &n);
    EXPECT_GT(n, 90u);
    const auto da = recorded.Outputs<draco::msgs::DvlVelocity>("dvl");
    const auto db = live.Outputs<draco::msgs::DvlVelocity>("dvl");
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_EQ(da[i]->valid, db[i]->valid) << i;
      ASSERT_EQ(da[i]->velocity_body_mps, db[i]->velocity_body_mps) << i;
      ASSERT_EQ(da[i]->altitude_m, db[i]->altitude_m) << i;
    }

    ExpectSameStamps<draco::msgs::Ahrs>(recorded, live, "ahrs", &n);
    EXPECT_GT(n, 1900u);
    const auto aa = recorded.Outputs<draco::msgs::Ahrs>("ahrs");
    const auto ab = live.Outputs<draco::msgs::Ahrs>("ahrs");
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_EQ(aa[i]->roll_rad, ab[i]->roll_rad) << i;
      ASSERT_EQ(aa[i]->pitch_rad, ab[i]->pitch_rad) << i;
      ASSERT_EQ(aa[i]->yaw_rad, ab[i]->yaw_rad) << i;
      ASSERT_EQ(aa[i]->yaw_rate_radps, ab[i]->yaw_rate_radps) << i;
    }

    ExpectSameStamps<draco::msgs::Depth>(recorded, live, "depth", &n);
    const auto za = recorded.Outputs<draco::msgs::Depth>("depth");
    const auto zb = live.Outputs<draco::msgs::Depth>("depth");
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(za[i]->depth_m, zb[i]->depth_m) << i;

    ExpectSameStamps<draco::msgs::GroundTruthPose>(recorded, live, "ground_truth", &n);
    EXPECT_GT(n, 390u);
    const auto ga = recorded.Outputs<draco::msgs::GroundTruthPose>("ground_truth");
    const auto gb = live.Outputs<draco::msgs::GroundTruthPose>("ground_truth");
    double worst_rad = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_EQ(ga[i]->position_m, gb[i]->position_m) << i;
      worst_rad = std::max({worst_rad, AngleDiff(ga[i]->roll_rad, gb[i]->roll_rad),
                            AngleDiff(ga[i]->pitch_rad, gb[i]->pitch_rad),
                            AngleDiff(ga[i]->yaw_rad, gb[i]->yaw_rad)});
    }
    EXPECT_LT(worst_rad, 1e-12);
    std::printf("%s: ground truth angles differ by at most %.3g rad\n", robot.c_str(), worst_rad);

    // The same end as the recording's replay length (the last AHRS stamp).
    ASSERT_TRUE(recorded.node().component->SourceEndTime().has_value());
    EXPECT_EQ(recorded.node().component->SourceEndTime(), live.node().component->SourceEndTime());
  }
}

// A graph that ends early (here: nothing taken) stops the simulator at its next record, not at
// the end of a 1000 s mission.
TEST_F(LiveRobotTest, StopsPromptly) {
  const auto start = std::chrono::steady_clock::now();
  {
    Harness live("sim.LiveRobot", "mission: " + kMission + "\nrobot: alpha\nqueue_records: 8");
    live.Stop();
  }
  {
    Harness live("sim.LiveRobot", "mission: " + kMission + "\nrobot: charlie\nqueue_records: 8");
  }  // destroyed without Stop()
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
}

TEST_F(LiveRobotTest, UnknownRobotFailsAtStart) {
  try {
    Harness live("sim.LiveRobot", "mission: " + kMission + "\nrobot: zulu");
    FAIL() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("zulu"), std::string::npos) << e.what();
  }
}

}  // namespace
