#include "draco/frontend/outliers.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

namespace fe = draco::frontend;
using draco::msgs::InterRobotLoop;
using draco::msgs::Pose2;

namespace {

// Own keyframes along a curve, headings turning; loops to teammates 1 and 2.
struct Stream {
  std::vector<Pose2> own;
  std::vector<InterRobotLoop> loops;
};

Stream MakeStream() {
  Stream s;
  for (int k = 0; k < 40; ++k) s.own.push_back({2.0 * k, 0.1 * k * k, 0.05 * k});
  for (int k = 0; k < 40; k += 2) {
    InterRobotLoop l;
    l.id = s.loops.size();
    l.own_keyframe = k;
    l.teammate_robot = k < 20 ? 1 : 2;
    l.teammate_keyframe = k / 2;
    l.T_ownkf_teammatekf = {1.0 + 0.1 * k, -0.5, 0.2};
    l.overlap = 0.9;
    s.loops.push_back(l);
  }
  return s;
}

// Teammate keyframe position in the own map frame through a loop.
std::pair<double, double> InMap(const Pose2& T_map_k, const Pose2& T_k_t) {
  const double c = std::cos(T_map_k.yaw_rad), s = std::sin(T_map_k.yaw_rad);
  return {T_map_k.x_m + c * T_k_t.x_m - s * T_k_t.y_m, T_map_k.y_m + s * T_k_t.x_m + c * T_k_t.y_m};
}

const InterRobotLoop& Original(const Stream& s, const InterRobotLoop& w) {
  for (const auto& l : s.loops) {
    if (l.own_keyframe == w.own_keyframe && l.teammate_robot == w.teammate_robot &&
        l.teammate_keyframe == w.teammate_keyframe)
      return l;
  }
  throw std::runtime_error("no original");
}

}  // namespace

TEST(Outliers, CountFollowsTheFraction) {
  const auto s = MakeStream();  // 20 candidates
  for (const auto kind : {fe::OutlierKind::kRandom, fe::OutlierKind::kCorrelated}) {
    fe::OutlierOptions o;
    o.kind = kind;
    o.fraction = 0.6;  // 30 wrong against 20
    const auto w = fe::InjectOutliers(s.loops, s.own, o, 100);
    ASSERT_EQ(w.size(), 30u);
    for (std::size_t i = 0; i < w.size(); ++i) EXPECT_EQ(w[i].id, 100 + i);
    o.fraction = 0.9;
    EXPECT_EQ(fe::InjectOutliers(s.loops, s.own, o, 0).size(), 180u);
    o.fraction = 0.0;
    EXPECT_TRUE(fe::InjectOutliers(s.loops, s.own, o, 0).empty());
  }
}

TEST(Outliers, RandomLoopsAreWrongByTheStatedAmount) {
  const auto s = MakeStream();
  fe::OutlierOptions o;
  o.fraction = 0.5;
  const auto w = fe::InjectOutliers(s.loops, s.own, o, 0);
  ASSERT_EQ(w.size(), 20u);
  for (const auto& l : w) {
    const auto& t = Original(s, l);
    const auto a = InMap(s.own[l.own_keyframe], t.T_ownkf_teammatekf);
    const auto b = InMap(s.own[l.own_keyframe], l.T_ownkf_teammatekf);
    const double d = std::hypot(a.first - b.first, a.second - b.second);
    EXPECT_GE(d, 2.0 - 1e-9);
    EXPECT_LE(d, 10.0 + 1e-9);
    EXPECT_LE(std::abs(std::remainder(l.T_ownkf_teammatekf.yaw_rad - t.T_ownkf_teammatekf.yaw_rad,
                                      2 * std::numbers::pi)),
              0.5236 + 1e-9);
    EXPECT_EQ(l.overlap, t.overlap);
  }
}

TEST(Outliers, CorrelatedGroupsShareOneMapOffset) {
  const auto s = MakeStream();
  fe::OutlierOptions o;
  o.kind = fe::OutlierKind::kCorrelated;
  o.fraction = 0.6;
  o.directions = 4;
  const auto w = fe::InjectOutliers(s.loops, s.own, o, 0);
  ASSERT_EQ(w.size(), 30u);
  // Consecutive emitted loops of one group: same teammate, same offset in the own map frame,
  // of length 2.4 m along +-x or +-y, whatever the own keyframe's heading.
  std::set<std::pair<long, long>> offsets;
  for (const auto& l : w) {
    const auto& t = Original(s, l);
    const auto a = InMap(s.own[l.own_keyframe], t.T_ownkf_teammatekf);
    const auto b = InMap(s.own[l.own_keyframe], l.T_ownkf_teammatekf);
    const double dx = b.first - a.first, dy = b.second - a.second;
    EXPECT_NEAR(std::hypot(dx, dy), 2.4, 1e-9);
    EXPECT_TRUE(std::abs(dx) < 1e-9 || std::abs(dy) < 1e-9) << dx << " " << dy;
    EXPECT_DOUBLE_EQ(l.T_ownkf_teammatekf.yaw_rad, t.T_ownkf_teammatekf.yaw_rad);
    offsets.insert({std::lround(dx * 10), std::lround(dy * 10)});
  }
  EXPECT_GE(offsets.size(), 2u);  // several groups, not one offset for all
  EXPECT_LE(offsets.size(), 4u);
  // A group is a run over one teammate's consecutive candidates with one offset.
  int runs = 1;
  for (std::size_t i = 1; i < w.size(); ++i) {
    const bool same_group = w[i].teammate_robot == w[i - 1].teammate_robot &&
                            w[i].own_keyframe == w[i - 1].own_keyframe + 2;
    runs += !same_group;
  }
  EXPECT_LE(runs, 30 / 2);  // groups of up to 6 (shorter only at the end of a teammate's run)
}

TEST(Outliers, DeterministicForASeed) {
  const auto s = MakeStream();
  fe::OutlierOptions o;
  o.kind = fe::OutlierKind::kCorrelated;
  o.fraction = 0.3;
  const auto a = fe::InjectOutliers(s.loops, s.own, o, 0);
  const auto b = fe::InjectOutliers(s.loops, s.own, o, 0);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].own_keyframe, b[i].own_keyframe);
    EXPECT_EQ(a[i].T_ownkf_teammatekf.x_m, b[i].T_ownkf_teammatekf.x_m);
  }
  o.seed = 2;
  const auto c = fe::InjectOutliers(s.loops, s.own, o, 0);
  bool differs = false;
  for (std::size_t i = 0; i < a.size() && i < c.size(); ++i)
    differs |= a[i].T_ownkf_teammatekf.x_m != c[i].T_ownkf_teammatekf.x_m;
  EXPECT_TRUE(differs);
}

TEST(Outliers, BadInputIsAnError) {
  auto s = MakeStream();
  fe::OutlierOptions o;
  o.fraction = 1.0;
  EXPECT_THROW(fe::InjectOutliers(s.loops, s.own, o, 0), std::invalid_argument);
  o.fraction = 0.3;
  s.loops[3].own_keyframe = 99;
  EXPECT_THROW(fe::InjectOutliers(s.loops, s.own, o, 0), std::invalid_argument);
}
