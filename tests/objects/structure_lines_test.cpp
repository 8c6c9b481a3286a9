// Structure-line matching: long objects matched by their axes (structure_lines.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "draco/objects/graph_matcher.hpp"
#include "draco/objects/structure_lines.hpp"

namespace draco::objects {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

msgs::Object Line(std::uint32_t id, double x0, double y0, double x1, double y1, double breadth) {
  msgs::Object o;
  o.id = id;
  o.rect_center = {0.5 * (x0 + x1), 0.5 * (y0 + y1)};
  o.center = o.rect_center;
  o.length_m = std::hypot(x1 - x0, y1 - y0);
  o.breadth_m = breadth;
  double yaw = std::atan2(y1 - y0, x1 - x0);
  if (yaw < 0) yaw += std::numbers::pi;
  if (yaw >= std::numbers::pi) yaw -= std::numbers::pi;
  o.yaw_rad = yaw;
  o.num_points = 100;
  return o;
}

msgs::Object Compact(std::uint32_t id, double x, double y, double size) {
  msgs::Object o;
  o.id = id;
  o.center = o.rect_center = {x, y};
  o.length_m = size;
  o.breadth_m = 0.5 * size;
  o.num_points = 30;
  return o;
}

// Objects of map a moved into a frame b: p_b = T_b_a * p_a.
msgs::Object Moved(const msgs::Object& o, const Pose2& T_b_a) {
  msgs::Object m = o;
  m.center = Transform(T_b_a, o.center);
  m.rect_center = Transform(T_b_a, o.rect_center);
  double yaw = std::fmod(o.yaw_rad + T_b_a.yaw_rad, std::numbers::pi);
  if (yaw < 0) yaw += std::numbers::pi;
  m.yaw_rad = yaw;
  return m;
}

Pose2 Inverse(const Pose2& T) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {-(c * T.x_m + s * T.y_m), s * T.x_m - c * T.y_m, -T.yaw_rad};
}

TEST(StructureLines, CornersOfTwoPiers) {
  msgs::ObjectMap m;
  m.objects = {Line(0, 0, 0, 30, 0, 1.0), Line(1, 35, 5, 35, 40, 1.0), Compact(2, 10, 10, 1.0),
               Line(3, 0, 3, 30, 3, 1.0)};  // parallel to 0: no corner with it
  StructureLineOptions o;
  const auto lines = ExtractLines(m, o);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(CompactObjects(m, o), std::vector<int>{2});
  const auto corners = Corners(lines, o);
  // 0 x 1 and 3 x 1 (0 and 3 are parallel); 1's axis meets y = 0 at (35, 0), 5 m beyond its end.
  ASSERT_EQ(corners.size(), 2u);
  bool found = false;
  for (const auto& c : corners) {
    if (std::abs(c.point.y_m) < 1e-9) {
      found = true;
      EXPECT_NEAR(c.point.x_m, 35.0, 1e-9);
      EXPECT_NEAR(std::min(c.angle_rad, std::numbers::pi - c.angle_rad), std::numbers::pi / 2,
                  1e-9);
    }
  }
  EXPECT_TRUE(found);
  o.max_reach_m = 4.0;  // both corners lie 5 m beyond line 0's / 3's end
  EXPECT_EQ(Corners(lines, o).size(), 0u);
}

// Two robots see different parts of the same piers (centres far apart), plus compact objects:
// the spectral path cannot match the centres, the line path recovers T_a_b.
TEST(StructureLines, RecoversTransformFromPartialViewsOfPiers) {
  // World = frame a. Piers: an L (0,0)-(60,0) and (60,0)-(60,50), a diagonal dock, piles.
  msgs::ObjectMap a, b;
  a.robot_id = 0;
  b.robot_id = 1;
  a.objects = {Line(0, 0, 0, 52, 0, 1.2), Line(1, 60, 5, 60, 22, 1.0), Line(2, 10, 20, 30, 31, 1.5),
               Compact(3, 40, 10, 1.0),   Compact(4, 45, 15, 0.8),     Compact(5, 20, 8, 1.5)};
  const Pose2 T_a_b{12.0, -7.0, 40.0 * kDeg};
  const Pose2 T_b_a = Inverse(T_a_b);
  // b sees other parts of the same piers and two of the compact objects, plus its own clutter.
  std::vector<msgs::Object> b_world = {
      Line(10, 30, 0.3, 55, 0.3, 1.0),   Line(11, 59.8, 8, 59.8, 45, 1.0),
      Line(12, 22, 26.6, 38, 35.4, 1.2), Compact(13, 40.5, 10.3, 1.1),
      Compact(14, 45.2, 14.6, 0.9),      Compact(15, 70, 70, 1.0)};
  for (const auto& o : b_world) b.objects.push_back(Moved(o, T_b_a));

  MatcherOptions opt;
  const auto spectral = MatchObjectMaps(a, b, opt);
  EXPECT_NE(spectral.status, msgs::MatchStatus::kMatched);

  opt.structure_lines = true;
  const auto lm = MatchStructureLines(a, b, opt.lines);
  EXPECT_TRUE(lm.found);
  EXPECT_GE(lm.best.support, 5) << lm.num_corners_a << " " << lm.num_corners_b << " "
                                << lm.num_hypotheses << " runner-up " << lm.runner_up_support;
  const auto m = MatchObjectMaps(a, b, opt);
  ASSERT_EQ(m.status, msgs::MatchStatus::kMatched) << msgs::MatchStatusName(m.status);
  EXPECT_TRUE(m.by_lines);
  EXPECT_NEAR(m.T_a_b.x_m, T_a_b.x_m, 0.5);
  EXPECT_NEAR(m.T_a_b.y_m, T_a_b.y_m, 0.5);
  EXPECT_NEAR(m.T_a_b.yaw_rad, T_a_b.yaw_rad, 1.0 * kDeg);
  EXPECT_EQ(m.num_line_pairs, 3);
  EXPECT_EQ(m.num_inliers, 5);
  for (const auto& p : m.pairs) EXPECT_EQ(p.id_b, p.id_a + 10);
}

// A square grid of identical perpendicular piers has many corners of the same angle: with
// nothing else to break the tie the answer is ambiguous, and the ambiguity test refuses it.
TEST(StructureLines, SymmetricLayoutIsAmbiguous) {
  msgs::ObjectMap a, b;
  for (int i = 0; i < 4; ++i) {
    a.objects.push_back(Line(i, 0, 20.0 * i, 15, 20.0 * i, 1.0));
    a.objects.push_back(Line(10 + i, 20.0 * i, 20, 20.0 * i, 35, 1.0));
  }
  const Pose2 T_a_b{3.0, 4.0, 0.3};
  for (const auto& o : a.objects) b.objects.push_back(Moved(o, Inverse(T_a_b)));
  MatcherOptions opt;
  opt.structure_lines = true;
  opt.max_line_ambiguity = 0.8;
  const auto lines = MatchStructureLines(a, b, opt.lines);
  ASSERT_TRUE(lines.found);
  EXPECT_GT(lines.runner_up_support, 2);
}

TEST(StructureLines, RefineRecoversSmallOffsetExactly) {
  msgs::ObjectMap a, b;
  a.objects = {Line(0, 0, 0, 30, 0, 1.0), Line(1, 0, 5, 0, 30, 1.0), Compact(2, 10, 10, 1.0)};
  const Pose2 T_a_b{2.0, 1.0, 0.2};
  for (const auto& o : a.objects) b.objects.push_back(Moved(o, Inverse(T_a_b)));
  std::vector<SupportPair> pairs = {{0, 0, true, 0.0}, {1, 1, true, 0.0}, {2, 2, false, 0.0}};
  const Pose2 T = RefineStructure(a, b, pairs, {2.3, 0.6, 0.23});
  EXPECT_NEAR(T.x_m, 2.0, 1e-6);
  EXPECT_NEAR(T.y_m, 1.0, 1e-6);
  EXPECT_NEAR(T.yaw_rad, 0.2, 1e-8);
}

// Unrelated maps of random segments and points: the line path must not invent matches.
TEST(StructureLines, UnrelatedMapsRarelyMatch) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 100.0), ang(0.0, std::numbers::pi), len(6.0, 30.0);
  int matched = 0;
  for (int trial = 0; trial < 50; ++trial) {
    msgs::ObjectMap a, b;
    for (auto* m : {&a, &b}) {
      for (int i = 0; i < 6; ++i) {
        const double x = u(rng), y = u(rng), t = ang(rng), l = len(rng);
        m->objects.push_back(Line(i, x, y, x + l * std::cos(t), y + l * std::sin(t), 1.0));
      }
      for (int i = 0; i < 8; ++i) m->objects.push_back(Compact(10 + i, u(rng), u(rng), 1.0));
    }
    MatcherOptions opt;
    opt.structure_lines = true;
    matched += MatchObjectMaps(a, b, opt).status == msgs::MatchStatus::kMatched;
  }
  EXPECT_LE(matched, 2);
}

}  // namespace
}  // namespace draco::objects
