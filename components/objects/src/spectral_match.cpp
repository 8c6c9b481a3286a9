// The spectral object-graph matcher (graph_matcher_internal.hpp MatchSpectral): 1. spectral
// relaxation of the QAP, 2. linear assignment, 3. RANSAC over pairs of assignments, then
// verification over all objects (negative evidence, ambiguity), 4. re-matching in the aligned
// frame, 5. the outcome.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <utility>
#include <vector>

#include "draco/objects/assignment.hpp"
#include "draco/objects/geometry.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "graph_matcher_internal.hpp"

namespace draco::objects::detail {
namespace {

using msgs::MatchStatus;
using msgs::ObjectMap;

Pose2 Inverse(const Pose2& T) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {-(c * T.x_m + s * T.y_m), s * T.x_m - c * T.y_m, -T.yaw_rad};
}

struct Hypothesis {
  Pose2 T;
  int inliers = -1;
  int misses = 0;
  double score = -std::numeric_limits<double>::infinity();  // inliers - miss_weight * misses
  double cost = std::numeric_limits<double>::infinity();
};

// Inliers (residual < threshold) and the truncated squared cost (MSAC) of T.
Hypothesis Score(const Pose2& T, const std::vector<Point2>& pa, const std::vector<Point2>& pb,
                 double threshold, std::vector<char>* inlier) {
  Hypothesis h{T, 0, 0, 0.0, 0.0};
  if (inlier) inlier->assign(pa.size(), 0);
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  for (std::size_t i = 0; i < pa.size(); ++i) {
    const Point2 q{T.x_m + c * pb[i].x_m - s * pb[i].y_m, T.y_m + s * pb[i].x_m + c * pb[i].y_m};
    const double r = Distance(pa[i], q);
    if (r < threshold) {
      ++h.inliers;
      if (inlier) (*inlier)[i] = 1;
    }
    h.cost += std::min(r * r, threshold * threshold);
  }
  h.score = h.inliers;
  return h;
}

bool Better(const Hypothesis& x, const Hypothesis& y) {
  return x.score > y.score || (x.score == y.score && x.cost < y.cost);
}

// Steps 2-5 for one vector of assignment weights (n_a x n_b); match carries step 1's counters.
msgs::ObjectMatch MatchWeights(const ObjectMap& a, const ObjectMap& b,
                               const std::vector<double>& weights, const MatcherOptions& options,
                               const Coverage* coverage_a, const Coverage* coverage_b,
                               msgs::ObjectMatch match) {
  const std::optional<double> yaw_prior = HeadingYawPrior(a, b);
  const auto heading_ok = [&](const Pose2& T) {
    return HeadingAllows(yaw_prior, T.yaw_rad, options.max_heading_gap_rad);
  };
  const int na = static_cast<int>(a.objects.size()), nb = static_cast<int>(b.objects.size());
  // 2. Linear assignment on the negated weights.
  std::vector<double> cost(weights.size());
  for (std::size_t c = 0; c < weights.size(); ++c) cost[c] = -weights[c];
  const std::vector<int> col = SolveAssignment(cost, na, nb);
  std::vector<Point2> pa, pb;
  for (int i = 0; i < na; ++i) {
    if (col[i] < 0) continue;
    if (!options.keep_zero_weight_assignments && weights[std::size_t(i) * nb + col[i]] <= 0.0) {
      continue;
    }
    pa.push_back(a.objects[i].center);
    pb.push_back(b.objects[col[i]].center);
  }
  match.num_assignments = static_cast<int>(pa.size());
  if (match.num_assignments < options.min_assignments) {
    match.status = MatchStatus::kTooFewAssignments;
    return match;
  }
  // Negative evidence of a transform, both ways.
  const bool negative = options.miss_weight > 0.0 && (coverage_a || coverage_b);
  const auto misses = [&](const Pose2& T) {
    int m = 0;
    if (coverage_a && !coverage_a->empty()) {
      m += CountMisses(b, a, T, *coverage_a, options.miss_distance_m);
    }
    if (coverage_b && !coverage_b->empty()) {
      m += CountMisses(a, b, Inverse(T), *coverage_b, options.miss_distance_m);
    }
    return m;
  };
  const auto charge = [&](Hypothesis* h) {
    if (!negative) return;
    h->misses = misses(h->T);
    h->score = h->inliers - options.miss_weight * h->misses;
  };
  // 3. RANSAC over pairs of assignments (every pair when there are few).
  const std::size_t n = pa.size();
  const double thr = options.ransac_threshold_m;
  Hypothesis best;
  const bool ambiguity = options.max_ambiguity_ratio > 0.0;
  auto try_sample = [&](std::size_t s, std::size_t t) {
    const double da = Distance(pa[s], pa[t]), db = Distance(pb[s], pb[t]);
    if (da < 1e-6 || std::abs(da - db) > thr) return;  // a rigid motion keeps distances
    const Pose2 T = FitRigid({pa[s], pa[t]}, {pb[s], pb[t]});
    if (!heading_ok(T)) return;
    Hypothesis h = Score(T, pa, pb, thr, nullptr);
    charge(&h);
    if (Better(h, best)) best = h;
  };
  const std::size_t all_pairs = n * (n - 1) / 2;
  if (all_pairs <= static_cast<std::size_t>(std::max(0, options.ransac_iterations))) {
    for (std::size_t s = 0; s < n; ++s) {
      for (std::size_t t = s + 1; t < n; ++t) try_sample(s, t);
    }
  } else {
    std::mt19937_64 rng(options.seed);
    for (int it = 0; it < options.ransac_iterations; ++it) {
      const std::size_t s = rng() % n;
      std::size_t t = rng() % (n - 1);
      if (t >= s) ++t;
      try_sample(s, t);
    }
  }
  if (best.inliers < 0) best.inliers = 0;
  if (best.inliers >= 2) {  // refit on the inliers while that does not lose any
    std::vector<char> inlier;
    Score(best.T, pa, pb, thr, &inlier);
    std::vector<Point2> qa, qb;
    for (std::size_t i = 0; i < n; ++i) {
      if (inlier[i]) qa.push_back(pa[i]), qb.push_back(pb[i]);
    }
    Hypothesis refit = Score(FitRigid(qa, qb), pa, pb, thr, nullptr);
    charge(&refit);
    if (!Better(best, refit) && heading_ok(refit.T)) best = refit;
  }
  match.num_ransac_inliers = best.inliers;
  if (best.inliers < options.min_inliers) {
    match.status = MatchStatus::kTooFewInliers;
    return match;
  }
  // Verification over all objects (negative evidence, ambiguity). RANSAC above only sees the
  // one-to-one assignment, which along a row of identical piles holds one shift only; here the
  // hypotheses also come from pairs of each object's top eigenvector candidates, and each is
  // scored by its support (b objects landing within the threshold of an a object) minus
  // miss_weight x misses. The best-supported hypothesis replaces RANSAC's when it is distinct
  // and better; the ambiguity is the runner-up's support beyond a two-point sample over the
  // winner's.
  if (negative || ambiguity) {
    const auto support = [&](const Pose2& T) {
      int n_in = 0;
      for (const auto& ob : b.objects) {
        const Point2 q = Transform(T, ob.center);
        for (const auto& oa : a.objects) {
          if (Distance(oa.center, q) < thr) {
            ++n_in;
            break;
          }
        }
      }
      return n_in - (negative ? options.miss_weight * misses(T) : 0.0);
    };
    const auto distinct = [&](const Pose2& x, const Pose2& y) {
      if (std::abs(NormalizeAngle(x.yaw_rad - y.yaw_rad)) > options.distinct_rad) return true;
      double moved = 0.0;
      for (const auto& ob : b.objects)
        moved += Distance(Transform(x, ob.center), Transform(y, ob.center));
      return moved / double(nb) > options.distinct_m;
    };
    // Candidate correspondences: the top verify_candidates b objects of each a object.
    std::vector<std::pair<Point2, Point2>> corr;
    std::vector<std::pair<int, int>> corr_ik;
    for (int i = 0; i < na; ++i) {
      std::vector<int> ks;
      for (int k = 0; k < nb; ++k) {
        if (weights[std::size_t(i) * nb + k] > 0.0) ks.push_back(k);
      }
      std::sort(ks.begin(), ks.end(), [&](int x, int y) {
        return weights[std::size_t(i) * nb + x] > weights[std::size_t(i) * nb + y] ||
               (weights[std::size_t(i) * nb + x] == weights[std::size_t(i) * nb + y] && x < y);
      });
      if (static_cast<int>(ks.size()) > options.verify_candidates)
        ks.resize(options.verify_candidates);
      for (const int k : ks) {
        corr.emplace_back(a.objects[i].center, b.objects[k].center);
        corr_ik.emplace_back(i, k);
      }
    }
    std::vector<Pose2> hyps{best.T};
    const auto add = [&](std::size_t u, std::size_t v) {
      if (corr_ik[u].first == corr_ik[v].first || corr_ik[u].second == corr_ik[v].second) return;
      const double da = Distance(corr[u].first, corr[v].first);
      const double db = Distance(corr[u].second, corr[v].second);
      if (da < 1e-6 || std::abs(da - db) > thr) return;
      const Pose2 T = FitRigid({corr[u].first, corr[v].first}, {corr[u].second, corr[v].second});
      if (heading_ok(T)) hyps.push_back(T);
    };
    const std::size_t m = corr.size();
    if (m * (m - 1) / 2 <= static_cast<std::size_t>(std::max(0, options.verify_iterations))) {
      for (std::size_t u = 0; u < m; ++u) {
        for (std::size_t v = u + 1; v < m; ++v) add(u, v);
      }
    } else if (m >= 2) {
      std::mt19937_64 rng(options.seed + 1);
      for (int it = 0; it < options.verify_iterations; ++it) {
        const std::size_t u = rng() % m;
        std::size_t v = rng() % (m - 1);
        if (v >= u) ++v;
        add(u, v);
      }
    }
    std::vector<double> score(hyps.size());
    std::size_t win = 0;
    for (std::size_t h = 0; h < hyps.size(); ++h) {
      score[h] = support(hyps[h]);
      if (score[h] > score[win] && distinct(hyps[h], hyps[0])) win = h;
    }
    if (win != 0) best.T = hyps[win];
    double runner_up = 0.0;
    for (std::size_t h = 0; h < hyps.size(); ++h) {
      if (score[h] > runner_up && distinct(hyps[h], hyps[win])) runner_up = score[h];
    }
    match.ambiguity = std::max(0.0, runner_up - 2.0) / std::max(1e-9, score[win] - 2.0);
    if (ambiguity && match.ambiguity >= options.max_ambiguity_ratio) {
      match.status = MatchStatus::kAmbiguous;
      return match;
    }
  }
  // 4. Re-match every object in the aligned frame on centre distance; refit (twice, so the
  // second assignment sees the refined transform).
  Pose2 T = best.T;
  std::vector<std::pair<int, int>> pairs;
  for (int round = 0; round < 2; ++round) {
    std::vector<Point2> moved_b(nb);
    for (int k = 0; k < nb; ++k) moved_b[k] = Transform(T, b.objects[k].center);
    std::vector<double> d(std::size_t(na) * nb);
    for (int i = 0; i < na; ++i) {
      for (int k = 0; k < nb; ++k)
        d[std::size_t(i) * nb + k] = Distance(a.objects[i].center, moved_b[k]);
    }
    // Gated cost: every pair beyond the gate costs the same, so far pairs never pull the
    // assignment away from near ones (with plain distances, two rows of piles shifted by
    // one pile have equal-cost assignments that pair no pile with its neighbour).
    std::vector<double> gated(d.size());
    for (std::size_t c = 0; c < d.size(); ++c)
      gated[c] = std::min(d[c], options.rematch_distance_m);
    const std::vector<int> rematch = SolveAssignment(gated, na, nb);
    std::vector<std::pair<int, int>> kept;
    std::vector<Point2> qa, qb;
    for (int i = 0; i < na; ++i) {
      if (rematch[i] < 0 || d[std::size_t(i) * nb + rematch[i]] >= options.rematch_distance_m) {
        continue;
      }
      kept.emplace_back(i, rematch[i]);
      qa.push_back(a.objects[i].center);
      qb.push_back(b.objects[rematch[i]].center);
    }
    if (static_cast<int>(kept.size()) < options.min_inliers) {
      match.status = MatchStatus::kTooFewInliers;
      match.num_inliers = static_cast<int>(kept.size());
      return match;
    }
    T = FitRigid(qa, qb);
    if (kept == pairs) break;
    pairs = std::move(kept);
  }
  // 5. Outcome (the headings' bound and negative evidence of the final transform first).
  if (!heading_ok(T)) {
    match.status = MatchStatus::kHeadingMismatch;
    match.num_inliers = static_cast<int>(pairs.size());
    return match;
  }
  if (negative) {
    match.num_misses = misses(T);
    if (double(pairs.size()) - options.miss_weight * match.num_misses < options.min_inliers) {
      match.status = MatchStatus::kContradicted;
      match.num_inliers = static_cast<int>(pairs.size());
      return match;
    }
  }
  SetMatched(a, b, T, pairs, &match);
  return match;
}

}  // namespace

msgs::ObjectMatch MatchSpectral(const ObjectMap& a, const ObjectMap& b,
                                const MatcherOptions& options, const Coverage* coverage_a,
                                const Coverage* coverage_b) {
  msgs::ObjectMatch match;
  match.robot_a = a.robot_id;
  match.robot_b = b.robot_id;
  const int na = static_cast<int>(a.objects.size()), nb = static_cast<int>(b.objects.size());
  const int edges = std::min(na * (na - 1), nb * (nb - 1)) / 2;
  if (std::min(na, nb) < options.min_objects || edges < options.min_edges) {
    match.status = MatchStatus::kTooFewObjects;
    return match;
  }
  // 1. Spectral relaxation of the QAP: one weight vector, or one per competing component of
  // the affinity graph (MatcherOptions::spectral_components).
  const std::vector<std::vector<double>> hypotheses =
      AssignmentHypotheses(a, b, options, &match.num_candidates, &match.num_affinity_entries);
  if (hypotheses.empty() || match.num_candidates == 0 || match.num_affinity_entries == 0) {
    match.status = MatchStatus::kNoCandidates;
    return match;
  }
  // Competing components: the best component answers; another that matches elsewhere
  // (distinct_m, distinct_rad) makes the answer ambiguous. A competitor never answers itself:
  // one that matches where the best component found nothing is a guess between near-equal
  // eigenvalues (on tuning seed 4 it placed two pairs 2.5 m / 5 deg off).
  const msgs::ObjectMatch best =
      MatchWeights(a, b, hypotheses[0], options, coverage_a, coverage_b, match);
  if (best.status != MatchStatus::kMatched) return best;
  for (std::size_t h = 1; h < hypotheses.size(); ++h) {
    const msgs::ObjectMatch rival =
        MatchWeights(a, b, hypotheses[h], options, coverage_a, coverage_b, match);
    if (rival.status != MatchStatus::kMatched) continue;
    const Pose2 &x = best.T_a_b, &y = rival.T_a_b;
    if (std::abs(NormalizeAngle(x.yaw_rad - y.yaw_rad)) > options.distinct_rad ||
        Distinct(b, x, y, options.distinct_m)) {
      msgs::ObjectMatch refused = best;
      refused.status = MatchStatus::kAmbiguous;
      refused.ambiguity =
          std::max(0, rival.num_inliers - 2) / std::max(1e-9, double(best.num_inliers - 2));
      return refused;
    }
  }
  return best;
}

}  // namespace draco::objects::detail
