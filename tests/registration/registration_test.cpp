// Inter-robot registration: SE(2) helpers, window bounds (symmetric and the reference's),
// window target geometry, recovery of a known relative pose from a perturbed seed,
// rejections, covariance models, and scan-request selection on hand-built maps.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "draco/registration/registration.hpp"
#include "synthetic.hpp"

namespace draco::registration {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

TEST(Se2, ComposeInverse) {
  const Pose2 T{3.0, -2.0, 2.5};
  const Pose2 I = Compose(Inverse(T), T);
  EXPECT_NEAR(I.x_m, 0.0, 1e-12);
  EXPECT_NEAR(I.y_m, 0.0, 1e-12);
  EXPECT_NEAR(I.yaw_rad, 0.0, 1e-12);
  // (1, 0) rotated by 90 deg and moved by (1, 1): (1, 2).
  const Point2 p = Apply(Pose2{1.0, 1.0, std::numbers::pi / 2}, Point2{1.0, 0.0});
  EXPECT_NEAR(p.x_m, 1.0, 1e-12);
  EXPECT_NEAR(p.y_m, 2.0, 1e-12);
  EXPECT_NEAR(WrapAngle(3 * std::numbers::pi), std::numbers::pi, 1e-12);
}

TEST(Window, SymmetricAndReference) {
  EXPECT_EQ(WindowPositions(10, 5, 3, false), (std::vector<int>{2, 3, 4, 5, 6, 7, 8}));
  EXPECT_EQ(WindowPositions(10, 5, 3, true), (std::vector<int>{2, 3, 4, 5, 6, 7, 5}));
  EXPECT_EQ(WindowPositions(10, 5, 1, false), (std::vector<int>{4, 5, 6}));
  EXPECT_EQ(WindowPositions(10, 5, 0, false), (std::vector<int>{5}));
  EXPECT_EQ(WindowPositions(10, 5, 0, true), (std::vector<int>{5}));
  EXPECT_EQ(WindowPositions(10, 0, 3, false), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(WindowPositions(10, 9, 1, false), (std::vector<int>{8, 9}));
  EXPECT_TRUE(WindowPositions(10, 10, 1, false).empty());
}

TEST(Window, TargetInKeyframeFrame) {
  // Keyframe 0 at the origin sees (1, 0); keyframe 1 at (2, 0) facing +y sees (1, 0), i.e.
  // (2, 1) in the map. In keyframe 1's frame: (-2, 0)... rotate: map (1,0) -> (1, 1);
  // map (2, 1) -> (1, 0).
  std::vector<KeyframeScan> kfs{{0, 0.0, {0, 0, 0}, {{1.0, 0.0}}},
                                {1, 1.0, {2.0, 0.0, std::numbers::pi / 2}, {{1.0, 0.0}}}};
  int n = 0;
  const auto cloud = BuildWindowTarget(kfs, 1, 1, false, &n);
  ASSERT_EQ(n, 2);
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_NEAR(cloud[0].x(), 0.0, 1e-12);  // map (1, 0) from (2, 0) facing +y: (0, 1)
  EXPECT_NEAR(cloud[0].y(), 1.0, 1e-12);
  EXPECT_NEAR(cloud[1].x(), 1.0, 1e-12);
  EXPECT_NEAR(cloud[1].y(), 0.0, 1e-12);
}

struct Scene {
  std::vector<Point2> world = synthetic::World(7);
  Pose2 T_world_own{5.0, -3.0, 0.3};
  Pose2 T_world_team{-7.0, 2.0, -0.8};
  std::vector<KeyframeScan> own = synthetic::Survey(world, {-20.0, 0.0, 0.0}, 21, T_world_own);
  std::vector<KeyframeScan> team =
      synthetic::Survey(world, {-6.0, -4.0, 10.0 * kDeg}, 10, T_world_team);
  // Truth: own keyframe 10 (world (0, 0, 0)) and teammate keyframe 3.
  Pose2 Truth(int own_k, int team_j) const {
    return Between(Compose(T_world_own, own[own_k].T_map_kf),
                   Compose(T_world_team, team[team_j].T_map_kf));
  }
};

void ExpectNear(const Pose2& a, const Pose2& b, double m, double rad) {
  EXPECT_NEAR(a.x_m, b.x_m, m);
  EXPECT_NEAR(a.y_m, b.y_m, m);
  EXPECT_NEAR(WrapAngle(a.yaw_rad - b.yaw_rad), 0.0, rad);
}

TEST(Register, RecoversKnownPoseFromPerturbedSeed) {
  const Scene s;
  const Pose2 truth = s.Truth(10, 3);
  const Pose2 seed = Compose(truth, Pose2{0.8, -0.5, 4.0 * kDeg});
  for (const int w : {0, 1, 3}) {
    RegistrationOptions o;
    o.window = w;
    o.min_overlap = 0.6;  // one scan sees a different part of the field of view
    const auto r = RegisterScan(s.own, 10, s.team[3].points_kf, seed, o, 1, 2, 3);
    ASSERT_TRUE(r.accepted()) << RegistrationStatusName(r.status) << " w=" << w << " overlap "
                              << r.loop.overlap;
    EXPECT_EQ(r.target_keyframes, 2 * w + 1);
    ExpectNear(r.loop.T_ownkf_teammatekf, truth, 0.02, 0.2 * kDeg);
    if (w == 3) {
      EXPECT_GE(r.loop.overlap, 0.85);
    }
    EXPECT_EQ(r.loop.own_robot, 1);
    EXPECT_EQ(r.loop.own_keyframe, 10);
    EXPECT_EQ(r.loop.teammate_robot, 2);
    EXPECT_EQ(r.loop.teammate_keyframe, 3);
    // Floored ICP covariance: at least the floors on the diagonal, symmetric.
    EXPECT_GE(r.loop.covariance[0], 0.01 - 1e-12);
    EXPECT_GE(r.loop.covariance[4], 0.01 - 1e-12);
    EXPECT_GE(r.loop.covariance[8], 1e-4 - 1e-12);
    EXPECT_DOUBLE_EQ(r.loop.covariance[1], r.loop.covariance[3]);
  }
}

TEST(Register, SeedFromMapTransform) {
  // The seed composed from the graph-matching transform (here exact) is the truth.
  const Scene s;
  const Pose2 T_own_team = Between(s.T_world_own, s.T_world_team);
  const Pose2 seed = SeedPose(s.own[10].T_map_kf, T_own_team, s.team[3].T_map_kf);
  ExpectNear(seed, s.Truth(10, 3), 1e-9, 1e-9);
}

TEST(Register, WindowWidensOverlap) {
  // Teammate keyframe 3 (world (-6 + 6 cos 10deg, ...)) registered against own keyframe 13
  // (world (6, 0)): more of its points fall inside the window-3 target than in one scan.
  const Scene s;
  const Pose2 truth = s.Truth(13, 3);
  RegistrationOptions o;
  o.min_overlap = 0.0;
  o.window = 0;
  const auto r0 = RegisterScan(s.own, 13, s.team[3].points_kf, truth, o);
  o.window = 3;
  const auto r3 = RegisterScan(s.own, 13, s.team[3].points_kf, truth, o);
  EXPECT_GE(r3.loop.overlap, r0.loop.overlap);
  EXPECT_GT(r3.target_points, r0.target_points);
}

TEST(Register, Rejections) {
  const Scene s;
  RegistrationOptions o;
  // Too few source points.
  std::vector<Point2> few(s.team[3].points_kf.begin(), s.team[3].points_kf.begin() + 10);
  EXPECT_EQ(RegisterScan(s.own, 10, few, s.Truth(10, 3), o).status,
            RegistrationStatus::kTooFewSourcePoints);
  // A scan of an unrelated world: low overlap.
  const auto other = synthetic::World(99);
  const auto foreign = synthetic::See(other, {0, 0, 0});
  ASSERT_GE(foreign.size(), 30u);
  const auto r = RegisterScan(s.own, 10, foreign, Pose2{}, o);
  EXPECT_FALSE(r.accepted());
  // Correction gate.
  o.max_correction_m = 0.3;
  const Pose2 seed = Compose(s.Truth(10, 3), Pose2{0.8, -0.5, 0.0});
  EXPECT_EQ(RegisterScan(s.own, 10, s.team[3].points_kf, seed, o).status,
            RegistrationStatus::kLargeCorrection);
}

// A row of identical piles longer than the scans: the answer and the answer one spacing along
// fit equally well, so the ambiguity test rejects; the same scans with a distinctive object
// beside the row pass it. Without the test both are accepted.
std::vector<Point2> PileRow(double spacing_m, int piles, bool with_block) {
  std::vector<Point2> pts;
  for (int i = 0; i < piles; ++i) {
    for (int k = 0; k < 8; ++k) {  // a 0.3 m pile's face, as sonar points
      const double a = 2.0 * std::numbers::pi * k / 8.0;
      pts.push_back({i * spacing_m + 0.15 * std::cos(a), 6.0 + 0.15 * std::sin(a)});
    }
  }
  if (with_block) {  // a 4 m x 1 m block beside the row, off-period
    for (int i = 0; i <= 40; ++i) pts.push_back({3.3 + 0.1 * i, 9.0});
    for (int i = 0; i <= 10; ++i) pts.push_back({3.3, 9.0 + 0.1 * i});
  }
  return pts;
}

TEST(Register, AmbiguityTestRejectsAPeriodicRow) {
  for (const bool with_block : {false, true}) {
    SCOPED_TRACE(with_block ? "row and block" : "row only");
    // Own window: piles at x = -30 .. 30 (the whole row); teammate scan: x = -9 .. 9 and the
    // block, seen from 1.7 m further along x, so the true pose is x = +1.7 (not a multiple of
    // the spacing, whatever the row shows).
    std::vector<Point2> target;
    for (const auto& p : PileRow(3.0, 21, false)) target.push_back({p.x_m - 30.0, p.y_m});
    if (with_block) {
      for (const auto& p : PileRow(3.0, 0, true)) target.push_back(p);
    }
    std::vector<Point2> source;
    for (const auto& p : target) {
      if (std::abs(p.x_m) <= 9.5) source.push_back({p.x_m - 1.7, p.y_m});
    }
    std::vector<KeyframeScan> own{{0, 0.0, {0.0, 0.0, 0.0}, target}};
    const Pose2 truth{1.7, 0.0, 0.0};
    const Pose2 seed{2.1, 0.3, 0.02};
    RegistrationOptions off;
    off.ambiguity_offsets_m.clear();
    off.ambiguity_turns_deg.clear();
    const auto plain = RegisterScan(own, 0, source, seed, off);
    ASSERT_TRUE(plain.accepted()) << RegistrationStatusName(plain.status);
    ExpectNear(plain.loop.T_ownkf_teammatekf, truth, 0.05, 0.01);
    const auto tested = RegisterScan(own, 0, source, seed, RegistrationOptions{});
    if (with_block) {
      EXPECT_TRUE(tested.accepted())
          << RegistrationStatusName(tested.status) << " runner-up " << tested.runner_up_overlap;
      EXPECT_LT(tested.runner_up_overlap, 0.9 * tested.loop.overlap);
    } else {
      EXPECT_EQ(tested.status, RegistrationStatus::kAmbiguous);
      // Shifts alone: the runner-up is the row moved by a whole number of spacings.
      RegistrationOptions shifts;
      shifts.ambiguity_turns_deg.clear();
      const auto shifted = RegisterScan(own, 0, source, seed, shifts);
      EXPECT_EQ(shifted.status, RegistrationStatus::kAmbiguous);
      const double shift = shifted.runner_up_T.x_m - shifted.loop.T_ownkf_teammatekf.x_m;
      EXPECT_NEAR(std::remainder(shift, 3.0), 0.0, 0.1) << shift;
      EXPECT_GE(std::abs(shift), 2.9);
      EXPECT_NEAR(WrapAngle(shifted.runner_up_T.yaw_rad - shifted.loop.T_ownkf_teammatekf.yaw_rad),
                  0.0, 0.02);
      // Turns alone: one straight row is the same turned by 180 deg.
      RegistrationOptions turns;
      turns.ambiguity_offsets_m.clear();
      const auto turned = RegisterScan(own, 0, source, seed, turns);
      EXPECT_EQ(turned.status, RegistrationStatus::kAmbiguous);
      EXPECT_NEAR(
          std::abs(WrapAngle(turned.runner_up_T.yaw_rad - turned.loop.T_ownkf_teammatekf.yaw_rad)),
          std::numbers::pi, 0.05);
    }
  }
}

TEST(Covariance, Models) {
  icp::IcpResult r;
  r.rmse_m = 0.2;
  r.T_target_source = {0, 0, std::numbers::pi / 2};
  r.covariance = {0.04, 0, 0, 0, 0.0001, 0, 0, 0, 1e-6};
  RegistrationOptions o;
  o.covariance = CovarianceModel::kReferenceResidual;
  auto c = LoopCovariance(r, o);
  EXPECT_NEAR(c[0], 20 * 0.04, 1e-12);
  EXPECT_NEAR(c[4], 20 * 0.04, 1e-12);
  EXPECT_NEAR(c[8], 20 * 0.04, 1e-12);
  EXPECT_EQ(c[1], 0.0);
  o.covariance = CovarianceModel::kIcpFloored;
  c = LoopCovariance(r, o);
  // Rotated by 90 deg: the source-frame x variance 0.04 becomes the y variance.
  EXPECT_NEAR(c[0], 0.01, 1e-12);  // floored 0.0001 -> 0.1^2
  EXPECT_NEAR(c[4], 0.04, 1e-12);
  EXPECT_NEAR(c[8], 1e-4, 1e-12);  // floored
}

TEST(Select, RequestsMatchedKeyframes) {
  msgs::ObjectMap team;
  // Object 1 seen by keyframes 0, 1, 2; object 2 by 2, 3; object 3 (unmatched) by 4.
  team.objects = {{.id = 1, .keyframes = {0, 1, 2}},
                  {.id = 2, .keyframes = {2, 3, 3}},
                  {.id = 3, .keyframes = {4}}};
  msgs::ObjectMatch match;
  match.status = msgs::MatchStatus::kMatched;
  match.T_a_b = {100.0, 0.0, std::numbers::pi / 2};
  match.pairs = {{.id_a = 10, .id_b = 1}, {.id_a = 11, .id_b = 2}};
  std::vector<KeyframeInfo> team_kfs;
  for (int i = 0; i < 5; ++i) team_kfs.push_back({i, {2.0 * i, 0.0, 0.0}, i == 1 ? 20 : 100});
  // Teammate keyframe i lands at own (100, 2 i) heading 90 deg.
  std::vector<KeyframeInfo> own_kfs{{0, {100.0, 0.0, 0.0}, 100},     // 0 m, 90 deg off
                                    {1, {100.0, 5.0, 1.5}, 100},     // near 2, 3
                                    {2, {100.0, 100.0, 1.5}, 100}};  // far
  SelectionOptions o;
  o.max_candidates_per_request = 0;
  auto req = SelectScanRequests({}, team, match, own_kfs, team_kfs, o);
  // Keyframe 2 sees both matched objects, then 3 and 0 (1 has 20 points, 4 no match).
  ASSERT_EQ(req.size(), 3u);
  EXPECT_EQ(req[0].teammate_keyframe, 2);
  EXPECT_EQ(req[0].matched_objects, 2);
  EXPECT_EQ(req[1].teammate_keyframe, 3);
  EXPECT_EQ(req[2].teammate_keyframe, 0);
  ExpectNear(req[0].T_own_teammatekf, Pose2{100.0, 4.0, std::numbers::pi / 2}, 1e-9, 1e-9);
  EXPECT_EQ(req[0].candidates, (std::vector<int>{1, 0}));  // 1 m, then 4 m
  EXPECT_NEAR(req[0].distances_m[0], 1.0, 1e-9);
  // Heading limit 60 deg drops own keyframe 0 (90 deg off).
  o.candidate_max_yaw_rad = 60.0 * kDeg;
  req = SelectScanRequests({}, team, match, own_kfs, team_kfs, o);
  EXPECT_EQ(req[0].candidates, (std::vector<int>{1}));
  // Cap, exclusion, nearest only.
  o.max_requests = 1;
  o.max_candidates_per_request = 1;
  req = SelectScanRequests({}, team, match, own_kfs, team_kfs, o, {2});
  ASSERT_EQ(req.size(), 1u);
  EXPECT_EQ(req[0].teammate_keyframe, 3);
  // No match: no requests.
  match.status = msgs::MatchStatus::kTooFewInliers;
  EXPECT_TRUE(SelectScanRequests({}, team, match, own_kfs, team_kfs, o).empty());
}

}  // namespace
}  // namespace draco::registration
