// MRPT rawlogs (rawlog.hpp): the first return per beam of hand-placed sonar points; a rawlog
// of odometry, a scan and a pose estimate round-trips and MRPT itself reads it; the
// action / sensory-frame format MRPT's own apps write is read with its odometry increments
// accumulated; missing and damaged files are clear errors.
#include <gtest/gtest.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <stdexcept>

#include "draco/rawlog/rawlog.hpp"

namespace draco::rawlog {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = std::numbers::pi / 180.0;

std::string TempPath(const std::string& name) {
  return (fs::temp_directory_path() / ("draco_rawlog_" + name)).string();
}

msgs::Point2 Polar(double r, double bearing_deg) {
  return {r * std::cos(bearing_deg * kDeg), r * std::sin(bearing_deg * kDeg)};
}

TEST(Rawlog, ScanKeepsTheFirstReturnPerBeam) {
  // 5 beams over 90 deg: -45, -22.5, 0, 22.5, 45 deg.
  const RangeScan s = ScanFromPoints(2.0,
                                     {Polar(5.0, 0.0), Polar(3.0, 1.0), Polar(4.0, 45.0),
                                      Polar(2.0, -60.0), Polar(40.0, -22.5), Polar(6.0, -22.0)},
                                     5, 90.0 * kDeg, 30.0);
  ASSERT_EQ(s.ranges_m.size(), 5u);
  EXPECT_EQ(s.valid, (std::vector<char>{0, 1, 1, 0, 1}));  // -60 deg outside, 40 m too far
  EXPECT_FLOAT_EQ(s.ranges_m[2], 3.0f);                    // nearer of 3 m and 5 m
  EXPECT_FLOAT_EQ(s.ranges_m[1], 6.0f);
  EXPECT_FLOAT_EQ(s.ranges_m[4], 4.0f);
  const auto points = ScanPoints(s);
  ASSERT_EQ(points.size(), 3u);
  EXPECT_NEAR(points[1].x_m, 3.0, 1e-6);
  EXPECT_NEAR(points[1].y_m, 0.0, 1e-6);
  EXPECT_NEAR(points[2].x_m, 4.0 * std::cos(45.0 * kDeg), 1e-6);
  EXPECT_NEAR(points[2].y_m, 4.0 * std::sin(45.0 * kDeg), 1e-6);
  EXPECT_THROW(ScanFromPoints(0.0, {}, 1, 1.0, 30.0), std::invalid_argument);
}

std::vector<Entry> Mission() {
  RangeScan scan =
      ScanFromPoints(0.2, {Polar(7.25, 10.0), Polar(12.5, -30.0)}, 512, 130.0 * kDeg, 30.0);
  scan.T_body_sensor = {0.5, 0.0, 0.0};
  return {Odometry{0.0, {0.0, 0.0, 0.0}}, Odometry{0.2, {0.1, 0.01, 0.02}}, scan,
          Odometry{0.4, {0.2, 0.03, 0.05}}, PoseEstimate{0.4, {0.21, 0.02, 0.049}}};
}

TEST(Rawlog, RoundTripsAndMrptReadsIt) {
  const auto entries = Mission();
  const std::string path = TempPath("mission.rawlog");
  WriteRawlog(path, entries);
  ReadStats stats;
  const auto back = ReadRawlog(path, &stats);
  EXPECT_EQ(stats.skipped, 0);
  ASSERT_EQ(back.size(), entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    ASSERT_EQ(back[i].index(), entries[i].index()) << i;
    EXPECT_NEAR(EntryTime(back[i]), EntryTime(entries[i]), 1e-6) << i;
  }
  const auto& o = std::get<Odometry>(back[3]);
  EXPECT_NEAR(o.T_odom_body.x_m, 0.2, 1e-12);
  EXPECT_NEAR(o.T_odom_body.y_m, 0.03, 1e-12);
  EXPECT_NEAR(o.T_odom_body.yaw_rad, 0.05, 1e-12);
  const auto& s = std::get<RangeScan>(back[2]);
  const auto& s0 = std::get<RangeScan>(entries[2]);
  EXPECT_EQ(s.ranges_m, s0.ranges_m);
  EXPECT_EQ(s.valid, s0.valid);
  EXPECT_NEAR(s.aperture_rad, 130.0 * kDeg, 1e-6);
  EXPECT_NEAR(s.max_range_m, 30.0, 1e-6);
  EXPECT_NEAR(s.T_body_sensor.x_m, 0.5, 1e-12);
  const auto& e = std::get<PoseEstimate>(back[4]);
  EXPECT_NEAR(e.T_map_body.x_m, 0.21, 1e-12);
  EXPECT_NEAR(e.T_map_body.yaw_rad, 0.049, 1e-12);

  // MRPT's own reading: five observations, the scan's first return at 7.25 m on the beam of
  // bearing 10 deg (beam round((10 + 65) / (130 / 511)) = 295).
  mrpt::obs::CRawlog log;
  ASSERT_TRUE(log.loadFromRawLogFile(path));
  ASSERT_EQ(log.size(), 5u);
  const auto scan = log.getAsObservation(2);
  const auto* mrpt_scan = dynamic_cast<const mrpt::obs::CObservation2DRangeScan*>(scan.get());
  ASSERT_NE(mrpt_scan, nullptr);
  EXPECT_EQ(mrpt_scan->sensorLabel, "SONAR");
  ASSERT_EQ(mrpt_scan->getScanSize(), 512u);
  EXPECT_TRUE(mrpt_scan->getScanRangeValidity(295));
  EXPECT_FLOAT_EQ(mrpt_scan->getScanRange(295), 7.25f);
  EXPECT_FALSE(mrpt_scan->getScanRangeValidity(296));
  const auto* odo =
      dynamic_cast<const mrpt::obs::CObservationOdometry*>(log.getAsObservation(1).get());
  ASSERT_NE(odo, nullptr);
  EXPECT_NEAR(odo->odometry.x(), 0.1, 1e-12);
  fs::remove(path);
}

TEST(Rawlog, ReadsMrptActionSensoryFramePairsAccumulatingOdometry) {
  mrpt::obs::CRawlog log;
  for (int k = 0; k < 2; ++k) {
    mrpt::obs::CActionRobotMovement2D move;
    move.computeFromOdometry(mrpt::poses::CPose2D(1.0, 0.0, 0.1),
                             mrpt::obs::CActionRobotMovement2D::TMotionModelOptions());
    move.timestamp = mrpt::Clock::fromDouble(1.0 + k);
    mrpt::obs::CActionCollection actions;
    actions.insert(move);
    log.insert(actions);
    mrpt::obs::CSensoryFrame frame;
    auto scan = std::make_shared<mrpt::obs::CObservation2DRangeScan>();
    scan->timestamp = mrpt::Clock::fromDouble(1.0 + k);
    scan->resizeScan(3);
    for (std::size_t i = 0; i < 3; ++i) {
      scan->setScanRange(i, 2.0f + static_cast<float>(i));
      scan->setScanRangeValidity(i, true);
    }
    frame.insert(scan);
    log.insert(frame);
  }
  const std::string path = TempPath("pairs.rawlog");
  ASSERT_TRUE(log.saveToRawLogFile(path));
  const auto entries = ReadRawlog(path);
  ASSERT_EQ(entries.size(), 4u);
  const auto& second = std::get<Odometry>(entries[2]);
  // (1, 0, 0.1) composed with itself.
  EXPECT_NEAR(second.T_odom_body.x_m, 1.0 + std::cos(0.1), 1e-9);
  EXPECT_NEAR(second.T_odom_body.y_m, std::sin(0.1), 1e-9);
  EXPECT_NEAR(second.T_odom_body.yaw_rad, 0.2, 1e-9);
  EXPECT_NEAR(second.time_s, 2.0, 1e-6);
  EXPECT_FLOAT_EQ(std::get<RangeScan>(entries[3]).ranges_m[2], 4.0f);
  fs::remove(path);
}

TEST(Rawlog, MissingDamagedAndInconsistentAreClearErrors) {
  try {
    ReadRawlog(TempPath("missing.rawlog"));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.rawlog"), std::string::npos) << e.what();
  }
  const std::string junk = TempPath("junk.rawlog");
  std::ofstream(junk) << "this is not a rawlog, only some text of some length\n";
  try {
    ReadRawlog(junk);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("junk.rawlog"), std::string::npos) << e.what();
  }
  fs::remove(junk);
  RangeScan bad;
  bad.ranges_m = {1.0f, 2.0f};
  bad.valid = {1};
  EXPECT_THROW(WriteRawlog(TempPath("bad.rawlog"), {bad}), std::invalid_argument);
}

}  // namespace
}  // namespace draco::rawlog
