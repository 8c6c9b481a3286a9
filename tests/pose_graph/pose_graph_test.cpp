// SE(2) pose graph: residual Jacobians, manifold, solves on synthetic graphs, robust losses,
// incremental updates and marginal covariances.
#include <ceres/gradient_checker.h>
#include <ceres/manifold_test_utils.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "draco/pose_graph/pose_graph_2d.hpp"
#include "se2_cost.hpp"
#include "synthetic.hpp"

// Ceres' manifold invariant macro names its matchers unqualified, so it runs inside ceres.
namespace ceres {
inline void ExpectManifoldInvariantsHold(const Manifold& manifold, const Vector& x,
                                         const Vector& delta, const Vector& y, double tolerance) {
  EXPECT_THAT_MANIFOLD_INVARIANTS_HOLD(manifold, x, delta, y, tolerance);
}
}  // namespace ceres

namespace draco::pose_graph {
namespace {

using testing::MakeGridWalk;
using testing::SyntheticGraph;
using testing::SyntheticOptions;

// A full (anisotropic, correlated) information matrix, so the whitening is exercised.
const Matrix3 kInformation = {40.0, 5.0, -2.0, 5.0, 25.0, 3.0, -2.0, 3.0, 300.0};

double PositionRmse(const PoseGraph2d& graph, const std::vector<Pose2>& truth) {
  double sum = 0.0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const Pose2 p = graph.Pose(static_cast<PoseId>(k));
    sum += std::pow(p.x_m - truth[k].x_m, 2) + std::pow(p.y_m - truth[k].y_m, 2);
  }
  return std::sqrt(sum / static_cast<double>(truth.size()));
}

// Poses at odometry dead reckoning, prior on pose 0 at the truth, all edges as factors.
PoseGraph2d BuildGraph(const SyntheticGraph& g, bool with_loops = true, RobustLoss loop_loss = {}) {
  PoseGraph2d graph;
  Pose2 dr = g.truth.front();
  graph.AddPose(0, dr);
  for (const auto& e : g.edges) {
    if (e.loop) continue;
    dr = Compose(dr, e.T_i_j);
    graph.AddPose(e.j, dr);
  }
  graph.AddPrior(0, g.truth.front(), InformationFromSigmas(0.01, 0.01, 0.001));
  for (const auto& e : g.edges) {
    if (e.loop && !with_loops) continue;
    graph.AddBetween(e.i, e.j, e.T_i_j, g.Information(),
                     e.loop ? FactorKind::kLoop : FactorKind::kOdometry,
                     e.loop ? loop_loss : RobustLoss{});
  }
  return graph;
}

TEST(Se2Cost, BetweenJacobiansMatchNumericDifferentiation) {
  internal::Pose2Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds{&manifold, &manifold};
  // The checker differentiates with Ridders' method; its default first step (1 % of the
  // value) is large enough to cross the angle wrap near yaw = +-pi, so start smaller.
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-4;
  for (const auto convention : {ErrorConvention::kG2o, ErrorConvention::kCeresExample}) {
    const internal::BetweenCost cost({0.7, -0.3, 2.9}, kInformation, convention);
    ceres::GradientChecker checker(&cost, &manifolds, numeric);
    // Includes yaws near +-pi, where the angle error wraps.
    const double poses[][6] = {{0.0, 0.0, 0.0, 1.0, 0.5, 0.3},
                               {1.2, -3.4, 3.1, 2.0, -1.0, -3.0},
                               {-5.0, 2.0, -1.5, -4.2, 2.7, 1.4}};
    for (const auto& p : poses) {
      const double* params[2] = {p, p + 3};
      ceres::GradientChecker::ProbeResults results;
      EXPECT_TRUE(checker.Probe(params, 1e-7, &results)) << results.error_log;
    }
  }
}

TEST(Se2Cost, PriorJacobianMatchesNumericDifferentiation) {
  internal::Pose2Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds{&manifold};
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-4;
  for (const auto convention : {ErrorConvention::kG2o, ErrorConvention::kCeresExample}) {
    const internal::PriorCost cost({1.0, 2.0, -2.5}, kInformation, convention);
    ceres::GradientChecker checker(&cost, &manifolds, numeric);
    const double x[3] = {1.3, 1.5, 3.0};
    const double* params[1] = {x};
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(checker.Probe(params, 1e-7, &results)) << results.error_log;
  }
}

TEST(Se2Cost, WhitenedResidualSquaredIsChi2) {
  const Pose2 a{0.3, -0.2, 0.4}, b{1.5, 0.9, 1.1}, z{1.0, 0.5, 0.6};
  const internal::BetweenCost cost(z, kInformation);
  const double pa[3] = {a.x_m, a.y_m, a.yaw_rad}, pb[3] = {b.x_m, b.y_m, b.yaw_rad};
  const double* params[2] = {pa, pb};
  double r[3];
  ASSERT_TRUE(cost.Evaluate(params, r, nullptr));
  const double chi2 = internal::Chi2(internal::BetweenError(a, b, z), kInformation);
  EXPECT_NEAR(r[0] * r[0] + r[1] * r[1] + r[2] * r[2], chi2, 1e-12);
  // g2o's error is Z^-1 * (A^-1 * B) written out.
  const Pose2 E = Compose(Inverse(z), Between(a, b));
  const auto e = internal::BetweenError(a, b, z);
  EXPECT_NEAR(e[0], E.x_m, 1e-12);
  EXPECT_NEAR(e[1], E.y_m, 1e-12);
  EXPECT_NEAR(e[2], E.yaw_rad, 1e-12);
  // Ceres' example keeps the translation error in frame i: A^-1 * B minus Z's translation.
  const Pose2 AB = Between(a, b);
  const auto ec = internal::BetweenError(a, b, z, ErrorConvention::kCeresExample);
  EXPECT_NEAR(ec[0], AB.x_m - z.x_m, 1e-12);
  EXPECT_NEAR(ec[1], AB.y_m - z.y_m, 1e-12);
  EXPECT_NEAR(ec[2], e[2], 1e-12);
}

TEST(Se2Cost, RejectsInformationThatIsNotPositiveDefinite) {
  EXPECT_THROW(internal::SqrtInformation(Diagonal3(1.0, 0.0, 1.0)), std::invalid_argument);
  EXPECT_THROW(internal::SqrtInformation({1, 2, 0, 0, 1, 0, 0, 0, 1}), std::invalid_argument);
  PoseGraph2d graph;
  graph.AddPose(0, {});
  graph.AddPose(1, {});
  EXPECT_THROW(graph.AddBetween(0, 1, {}, Diagonal3(1.0, -1.0, 1.0)), std::invalid_argument);
  EXPECT_THROW(graph.AddBetween(0, 7, {}, Diagonal3(1.0, 1.0, 1.0)), std::out_of_range);
  EXPECT_THROW(graph.AddPose(1, {}), std::invalid_argument);
}

TEST(YawGaussMarkovCost, ResidualAndJacobiansByHand) {
  // phi 0.9, sigma 0.1; mean yaw 0.2, previous 0.5, current 0.4: deviations 0.3 and 0.2,
  // r = (0.2 - 0.9 * 0.3) / 0.1 = -0.7; dr/dmean = (0.9 - 1) / 0.1 = -1, dr/dprevious = -9,
  // dr/dcurrent = 10, nothing on x, y.
  const internal::YawGaussMarkovCost cost(0.9, 0.1);
  const double m[3] = {5.0, -1.0, 0.2}, b[3] = {-3.0, 2.0, 0.5}, c[3] = {7.0, 4.0, 0.4};
  const double* params[3] = {m, b, c};
  double r = 0.0, jm[3], jb[3], jc[3];
  double* jacobians[3] = {jm, jb, jc};
  ASSERT_TRUE(cost.Evaluate(params, &r, jacobians));
  EXPECT_NEAR(r, -0.7, 1e-12);
  EXPECT_THAT(jm, ::testing::Pointwise(::testing::DoubleNear(1e-12), {0.0, 0.0, -1.0}));
  EXPECT_THAT(jb, ::testing::Pointwise(::testing::DoubleNear(1e-12), {0.0, 0.0, -9.0}));
  EXPECT_THAT(jc, ::testing::Pointwise(::testing::DoubleNear(1e-12), {0.0, 0.0, 10.0}));
  // The deviations wrap: mean 3.0, previous 3.1 (0.1), current -3.0 (2 pi - 6 = 0.2832).
  const double m2[3] = {0, 0, 3.0}, b2[3] = {0, 0, 3.1}, c2[3] = {0, 0, -3.0};
  const double* params2[3] = {m2, b2, c2};
  ASSERT_TRUE(cost.Evaluate(params2, &r, nullptr));
  EXPECT_NEAR(r, (2 * std::numbers::pi - 6.0 - 0.9 * 0.1) / 0.1, 1e-12);
  EXPECT_NEAR(internal::YawGaussMarkovError({0, 0, 3.0}, {0, 0, 3.1}, {0, 0, -3.0}, 0.9), 0.1 * r,
              1e-12);
  EXPECT_THROW(internal::YawGaussMarkovCost(1.5, 0.1), std::invalid_argument);
  EXPECT_THROW(internal::YawGaussMarkovCost(0.9, 0.0), std::invalid_argument);
}

TEST(YawGaussMarkovCost, JacobiansMatchNumericDifferentiation) {
  internal::Pose2Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds{&manifold, &manifold, &manifold};
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-4;
  const internal::YawGaussMarkovCost cost(0.97, 0.012);
  ceres::GradientChecker checker(&cost, &manifolds, numeric);
  const double m[3] = {1.0, 2.0, -0.4}, b[3] = {3.0, -1.0, 0.3}, c[3] = {-2.0, 0.5, 3.0};
  const double* params[3] = {m, b, c};
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(params, 1e-7, &results)) << results.error_log;
}

TEST(PoseGraph2d, YawGaussMarkovFactorChi2AndValidation) {
  PoseGraph2d graph;
  graph.AddPose(-1, {0.0, 0.0, 0.2});
  graph.AddPose(-2, {1.0, 0.0, 0.5});
  graph.AddPose(-3, {2.0, 0.0, 0.4});
  const std::size_t k = graph.AddYawGaussMarkov(-1, -2, -3, 0.9, 0.1);
  EXPECT_NEAR(graph.FactorChi2(k), 0.49, 1e-12);
  const Factor& f = graph.Factors()[k];
  ASSERT_TRUE(f.yaw_gauss_markov.has_value());
  EXPECT_EQ(f.yaw_gauss_markov->mean, -1);
  EXPECT_EQ(f.i, -2);
  EXPECT_EQ(f.j, -3);
  EXPECT_THROW(graph.AddYawGaussMarkov(-1, -1, -3, 0.9, 0.1), std::invalid_argument);
  EXPECT_THROW(graph.AddYawGaussMarkov(-1, -2, -3, 0.9, -0.1), std::invalid_argument);
  EXPECT_THROW(graph.AddYawGaussMarkov(-1, -2, -9, 0.9, 0.1), std::out_of_range);
  EXPECT_EQ(graph.NumFactors(), 1u);
  // Not an SE(2) relation: the spanning tree does not follow it.
  EXPECT_EQ(graph.InitializeFromSpanningTree(-1), 0u);
}

// A heading estimated from a gyro-like yaw odometry (sigma 2 mrad per 2 s step) and an
// AHRS heading z_k = theta_k + e_k - e_0 (relative to its first reading, as the simulator's
// dead reckoning) whose error e is a first-order Gauss-Markov process (sigma 0.05 rad, tau
// 120 s) plus 3 mrad white noise. Without a bias model a yaw prior at z_k (sigma 0.05) drags
// the heading along the AHRS error; the exact Gauss-Markov state separates the two.
struct HeadingRun {
  double rms_none = 0.0;  // yaw-only prior at z_k
  double rms_gm = 0.0;    // bias states with the exact Gauss-Markov factor
};

HeadingRun RunHeadingBias(unsigned seed) {
  const int n = 300;
  const double dt = 2.0, tau = 120.0, sb = 0.05, so = 0.002, sm = 0.003;
  const double phi = std::exp(-dt / tau), sw = sb * std::sqrt(1.0 - phi * phi);
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> theta(n), e(n), z(n), odo(n, 0.0);
  theta[0] = 0.3;
  e[0] = sb * g(rng);
  for (int k = 1; k < n; ++k) {
    theta[k] = theta[k - 1] + 0.05 * g(rng);
    e[k] = phi * e[k - 1] + sw * g(rng);
    odo[k] = theta[k] - theta[k - 1] + so * g(rng);
  }
  for (int k = 0; k < n; ++k) z[k] = theta[k] + e[k] - e[0] + (k > 0 ? sm * g(rng) : 0.0);
  const double tiny = 1e-9;
  auto build = [&](bool gm) {
    PoseGraph2d graph;
    for (int k = 0; k < n; ++k) graph.AddPose(k, {static_cast<double>(k), 0.0, z[k]});
    graph.AddPrior(0, {0.0, 0.0, theta[0]}, Diagonal3(1.0, 1.0, 1e6));
    for (int k = 1; k < n; ++k) {
      graph.AddBetween(k - 1, k, {1.0, 0.0, odo[k]}, Diagonal3(1.0, 1.0, 1.0 / (so * so)));
    }
    if (!gm) {
      for (int k = 1; k < n; ++k) {
        graph.AddPrior(k, {static_cast<double>(k), 0.0, z[k]},
                       Diagonal3(tiny, tiny, 1 / (sb * sb)));
      }
      return graph;
    }
    // Bias b_k (yaw only) with yaw_k - b_k = z_k; b_k - mean is the Gauss-Markov process.
    graph.AddPose(-1, {});
    graph.AddPrior(-1, {}, Diagonal3(1.0, 1.0, 1e-6));
    for (int k = 0; k < n; ++k) {
      graph.AddPose(-2 - k, {});
      graph.AddPrior(-2 - k, {}, Diagonal3(1.0, 1.0, tiny));
      graph.AddBetween(-2 - k, k, {0.0, 0.0, z[k]}, Diagonal3(tiny, tiny, 1 / (sm * sm)));
      if (k == 0) {
        graph.AddBetween(-1, -2, {}, Diagonal3(tiny, tiny, 1 / (sb * sb)));
      } else {
        graph.AddYawGaussMarkov(-1, -1 - k, -2 - k, phi, sw);
      }
    }
    return graph;
  };
  auto rms = [&](PoseGraph2d graph) {
    const SolveSummary s = graph.Optimize();
    EXPECT_TRUE(s.usable) << s.report;
    double sum = 0.0;
    for (int k = 0; k < n; ++k)
      sum += std::pow(NormalizeAngle(graph.Pose(k).yaw_rad - theta[k]), 2);
    return std::sqrt(sum / n);
  };
  return {rms(build(false)), rms(build(true))};
}

TEST(PoseGraph2d, ExactGaussMarkovHeadingBiasBeatsAYawPrior) {
  double none = 0.0, gm = 0.0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const HeadingRun r = RunHeadingBias(seed);
    EXPECT_LT(r.rms_gm, r.rms_none) << "seed " << seed;
    none += r.rms_none / 5;
    gm += r.rms_gm / 5;
  }
  RecordProperty("rms_yaw_prior_mrad", std::to_string(1e3 * none));
  RecordProperty("rms_yaw_gauss_markov_mrad", std::to_string(1e3 * gm));
  EXPECT_LT(gm, 0.6 * none) << "mean RMS yaw error: prior " << none << ", Gauss-Markov " << gm;
}

TEST(Pose2Manifold, InvariantsHold) {
  internal::Pose2Manifold manifold;
  const ceres::Vector x = Eigen::Vector3d(1.0, -2.0, 3.0);  // near +pi: Plus wraps
  const ceres::Vector delta = Eigen::Vector3d(0.1, 0.2, 0.4);
  const ceres::Vector y = Eigen::Vector3d(-0.5, 0.7, -3.0);
  ceres::ExpectManifoldInvariantsHold(manifold, x, delta, y, 1e-10);
  double out[3];
  manifold.Plus(x.data(), delta.data(), out);
  EXPECT_NEAR(out[2], 3.4 - 2 * std::numbers::pi, 1e-12);
}

TEST(Pose2, ComposeInverseBetween) {
  const Pose2 a{1.0, 2.0, 0.5}, b{-0.3, 0.8, -2.9};
  const Pose2 ab = Between(a, b);
  const Pose2 b2 = Compose(a, ab);
  EXPECT_NEAR(b2.x_m, b.x_m, 1e-12);
  EXPECT_NEAR(b2.y_m, b.y_m, 1e-12);
  EXPECT_NEAR(b2.yaw_rad, b.yaw_rad, 1e-12);
  const Pose2 id = Compose(a, Inverse(a));
  EXPECT_NEAR(id.x_m, 0.0, 1e-12);
  EXPECT_NEAR(id.y_m, 0.0, 1e-12);
  EXPECT_NEAR(id.yaw_rad, 0.0, 1e-12);
  EXPECT_NEAR(NormalizeAngle(3 * std::numbers::pi), -std::numbers::pi, 1e-12);
}

TEST(PoseGraph2d, RecoversKnownPosesOnNoisySyntheticGraph) {
  const SyntheticGraph g = MakeGridWalk({.num_poses = 300, .seed = 7});
  int loops = 0;
  for (const auto& e : g.edges) loops += e.loop ? 1 : 0;
  ASSERT_GT(loops, 20);
  PoseGraph2d graph = BuildGraph(g);
  const double dr_rmse = PositionRmse(graph, g.truth);
  const SolveSummary s = graph.Optimize();
  ASSERT_TRUE(s.usable) << s.report;
  EXPECT_TRUE(s.converged) << s.report;
  EXPECT_LT(s.final_chi2, s.initial_chi2);
  EXPECT_NEAR(s.final_chi2, graph.Chi2(), 1e-9);
  const double rmse = PositionRmse(graph, g.truth);
  EXPECT_LT(rmse, 0.25 * dr_rmse) << "dead reckoning " << dr_rmse << " m";
  EXPECT_LT(rmse, 0.2);
  // At the optimum chi2 is about the degrees of freedom (3 per factor minus 3 per pose).
  const double dof = 3.0 * (graph.NumFactors() - graph.NumPoses());
  EXPECT_GT(s.final_chi2, 0.5 * dof);
  EXPECT_LT(s.final_chi2, 1.5 * dof);
  for (std::size_t k = 0; k < g.truth.size(); ++k) {
    EXPECT_LT(std::abs(NormalizeAngle(graph.Pose(k).yaw_rad - g.truth[k].yaw_rad)), 0.1);
  }
}

TEST(PoseGraph2d, NoiselessGraphIsSolvedExactlyWithoutPriorByFixingFirstPose) {
  SyntheticGraph g = MakeGridWalk({.num_poses = 60, .sigma_xy_m = 1e-9, .sigma_yaw_rad = 1e-9});
  PoseGraph2d graph;
  for (std::size_t k = 0; k < g.truth.size(); ++k) graph.AddPose(k, {});
  graph.SetPose(0, g.truth[0]);
  for (const auto& e : g.edges) graph.AddBetween(e.i, e.j, e.T_i_j, Diagonal3(1, 1, 10));
  EXPECT_EQ(graph.InitializeFromSpanningTree(), g.truth.size() - 1);
  graph.SetPose(5, {3.0, -2.0, 1.0});  // perturb a pose; the first one stays the gauge
  const SolveSummary s = graph.Optimize();
  ASSERT_TRUE(s.usable);
  EXPECT_EQ(s.variable_poses, static_cast<int>(g.truth.size()) - 1);
  EXPECT_LT(PositionRmse(graph, g.truth), 1e-6);
  EXPECT_LT(s.final_chi2, 1e-10);
}

TEST(PoseGraph2d, RobustLossDownWeightsAnInjectedOutlierLoop) {
  SyntheticGraph g = MakeGridWalk({.num_poses = 200, .seed = 3});
  // A wrong loop closure: poses 40 and 170 are claimed to be 0.5 m apart.
  g.edges.push_back({40, 170, {0.5, 0.0, 0.3}, true});
  const std::size_t outlier = g.edges.size() - 1;

  PoseGraph2d plain = BuildGraph(g);
  PoseGraph2d robust = BuildGraph(g, true, {LossKind::kCauchy, 1.0});
  PoseGraph2d huber = BuildGraph(g, true, {LossKind::kHuber, 1.0});
  ASSERT_TRUE(plain.Optimize().usable);
  ASSERT_TRUE(robust.Optimize().usable);
  ASSERT_TRUE(huber.Optimize().usable);
  const double plain_rmse = PositionRmse(plain, g.truth);
  const double robust_rmse = PositionRmse(robust, g.truth);
  const double huber_rmse = PositionRmse(huber, g.truth);
  EXPECT_LT(robust_rmse, 0.25 * plain_rmse) << plain_rmse;
  EXPECT_LT(robust_rmse, 0.2);
  EXPECT_LT(huber_rmse, plain_rmse);
  // The outlier is left unexplained by the robust solution: its chi2 stays huge (the factor
  // index is the edge index + 1, after the prior).
  EXPECT_GT(robust.FactorChi2(outlier + 1), 1000.0);
  // and the inliers are fitted as if it were absent: their chi2 is near its expectation
  // (3 per factor minus 3 per pose) with the robust loss, far above it without.
  auto inlier_chi2 = [&](const PoseGraph2d& graph) {
    return graph.Chi2() - graph.FactorChi2(outlier + 1);
  };
  SyntheticGraph clean_edges = g;
  clean_edges.edges.pop_back();
  PoseGraph2d clean = BuildGraph(clean_edges);
  ASSERT_TRUE(clean.Optimize().usable);
  EXPECT_LT(inlier_chi2(robust), 2.0 * clean.Chi2());  // Cauchy also softens inlier loops
  EXPECT_GT(inlier_chi2(plain), 5.0 * inlier_chi2(robust));
}

TEST(PoseGraph2d, IncrementalUpdatesMatchABatchSolve) {
  const SyntheticGraph g = MakeGridWalk({.num_poses = 250, .seed = 11});
  PoseGraph2d batch = BuildGraph(g);
  ASSERT_TRUE(batch.Optimize().usable);

  PoseGraph2d inc;
  inc.AddPose(0, g.truth[0]);
  inc.AddPrior(0, g.truth[0], InformationFromSigmas(0.01, 0.01, 0.001));
  const IncrementalOptions options{.window_size = 15};
  int full = 0, local = 0;
  std::size_t e = 0;
  for (int k = 1; k < static_cast<int>(g.truth.size()); ++k) {
    // Odometry edge to k, then any loops ending at k.
    ASSERT_EQ(g.edges[e].j, k);
    inc.AddPose(k, Compose(inc.Pose(k - 1), g.edges[e].T_i_j));
    for (; e < g.edges.size() && g.edges[e].j == k; ++e) {
      inc.AddBetween(g.edges[e].i, k, g.edges[e].T_i_j, g.Information(),
                     g.edges[e].loop ? FactorKind::kLoop : FactorKind::kOdometry);
    }
    const SolveSummary s = inc.Update(options);
    ASSERT_TRUE(s.usable) << s.report;
    (s.full ? full : local) += 1;
  }
  EXPECT_GT(local, 0);
  EXPECT_GT(full, 0);
  // Finish with a full solve, then both reach the same optimum.
  inc.Optimize();
  EXPECT_NEAR(inc.Chi2(), batch.Chi2(), 1e-6 * batch.Chi2());
  for (std::size_t k = 0; k < g.truth.size(); ++k) {
    // Both stop at Ceres' relative function tolerance, not at the exact optimum.
    EXPECT_NEAR(inc.Pose(k).x_m, batch.Pose(k).x_m, 1e-3);
    EXPECT_NEAR(inc.Pose(k).y_m, batch.Pose(k).y_m, 1e-3);
  }
}

// full_solve_max_boundary_chi2: on a walk whose loops all agree with the odometry (the
// synthetic noise), most triggered full solves are answered by the window and the estimate
// stays near the batch optimum; a loop that disagrees (1 m off at 5 cm sigma) is solved in full.
TEST(PoseGraph2d, LoopsThatAgreeWithTheOlderGraphNeedNoFullSolve) {
  const SyntheticGraph g = MakeGridWalk({.num_poses = 250, .seed = 11});
  PoseGraph2d batch = BuildGraph(g);
  ASSERT_TRUE(batch.Optimize().usable);
  struct Run {
    int full = 0, avoided = 0;
    bool wrong_loop_solved_in_full = false;
    double max_error_m = 0.0;  // against the batch optimum, at the end, no final solve
  };
  constexpr int kWrongAt = 200;
  const auto run = [&](double max_chi2, bool wrong_loop) {
    Run out;
    PoseGraph2d inc;
    inc.AddPose(0, g.truth[0]);
    inc.AddPrior(0, g.truth[0], InformationFromSigmas(0.01, 0.01, 0.001));
    const IncrementalOptions options{.window_size = 15, .full_solve_max_boundary_chi2 = max_chi2};
    std::size_t e = 0;
    for (int k = 1; k < static_cast<int>(g.truth.size()); ++k) {
      inc.AddPose(k, Compose(inc.Pose(k - 1), g.edges[e].T_i_j));
      for (; e < g.edges.size() && g.edges[e].j == k; ++e) {
        inc.AddBetween(g.edges[e].i, k, g.edges[e].T_i_j, g.Information(),
                       g.edges[e].loop ? FactorKind::kLoop : FactorKind::kOdometry);
      }
      if (wrong_loop && k == kWrongAt) {
        // Pose 0 seen from k, 1 m off in x.
        Pose2 T = Between(g.truth[k], g.truth[0]);
        T.x_m += 1.0;
        inc.AddBetween(k, 0, T, g.Information(), FactorKind::kLoop);
      }
      const SolveSummary s = inc.Update(options);
      EXPECT_TRUE(s.usable) << s.report;
      out.full += s.full ? 1 : 0;
      out.avoided += s.full_avoided ? 1 : 0;
      EXPECT_FALSE(s.full && s.full_avoided);
      if (k == kWrongAt) out.wrong_loop_solved_in_full = s.full;
    }
    for (std::size_t k = 0; k < g.truth.size(); ++k) {
      out.max_error_m = std::max(out.max_error_m, std::hypot(inc.Pose(k).x_m - batch.Pose(k).x_m,
                                                             inc.Pose(k).y_m - batch.Pose(k).y_m));
    }
    return out;
  };
  const Run at_once = run(0.0, false), tried = run(11.34, false);
  EXPECT_EQ(at_once.avoided, 0);
  EXPECT_GT(tried.avoided, at_once.full / 2);
  EXPECT_EQ(tried.full + tried.avoided, at_once.full);
  // The noise is 5 cm per edge: the window's answers stay within 6 sigma of the optimum
  // (0.15 m here).
  EXPECT_LT(at_once.max_error_m, 0.02);
  EXPECT_LT(tried.max_error_m, 0.3);
  EXPECT_TRUE(run(11.34, true).wrong_loop_solved_in_full);
}

TEST(PoseGraph2d, DeferredFullSolvesComeAtMostEveryMinPosesAndReachTheBatchOptimum) {
  const SyntheticGraph g = MakeGridWalk({.num_poses = 250, .seed = 11});
  PoseGraph2d batch = BuildGraph(g);
  ASSERT_TRUE(batch.Optimize().usable);
  const auto run = [&](int min_poses, std::vector<int>* full_at) {
    PoseGraph2d inc;
    inc.AddPose(0, g.truth[0]);
    inc.AddPrior(0, g.truth[0], InformationFromSigmas(0.01, 0.01, 0.001));
    const IncrementalOptions options{.window_size = 15, .full_solve_min_poses = min_poses};
    std::size_t e = 0;
    int pending_since = -1;  // first pose whose loop reached behind the window, not yet solved
    for (int k = 1; k < static_cast<int>(g.truth.size()); ++k) {
      inc.AddPose(k, Compose(inc.Pose(k - 1), g.edges[e].T_i_j));
      for (; e < g.edges.size() && g.edges[e].j == k; ++e) {
        inc.AddBetween(g.edges[e].i, k, g.edges[e].T_i_j, g.Information(),
                       g.edges[e].loop ? FactorKind::kLoop : FactorKind::kOdometry);
        if (g.edges[e].loop && g.edges[e].i < k - 15 && pending_since < 0) pending_since = k;
      }
      const SolveSummary s = inc.Update(options);
      EXPECT_TRUE(s.usable) << s.report;
      if (s.full) {
        full_at->push_back(k);
        pending_since = -1;
      }
      // A loop behind the window waits for at most min_poses poses.
      if (pending_since >= 0) {
        EXPECT_LT(k - pending_since, std::max(min_poses, 1)) << k;
      }
    }
    inc.Optimize();
    EXPECT_NEAR(inc.Chi2(), batch.Chi2(), 1e-6 * batch.Chi2());
    for (std::size_t k = 0; k < g.truth.size(); ++k) {
      EXPECT_NEAR(inc.Pose(k).x_m, batch.Pose(k).x_m, 1e-3);
      EXPECT_NEAR(inc.Pose(k).y_m, batch.Pose(k).y_m, 1e-3);
    }
  };
  std::vector<int> at_once, deferred;
  run(0, &at_once);
  run(10, &deferred);
  ASSERT_FALSE(deferred.empty());
  // Past the first window (full while the graph is no larger), full solves are >= 10 apart.
  for (std::size_t i = 1; i < deferred.size(); ++i) {
    if (deferred[i - 1] >= 15) {
      EXPECT_GE(deferred[i] - deferred[i - 1], 10) << deferred[i];
    }
  }
  const auto after_window = [](const std::vector<int>& v) {
    return std::count_if(v.begin(), v.end(), [](int k) { return k > 15; });
  };
  EXPECT_GT(after_window(deferred), 0);
  EXPECT_LT(after_window(deferred), after_window(at_once));
}

TEST(PoseGraph2d, WindowSolveOnlyMovesTheNewestPoses) {
  const SyntheticGraph g =
      MakeGridWalk({.num_poses = 40, .loop_radius_m = -1.0, .seed = 5});  // no loops
  PoseGraph2d graph = BuildGraph(g);
  graph.SetPose(39, {100.0, 100.0, 0.0});
  graph.SetPose(10, {-50.0, 0.0, 0.0});
  const SolveSummary s = graph.OptimizeWindow(5);
  ASSERT_TRUE(s.usable) << s.report;
  EXPECT_FALSE(s.full);
  EXPECT_EQ(s.variable_poses, 5);
  EXPECT_LT(std::abs(graph.Pose(39).x_m - g.truth[39].x_m), 1.0);
  EXPECT_EQ(graph.Pose(10).x_m, -50.0);  // outside the window: untouched
}

TEST(PoseGraph2d, ConstantPoseReplacesTheAutomaticGauge) {
  PoseGraph2d graph;
  graph.AddPose(0, {});
  graph.AddPose(1, {5.0, 5.0, 1.0});
  graph.AddPose(2, {0.0, 0.0, 0.0});
  graph.AddBetween(0, 1, {1.0, 0.0, 0.0}, Diagonal3(1, 1, 1));
  graph.AddBetween(1, 2, {1.0, 0.0, 0.0}, Diagonal3(1, 1, 1));
  graph.SetPoseConstant(1);  // pose 1 holds the gauge; pose 0 is free now
  const SolveSummary s = graph.Optimize();
  ASSERT_TRUE(s.usable);
  EXPECT_EQ(s.variable_poses, 2);
  EXPECT_EQ(graph.Pose(1).x_m, 5.0);
  EXPECT_NEAR(graph.Pose(2).x_m, 5.0 + std::cos(1.0), 1e-6);
  EXPECT_NEAR(graph.Pose(0).x_m, 5.0 - std::cos(1.0), 1e-6);
  graph.SetPoseConstant(1, false);  // back to the automatic gauge on pose 0
  EXPECT_EQ(graph.Optimize().variable_poses, 2);
}

TEST(PoseGraph2d, UpdateRunsAPeriodicFullSolve) {
  const SyntheticGraph g = MakeGridWalk({.num_poses = 60, .loop_radius_m = -1.0, .seed = 9});
  PoseGraph2d graph;
  graph.AddPose(0, g.truth[0]);
  graph.AddPrior(0, g.truth[0], g.Information());
  std::vector<int> full_at;
  for (const auto& e : g.edges) {
    graph.AddPose(e.j, Compose(graph.Pose(e.i), e.T_i_j));
    graph.AddBetween(e.i, e.j, e.T_i_j, g.Information());
    if (graph.Update({.window_size = 10, .full_solve_every = 25}).full) full_at.push_back(e.j);
  }
  // Full while the graph fits the window (poses 1-9: 2-10 poses), then every 25 poses.
  ASSERT_GE(full_at.size(), 3u);
  EXPECT_EQ(full_at[full_at.size() - 2], 34);
  EXPECT_EQ(full_at.back(), 59);
}

// Two poses, a prior on the first and one between factor: the relative pose is determined by
// the measurement alone, so its covariance (right perturbation, frame of pose 1) is exactly
// the measurement covariance Omega^-1, whatever the prior and the measured rotation.
TEST(PoseGraph2d, RelativeCovarianceOfTwoPoseGraphIsTheMeasurementCovariance) {
  PoseGraph2d graph;
  const Pose2 z{2.0, 1.0, 0.8};
  graph.AddPose(0, {1.0, -1.0, 0.3});
  graph.AddPose(1, Compose({1.0, -1.0, 0.3}, z));
  graph.AddPrior(0, {1.0, -1.0, 0.3}, InformationFromSigmas(0.5, 0.3, 0.1));
  // Omega = diag(4, 16, 100) -> Sigma = diag(0.25, 0.0625, 0.01), plus a correlation term:
  // Omega = [[4, 1, 0], [1, 16, 0], [0, 0, 100]], Sigma_xy block = 1/63 * [[16, -1], [-1, 4]].
  const Matrix3 omega = {4, 1, 0, 1, 16, 0, 0, 0, 100};
  graph.AddBetween(0, 1, z, omega);
  const Matrix3 cov = graph.RelativeCovariance(0, 1);
  const Matrix3 expected = {16.0 / 63, -1.0 / 63, 0, -1.0 / 63, 4.0 / 63, 0, 0, 0, 0.01};
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(cov[k], expected[k], 1e-9) << k;

  // Absolute marginal of pose 0 is the prior's covariance; g2o's prior error is in the
  // measured pose's frame, so in the world frame it is R(0.3) diag(0.25, 0.09) R(0.3)^T.
  const Matrix3 c0 = graph.MarginalCovariance(0);
  const double c = std::cos(0.3), s = std::sin(0.3);
  EXPECT_NEAR(c0[0], 0.25 * c * c + 0.09 * s * s, 1e-9);
  EXPECT_NEAR(c0[1], (0.25 - 0.09) * c * s, 1e-9);
  EXPECT_NEAR(c0[4], 0.25 * s * s + 0.09 * c * c, 1e-9);
  EXPECT_NEAR(c0[8], 0.01, 1e-9);
  // Absolute marginal of pose 1 = J0 Sigma0 J0^T + R Sigma_z R^T (first-order propagation),
  // checked through its yaw term: 0.01 + 0.01.
  const Matrix3 c1 = graph.MarginalCovariance(1);
  EXPECT_NEAR(c1[8], 0.02, 1e-9);
}

// Without a prior the first pose is the gauge: its covariance is zero and the relative
// covariance along a chain accumulates the measurement covariances.
TEST(PoseGraph2d, RelativeCovarianceAlongAChainAccumulates) {
  PoseGraph2d graph;
  graph.AddPose(0, {});
  graph.AddPose(1, {1.0, 0.0, 0.0});
  graph.AddPose(2, {2.0, 0.0, 0.0});
  const Matrix3 omega = InformationFromSigmas(0.1, 0.1, 0.01);
  graph.AddBetween(0, 1, {1.0, 0.0, 0.0}, omega);
  graph.AddBetween(1, 2, {1.0, 0.0, 0.0}, omega);
  const std::vector<std::pair<PoseId, PoseId>> pairs{{0, 1}, {1, 2}, {0, 2}};
  const auto covs = graph.RelativeCovariances(pairs);
  EXPECT_NEAR(covs[0][0], 0.01, 1e-9);
  EXPECT_NEAR(covs[1][8], 1e-4, 1e-12);
  // 0 -> 2: x adds (0.01 + 0.01); y adds the two y variances plus the lever arm of the first
  // yaw error over 1 m: 0.01 + 0.01 + 1^2 * 1e-4; yaw adds 2e-4.
  EXPECT_NEAR(covs[2][0], 0.02, 1e-9);
  EXPECT_NEAR(covs[2][4], 0.0201, 1e-9);
  EXPECT_NEAR(covs[2][8], 2e-4, 1e-12);
  EXPECT_NEAR(covs[2][5], 1e-4, 1e-12);  // y-yaw correlation through that lever arm
}

TEST(PoseGraph2d, CovarianceOfAnUnconstrainedPoseThrows) {
  PoseGraph2d graph;
  for (PoseId id = 0; id < 5; ++id) graph.AddPose(id, {static_cast<double>(id), 0.0, 0.0});
  graph.AddBetween(0, 1, {1.0, 0.0, 0.0}, Diagonal3(1, 1, 1));
  graph.AddBetween(2, 3, {1.0, 0.0, 0.0}, Diagonal3(1, 1, 1));       // not linked to the gauge
  EXPECT_THROW(graph.RelativeCovariance(0, 4), std::runtime_error);  // no factor at all
  EXPECT_THROW(graph.MarginalCovariance(4), std::runtime_error);
  EXPECT_THROW(graph.RelativeCovariance(0, 2), std::runtime_error);  // rank-deficient
}

// Two opposite lanes 10 m apart (out along y = 0, back along y = 10) over a row of point
// landmarks on y = 5, each seen from both lanes within 8 m: the lawnmower survey of the
// local-SLAM landmarks. Odometry carries a heading bias of 0.01 rad per step (plus noise when
// sigma > 0); observations are exact.
struct LaneWorld {
  std::vector<Pose2> truth;
  std::vector<Pose2> odometry;  // T_k-1_k measured, odometry[0] unused
  std::vector<Point2> landmarks;
  struct Obs {
    int pose;
    int point;
    Point2 p_pose;
  };
  std::vector<Obs> observations;  // in pose order
};

LaneWorld MakeLaneWorld(double yaw_bias_rad = 0.01) {
  LaneWorld w;
  for (int k = 0; k < 20; ++k) w.truth.push_back({2.0 * k, 0.0, 0.0});
  for (int k = 0; k < 20; ++k) w.truth.push_back({38.0 - 2.0 * k, 10.0, std::numbers::pi});
  for (int j = 0; j < 10; ++j) w.landmarks.push_back({4.0 * j + 1.0, 5.0});
  w.odometry.push_back({});
  for (std::size_t k = 1; k < w.truth.size(); ++k) {
    Pose2 z = Between(w.truth[k - 1], w.truth[k]);
    z.yaw_rad += yaw_bias_rad;
    w.odometry.push_back(z);
  }
  for (int k = 0; k < static_cast<int>(w.truth.size()); ++k) {
    for (int j = 0; j < static_cast<int>(w.landmarks.size()); ++j) {
      const Point2 z = Transform(Inverse(w.truth[k]), w.landmarks[j]);
      if (std::hypot(z.x_m, z.y_m) < 8.0) w.observations.push_back({k, j, z});
    }
  }
  return w;
}

const Matrix3 kLaneOdometryInfo = InformationFromSigmas(0.05, 0.05, 0.01);
const Matrix2 kLaneObsInfo = {100.0, 0.0, 0.0, 100.0};  // 0.1 m

// Poses at dead reckoning, prior on pose 0; points (if wanted) at their first observation.
PoseGraph2d BuildLaneGraph(const LaneWorld& w, bool with_points) {
  PoseGraph2d graph;
  Pose2 dr = w.truth[0];
  graph.AddPose(0, dr);
  graph.AddPrior(0, w.truth[0], InformationFromSigmas(0.01, 0.01, 0.001));
  for (std::size_t k = 1; k < w.truth.size(); ++k) {
    dr = Compose(dr, w.odometry[k]);
    graph.AddPose(static_cast<PoseId>(k), dr);
    graph.AddBetween(static_cast<PoseId>(k - 1), static_cast<PoseId>(k), w.odometry[k],
                     kLaneOdometryInfo);
  }
  if (!with_points) return graph;
  for (const auto& o : w.observations) {
    if (!graph.HasPoint(o.point)) graph.AddPoint(o.point, Transform(graph.Pose(o.pose), o.p_pose));
    graph.AddPointObservation(o.pose, o.point, o.p_pose, kLaneObsInfo);
  }
  return graph;
}

TEST(PointObservationCost, JacobiansMatchNumericDifferentiation) {
  internal::Pose2Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds{&manifold, nullptr};
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-4;
  // A correlated 2x2 information, so the whitening is exercised.
  const internal::PointObservationCost cost({2.0, -1.5}, {30.0, 4.0, 4.0, 12.0});
  ceres::GradientChecker checker(&cost, &manifolds, numeric);
  const double cases[][5] = {
      {0.0, 0.0, 0.0, 2.5, -1.0}, {1.2, -3.4, 3.1, -2.0, 4.0}, {-5.0, 2.0, -1.5, -4.2, -7.3}};
  for (const auto& c : cases) {
    const double* params[2] = {c, c + 3};
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(checker.Probe(params, 1e-7, &results)) << results.error_log;
  }
}

TEST(PointObservationCost, ErrorIsTheLandmarkInThePoseFrameMinusTheMeasurement) {
  // Pose at (1, 2) facing +y; the landmark 3 m ahead at (1, 5) is (3, 0) in the pose frame.
  PoseGraph2d graph;
  graph.AddPose(0, {1.0, 2.0, std::numbers::pi / 2});
  graph.AddPoint(7, {1.0, 5.0});
  const std::size_t exact = graph.AddPointObservation(0, 7, {3.0, 0.0}, {4.0, 0.0, 0.0, 1.0});
  EXPECT_NEAR(graph.PointObservationChi2(exact), 0.0, 1e-12);
  // Off by (0.5, -0.5): chi2 = 4 * 0.25 + 1 * 0.25.
  const std::size_t off = graph.AddPointObservation(0, 7, {2.5, 0.5}, {4.0, 0.0, 0.0, 1.0});
  EXPECT_NEAR(graph.PointObservationChi2(off), 1.25, 1e-12);
  EXPECT_NEAR(graph.Chi2(), 1.25, 1e-12);
  // The whitened residual squared is the chi2, with a correlated information too.
  const Matrix2 info = {30.0, 4.0, 4.0, 12.0};
  const internal::PointObservationCost cost({2.5, 0.5}, info);
  const double pose[3] = {1.0, 2.0, std::numbers::pi / 2}, point[2] = {1.0, 5.0};
  const double* params[2] = {pose, point};
  double r[2];
  ASSERT_TRUE(cost.Evaluate(params, r, nullptr));
  EXPECT_NEAR(r[0] * r[0] + r[1] * r[1], 30 * 0.25 + 2 * 4 * 0.5 * -0.5 + 12 * 0.25, 1e-12);
  EXPECT_THROW(graph.AddPointObservation(0, 7, {}, {1.0, 2.0, 2.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(graph.AddPointObservation(0, 8, {}, {1.0, 0.0, 0.0, 1.0}), std::out_of_range);
  EXPECT_THROW(graph.AddPoint(7, {}), std::invalid_argument);
}

TEST(PoseGraph2d, NoiselessLandmarksRecoverPosesAndPointsExactly) {
  const LaneWorld w = MakeLaneWorld(0.0);
  PoseGraph2d graph = BuildLaneGraph(w, true);
  // Perturb poses and points; exact odometry and observations pull them back.
  graph.SetPose(25, {20.0, 5.0, 2.0});
  graph.SetPoint(3, {10.0, 7.0});
  const SolveSummary s = graph.Optimize();
  ASSERT_TRUE(s.usable) << s.report;
  EXPECT_LT(s.final_chi2, 1e-10);
  EXPECT_LT(PositionRmse(graph, w.truth), 1e-5);
  for (int j = 0; j < 10; ++j) {
    EXPECT_NEAR(graph.Point(j).x_m, w.landmarks[j].x_m, 1e-5);
    EXPECT_NEAR(graph.Point(j).y_m, w.landmarks[j].y_m, 1e-5);
  }
}

TEST(PoseGraph2d, LandmarksSeenFromOppositeLanesCorrectAHeadingBias) {
  const LaneWorld w = MakeLaneWorld(0.01);
  PoseGraph2d without = BuildLaneGraph(w, false);
  PoseGraph2d with = BuildLaneGraph(w, true);
  ASSERT_EQ(with.NumPoints(), 10u);
  ASSERT_TRUE(without.Optimize().usable);
  const double dr_rmse = PositionRmse(without, w.truth);  // odometry only: dead reckoning
  ASSERT_GT(dr_rmse, 2.0);
  const SolveSummary s = with.Optimize();
  ASSERT_TRUE(s.usable) << s.report;
  EXPECT_EQ(s.factors, static_cast<int>(with.NumFactors() + w.observations.size()));
  // The bias is systematic (1 sigma of the odometry yaw per step, all one way), so the
  // optimum is a compromise, not the truth: 0.36 m against 3.04 m.
  const double rmse = PositionRmse(with, w.truth);
  EXPECT_LT(rmse, 0.2 * dr_rmse) << "dead reckoning " << dr_rmse << " m";
  for (int j = 0; j < 10; ++j) {
    EXPECT_NEAR(with.Point(j).x_m, w.landmarks[j].x_m, 1.0);
    EXPECT_NEAR(with.Point(j).y_m, w.landmarks[j].y_m, 1.0);
  }
}

TEST(PointRadiusObservation, PredictsTheNearFaceOfTheCentre) {
  // Pose at (1, 2) facing +y; a centre 5 m ahead at (1, 7) is (5, 0) in the pose frame; with
  // radius 1 the near face is seen at (4, 0).
  PoseGraph2d graph;
  graph.AddPose(0, {1.0, 2.0, std::numbers::pi / 2});
  graph.AddPoint(3, {1.0, 7.0}, PointRadiusPrior{.prior_m = 1.0, .sigma_m = 0.5, .max_m = 3.0});
  ASSERT_TRUE(graph.PointRadius(3).has_value());
  EXPECT_DOUBLE_EQ(*graph.PointRadius(3), 1.0);
  const std::size_t exact = graph.AddPointObservation(0, 3, {4.0, 0.0}, {4.0, 0.0, 0.0, 1.0});
  EXPECT_NEAR(graph.PointObservationChi2(exact), 0.0, 1e-12);
  // Seen at (4.5, 0.5): error (0.5, 0.5), chi2 = 4 * 0.25 + 0.25.
  const std::size_t off = graph.AddPointObservation(0, 3, {4.5, 0.5}, {4.0, 0.0, 0.0, 1.0});
  EXPECT_NEAR(graph.PointObservationChi2(off), 1.25, 1e-12);
  EXPECT_NEAR(
      internal::PointRadiusError({1.0, 2.0, std::numbers::pi / 2}, {1.0, 7.0}, 1.0, {4.5, 0.5})[1],
      -0.5, 1e-12);
  graph.AddPoint(4, {0.0, 0.0});
  EXPECT_FALSE(graph.PointRadius(4).has_value());
  EXPECT_THROW(graph.AddPoint(5, {}, PointRadiusPrior{.prior_m = 4.0, .max_m = 3.0}),
               std::invalid_argument);
  EXPECT_THROW(graph.AddPoint(6, {}, PointRadiusPrior{.sigma_m = 0.0}), std::invalid_argument);
}

// The lane world with round objects of radius_m: each sighting is moved to the face toward the
// sonar (*w gets the moved sightings); the graph has a radius state per point (prior 0.3 m,
// sigma 5 m, at most max_m).
PoseGraph2d RoundObjectsGraph(double radius_m, double max_m, LaneWorld* w) {
  *w = MakeLaneWorld(0.0);
  for (auto& o : w->observations) {
    const double d = std::hypot(o.p_pose.x_m, o.p_pose.y_m);
    o.p_pose = {o.p_pose.x_m * (1.0 - radius_m / d), o.p_pose.y_m * (1.0 - radius_m / d)};
  }
  PoseGraph2d round = BuildLaneGraph(*w, false);
  for (const auto& o : w->observations) {
    if (!round.HasPoint(o.point)) {
      round.AddPoint(o.point, Transform(round.Pose(o.pose), o.p_pose),
                     PointRadiusPrior{.prior_m = 0.3, .sigma_m = 5.0, .max_m = max_m});
    }
    round.AddPointObservation(o.pose, o.point, o.p_pose, kLaneObsInfo);
  }
  return round;
}

TEST(PoseGraph2d, RadiusStateExplainsNearFaceSightingsFromOppositeLanes) {
  // Round objects of radius 0.8 m: each sighting is the face toward the sonar, so sightings
  // from the two lanes disagree by 1.6 m. A point without radius cannot explain both; a
  // point with a radius state (prior 0.3 m, sigma 5 m) recovers the radius and the centre.
  constexpr double kRadius = 0.8;
  LaneWorld w;
  PoseGraph2d round = RoundObjectsGraph(kRadius, 2.0, &w);
  PoseGraph2d plain = BuildLaneGraph(w, true);
  const SolveSummary sp = plain.Optimize(), sr = round.Optimize();
  ASSERT_TRUE(sp.usable && sr.usable) << sr.report;
  // Without a radius the sightings leave a chi2 of 8 per observation (112 of them).
  EXPECT_GT(sp.final_chi2, 5.0 * static_cast<double>(w.observations.size()));
  EXPECT_LT(sr.final_chi2, 0.2);  // the ten radius priors' own (0.5 / 5)^2 is most of it
  for (int j = 0; j < 10; ++j) {
    EXPECT_NEAR(*round.PointRadius(j), kRadius, 0.02) << "point " << j;
    EXPECT_NEAR(round.Point(j).x_m, w.landmarks[j].x_m, 0.02);
    EXPECT_NEAR(round.Point(j).y_m, w.landmarks[j].y_m, 0.02);
  }
  EXPECT_LT(PositionRmse(round, w.truth), 0.02);
}

TEST(PoseGraph2d, RadiusStateStopsAtItsBounds) {
  // Sightings that imply a radius beyond max_m (1.2 m objects, max 0.5 m) or below 0 (the far
  // face, -0.5 m) leave the radius exactly at the bound; the centres stay within the part of the
  // radius the bound leaves unexplained. With Ceres' projected line search and without it
  // (SolverOptions::bounded_line_search_iterations 0: steps only projected onto the bounds).
  for (const int line_search : {20, 0}) {
    for (const double implied : {1.2, -0.5}) {
      LaneWorld w;
      PoseGraph2d round = RoundObjectsGraph(implied, 0.5, &w);
      const SolveSummary s =
          round.Optimize(SolverOptions{.bounded_line_search_iterations = line_search});
      ASSERT_TRUE(s.usable) << s.report;
      const double bound = implied > 0.5 ? 0.5 : 0.0;
      for (int j = 0; j < 10; ++j) {
        EXPECT_NEAR(*round.PointRadius(j), bound, 1e-6) << "point " << j << ", implied " << implied;
        EXPECT_LT(std::hypot(round.Point(j).x_m - w.landmarks[j].x_m,
                             round.Point(j).y_m - w.landmarks[j].y_m),
                  std::abs(implied - bound))
            << implied;
      }
    }
  }
}

TEST(PoseGraph2d, ASolveFromASolutionWithRadiiOnTheirBoundTakesFewSteps) {
  // Far-face sightings (-0.5 m) put the radii at 0. Each solve after the first starts from the
  // last solution with every sighting added again, as the local SLAM's next full solve starts
  // from its last. Ceres computes a step without the bounds and then projects it, so a radius
  // the evidence pushes past its bound took the rest of the step with it: with the radii free
  // these solves took 37-49 iterations (with or without the projected line search), held on
  // their bound (an active set) 1-4.
  for (const int line_search : {20, 0}) {
    LaneWorld w;
    PoseGraph2d round = RoundObjectsGraph(-0.5, 0.5, &w);
    const SolverOptions options{.bounded_line_search_iterations = line_search};
    ASSERT_TRUE(round.Optimize(options).usable);
    int worst = 0;
    for (int again = 0; again < 3; ++again) {
      for (const auto& o : w.observations) {
        round.AddPointObservation(o.pose, o.point, o.p_pose, kLaneObsInfo);
      }
      const SolveSummary s = round.Optimize(options);
      ASSERT_TRUE(s.usable) << s.report;
      worst = std::max(worst, s.iterations);
      for (int j = 0; j < 10; ++j) {
        EXPECT_GE(*round.PointRadius(j), 0.0);
        EXPECT_LE(*round.PointRadius(j), 0.5);
      }
      EXPECT_EQ(*round.PointRadius(5), 0.0);  // seen from both lanes alike: held
    }
    EXPECT_LE(worst, 6) << "line search " << line_search;
  }
}

TEST(PoseGraph2d, ARadiusHeldOnItsBoundIsFreedWhenTheEvidenceTurns) {
  // Far-face sightings (-0.5 m) put every radius at 0; then near-face sightings of 1 m
  // objects, three times as many, pull them back into the range. The solve from the held
  // radii frees them and ends where a solve of the same graph from the start ends: three
  // sightings at 1 m for each at -0.5 m, 0.625 m.
  const auto with_near_faces = [](PoseGraph2d& graph) {
    LaneWorld near;
    (void)RoundObjectsGraph(1.0, 2.0, &near);
    for (int times = 0; times < 3; ++times) {
      for (const auto& o : near.observations) {
        graph.AddPointObservation(o.pose, o.point, o.p_pose, kLaneObsInfo);
      }
    }
  };
  LaneWorld far;
  PoseGraph2d held = RoundObjectsGraph(-0.5, 2.0, &far);
  ASSERT_TRUE(held.Optimize().usable);
  for (int j = 0; j < 10; ++j) ASSERT_EQ(*held.PointRadius(j), 0.0) << "point " << j;
  with_near_faces(held);
  const SolveSummary s = held.Optimize();
  ASSERT_TRUE(s.usable) << s.report;

  PoseGraph2d fresh = RoundObjectsGraph(-0.5, 2.0, &far);
  with_near_faces(fresh);
  const SolveSummary f = fresh.Optimize();
  ASSERT_TRUE(f.usable) << f.report;
  EXPECT_NEAR(s.final_chi2, f.final_chi2, 1e-4 * f.final_chi2);
  for (int j = 0; j < 10; ++j) {
    EXPECT_NEAR(*held.PointRadius(j), 0.625, 0.002) << "point " << j;
    EXPECT_NEAR(*held.PointRadius(j), *fresh.PointRadius(j), 0.001) << "point " << j;
  }
}

TEST(PoseGraph2d, IncrementalUpdatesWithLandmarksMatchABatchSolve) {
  const LaneWorld w = MakeLaneWorld(0.01);
  PoseGraph2d batch = BuildLaneGraph(w, true);
  ASSERT_TRUE(batch.Optimize().usable);

  PoseGraph2d inc;
  inc.AddPose(0, w.truth[0]);
  inc.AddPrior(0, w.truth[0], InformationFromSigmas(0.01, 0.01, 0.001));
  const IncrementalOptions options{.window_size = 5};
  int full_on_second_lane = 0, local = 0;
  std::size_t o = 0;
  for (int k = 0; k < static_cast<int>(w.truth.size()); ++k) {
    if (k > 0) {
      inc.AddPose(k, Compose(inc.Pose(k - 1), w.odometry[k]));
      inc.AddBetween(k - 1, k, w.odometry[k], kLaneOdometryInfo);
    }
    for (; o < w.observations.size() && w.observations[o].pose == k; ++o) {
      const auto& ob = w.observations[o];
      if (!inc.HasPoint(ob.point)) inc.AddPoint(ob.point, Transform(inc.Pose(k), ob.p_pose));
      inc.AddPointObservation(k, ob.point, ob.p_pose, kLaneObsInfo);
    }
    const SolveSummary s = inc.Update(options);
    ASSERT_TRUE(s.usable) << s.report;
    if (s.full && k >= 20) ++full_on_second_lane;
    if (!s.full) ++local;
  }
  EXPECT_GT(local, 0);
  // The second lane re-observes points last seen from the first: full solves.
  EXPECT_GT(full_on_second_lane, 5);
  inc.Optimize();
  EXPECT_NEAR(inc.Chi2(), batch.Chi2(), 1e-4 * batch.Chi2() + 1e-9);
  for (std::size_t k = 0; k < w.truth.size(); ++k) {
    EXPECT_NEAR(inc.Pose(k).x_m, batch.Pose(k).x_m, 1e-3);
    EXPECT_NEAR(inc.Pose(k).y_m, batch.Pose(k).y_m, 1e-3);
  }
}

}  // namespace
}  // namespace draco::pose_graph
