#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "draco/team/team_pgo.hpp"
#include "team_synthetic.hpp"

namespace draco::team {
namespace {

using synthetic::Ate;
using synthetic::MakeMission;
using synthetic::TruthInFrame;

// Teammates placed by the map guess alone (dead reckoning through the noisy transform).
double GuessAte(const synthetic::Mission& m, int own, int r) {
  Pose2 T;
  EXPECT_TRUE(MapGuess(m.problem, own, r, &T));
  std::vector<Pose2> placed;
  for (const Pose2& p : m.problem.robots.at(r).poses) placed.push_back(pose_graph::Compose(T, p));
  return Ate(placed, TruthInFrame(m, own, r));
}

double TeammateAte(const TeamEstimate& e, const synthetic::Mission& m, int r) {
  return Ate(e.trajectories.at(r), TruthInFrame(m, e.own_robot, r));
}

TEST(TeamPgo, BothMethodsRecoverTeammatesInOwnFrame) {
  // A poor map-to-map guess (graph matching off by metres and degrees).
  const auto m = MakeMission({.map_sigma_xy_m = 3.0, .map_sigma_yaw_rad = 0.1});
  for (int own = 0; own < 3; ++own) {
    const TeamEstimate two = TwoStepPgo(m.problem, own);
    const TeamEstimate full = FullPgo(m.problem, own);
    ASSERT_TRUE(two.local.usable);
    ASSERT_TRUE(full.local.usable);
    EXPECT_EQ(two.trajectories.size(), 3u);
    EXPECT_EQ(full.trajectories.size(), 3u);
    for (int r = 0; r < 3; ++r) {
      if (r == own) continue;
      const double guess = GuessAte(m, own, r);
      const double ate_two = TeammateAte(two, m, r);
      const double ate_full = TeammateAte(full, m, r);
      std::printf("own %d robot %d: guess %.3f two-step %.3f full %.3f m\n", own, r, guess, ate_two,
                  ate_full);
      // The two-step keeps the own chain's drift (teammates do not correct it), the full
      // PGO spreads it over the team.
      EXPECT_LT(ate_two, 0.5 * guess);
      EXPECT_LT(ate_two, 1.0);
      EXPECT_LT(ate_full, 0.35 * guess);
      EXPECT_LT(ate_full, 0.5);
    }
  }
}

TEST(TeamPgo, FullAndTwoStepAgreeWithCorrectLoops) {
  // Little own drift: the full PGO has nothing to correct in the own chain that the two-step
  // cannot, so both place the teammates alike. (With drift the full PGO also corrects the own
  // chain through the teammates; see docs/back-end.md.)
  const auto m = MakeMission({.odom_sigma_yaw_rad = 0.0005});
  const TeamEstimate two = TwoStepPgo(m.problem, 0);
  const TeamEstimate full = FullPgo(m.problem, 0);
  for (int r = 0; r < 3; ++r) {
    const double diff = Ate(two.trajectories.at(r), full.trajectories.at(r));
    const double truth = TeammateAte(full, m, r);
    std::printf("robot %d: two-step vs full %.3f m (full vs truth %.3f m)\n", r, diff, truth);
    EXPECT_LT(diff, 0.35);
  }
}

TEST(TeamPgo, CauchyLossLimitsWrongLoops) {
  synthetic::Options o;
  o.wrong_loops_per_pair = 3;
  const auto clean = MakeMission({});
  const auto m = MakeMission(o);
  TwoStepOptions plain;
  plain.loop_loss = {};
  plain.anchor_loss = {};
  FullOptions full_plain;
  full_plain.loop_loss = {};
  for (int r = 1; r < 3; ++r) {
    const double clean_two = TeammateAte(TwoStepPgo(clean.problem, 0), clean, r);
    const double robust_two = TeammateAte(TwoStepPgo(m.problem, 0), m, r);
    const double plain_two = TeammateAte(TwoStepPgo(m.problem, 0, plain), m, r);
    const double robust_full = TeammateAte(FullPgo(m.problem, 0), m, r);
    const double plain_full = TeammateAte(FullPgo(m.problem, 0, full_plain), m, r);
    std::printf(
        "robot %d: clean %.3f, wrong loops: two-step Cauchy %.3f none %.3f, full Cauchy "
        "%.3f none %.3f m\n",
        r, clean_two, robust_two, plain_two, robust_full, plain_full);
    EXPECT_LT(robust_two, 2.0 * clean_two + 0.2);
    EXPECT_LT(robust_two, 0.7 * plain_two);
    EXPECT_LT(robust_full, 0.7 * plain_full);
  }
}

TEST(TeamPgo, LocalStepOnlyHoldsOwnAndTouchedTeammatePoses) {
  const auto m = MakeMission({});
  for (int own = 0; own < 3; ++own) {
    std::set<std::pair<int, int>> touched;
    int loops = 0;
    for (const auto& l : m.problem.loops) {
      if (l.own_robot == own) touched.insert({l.teammate_robot, l.teammate_keyframe}), ++loops;
      if (l.teammate_robot == own) touched.insert({l.own_robot, l.own_keyframe}), ++loops;
    }
    const TeamEstimate two = TwoStepPgo(m.problem, own);
    const int own_poses = static_cast<int>(m.problem.robots.at(own).poses.size());
    EXPECT_EQ(two.touched_teammate_poses, static_cast<int>(touched.size()));
    EXPECT_EQ(two.loops_used, loops);
    // The own first pose is the gauge (constant).
    EXPECT_EQ(two.local.variable_poses, own_poses - 1 + static_cast<int>(touched.size()));
    EXPECT_EQ(two.local.factors, own_poses - 1 + loops);
    ASSERT_EQ(two.global.size(), 2u);
    for (const auto& [r, s] : two.global) {
      EXPECT_EQ(s.variable_poses, static_cast<int>(m.problem.robots.at(r).poses.size()));
    }
    const TeamEstimate full = FullPgo(m.problem, own);
    EXPECT_EQ(full.local.variable_poses, 3 * own_poses - 1);
    EXPECT_EQ(full.loops_used, static_cast<int>(m.problem.loops.size()));
  }
}

// Rigid placement: the teammate's relative poses are its own.
void ExpectRigid(const TeamEstimate& e, const synthetic::Mission& m, int r) {
  const auto& traj = e.trajectories.at(r);
  const auto& local = m.problem.robots.at(r).poses;
  const Pose2 a = pose_graph::Between(traj[0], traj[100]);
  const Pose2 b = pose_graph::Between(local[0], local[100]);
  EXPECT_NEAR(a.x_m, b.x_m, 1e-9) << "robot " << r;
  EXPECT_NEAR(a.y_m, b.y_m, 1e-9) << "robot " << r;
  EXPECT_NEAR(a.yaw_rad, b.yaw_rad, 1e-9) << "robot " << r;
}

TEST(TeamPgo, FirstLoopAnchorPlacesTeammateRigidly) {
  const auto m = MakeMission({});
  TwoStepOptions o;
  o.anchor = GlobalAnchor::kFirstLoop;
  const TeamEstimate two = TwoStepPgo(m.problem, 0, o);
  EXPECT_TRUE(two.global.empty());
  for (int r = 1; r < 3; ++r) {
    ExpectRigid(two, m, r);
    std::printf("robot %d: first-loop anchor %.3f m, guess %.3f m\n", r, TeammateAte(two, m, r),
                GuessAte(m, 0, r));
    EXPECT_LT(TeammateAte(two, m, r), GuessAte(m, 0, r));
  }
}

TEST(TeamPgo, RigidAnchorPlacesTeammateByAllItsLoops) {
  const auto m = MakeMission({});
  TwoStepOptions rigid, first;
  rigid.anchor = GlobalAnchor::kRigid;
  first.anchor = GlobalAnchor::kFirstLoop;
  const TeamEstimate two = TwoStepPgo(m.problem, 0, rigid);
  const TeamEstimate one = TwoStepPgo(m.problem, 0, first);
  EXPECT_TRUE(two.global.empty());
  for (int r = 1; r < 3; ++r) {
    ExpectRigid(two, m, r);
    // Placed by the loops, not the guess. (On this synthetic mission the teammate's chain
    // drifts, so a fit over all its touched poses is not better than its first loop: 0.99 /
    // 0.65 m against 0.91 / 0.58 m.)
    const double ate_rigid = TeammateAte(two, m, r), ate_first = TeammateAte(one, m, r);
    std::printf("robot %d: rigid anchor %.3f m, first loop %.3f m, guess %.3f m\n", r, ate_rigid,
                ate_first, GuessAte(m, 0, r));
    EXPECT_LT(ate_rigid, 0.7 * GuessAte(m, 0, r));
  }
}

TEST(TeamPgo, TeammateWithoutLoopsPlacedByGuess) {
  auto m = MakeMission({});
  std::erase_if(m.problem.loops, [](const auto& l) { return l.teammate_robot == 2; });
  const TeamEstimate two = TwoStepPgo(m.problem, 0);
  ASSERT_EQ(two.trajectories.at(2).size(), 150u);
  EXPECT_NEAR(TeammateAte(two, m, 2), GuessAte(m, 0, 2), 1e-9);
  EXPECT_EQ(two.global.size(), 1u);
}

TEST(TeamPgo, MapGuessChainsAndInverts) {
  TeamProblem p;
  p.maps[{0, 1}] = {1.0, 2.0, 0.3};
  p.maps[{2, 1}] = {-3.0, 0.5, -0.2};
  Pose2 T;
  ASSERT_TRUE(MapGuess(p, 1, 0, &T));
  const Pose2 inv = pose_graph::Inverse(p.maps[{0, 1}]);
  EXPECT_NEAR(T.x_m, inv.x_m, 1e-12);
  ASSERT_TRUE(MapGuess(p, 0, 2, &T));
  const Pose2 chained = pose_graph::Compose(p.maps[{0, 1}], pose_graph::Inverse(p.maps[{2, 1}]));
  EXPECT_NEAR(T.x_m, chained.x_m, 1e-12);
  EXPECT_NEAR(T.y_m, chained.y_m, 1e-12);
  EXPECT_NEAR(T.yaw_rad, chained.yaw_rad, 1e-12);
  EXPECT_FALSE(MapGuess(p, 0, 3, &T));
}

TEST(TeamPgo, FromPoseGraphKeepsBetweenFactorsInInsertionOrder) {
  pose_graph::PoseGraph2d g;
  g.AddPose(10, {0, 0, 0});
  g.AddPose(20, {1, 0, 0});
  g.AddPose(5, {2, 0, 0});
  g.AddPrior(10, {0, 0, 0}, pose_graph::Diagonal3(1, 1, 1));
  g.AddBetween(10, 20, {1, 0, 0}, pose_graph::Diagonal3(4, 4, 9));
  g.AddBetween(20, 5, {1, 0, 0}, pose_graph::Diagonal3(4, 4, 9));
  const RobotGraph r = FromPoseGraph(g);
  ASSERT_EQ(r.poses.size(), 3u);
  EXPECT_DOUBLE_EQ(r.poses[2].x_m, 2.0);
  ASSERT_EQ(r.factors.size(), 2u);
  EXPECT_EQ(r.factors[1].from, 1);
  EXPECT_EQ(r.factors[1].to, 2);
  EXPECT_DOUBLE_EQ(r.factors[1].information[8], 9.0);
}

// The largest position and yaw gap between two estimates' trajectories (same robots).
std::pair<double, double> Gap(const TeamEstimate& a, const TeamEstimate& b) {
  double m = 0.0, rad = 0.0;
  EXPECT_EQ(a.trajectories.size(), b.trajectories.size());
  for (const auto& [r, ta] : a.trajectories) {
    const auto& tb = b.trajectories.at(r);
    EXPECT_EQ(ta.size(), tb.size()) << r;
    for (std::size_t k = 0; k < ta.size() && k < tb.size(); ++k) {
      m = std::max(m, std::hypot(ta[k].x_m - tb[k].x_m, ta[k].y_m - tb[k].y_m));
      rad = std::max(rad, std::abs(std::remainder(ta[k].yaw_rad - tb[k].yaw_rad, 2.0 * M_PI)));
    }
  }
  return {m, rad};
}

std::map<int, WarmStart> WarmFrom(const TeamProblem& p, const TeamEstimate& e) {
  std::map<int, WarmStart> warm;
  for (const auto& [r, traj] : e.trajectories) {
    const auto l = e.local_teammate_poses.find(r);
    warm[r] = {p.robots.at(r).poses, traj,
               l != e.local_teammate_poses.end() ? l->second : std::map<int, Pose2>{}};
  }
  return warm;
}

TEST(TeamPgo, WarmStartGivesTheColdSolveToTheSolversTolerance) {
  const auto m = MakeMission({.map_sigma_xy_m = 3.0, .map_sigma_yaw_rad = 0.1});
  TwoStepOptions o;
  o.solver.num_threads = 1;
  const TeamEstimate cold = TwoStepPgo(m.problem, 0, o);
  ASSERT_TRUE(cold.local.usable);
  EXPECT_GT(cold.local.iterations, 10);
  // From its own solution (nothing changed): the same estimate at once.
  auto again = m.problem;
  again.warm = WarmFrom(m.problem, cold);
  const TeamEstimate same = TwoStepPgo(again, 0, o);
  auto [gap_m, gap_rad] = Gap(cold, same);
  EXPECT_LT(gap_m, 1e-6);
  EXPECT_LT(gap_rad, 1e-8);
  EXPECT_LE(same.local.iterations, 1);
  // A warm start half a metre off: only the start moves, the solution is the cold one to the
  // solver's tolerance.
  auto off = again;
  for (auto& [r, w] : off.warm) {
    for (auto& p : w.solution) p = pose_graph::Compose({0.5, 0.3, 0.02}, p);
    for (auto& [k, p] : w.local) p = pose_graph::Compose({0.5, 0.3, 0.02}, p);
  }
  std::tie(gap_m, gap_rad) = Gap(cold, TwoStepPgo(off, 0, o));
  EXPECT_LT(gap_m, 5e-3);
  EXPECT_LT(gap_rad, 1e-3);
  // The problem grown since the warm start (30 more keyframes per robot and their loops, the
  // teammates' maps moved): every keyframe placed, the own trajectory the cold solve's. The
  // teammates may settle in another minimum of the robust loops' cost than from the 3 m
  // guess (robot 2 here: 0.17 m apart), not a worse one.
  auto early = m.problem;
  for (auto& [r, rg] : early.robots) {
    rg.poses.resize(120);
    std::erase_if(rg.factors, [](const ChainFactor& f) { return f.from >= 120 || f.to >= 120; });
  }
  std::erase_if(early.loops, [](const msgs::InterRobotLoop& l) {
    return l.own_keyframe >= 120 || l.teammate_keyframe >= 120;
  });
  ASSERT_LT(early.loops.size(), m.problem.loops.size());
  const TeamEstimate early_est = TwoStepPgo(early, 0, o);
  auto grown = m.problem;
  for (auto& [r, rg] : grown.robots) {
    if (r == 0) continue;
    for (auto& p : rg.poses) p = pose_graph::Compose({0.3, -0.2, 0.01}, p);
  }
  const TeamEstimate grown_cold = TwoStepPgo(grown, 0, o);
  grown.warm = WarmFrom(early, early_est);
  const TeamEstimate grown_warm = TwoStepPgo(grown, 0, o);
  EXPECT_LT(grown_warm.local.iterations, grown_cold.local.iterations);
  ASSERT_EQ(grown_warm.trajectories.size(), 3u);
  for (const auto& [r, t] : grown_warm.trajectories) EXPECT_EQ(t.size(), 150u) << r;
  std::tie(gap_m, gap_rad) =
      Gap(TeamEstimate{.trajectories = {{0, grown_cold.trajectories.at(0)}}},
          TeamEstimate{.trajectories = {{0, grown_warm.trajectories.at(0)}}});
  EXPECT_LT(gap_m, 1e-3);
  EXPECT_LT(gap_rad, 1e-4);
  for (const int r : {1, 2}) {
    EXPECT_LT(TeammateAte(grown_warm, m, r), TeammateAte(grown_cold, m, r) + 1e-3) << r;
  }
}

TEST(TeamPgo, RejectsBadInput) {
  auto m = MakeMission({.keyframes = 40, .loops_per_pair = 3});
  EXPECT_THROW(TwoStepPgo(m.problem, 7), std::invalid_argument);
  auto bad = m;
  bad.problem.loops[0].teammate_keyframe = 999;
  EXPECT_THROW(TwoStepPgo(bad.problem, 0), std::invalid_argument);
  EXPECT_THROW(FullPgo(bad.problem, 0), std::invalid_argument);
  bad = m;
  bad.problem.maps.clear();
  EXPECT_THROW(TwoStepPgo(bad.problem, 0), std::invalid_argument);
}

}  // namespace
}  // namespace draco::team
