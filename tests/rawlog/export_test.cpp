// A recorded mission as an MRPT rawlog (export.hpp): a hand-made mission (straight drive at
// 0.5 m/s, heading 0; every ping a bright patch 5.0-5.4 m ahead on a dark background) gives
// one odometry per DVL sample along x, one range scan per ping whose beams with a return are
// the patch's, at its range; the file round-trips; a trajectory merges in by time; the rawlog
// read back by sonar.RawlogReader feeds the local-SLAM graph (local-slam-rawlog.yaml) the
// same dead reckoning and the patch as features.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "draco/eval/trajectory.hpp"
#include "draco/graph/graph.hpp"
#include "draco/graph/testing/harness.hpp"
#include "draco/msgs/slam.hpp"
#include "draco/rawlog/export.hpp"
#include "draco/rawlog/import.hpp"
#include "draco/rawlog/rawlog.hpp"
#include "draco/recording/recording.hpp"

namespace draco::rawlog {
namespace {

namespace fs = std::filesystem;

class RawlogExport : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("draco-rawlog-export-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    recording::MissionInfo info;
    info.name = "rawlog test";
    info.world = "none";
    info.robots = {{"alpha", 0, true}};
    info.sonar.mount.position_m = {0.4, 0.0, 0.0};
    auto mission = recording::MissionWriter::Create(dir_, info);
    auto w = mission.OpenRobot("alpha");
    for (int i = 0; i < 5; ++i) {
      msgs::SonarPing ping;
      ping.time_s = 0.2 * i + 0.05;
      ping.ping_id = static_cast<std::uint32_t>(i);
      ping.num_ranges = 100;
      ping.num_beams = 64;
      ping.range_resolution_m = 0.1;
      for (int b = 0; b < 64; ++b) ping.bearings_rad.push_back(static_cast<float>(-0.5 + b / 63.0));
      ping.intensity.assign(100 * 64, 0);
      for (int r = 49; r < 53; ++r) {  // rows 49-52: ranges 5.0-5.3 m
        for (int b = 28; b < 36; ++b) ping.intensity[static_cast<std::size_t>(r) * 64 + b] = 255;
      }
      w.WritePing(ping);
    }
    for (int i = 0; i <= 10; ++i) {
      msgs::Ahrs ahrs;
      ahrs.time_s = 0.1 * i;
      w.WriteAhrs(ahrs);
      msgs::DvlVelocity dvl;
      dvl.time_s = 0.1 * i;
      dvl.velocity_body_mps = {0.5, 0.0, 0.0};
      w.WriteDvl(dvl);
    }
    w.Close();
    mission.Close();
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(RawlogExport, OdometryAndFirstReturnsOfAHandMadeMission) {
  ExportStats stats;
  const auto entries = MissionEntries(dir_, "alpha", &stats);
  EXPECT_EQ(stats.scans, 5);
  EXPECT_GE(stats.odometry, 10);
  EXPECT_TRUE(std::is_sorted(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return EntryTime(a) < EntryTime(b);
  }));
  const Odometry* last = nullptr;
  for (const auto& e : entries) {
    if (const auto* o = std::get_if<Odometry>(&e)) {
      // Straight along x at 0.5 m/s from the first DVL sample.
      EXPECT_NEAR(o->T_odom_body.x_m, 0.5 * o->time_s, 1e-6) << o->time_s;
      EXPECT_NEAR(o->T_odom_body.y_m, 0.0, 1e-9);
      last = o;
    } else if (const auto* s = std::get_if<RangeScan>(&e)) {
      ASSERT_EQ(s->ranges_m.size(), 64u);
      EXPECT_NEAR(s->aperture_rad, 1.0, 1e-6);
      EXPECT_NEAR(s->max_range_m, 10.0, 1e-9);
      EXPECT_NEAR(s->T_body_sensor.x_m, 0.4, 1e-12);
      int valid = 0;
      for (std::size_t b = 0; b < 64; ++b) {
        if (!s->valid[b]) continue;
        ++valid;
        EXPECT_GE(b, 27u);  // the patch's beams 28-35, one beam either side for rounding
        EXPECT_LE(b, 36u);
        EXPECT_GE(s->ranges_m[b], 4.9f);  // rows 49-52: 5.0-5.3 m
        EXPECT_LE(s->ranges_m[b], 5.45f);
      }
      EXPECT_GT(valid, 0);
    }
  }
  ASSERT_NE(last, nullptr);
  EXPECT_NEAR(last->T_odom_body.x_m, 0.5, 1e-6);

  const std::string path = (dir_ / "alpha.rawlog").string();
  WriteRawlog(path, entries);
  const auto back = ReadRawlog(path);
  ASSERT_EQ(back.size(), entries.size());
  for (std::size_t i = 0; i < back.size(); ++i) EXPECT_EQ(back[i].index(), entries[i].index());
}

TEST_F(RawlogExport, TrajectoryMergesByTimeAndBadInputNamesIt) {
  const std::string tum = (dir_ / "alpha.trajectory.tum").string();
  eval::WriteTum(tum, {{0.15, 0.07, 0.0, 0.0}, {0.55, 0.27, 0.01, 0.02}});
  const auto merged = MergeByTime(MissionEntries(dir_, "alpha"), TrajectoryEntries(tum));
  int poses = 0;
  for (std::size_t i = 0; i < merged.size(); ++i) {
    if (i > 0) {
      EXPECT_LE(EntryTime(merged[i - 1]), EntryTime(merged[i]));
    }
    if (const auto* p = std::get_if<PoseEstimate>(&merged[i])) {
      ++poses;
      if (poses == 2) {
        EXPECT_NEAR(p->T_map_body.yaw_rad, 0.02, 1e-9);
      }
    }
  }
  EXPECT_EQ(poses, 2);
  try {
    MissionEntries(dir_, "zulu");
    FAIL() << "no exception";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("zulu"), std::string::npos) << e.what();
  }
  EXPECT_THROW(TrajectoryEntries((dir_ / "missing.tum").string()), std::exception);
}

TEST_F(RawlogExport, ReaderFeedsLocalSlamTheSameOdometryAndThePatch) {
  const auto entries = MissionEntries(dir_, "alpha");
  const std::string path = (dir_ / "alpha.rawlog").string();
  WriteRawlog(path, entries);
  graph::testing::Harness h("sonar.RawlogReader", "rawlog: \"" + path + "\"\n");
  h.RunUntilIdle();
  EXPECT_EQ(h.error(), "");
  const auto odometry = h.Outputs<msgs::DeadReckoning>("odometry");
  const auto features = h.Outputs<msgs::SonarFeatures>("features");
  ASSERT_EQ(features.size(), 5u);
  ASSERT_GE(odometry.size(), 10u);
  for (std::size_t i = 1; i < odometry.size(); ++i) {
    const auto& d = *odometry[i].value;
    EXPECT_NEAR(d.T_odom_body.x_m, 0.5 * d.time_s, 1e-6);
    EXPECT_EQ(odometry[i].stamp, graph::Time::FromSeconds(d.time_s));
    // 0.1 s at 0.5 m/s: a 5 cm step, its variance (0.02 m/s x 0.1 s)^2 along x.
    EXPECT_NEAR(d.T_prev_body.x_m, 0.05, 1e-6);
    EXPECT_NEAR(d.covariance_prev_body[0], 4e-6, 1e-9);
    EXPECT_GT(d.covariance_prev_body[8], 0.0);
  }
  for (const auto& f : features) {
    ASSERT_FALSE(f.value->points_sensor.empty());
    for (const auto& p : f.value->points_sensor) {
      EXPECT_NEAR(std::hypot(p.x_m, p.y_m), 5.2, 0.25);
      EXPECT_LT(std::abs(std::atan2(p.y_m, p.x_m)), 0.1);  // beams 27-36 of 64 over 1 rad
    }
  }
  // The graph of local SLAM from a rawlog loads with the reader in it.
  EXPECT_NO_THROW(graph::LoadGraphFile(std::string(DRACO_SOURCE_DIR) +
                                       "/config/graphs/local-slam-rawlog.yaml"));
  // A missing rawlog stops the reader with its name.
  try {
    graph::testing::Harness bad("sonar.RawlogReader", "rawlog: \"/nonexistent/x.rawlog\"\n");
    FAIL() << "no exception";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("x.rawlog"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace draco::rawlog
