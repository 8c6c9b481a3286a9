// Spectral relaxation per connected component of the affinity graph
// (MatcherOptions::spectral_components): a tied spectrum from two disconnected clusters, a
// bipartite component on which power iteration of the whole matrix never converges, and a
// clear match left as it was.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <vector>

#include "draco/objects/graph_matcher.hpp"
#include "object_world.hpp"

namespace draco::objects {
namespace {

using msgs::MatchStatus;

// Six objects of distinct sizes at irregular places (no symmetry of their own).
std::vector<msgs::Object> Cluster() {
  const double xy[6][2] = {{0, 0}, {9, 2}, {4, 11}, {-6, 7}, {14, 9}, {2, -8}};
  const double size[6][2] = {{3, 1}, {5, 2}, {7, 3}, {4, 1.5}, {9, 4}, {6, 1}};
  std::vector<msgs::Object> out(6);
  for (int i = 0; i < 6; ++i) {
    out[i].center = {xy[i][0], xy[i][1]};
    out[i].length_m = size[i][0];
    out[i].breadth_m = size[i][1];
  }
  return out;
}

// Map a holds the cluster twice, 200 m apart; map b holds it once, turned and moved. Both
// copies fit b equally well: the affinity graph has two components of equal eigenvalue.
struct TwoCopies {
  msgs::ObjectMap a, b;
  msgs::Pose2 T_first{-20.0, 35.0, 0.4}, T_second;  // a's frame <- b's, for each copy
};
TwoCopies MakeTwoCopies() {
  TwoCopies s;
  const auto cluster = Cluster();
  for (int copy = 0; copy < 2; ++copy) {
    for (std::size_t i = 0; i < cluster.size(); ++i) {
      msgs::Object o = cluster[i];
      o.center.x_m += 200.0 * copy;
      o.id = static_cast<std::uint32_t>(10 * copy + i);
      s.a.objects.push_back(o);
    }
  }
  const msgs::Pose2 T_b_a = world::Inverse(s.T_first);
  for (std::size_t i = 0; i < cluster.size(); ++i) {
    msgs::Object o = cluster[i];
    o.center = Transform(T_b_a, o.center);
    o.id = static_cast<std::uint32_t>(100 + i);
    s.b.objects.push_back(o);
  }
  s.T_second = world::Compose({200.0, 0.0, 0.0}, s.T_first);
  return s;
}

bool Close(const msgs::Pose2& x, const msgs::Pose2& y) {
  return std::hypot(x.x_m - y.x_m, x.y_m - y.y_m) <= 0.5 &&
         std::abs(NormalizeAngle(x.yaw_rad - y.yaw_rad)) <= 0.01;
}

TEST(SpectralComponents, TwoDisconnectedCopiesGiveATiedSpectrum) {
  const TwoCopies s = MakeTwoCopies();
  const MatcherOptions options;
  const SparseAffinity affinity = BuildAffinity(s.a, s.b, options);
  const auto components = AffinityComponents(affinity, options);
  // The two largest (smaller ones pair objects of similar size at a coincidental distance).
  ASSERT_GE(components.size(), 2u);
  EXPECT_NEAR(components[1].eigenvalue / components[0].eigenvalue, 1.0, 1e-9);
  if (components.size() > 2) {
    EXPECT_LT(components[2].eigenvalue, 0.5 * components[0].eigenvalue);
  }
  std::set<int> copies;  // each pairs b with one copy of a only
  for (int k = 0; k < 2; ++k) {
    const auto& c = components[k];
    EXPECT_LT(c.iterations, options.max_power_iterations);
    std::set<int> copy;
    for (const int m : c.members) copy.insert(affinity.candidates[m].first / 6);
    ASSERT_EQ(copy.size(), 1u);
    copies.insert(*copy.begin());
  }
  EXPECT_EQ(copies.size(), 2u);
  // The whole matrix's power iteration returns a mix of both: half of the two components'
  // weight on each.
  const auto x = PrincipalEigenvector(affinity, options);
  double on[2] = {0.0, 0.0};
  for (int k = 0; k < 2; ++k) {
    for (const int m : components[k].members) on[k] += x[m] * x[m];
  }
  std::printf("whole matrix: weight %.4f on one copy's component, %.4f on the other's\n", on[0],
              on[1]);
  EXPECT_NEAR(on[0], on[1], 1e-6);
  EXPECT_GT(on[0] + on[1], 0.99);
}

TEST(SpectralComponents, TiedCopiesAreAmbiguousAndTheMixIsNot) {
  const TwoCopies s = MakeTwoCopies();
  // The whole matrix: the assignment draws on the mix (the linear assignment's tie-break
  // takes the first copy) and answers with no evidence for one copy over the other.
  const auto mixed = MatchObjectMaps(s.a, s.b, {});
  EXPECT_EQ(mixed.status, MatchStatus::kMatched);
  // Per component: one hypothesis per copy, both matched and 200 m apart: refused.
  const auto split = MatchObjectMaps(s.a, s.b, {.spectral_components = true});
  EXPECT_EQ(split.status, MatchStatus::kAmbiguous);
  EXPECT_GT(split.ambiguity, 0.99);
  // With only the best component (a tie ratio above 1), the first copy (lowest candidates on
  // the tie) is matched, exactly.
  const auto best =
      MatchObjectMaps(s.a, s.b, {.spectral_components = true, .component_tie_ratio = 1.5});
  ASSERT_EQ(best.status, MatchStatus::kMatched);
  EXPECT_TRUE(Close(best.T_a_b, s.T_first));
  EXPECT_EQ(best.num_inliers, 6);
  // Only the second copy in map a: matched at the second copy's place.
  msgs::ObjectMap a2 = s.a;
  a2.objects.erase(a2.objects.begin(), a2.objects.begin() + 6);
  const auto second = MatchObjectMaps(a2, s.b, {.spectral_components = true});
  ASSERT_EQ(second.status, MatchStatus::kMatched);
  EXPECT_TRUE(Close(second.T_a_b, s.T_second));
}

// A star of candidates (a tree, so bipartite): -lambda is an eigenvalue too and power iteration
// of the whole matrix from the uniform vector swings between two vectors until its cap; the
// shifted iteration per component converges to the positive eigenvector.
TEST(SpectralComponents, BipartiteComponentConverges) {
  SparseAffinity affinity;
  affinity.n_a = 4;
  affinity.n_b = 4;
  affinity.candidates = {{0, 0}, {1, 1}, {2, 2}, {3, 3}};
  affinity.entries = {{0, 1, 0.9f, 0.9f}, {0, 2, 0.5f, 0.5f}, {0, 3, 0.2f, 0.2f}};
  const MatcherOptions options;
  int iterations = 0;
  const auto x = PrincipalEigenvector(affinity, options, &iterations);
  EXPECT_EQ(iterations, options.max_power_iterations);
  const auto components = AffinityComponents(affinity, options);
  ASSERT_EQ(components.size(), 1u);
  const auto& c = components[0];
  EXPECT_LT(c.iterations, options.max_power_iterations);
  const double lambda = std::sqrt(0.81 + 0.25 + 0.04);  // the star's top eigenvalue
  EXPECT_NEAR(c.eigenvalue, lambda, 1e-6);
  // v = (lambda, 0.9, 0.5, 0.2) / norm.
  const double norm = std::sqrt(lambda * lambda + 1.1);
  const double v[4] = {lambda / norm, 0.9 / norm, 0.5 / norm, 0.2 / norm};
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(c.vector[i], v[i], 1e-6);
  // The whole matrix's vector is off: the centre's weight against the leaves' is set by where
  // the swing stopped.
  std::printf("whole matrix: centre %.4f (Perron %.4f) after %d iterations\n", x[0], v[0],
              iterations);
  EXPECT_GT(std::abs(x[0] - v[0]), 0.05);
}

// A clear match (random worlds of the matcher tests): the same answers with and without the
// split.
TEST(SpectralComponents, ClearMatchesUnchanged) {
  int same = 0, right_split = 0, right_whole = 0, trials = 0;
  for (std::uint64_t seed = 0; trials < 30; ++seed) {
    std::mt19937_64 rng(3000 + seed);
    const world::WorldOptions wo;
    const auto w = world::RandomWorld(&rng, wo);
    std::vector<int> va, vb;
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < static_cast<int>(w.size()); ++i) {
      if (u(rng) < 0.7) va.push_back(i);
      if (u(rng) < 0.7) vb.push_back(i);
    }
    const msgs::Pose2 T_w_a{10.0, -20.0, 0.3}, T_w_b{-30.0, 5.0, 2.0};
    const auto a = world::View(w, va, T_w_a, 3, wo, &rng);
    const auto b = world::View(w, vb, T_w_b, 3, wo, &rng);
    const msgs::Pose2 truth = world::Compose(world::Inverse(T_w_a), T_w_b);
    ++trials;
    const auto whole = MatchObjectMaps(a, b, {});
    const auto split = MatchObjectMaps(a, b, {.spectral_components = true});
    const auto right = [&](const msgs::ObjectMatch& m) {
      return m.status == MatchStatus::kMatched &&
             std::hypot(m.T_a_b.x_m - truth.x_m, m.T_a_b.y_m - truth.y_m) <= 2.0;
    };
    right_whole += right(whole);
    right_split += right(split);
    same += whole.status == split.status && whole.num_inliers == split.num_inliers;
  }
  std::printf("right: whole matrix %d / %d, per component %d; same answer %d\n", right_whole,
              trials, right_split, same);
  EXPECT_GE(right_split, right_whole);
  EXPECT_GE(right_split, 27);
}

TEST(SpectralComponents, Deterministic) {
  const TwoCopies s = MakeTwoCopies();
  msgs::ObjectMap a2 = s.a;
  a2.objects.erase(a2.objects.begin(), a2.objects.begin() + 6);
  const MatcherOptions options{.spectral_components = true};
  const auto m1 = MatchObjectMaps(a2, s.b, options), m2 = MatchObjectMaps(a2, s.b, options);
  EXPECT_EQ(m1.status, m2.status);
  EXPECT_EQ(m1.T_a_b.x_m, m2.T_a_b.x_m);
  EXPECT_EQ(m1.num_inliers, m2.num_inliers);
}

}  // namespace
}  // namespace draco::objects
