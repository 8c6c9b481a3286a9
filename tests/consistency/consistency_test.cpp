#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <set>

#include "draco/consistency/filter.hpp"
#include "draco/consistency/max_clique.hpp"
#include "draco/consistency/pairwise.hpp"
#include "draco/consistency/se2.hpp"
#include "synthetic.hpp"

namespace draco::consistency {
namespace {

Eigen::Vector3d Vec(const Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }
Pose2 Plus(const Pose2& p, const Eigen::Vector3d& d) {
  return {p.x_m + d.x(), p.y_m + d.y(), p.yaw_rad + d.z()};
}
Eigen::Vector3d Diff(const Pose2& a, const Pose2& b) {
  return {a.x_m - b.x_m, a.y_m - b.y_m, WrapAngle(a.yaw_rad - b.yaw_rad)};
}

template <typename F>
Eigen::Matrix3d Numeric(const Pose2& at, F f) {
  Eigen::Matrix3d J;
  const double h = 1e-6;
  for (int c = 0; c < 3; ++c) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d(c) = h;
    J.col(c) = Diff(f(Plus(at, d)), f(Plus(at, -d))) / (2.0 * h);
  }
  return J;
}

TEST(Se2, ComposeInverseJacobiansMatchNumericDifferentiation) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Pose2 a{u(rng), u(rng), u(rng)};
    const Pose2 b{u(rng), u(rng), u(rng)};
    Eigen::Matrix3d J_a;
    Eigen::Matrix3d J_b;
    Eigen::Matrix3d J_i;
    Compose(a, b, &J_a, &J_b);
    Inverse(a, &J_i);
    EXPECT_TRUE(J_a.isApprox(Numeric(a, [&](const Pose2& x) { return Compose(x, b); }), 1e-6));
    EXPECT_TRUE(J_b.isApprox(Numeric(b, [&](const Pose2& x) { return Compose(a, x); }), 1e-6));
    EXPECT_TRUE(J_i.isApprox(Numeric(a, [&](const Pose2& x) { return Inverse(x); }), 1e-6));
    const Pose2 id = Compose(a, Inverse(a));
    EXPECT_NEAR(Vec(id).norm(), 0.0, 1e-12);
  }
}

TEST(Se2, CovariancePropagationMatchesMonteCarlo) {
  const UncertainPose a{{1.0, 2.0, 0.7}, Eigen::Vector3d(0.01, 0.02, 0.001).asDiagonal()};
  const UncertainPose b{{3.0, -1.0, -0.4}, Eigen::Vector3d(0.03, 0.01, 0.002).asDiagonal()};
  const UncertainPose c = Compose(Inverse(a), b);
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Matrix3d La = a.covariance.llt().matrixL();
  const Eigen::Matrix3d Lb = b.covariance.llt().matrixL();
  Eigen::Matrix3d sample = Eigen::Matrix3d::Zero();
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d na = La * Eigen::Vector3d(g(rng), g(rng), g(rng));
    const Eigen::Vector3d nb = Lb * Eigen::Vector3d(g(rng), g(rng), g(rng));
    const Eigen::Vector3d d = Diff(Compose(Inverse(Plus(a.pose, na)), Plus(b.pose, nb)), c.pose);
    sample += d * d.transpose();
  }
  sample /= n;
  EXPECT_LT((sample - c.covariance).norm(), 0.05 * c.covariance.norm());
}

TEST(ChainPoseSource, RelativeMarginalEqualsChainPropagation) {
  ChainPoseSource source;
  const Eigen::Matrix3d step = Eigen::Vector3d(0.01, 0.02, 0.0005).asDiagonal();
  std::vector<UncertainPose> steps;
  Pose2 pose{5.0, 1.0, 0.3};
  source.AddKeyframe(0, pose, step);
  for (int k = 1; k < 12; ++k) {
    const UncertainPose s{{1.5, 0.2 * k, 0.1 * (k % 3 - 1)}, step};
    steps.push_back(s);
    pose = Compose(pose, s.pose);
    source.AddKeyframe(0, pose, step);
  }
  UncertainPose expected{{0, 0, 0}, Eigen::Matrix3d::Zero()};
  for (int k = 3; k < 9; ++k) expected = Compose(expected, steps[static_cast<std::size_t>(k)]);
  const auto rel = source.Relative(0, 3, 9);
  ASSERT_TRUE(rel.has_value());
  EXPECT_NEAR(Diff(rel->pose, expected.pose).norm(), 0.0, 1e-9);
  EXPECT_TRUE(rel->covariance.isApprox(expected.covariance, 1e-9));
  const auto back = source.Relative(0, 9, 3);
  ASSERT_TRUE(back.has_value());
  EXPECT_TRUE(back->covariance.isApprox(Inverse(expected).covariance, 1e-9));
}

msgs::InterRobotLoop TrueLoop(const std::vector<Pose2>& own, int i, int teammate,
                              const std::vector<Pose2>& team, int k, const Pose2& shift = {}) {
  msgs::InterRobotLoop z;
  z.own_keyframe = i;
  z.teammate_robot = teammate;
  z.teammate_keyframe = k;
  Pose2 target = team[static_cast<std::size_t>(k)];
  target.x_m += shift.x_m;
  target.y_m += shift.y_m;
  z.T_ownkf_teammatekf = Between(own[static_cast<std::size_t>(i)], target);
  z.covariance = {0.01, 0, 0, 0, 0.01, 0, 0, 0, 1e-4};
  return z;
}

// Noise-free chains in map frames = each robot's first keyframe; exact map transforms.
struct World {
  std::vector<std::vector<Pose2>> poses;
  ChainPoseSource source;
  explicit World(int n) {
    const Eigen::Matrix3d step = Eigen::Vector3d(4e-4, 4e-4, 1e-6).asDiagonal();
    for (int r = 0; r < 3; ++r) {
      poses.push_back(synthetic::Survey(r, n, 2.0));
      for (int k = 0; k < n; ++k) source.AddKeyframe(r, Between(poses[r][0], poses[r][k]), step);
    }
    for (int b = 1; b < 3; ++b) {
      source.SetMapTransform(
          0, b,
          {Between(poses[0][0], poses[b][0]), Eigen::Vector3d(0.01, 0.01, 1e-5).asDiagonal()});
    }
  }
};

TEST(Pairwise, TrueLoopsConsistentShiftedInconsistentBothModels) {
  World w(160);
  const auto z1 = TrueLoop(w.poses[0], 10, 1, w.poses[1], 140);
  const auto z2 = TrueLoop(w.poses[0], 40, 1, w.poses[1], 120);
  const auto z3 = TrueLoop(w.poses[0], 40, 2, w.poses[2], 60);
  const auto bad = TrueLoop(w.poses[0], 40, 1, w.poses[1], 120, {2.0, 0.0, 0.0});
  for (const auto model : {CovarianceModel::kFirstLoop, CovarianceModel::kPropagated}) {
    const PairwiseOptions o{model, 11.34};
    const auto same = TestPair(z1, z2, w.source, o);
    EXPECT_TRUE(same.evaluated);
    EXPECT_TRUE(same.consistent) << same.mahalanobis_squared;
    EXPECT_NEAR(same.error.norm(), 0.0, 1e-9);
    const auto across = TestPair(z1, z3, w.source, o);  // GCM: two teammates
    EXPECT_TRUE(across.evaluated);
    EXPECT_NEAR(across.error.norm(), 0.0, 1e-9);
    EXPECT_FALSE(TestPair(z1, bad, w.source, o).consistent);
  }
  // Without a map transform a cross-teammate pair cannot be evaluated.
  ChainPoseSource no_maps;
  for (int r = 0; r < 3; ++r) {
    for (const auto& p : w.poses[r]) no_maps.AddKeyframe(r, p, Eigen::Matrix3d::Identity());
  }
  EXPECT_FALSE(TestPair(z1, z3, no_maps, {}).evaluated);
}

// Random chains, map transforms and loops (errors spread around the threshold, covariances
// random SPD over four orders of magnitude, some keyframes unknown, one teammate without a
// map transform in some trials, intra-robot loops): PairTester decides every pair as
// TestPair does, for both covariance models and several thresholds.
Eigen::Matrix3d RandomSpd(std::mt19937& rng, double sigma_xy, double sigma_yaw) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Matrix3d B;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) B(r, c) = g(rng);
  }
  const Eigen::Vector3d scale(sigma_xy, sigma_xy, sigma_yaw);
  const Eigen::Matrix3d C = scale.asDiagonal() *
                            (B * B.transpose() / 3.0 + 0.2 * Eigen::Matrix3d::Identity()) *
                            scale.asDiagonal();
  return C;
}

TEST(PairTester, SameDecisionsAsTestPairOnRandomInputs) {
  std::mt19937 rng(101);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  std::int64_t pairs = 0;
  std::int64_t consistent = 0;
  std::int64_t fast_outs = 0;
  for (int trial = 0; trial < 24; ++trial) {
    const double sigma = std::pow(10.0, -2.5 + 2.0 * u(rng));  // 3 mm .. 0.3 m
    ChainPoseSource source;
    std::vector<std::vector<Pose2>> truth(3);
    for (int r = 0; r < 3; ++r) {
      Pose2 pose{30.0 * g(rng), 30.0 * g(rng), 3.0 * (u(rng) - 0.5)};
      const int n = 20 + static_cast<int>(40 * u(rng));
      for (int k = 0; k < n; ++k) {
        if (k > 0) pose = Compose(pose, {3.0 * u(rng), g(rng), 0.4 * g(rng)});
        truth[static_cast<std::size_t>(r)].push_back(pose);
        source.AddKeyframe(r, Between(truth[static_cast<std::size_t>(r)][0], pose),
                           RandomSpd(rng, 0.2 * sigma, 0.02 * sigma));
      }
    }
    for (int b = 1; b < 3; ++b) {
      if (trial % 4 == 3 && b == 2) continue;  // teammate 2 without a map transform
      const Eigen::Matrix3d C = RandomSpd(rng, sigma, 0.1 * sigma);
      const Eigen::Matrix3d L = C.llt().matrixL();
      const Eigen::Vector3d noise = L * Eigen::Vector3d(g(rng), g(rng), g(rng));
      source.SetMapTransform(
          0, b, {Plus(Between(truth[0][0], truth[static_cast<std::size_t>(b)][0]), noise), C});
    }
    std::vector<PreparedLoop> loops;
    for (int q = 0; q < 40; ++q) {
      msgs::InterRobotLoop z;
      z.id = static_cast<std::uint64_t>(q);
      z.teammate_robot = q % 7 == 0 ? 0 : 1 + q % 2;  // some intra-robot
      const int own_n = static_cast<int>(truth[0].size());
      const int team_n = static_cast<int>(truth[static_cast<std::size_t>(z.teammate_robot)].size());
      z.own_keyframe = static_cast<int>(u(rng) * own_n);
      z.teammate_keyframe = static_cast<int>(u(rng) * team_n);
      if (q == 13) z.teammate_keyframe = team_n + 2;  // unknown keyframe
      const Eigen::Matrix3d C = RandomSpd(rng, sigma, 0.1 * sigma);
      const Pose2 target =
          truth[static_cast<std::size_t>(z.teammate_robot)]
               [static_cast<std::size_t>(std::min(z.teammate_keyframe, team_n - 1))];
      const double spread = 3.0 * u(rng);  // error scale, in sigmas
      const Eigen::Matrix3d L = C.llt().matrixL();
      const Eigen::Vector3d noise = spread * (L * Eigen::Vector3d(g(rng), g(rng), g(rng)));
      z.T_ownkf_teammatekf =
          Plus(Between(truth[0][static_cast<std::size_t>(z.own_keyframe)], target), noise);
      z.covariance = FromMatrix(C);
      loops.push_back(Prepare(z, source));
    }
    for (const auto model : {CovarianceModel::kFirstLoop, CovarianceModel::kPropagated}) {
      for (const double threshold : {1.0, 4.0, 11.34, 40.0}) {
        const PairwiseOptions o{model, threshold};
        PairTester tester;
        ASSERT_TRUE(tester.Reset(loops, source, o));
        for (int a = 0; a < static_cast<int>(loops.size()); ++a) {
          for (int b = 0; b < static_cast<int>(loops.size()); ++b) {
            if (a == b) continue;
            const bool expected = TestPair(loops[static_cast<std::size_t>(a)],
                                           loops[static_cast<std::size_t>(b)], source, o)
                                      .consistent;
            ASSERT_EQ(tester.Consistent(a, b), expected)
                << "trial " << trial << " pair " << a << "," << b << " "
                << CovarianceModelName(model) << " " << threshold;
            ++pairs;
            consistent += expected ? 1 : 0;
          }
        }
        fast_outs += tester.early_outs();
        EXPECT_LE(tester.fallbacks() * 1000,
                  static_cast<std::int64_t>(loops.size() * loops.size()));
      }
    }
  }
  // Both outcomes well represented, and the yaw bound used.
  EXPECT_GT(consistent * 5, pairs);
  EXPECT_GT((pairs - consistent) * 5, pairs);
  EXPECT_GT(fast_outs, 0);
}

// A source that is not an open chain: the filter falls back to TestPair for every pair.
class NotAChain : public PoseSource {
 public:
  explicit NotAChain(const ChainPoseSource& s) : s_(s) {}
  std::optional<UncertainPose> Relative(int r, int from, int to) const override {
    return s_.Relative(r, from, to);
  }
  std::optional<UncertainPose> MapTransform(int own, int teammate) const override {
    return s_.MapTransform(own, teammate);
  }

 private:
  const ChainPoseSource& s_;
};

// ---------------------------------------------------------------- maximum clique

Graph RandomGraph(int n, double p, std::mt19937& rng) {
  std::bernoulli_distribution edge(p);
  Graph g(n);
  for (int u = 0; u < n; ++u) {
    for (int v = u + 1; v < n; ++v) {
      if (edge(rng)) g.AddEdge(u, v);
    }
  }
  return g;
}

bool IsClique(const Graph& g, const std::vector<int>& c) {
  for (std::size_t a = 0; a < c.size(); ++a) {
    for (std::size_t b = a + 1; b < c.size(); ++b) {
      if (!g.HasEdge(c[a], c[b])) return false;
    }
  }
  return true;
}

int BruteForceCliqueSize(const Graph& g) {
  const int n = g.NumVertices();
  int best = 0;
  for (std::uint32_t mask = 0; mask < (1u << n); ++mask) {
    std::vector<int> c;
    for (int v = 0; v < n; ++v) {
      if ((mask >> v) & 1u) c.push_back(v);
    }
    if (static_cast<int>(c.size()) > best && IsClique(g, c)) best = static_cast<int>(c.size());
  }
  return best;
}

TEST(MaxClique, ExactMatchesBruteForceOnRandomSmallGraphs) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + trial % 16;
    const double p = 0.2 + 0.7 * (trial % 7) / 6.0;
    const Graph g = RandomGraph(n, p, rng);
    const CliqueResult r = MaximumClique(g);
    EXPECT_TRUE(r.exact);
    EXPECT_TRUE(IsClique(g, r.vertices));
    const int brute = BruteForceCliqueSize(g);
    EXPECT_EQ(static_cast<int>(r.vertices.size()), brute) << "trial " << trial;
    EXPECT_EQ(static_cast<int>(MaximumCliqueBronKerboschNaive(g).size()), brute);
  }
}

TEST(MaxClique, ExactMatchesNaiveBronKerboschOnMediumGraphs) {
  std::mt19937 rng(12);
  for (int trial = 0; trial < 20; ++trial) {
    const Graph g = RandomGraph(30 + trial * 2, 0.3 + 0.02 * trial, rng);
    const CliqueResult r = MaximumClique(g);
    EXPECT_TRUE(IsClique(g, r.vertices));
    EXPECT_EQ(r.vertices.size(), MaximumCliqueBronKerboschNaive(g).size());
  }
}

TEST(MaxClique, LowerBoundAndRequiredVertices) {
  std::mt19937 rng(13);
  const Graph g = RandomGraph(30, 0.5, rng);
  const auto best = MaximumClique(g).vertices;
  EXPECT_TRUE(MaximumClique(g, {0.0, static_cast<int>(best.size())}).vertices.empty());
  EXPECT_EQ(MaximumClique(g, {0.0, static_cast<int>(best.size()) - 1}).vertices.size(),
            best.size());
  // Clique through best[0]: candidates = its neighbours.
  std::vector<int> nb;
  for (int u = 0; u < 30; ++u) {
    if (g.HasEdge(u, best[0])) nb.push_back(u);
  }
  EXPECT_EQ(MaximumCliqueWithin(g, {best[0]}, nb).vertices.size(), best.size());
}

TEST(MaxClique, TinyBudgetFallsBackToHeuristicAndSaysSo) {
  std::mt19937 rng(14);
  const Graph g = RandomGraph(400, 0.9, rng);
  const CliqueResult r = MaximumClique(g, {1e-6, 0});
  EXPECT_FALSE(r.exact);
  EXPECT_TRUE(IsClique(g, r.vertices));
  EXPECT_GT(r.vertices.size(), 10u);
  CliqueOptions by_nodes;
  by_nodes.max_nodes = 100;
  const CliqueResult n = MaximumClique(g, by_nodes);
  EXPECT_FALSE(n.exact);
  EXPECT_LE(n.nodes, 101);
  EXPECT_TRUE(IsClique(g, n.vertices));
  EXPECT_GT(n.vertices.size(), 10u);
  EXPECT_EQ(MaximumClique(g, by_nodes).vertices, n.vertices);  // deterministic
}

// The marina's shape: a large clique (true loops) and outliers, each adjacent to most of it
// or to little, to each other at random.
Graph PlantedClique(int clique, int outliers, double p_to_clique, double p_outliers,
                    std::mt19937& rng) {
  Graph g(clique + outliers);
  for (int u = 0; u < clique; ++u) {
    for (int v = u + 1; v < clique; ++v) g.AddEdge(u, v);
  }
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int q = clique; q < clique + outliers; ++q) {
    const double p = unit(rng) < 0.5 ? p_to_clique : 0.3;  // near-inliers and plain outliers
    for (int u = 0; u < clique; ++u) {
      if (unit(rng) < p) g.AddEdge(q, u);
    }
    for (int w = clique; w < q; ++w) {
      if (unit(rng) < p_outliers) g.AddEdge(q, w);
    }
  }
  return g;
}

// The kernel search gives the size of the full search, a clique holding the required vertex
// within the candidates, for any known clique (the planted one, part of it, a greedy one,
// none) and any lower bound; on the planted graphs, around the planted clique, the branch and
// bound runs on a small part of the candidates when the lower bound is that clique's size
// (the filter's searches).
TEST(MaxClique, KernelGivesTheSizeOfTheFullSearch) {
  std::mt19937 rng(15);
  std::int64_t searched_full = 0;
  std::int64_t searched_kernel = 0;
  int searches = 0;
  int same_vertices = 0;
  for (int trial = 0; trial < 120; ++trial) {
    const bool planted = trial % 2 == 0;
    const Graph g = planted ? PlantedClique(60 + trial, 10 + trial % 25, 0.995, 0.5, rng)
                            : RandomGraph(12 + trial % 40, 0.3 + 0.6 * (trial % 5) / 4.0, rng);
    const int n = g.NumVertices();
    const std::vector<int> best = MaximumClique(g).vertices;
    std::vector<std::vector<int>> knowns{{}, best, GreedyClique(g, best)};
    std::vector<int> part;
    for (std::size_t i = 0; i < best.size(); i += 2) part.push_back(best[i]);
    knowns.push_back(part);
    std::uniform_int_distribution<int> pick(0, n - 1);
    for (int round = 0; round < 4; ++round) {
      const int v = round == 0 && !best.empty() ? best.back() : pick(rng);
      std::vector<int> candidates;  // neighbours of v, some left out
      for (int u = 0; u < n; ++u) {
        if (u != v && g.HasEdge(u, v) && pick(rng) % 10 != 0) candidates.push_back(u);
      }
      const int full_size =
          static_cast<int>(MaximumCliqueWithin(g, {v}, candidates).vertices.size());
      for (const int lower : {0, full_size - 2, full_size - 1, full_size}) {
        CliqueOptions co;
        co.lower_bound = std::max(0, lower);
        const CliqueResult full = MaximumCliqueWithin(g, {v}, candidates, co);
        for (const auto& known : knowns) {
          // `known` minus v and outside the candidates stays a clique.
          const CliqueResult k = MaximumCliqueWithinKernel(g, {v}, candidates, known, co);
          ASSERT_TRUE(k.exact);
          ASSERT_EQ(k.vertices.size(), full.vertices.size())
              << "trial " << trial << " v " << v << " lower " << lower;
          if (k.vertices.empty()) continue;
          EXPECT_TRUE(IsClique(g, k.vertices));
          EXPECT_TRUE(std::binary_search(k.vertices.begin(), k.vertices.end(), v));
          for (const int u : k.vertices) {
            EXPECT_TRUE(u == v ||
                        std::find(candidates.begin(), candidates.end(), u) != candidates.end());
          }
          if (planted && known == best && lower >= full_size - 1) {  // the filter's case
            same_vertices += k.vertices == full.vertices ? 1 : 0;
            searched_full += full.searched;
            searched_kernel += k.searched;
            ++searches;
          }
        }
      }
    }
  }
  EXPECT_GT(searches, 100);
  EXPECT_EQ(same_vertices, searches);
  EXPECT_LT(searched_kernel * 5, searched_full) << searched_kernel << " vs " << searched_full;
}

// ---------------------------------------------------------------- filters

std::set<std::uint64_t> Ids(const std::vector<std::uint64_t>& v) { return {v.begin(), v.end()}; }

// Feeds a mission step by step; returns the union of every newly accepted loop.
std::set<std::uint64_t> Feed(ConsistencyFilter& filter, const synthetic::Mission& m,
                             int batch_steps, Decision* last = nullptr) {
  std::set<std::uint64_t> emitted;
  std::size_t next = 0;
  for (int step = 0; next < m.loops.size(); step += batch_steps) {
    std::vector<msgs::InterRobotLoop> batch;
    while (next < m.loops.size() && m.arrival[next] < step + batch_steps) {
      batch.push_back(m.loops[next++]);
    }
    if (batch.empty()) continue;
    const Decision d = filter.Add(batch, m.poses);
    emitted.insert(d.newly_accepted.begin(), d.newly_accepted.end());
    if (last != nullptr) *last = d;
  }
  return emitted;
}

TEST(Filter, AcceptsTrueLoopsRejectsRandomOutliers) {
  for (const auto method : {Method::kPcm, Method::kGcm}) {
    synthetic::MissionOptions mo;
    mo.outlier_fraction = 0.5;
    mo.seed = 21;
    const auto m = synthetic::MakeMission(mo);
    FilterOptions fo;
    fo.method = method;
    ConsistencyFilter filter(fo);
    Decision last;
    const auto emitted = Feed(filter, m, 5, &last);
    EXPECT_TRUE(last.exact);
    int true_accepted = 0;
    for (const auto id : emitted) {
      EXPECT_TRUE(m.inlier[id]) << MethodName(method) << " accepted outlier " << id;
      true_accepted += m.inlier[id] ? 1 : 0;
    }
    EXPECT_GE(true_accepted, 50) << MethodName(method);  // of 60
  }
}

// Teammate 1: 4 true loops and 6 nearby loops sharing one wrong offset (one pile spacing);
// teammate 2: 6 true loops. PCM with teammate 1 alone accepts the wrong group (the largest
// clique, above the minimum of 5); GCM tests them against teammate 2's loops through the
// map transforms and keeps the 10 true ones.
TEST(Filter, GcmRejectsCorrelatedGroupThatPcmAccepts) {
  World w(160);
  std::vector<msgs::InterRobotLoop> loops;
  const std::vector<std::pair<int, int>> true1{{2, 158}, {30, 122}, {55, 97}, {90, 60}};
  for (const auto& [i, k] : true1) loops.push_back(TrueLoop(w.poses[0], i, 1, w.poses[1], k));
  for (int g = 0; g < 6; ++g) {
    loops.push_back(TrueLoop(w.poses[0], 40 + g, 1, w.poses[1], 112 - g, {2.0, 0.0, 0.0}));
  }
  const std::vector<std::pair<int, int>> true2{{0, 0},   {20, 46},  {45, 70},
                                               {60, 30}, {100, 88}, {130, 120}};
  for (const auto& [i, k] : true2) loops.push_back(TrueLoop(w.poses[0], i, 2, w.poses[2], k));
  for (std::size_t id = 0; id < loops.size(); ++id) loops[id].id = id;
  for (const auto model : {CovarianceModel::kFirstLoop, CovarianceModel::kPropagated}) {
    FilterOptions fo;
    fo.pairwise.covariance = model;
    fo.method = Method::kPcm;
    ConsistencyFilter pcm(fo);
    const auto p = Ids(pcm.Add(loops, w.source).accepted);
    const std::set<std::uint64_t> wrong{4, 5, 6, 7, 8, 9};
    for (const auto id : wrong) EXPECT_TRUE(p.count(id)) << "PCM should fall for " << id;
    fo.method = Method::kGcm;
    ConsistencyFilter gcm(fo);
    const auto g = Ids(gcm.Add(loops, w.source).accepted);
    const std::set<std::uint64_t> good{0, 1, 2, 3, 10, 11, 12, 13, 14, 15};
    EXPECT_EQ(g, good) << CovarianceModelName(model);
  }
}

// The map-prior gate (GCM): a group sharing a 2 m offset disagrees with an accurate
// map-to-map guess and gets no edge; without a map transform for its teammate it is not
// gated. The span rule: a lone group over 3 own keyframes is no independent support.
TEST(Filter, MapPriorGateAndSpanRule) {
  World w(160);
  std::vector<msgs::InterRobotLoop> wrong;
  for (int g = 0; g < 6; ++g) {
    wrong.push_back(
        TrueLoop(w.poses[0], 40 + g / 2, 1, w.poses[1], 112 - (g + 1) / 2, {2.0, 0.0, 0.0}));
    wrong.back().id = static_cast<std::uint64_t>(g);
  }
  FilterOptions fo;
  fo.map_prior_gate = false;
  EXPECT_EQ(ConsistencyFilter(fo).Add(wrong, w.source).accepted.size(), 6u);
  fo.map_prior_gate = true;
  const Decision gated = ConsistencyFilter(fo).Add(wrong, w.source);
  EXPECT_TRUE(gated.accepted.empty());
  EXPECT_EQ(gated.prior_gated, 6);
  EXPECT_EQ(gated.pair_tests, 0);
  ChainPoseSource no_maps;  // the same chains, no map transforms
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 160; ++k) {
      no_maps.AddKeyframe(r, w.source.KeyframePose(r, k),
                          Eigen::Vector3d(4e-4, 4e-4, 1e-6).asDiagonal());
    }
  }
  EXPECT_EQ(ConsistencyFilter(fo).Add(wrong, no_maps).accepted.size(), 6u);
  fo.min_clique_span_keyframes = 5;
  EXPECT_TRUE(ConsistencyFilter(fo).Add(wrong, no_maps).accepted.empty());
  // True loops spread along the trajectory pass both.
  std::vector<msgs::InterRobotLoop> good;
  const std::vector<std::pair<int, int>> pairs{{2, 158}, {30, 122}, {55, 97}, {90, 60}, {20, 140}};
  for (const auto& [i, k] : pairs) {
    good.push_back(TrueLoop(w.poses[0], i, 1, w.poses[1], k));
    good.back().id = good.size();
  }
  EXPECT_EQ(ConsistencyFilter(fo).Add(good, w.source).accepted.size(), 5u);
}

// Map frames that do not start at the first keyframe (the agent's case): every robot's map
// frame is the world, map transforms the identity. The gate and GCM's cross-teammate pairs
// use InMap, so true loops pass and a shifted group is still gated.
TEST(Filter, MapFramesNeedNotStartAtTheFirstKeyframe) {
  World w(160);
  ChainPoseSource world_frames;
  for (int r = 0; r < 3; ++r) {
    for (const auto& p : w.poses[static_cast<std::size_t>(r)]) {
      world_frames.AddKeyframe(r, p, Eigen::Vector3d(4e-4, 4e-4, 1e-6).asDiagonal());
    }
  }
  for (int b = 1; b < 3; ++b) {
    world_frames.SetMapTransform(0, b, {Pose2{}, Eigen::Vector3d(0.01, 0.01, 1e-5).asDiagonal()});
  }
  ASSERT_GT(std::hypot(w.poses[1][0].x_m, w.poses[1][0].y_m), 10.0);
  std::vector<msgs::InterRobotLoop> loops;
  const std::vector<std::pair<int, int>> true1{{2, 158}, {30, 122}, {55, 97}, {90, 60}};
  for (const auto& [i, k] : true1) loops.push_back(TrueLoop(w.poses[0], i, 1, w.poses[1], k));
  const std::vector<std::pair<int, int>> true2{{0, 0}, {20, 46}, {45, 70}, {60, 30}};
  for (const auto& [i, k] : true2) loops.push_back(TrueLoop(w.poses[0], i, 2, w.poses[2], k));
  for (int g = 0; g < 6; ++g) {
    loops.push_back(
        TrueLoop(w.poses[0], 40 + g / 2, 1, w.poses[1], 112 - (g + 1) / 2, {2.0, 0.0, 0.0}));
  }
  for (std::size_t id = 0; id < loops.size(); ++id) loops[id].id = id;
  const Decision d = ConsistencyFilter().Add(loops, world_frames);
  EXPECT_EQ(d.accepted, (std::vector<std::uint64_t>{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(d.prior_gated, 6);
}

TEST(Filter, IncrementalEqualsBatch) {
  for (const auto kind : {synthetic::OutlierKind::kRandom, synthetic::OutlierKind::kCorrelated}) {
    for (const auto method : {Method::kPcm, Method::kGcm}) {
      synthetic::MissionOptions mo;
      mo.outlier_fraction = 0.6;
      mo.outliers = kind;
      mo.seed = 31;
      const auto m = synthetic::MakeMission(mo);
      FilterOptions fo;
      fo.method = method;
      fo.time_budget_ms = 0.0;
      ConsistencyFilter incremental(fo);
      Decision last;
      Feed(incremental, m, 3, &last);
      ConsistencyFilter batch(fo);
      const Decision all = batch.Add(m.loops, m.poses);
      EXPECT_EQ(last.accepted.size(), all.accepted.size()) << MethodName(method);
      // Equal-size maximum cliques may differ (a tie keeps the clique found first).
      std::vector<std::uint64_t> common;
      std::set_intersection(last.accepted.begin(), last.accepted.end(), all.accepted.begin(),
                            all.accepted.end(), std::back_inserter(common));
      EXPECT_GE(common.size() * 10, all.accepted.size() * 9) << MethodName(method);
      EXPECT_LT(last.pair_tests, all.pair_tests + 1);
    }
  }
}

// The optimised pair tests change nothing: same graph, same decisions, step by step, in
// both queue modes and for PCM and GCM, against the straightforward path and a source
// without open chains.
TEST(Filter, FastPairTestsGiveIdenticalDecisions) {
  for (const auto kind : {synthetic::OutlierKind::kRandom, synthetic::OutlierKind::kCorrelated}) {
    for (const auto method : {Method::kPcm, Method::kGcm}) {
      for (const auto queue : {QueueMode::kIncremental, QueueMode::kReference}) {
        synthetic::MissionOptions mo;
        mo.outlier_fraction = 0.6;
        mo.outliers = kind;
        mo.seed = 51;
        const auto m = synthetic::MakeMission(mo);
        const NotAChain opaque(m.poses);
        FilterOptions fo;
        fo.method = method;
        fo.queue = queue;
        ConsistencyFilter fast(fo);
        fo.fast_pair_tests = false;
        ConsistencyFilter slow(fo);
        fo.fast_pair_tests = true;
        ConsistencyFilter via_opaque(fo);
        std::size_t next = 0;
        for (int step = 0; next < m.loops.size(); step += 4) {
          std::vector<msgs::InterRobotLoop> batch;
          while (next < m.loops.size() && m.arrival[next] < step + 4) {
            batch.push_back(m.loops[next++]);
          }
          if (batch.empty()) continue;
          const Decision a = fast.Add(batch, m.poses);
          const Decision b = slow.Add(batch, m.poses);
          const Decision c = via_opaque.Add(batch, opaque);
          ASSERT_EQ(a.accepted, b.accepted) << "step " << step;
          ASSERT_EQ(a.newly_accepted, b.newly_accepted);
          ASSERT_EQ(a.retracted, b.retracted);
          ASSERT_EQ(a.clique_nodes, b.clique_nodes);
          ASSERT_EQ(c.accepted, b.accepted);
        }
      }
    }
  }
}

// The kernel searches (the default) decide as the searches over every candidate, step by
// step: the same accepted sets on these missions, and the same sizes in any case.
TEST(Filter, CliqueKernelGivesTheSameDecisions) {
  int steps = 0;
  int same_sets = 0;
  std::int64_t nodes_kernel = 0;
  std::int64_t nodes_full = 0;
  for (const auto kind : {synthetic::OutlierKind::kRandom, synthetic::OutlierKind::kCorrelated}) {
    for (const auto method : {Method::kPcm, Method::kGcm}) {
      for (const double outliers : {0.1, 0.6}) {
        synthetic::MissionOptions mo;
        mo.outlier_fraction = outliers;
        mo.outliers = kind;
        mo.inliers = 120;
        mo.seed = 71;
        const auto m = synthetic::MakeMission(mo);
        FilterOptions fo;
        fo.method = method;
        ConsistencyFilter kernel(fo);
        fo.clique_kernel = false;
        ConsistencyFilter full(fo);
        std::size_t next = 0;
        for (int step = 0; next < m.loops.size(); step += 2) {
          std::vector<msgs::InterRobotLoop> batch;
          while (next < m.loops.size() && m.arrival[next] < step + 2) {
            batch.push_back(m.loops[next++]);
          }
          if (batch.empty()) continue;
          const Decision a = kernel.Add(batch, m.poses);
          const Decision b = full.Add(batch, m.poses);
          ASSERT_TRUE(a.exact && b.exact);
          ASSERT_EQ(a.accepted.size(), b.accepted.size()) << "step " << step;
          ++steps;
          same_sets += a.accepted == b.accepted ? 1 : 0;
          nodes_kernel += a.clique_nodes;
          nodes_full += b.clique_nodes;
        }
      }
    }
  }
  EXPECT_GT(steps, 100);
  EXPECT_EQ(same_sets, steps);
  EXPECT_LT(nodes_kernel, nodes_full);
}

TEST(Filter, NodeBudgetIsDeterministicAndSaysSo) {
  synthetic::MissionOptions mo;
  mo.outlier_fraction = 0.6;
  mo.outliers = synthetic::OutlierKind::kCorrelated;
  mo.seed = 61;
  const auto m = synthetic::MakeMission(mo);
  FilterOptions fo;
  const Decision full = ConsistencyFilter(fo).Add(m.loops, m.poses);
  EXPECT_TRUE(full.exact);
  EXPECT_GT(full.clique_nodes, 3);
  fo.max_clique_nodes = 2;
  const Decision cut = ConsistencyFilter(fo).Add(m.loops, m.poses);
  EXPECT_FALSE(cut.exact);
  EXPECT_LE(cut.clique_nodes, 3);
  EXPECT_EQ(ConsistencyFilter(fo).Add(m.loops, m.poses).accepted, cut.accepted);
}

TEST(Filter, ReferenceQueueTrimsAfterSuccessAndNeverRetracts) {
  synthetic::MissionOptions mo;
  mo.outlier_fraction = 0.3;
  mo.seed = 41;
  const auto m = synthetic::MakeMission(mo);
  FilterOptions fo;
  fo.queue = QueueMode::kReference;
  ConsistencyFilter filter(fo);
  std::size_t accepted = 0;
  std::size_t next = 0;
  for (int step = 0; next < m.loops.size(); step += 5) {
    std::vector<msgs::InterRobotLoop> batch;
    while (next < m.loops.size() && m.arrival[next] < step + 5) batch.push_back(m.loops[next++]);
    if (batch.empty()) continue;
    const Decision d = filter.Add(batch, m.poses);
    EXPECT_TRUE(d.retracted.empty());
    EXPECT_GE(d.accepted.size(), accepted);
    accepted = d.accepted.size();
    // After a success the pair tests of the next step are against at most keep + new loops.
    EXPECT_LE(d.pair_tests, static_cast<std::int64_t>(m.loops.size() * batch.size()));
  }
  EXPECT_GT(accepted, 20u);
}

}  // namespace
}  // namespace draco::consistency
