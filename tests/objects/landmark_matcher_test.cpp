#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "draco/objects/geometry.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "draco/objects/landmark_matcher.hpp"

namespace draco::objects {
namespace {

using msgs::Point2;
using msgs::Pose2;

Point2 Apply(const Pose2& T, const Point2& p) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {c * p.x_m - s * p.y_m + T.x_m, s * p.x_m + c * p.y_m + T.y_m};
}

Pose2 Inverse(const Pose2& T) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {-(c * T.x_m + s * T.y_m), -(-s * T.x_m + c * T.y_m), -T.yaw_rad};
}

// World: 24 scattered objects in 80 x 60 m. Robot a holds 16 of them, robot b 14, 9 shared,
// each in its own map frame (b's frame = T_a_b^-1 applied), with 0.3 m noise.
struct TwoMaps {
  std::vector<Point2> a, b;
  Pose2 T_a_b{12.0, -7.0, 2.2};
};

TwoMaps MakeMaps(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(0.0, 80.0), uy(0.0, 60.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::vector<Point2> world;
  while (world.size() < 24) {
    const Point2 p{ux(rng), uy(rng)};
    bool far = true;
    for (const auto& q : world) far = far && std::hypot(p.x_m - q.x_m, p.y_m - q.y_m) > 4.0;
    if (far) world.push_back(p);
  }
  TwoMaps m;
  const Pose2 T_b_a = Inverse(m.T_a_b);
  for (int i = 0; i < 16; ++i)
    m.a.push_back({world[i].x_m + noise(rng), world[i].y_m + noise(rng)});
  for (int i = 7; i < 21; ++i) {
    const Point2 p = Apply(T_b_a, world[i]);
    m.b.push_back({p.x_m + noise(rng), p.y_m + noise(rng)});
  }
  return m;
}

// Where T places b's centroid against where the true transform does.
double PlacementError(const Pose2& T, const TwoMaps& m) {
  Point2 c{0.0, 0.0};
  for (const auto& p : m.b)
    c.x_m += p.x_m / double(m.b.size()), c.y_m += p.y_m / double(m.b.size());
  const Point2 p = Apply(T, c), q = Apply(m.T_a_b, c);
  return std::hypot(p.x_m - q.x_m, p.y_m - q.y_m);
}

TEST(LandmarkMatcher, RecoversTheTransformFromSharedPoints) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const TwoMaps m = MakeMaps(seed);
    const LandmarkMatchResult r = MatchLandmarkPoints(m.a, m.b);
    ASSERT_TRUE(r.found);
    // 9 shared; with 0.3 m noise per map a true pair can miss the 1 m tolerance.
    EXPECT_GE(r.support, 8) << "seed " << seed;
    EXPECT_LE(r.support, 9) << "seed " << seed;
    EXPECT_LT(PlacementError(r.T_a_b, m), 0.5) << "seed " << seed;
    EXPECT_NEAR(std::remainder(r.T_a_b.yaw_rad - m.T_a_b.yaw_rad, 2 * std::numbers::pi), 0.0, 0.03);
    EXPECT_LT(r.runner_up_support, 5);
    EXPECT_LT(r.rmse_m, 0.9);  // sqrt(2) x sqrt(2) x 0.3 m expected
    // Each pair joins a's object i with b's object i - 7 + ... : the same world object.
    for (const auto& [i, k] : r.pairs) EXPECT_EQ(i, k + 7);
  }
}

TEST(LandmarkMatcher, TheHeadingsRuleOutATurnedTwin) {
  // A scene with a half-turn symmetry: 7 scattered points and their copies turned by 180 deg
  // about the origin. Map b is the scene seen from a frame shifted and turned by 0.3 rad: the
  // true transform and the true one turned by 180 deg explain every point alike.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(4.0, 30.0), sign(-1.0, 1.0);
  std::vector<Point2> half;
  while (half.size() < 7) {
    const Point2 p{u(rng), sign(rng) * u(rng)};
    bool far = true;
    for (const auto& q : half) {
      far = far && std::hypot(p.x_m - q.x_m, p.y_m - q.y_m) > 4.0 &&
            std::hypot(p.x_m + q.x_m, p.y_m + q.y_m) > 4.0;
    }
    if (far) half.push_back(p);
  }
  std::vector<Point2> a;
  for (const auto& p : half) a.push_back(p), a.push_back({-p.x_m, -p.y_m});
  const Pose2 T_a_b{6.0, -3.0, 0.3};
  std::vector<Point2> b;
  for (const auto& p : a) b.push_back(Apply(Inverse(T_a_b), p));

  const LandmarkMatchResult blind = MatchLandmarkPoints(a, b);
  ASSERT_TRUE(blind.found);
  EXPECT_EQ(blind.support, 14);
  EXPECT_EQ(blind.runner_up_support, 14);  // the turned twin: as good, so ambiguous

  LandmarkMatchOptions o;
  o.yaw_prior_rad = 0.3 + 0.1;  // the compasses' difference, 0.1 rad off
  o.max_yaw_gap_rad = 0.5236;   // 30 deg
  const LandmarkMatchResult headed = MatchLandmarkPoints(a, b, o);
  ASSERT_TRUE(headed.found);
  EXPECT_EQ(headed.support, 14);
  EXPECT_LT(headed.runner_up_support, 7);
  EXPECT_NEAR(headed.T_a_b.yaw_rad, 0.3, 1e-6);
  EXPECT_NEAR(headed.T_a_b.x_m, 6.0, 1e-6);
  EXPECT_NEAR(headed.T_a_b.y_m, -3.0, 1e-6);
  EXPECT_LT(headed.hypotheses, blind.hypotheses / 3);  // turned hypotheses are not scored
}

TEST(LandmarkMatcher, RowOfEquallySpacedPilesIsAmbiguous) {
  // A row of piles 5 m apart: every shift by one spacing explains all but one pile.
  std::vector<Point2> a, b;
  for (int i = 0; i < 10; ++i) a.push_back({5.0 * i, 0.0});
  for (int i = 0; i < 8; ++i) b.push_back({5.0 * i + 0.1, 0.05});
  const LandmarkMatchResult r = MatchLandmarkPoints(a, b);
  ASSERT_TRUE(r.found);
  EXPECT_EQ(r.support, 8);
  EXPECT_GE(r.runner_up_support, 7);
  // Through the object matcher the ambiguity test refuses the landmark answer.
  msgs::ObjectMap ma, mb;
  for (std::size_t i = 0; i < a.size(); ++i) {
    msgs::Object o;
    o.id = std::uint32_t(i), o.center = o.rect_center = a[i], o.landmark = true;
    ma.objects.push_back(o);
  }
  for (std::size_t i = 0; i < b.size(); ++i) {
    msgs::Object o;
    o.id = std::uint32_t(i), o.center = o.rect_center = b[i], o.landmark = true;
    mb.objects.push_back(o);
  }
  MatcherOptions options;
  options.landmarks = true;
  const msgs::ObjectMatch match = MatchObjectMaps(ma, mb, options);
  // Reported as the landmarks' refusal (not the clusters' "too few objects": there are none).
  EXPECT_TRUE(match.by_landmarks);
  EXPECT_EQ(match.status, msgs::MatchStatus::kAmbiguous);
  EXPECT_EQ(match.num_inliers, 8);
  EXPECT_GE(match.ambiguity, 7.0 / 8.0);
  // Fewer landmarks than an answer needs (min_landmark_support 5): too few objects, as before.
  ma.objects.resize(4);
  EXPECT_EQ(MatchObjectMaps(ma, mb, options).status, msgs::MatchStatus::kTooFewObjects);
}

TEST(LandmarkMatcher, ObjectMatcherAnswersByLandmarksAndKeepsIds) {
  const TwoMaps m = MakeMaps(3);
  msgs::ObjectMap ma, mb;
  for (std::size_t i = 0; i < m.a.size(); ++i) {
    msgs::Object o;
    o.id = std::uint32_t(100 + i), o.center = o.rect_center = m.a[i], o.landmark = true;
    o.length_m = o.breadth_m = 1.5;
    ma.objects.push_back(o);
  }
  for (std::size_t i = 0; i < m.b.size(); ++i) {
    msgs::Object o;
    o.id = std::uint32_t(200 + i), o.center = o.rect_center = m.b[i], o.landmark = true;
    o.length_m = o.breadth_m = 1.5;
    mb.objects.push_back(o);
  }
  MatcherOptions options;
  options.landmarks = false;
  const msgs::ObjectMatch off = MatchObjectMaps(ma, mb, options);
  EXPECT_FALSE(off.by_landmarks);  // landmarks off: they are left out of the cluster path
  EXPECT_NE(off.status, msgs::MatchStatus::kMatched);
  options.landmarks = true;
  const msgs::ObjectMatch on = MatchObjectMaps(ma, mb, options);
  ASSERT_EQ(on.status, msgs::MatchStatus::kMatched);
  EXPECT_TRUE(on.by_landmarks);
  EXPECT_GE(on.num_inliers, 8);
  EXPECT_LT(PlacementError(on.T_a_b, m), 0.5);
  for (const auto& p : on.pairs) EXPECT_EQ(p.id_a - 100, p.id_b - 200 + 7);
}

}  // namespace
}  // namespace draco::objects
