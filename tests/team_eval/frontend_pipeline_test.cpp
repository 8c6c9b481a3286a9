#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <filesystem>
#include <numbers>

#include "draco/frontend/pipeline.hpp"

namespace fe = draco::frontend;

TEST(FrontendPipeline, TruthAtInterpolatesAndRefusesGaps) {
  draco::eval::Trajectory truth{{0.0, 0.0, 0.0, 3.0},
                                {0.4, 2.0, -4.0, -3.0},   // yaw crosses +-pi
                                {2.0, 2.0, -4.0, -3.0}};  // 1.6 s gap
  draco::msgs::Pose2 p;
  ASSERT_TRUE(fe::TruthAt(truth, 0.2, &p));
  EXPECT_NEAR(p.x_m, 1.0, 1e-12);
  EXPECT_NEAR(p.y_m, -2.0, 1e-12);
  // Shortest arc from 3.0 to -3.0 passes through pi.
  EXPECT_NEAR(std::abs(p.yaw_rad), std::numbers::pi, 1e-9);
  ASSERT_TRUE(fe::TruthAt(truth, 0.0, &p));
  EXPECT_NEAR(p.yaw_rad, 3.0, 1e-12);
  EXPECT_FALSE(fe::TruthAt(truth, 1.0, &p));   // inside the gap
  EXPECT_FALSE(fe::TruthAt(truth, -0.1, &p));  // before the span
  EXPECT_FALSE(fe::TruthAt(truth, 2.1, &p));   // after
}

TEST(FrontendPipeline, KeyframeCacheRoundTrip) {
  std::vector<draco::registration::KeyframeScan> kfs(2);
  kfs[0] = {0, 1.5, {1.0, 2.0, 0.3}, {{0.5, 0.25}, {-1.0, 4.0}}};
  kfs[1] = {1, 2.5, {-1.0, 0.0, -0.3}, {}};
  const auto path = (std::filesystem::temp_directory_path() /
                     ("frontend_cache_" + std::to_string(::getpid()) + ".bin"))
                        .string();
  fe::SaveKeyframes(path, kfs);
  std::vector<draco::registration::KeyframeScan> back;
  ASSERT_TRUE(fe::LoadKeyframes(path, &back));
  std::filesystem::remove(path);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].index, 1);
  EXPECT_DOUBLE_EQ(back[0].time_s, 1.5);
  EXPECT_DOUBLE_EQ(back[0].T_map_kf.yaw_rad, 0.3);
  ASSERT_EQ(back[0].points_kf.size(), 2u);
  EXPECT_DOUBLE_EQ(back[0].points_kf[1].y_m, 4.0);
  EXPECT_TRUE(back[1].points_kf.empty());
  EXPECT_FALSE(fe::LoadKeyframes(path + ".missing", &back));
}

TEST(FrontendPipeline, NoObjectsMeansNoMatchAndNoRegistration) {
  fe::Robot a, b;
  a.id = 0;
  b.id = 1;
  a.name = "a";
  b.name = "b";
  b.T_world_map = {10.0, 0.0, 0.5};
  for (int k = 0; k < 3; ++k) {
    a.kfs.push_back({k, 1.0 * k, {1.0 * k, 0.0, 0.0}, {{1.0, 1.0}}});
    b.kfs.push_back({k, 1.0 * k, {1.0 * k, 0.0, 0.0}, {{1.0, 1.0}}});
  }
  a.truth_kf.assign(3, {});
  b.truth_kf.assign(3, {});
  a.has_truth.assign(3, 1);
  b.has_truth.assign(3, 1);
  fe::PairOptions o;
  o.oracle = true;  // no true shared object: the oracle has nothing to give either
  const auto r = fe::MatchAndRegister(a, b, o);
  EXPECT_FALSE(r.matched);
  EXPECT_FALSE(r.oracle_used);
  EXPECT_EQ(r.shared_objects, 0);
  EXPECT_EQ(r.requests, 0u);
  EXPECT_TRUE(r.registrations.empty());
  EXPECT_NEAR(r.T_true.x_m, 10.0, 1e-12);
  EXPECT_NEAR(r.T_true.yaw_rad, 0.5, 1e-12);
}

// A robot whose keyframe k (time 10 k) sees a 4 m x 1 m block of points 20 m apart from the
// previous one.
fe::Robot BlockRobot(int id, const draco::msgs::Pose2& T_world_map, int keyframes) {
  fe::Robot r;
  r.id = id;
  r.T_world_map = T_world_map;
  for (int k = 0; k < keyframes; ++k) {
    draco::registration::KeyframeScan s;
    s.index = k;
    s.time_s = 10.0 * k;
    s.T_map_kf = {20.0 * k, 0.0, 0.0};
    for (int i = 0; i < 41; ++i) {
      for (int j = 0; j < 6; ++j) s.points_kf.push_back({0.1 * i, 0.2 * j});
    }
    r.kfs.push_back(s);
  }
  return r;
}

TEST(FrontendPipeline, ObjectMapsUpToATimeAndSharedObjects) {
  const auto a = BlockRobot(0, {0.0, 0.0, 0.0}, 6);
  const draco::objects::ObjectMapperOptions mapper;  // d_min 1 m: the 4 m blocks are objects
  EXPECT_EQ(fe::BuildObjectMap(a, mapper).objects.size(), 6u);
  EXPECT_EQ(fe::BuildObjectMap(a, mapper, 25.0).objects.size(), 3u);  // keyframes 0, 1, 2
  // b's map frame is a's shifted by 20 m: its blocks lie on a's blocks 1..6 in the world.
  const auto b = BlockRobot(1, {20.0, 0.0, 0.0}, 6);
  EXPECT_EQ(fe::SharedObjects(a, fe::BuildObjectMap(a, mapper), b, fe::BuildObjectMap(b, mapper)),
            5);
  // Matched over time: a straight row of identical blocks is ambiguous, so only the status
  // and the bookkeeping are checked here.
  const auto series = fe::MatchOverTime(a, b, mapper, {}, 10.0);
  ASSERT_EQ(series.size(), 5u);  // t = 10 .. 50
  EXPECT_EQ(series.back().objects_a, 6);
  EXPECT_EQ(series.back().shared, 5);
  EXPECT_EQ(series.front().match.status, draco::msgs::MatchStatus::kTooFewObjects);
}

namespace {

draco::msgs::Object Rect(std::uint32_t id, double cx, double cy, double length, double breadth,
                         double yaw, bool landmark = false) {
  draco::msgs::Object o;
  o.id = id;
  o.center = o.rect_center = {cx, cy};
  o.length_m = length;
  o.breadth_m = breadth;
  o.yaw_rad = yaw;
  o.landmark = landmark;
  return o;
}

}  // namespace

TEST(FrontendPipeline, PairsUnderTransformPairsMeetingRectangles) {
  // Own map: a 20 x 2 m pier along x at the origin, a pile at (0, 10), a landmark at (5, 5).
  draco::msgs::ObjectMap a;
  a.objects = {Rect(1, 0.0, 0.0, 20.0, 2.0, 0.0), Rect(2, 0.0, 10.0, 1.0, 1.0, 0.0),
               Rect(3, 5.0, 5.0, 0.5, 0.5, 0.0, true)};
  // Teammate map, rotated by 90 deg and shifted: T_a_b = (3, -1, pi/2).
  const draco::msgs::Pose2 T_a_b{3.0, -1.0, std::numbers::pi / 2};
  // In b's frame, a point q maps to a as (3 - q.y, -1 + q.x). The same pier seen from the
  // other side: its cluster is 8 m long, centred 7 m along the pier from a's centre and 1.5 m
  // across (centres 7.2 m apart: no centre criterion would pair them).
  // a-frame centre (7, 1.5) <- b-frame (2.5, -4); its long side along a's x = b's -y.
  draco::msgs::ObjectMap b;
  b.objects = {Rect(10, 2.5, -4.0, 8.0, 1.0, std::numbers::pi / 2),
               // 3.4 m from the pile in a: (0, 13.4) <- b (14.4, 3): grown by 1 m each, the
               // 1 m squares miss (gap 3.4 - 1 - 2 = 0.4 m).
               Rect(11, 14.4, 3.0, 1.0, 1.0, 0.0),
               // A landmark on the pier in b: never paired.
               Rect(12, 1.0, 0.0, 0.5, 0.5, 0.0, true)};
  const auto pairs = draco::objects::PairsUnderTransform(a, b, T_a_b, 1.0);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].id_a, 1u);
  EXPECT_EQ(pairs[0].id_b, 10u);
  EXPECT_NEAR(pairs[0].residual_m, std::hypot(7.0, 1.5), 1e-9);
  // With a 1.5 m margin the pile squares meet (0.4 m gap < 2 x 0.5 m more).
  const auto wider = draco::objects::PairsUnderTransform(a, b, T_a_b, 1.5);
  ASSERT_EQ(wider.size(), 2u);
  EXPECT_EQ(wider[1].id_a, 2u);
  EXPECT_EQ(wider[1].id_b, 11u);
  // A transform 30 m off pairs nothing.
  EXPECT_TRUE(
      draco::objects::PairsUnderTransform(a, b, {33.0, -1.0, std::numbers::pi / 2}, 1.0).empty());
}
