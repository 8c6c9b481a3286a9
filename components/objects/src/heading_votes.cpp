// Object-graph matching by translation votes under the rotation the map headings give
// (graph_matcher_internal.hpp MatchByHeadingVotes, MatcherOptions::heading_votes).
#include <algorithm>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "draco/objects/geometry.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "graph_matcher_internal.hpp"

namespace draco::objects::detail {
namespace {

using msgs::MatchStatus;
using msgs::ObjectMap;

}  // namespace

bool VoteCompatible(const msgs::Object& p, const msgs::Object& q, const MatcherOptions& options) {
  if (p.landmark != q.landmark) return false;
  return p.landmark || Shape(p, q, options) >= options.min_shape_similarity;
}

int VoteSupport(const ObjectMap& a, const ObjectMap& b, const Pose2& T,
                const MatcherOptions& options) {
  int n = 0;
  for (const auto& ob : b.objects) {
    const Point2 q = Transform(T, ob.center);
    for (const auto& oa : a.objects) {
      if (Distance(oa.center, q) < options.heading_vote_inlier_m &&
          VoteCompatible(oa, ob, options)) {
        ++n;
        break;
      }
    }
  }
  return n;
}

double VoteMissPenalty(const ObjectMap& b, const Pose2& T, const MatcherOptions& options,
                       const VoteEvidence& evidence) {
  if (!evidence.On(options)) return 0.0;
  const PointSupport seen =
      SupportByPoints(b, T, *evidence.points_a, *evidence.coverage_a, options.vote_miss_margin_m,
                      options.vote_miss_min_points);
  return options.vote_miss_weight * seen.Misses();
}

double VoteScore(const ObjectMap& a, const ObjectMap& b, const Pose2& T,
                 const MatcherOptions& options, const VoteEvidence& evidence) {
  return VoteSupport(a, b, T, options) - VoteMissPenalty(b, T, options, evidence);
}

bool Distinct(const ObjectMap& b, const Pose2& x, const Pose2& y, double distinct_m) {
  if (b.objects.empty()) return false;
  double moved = 0.0;
  for (const auto& ob : b.objects)
    moved += Distance(Transform(x, ob.center), Transform(y, ob.center));
  return moved / double(b.objects.size()) > distinct_m;
}

// Translation votes under a known rotation (MatcherOptions::heading_votes).
msgs::ObjectMatch MatchByHeadingVotes(const ObjectMap& a, const ObjectMap& b, double yaw_prior,
                                      const MatcherOptions& options, const VoteEvidence& evidence,
                                      VotePeaks* scored) {
  msgs::ObjectMatch match;
  match.robot_a = a.robot_id;
  match.robot_b = b.robot_id;
  const int na = static_cast<int>(a.objects.size()), nb = static_cast<int>(b.objects.size());
  if (std::min(na, nb) < options.min_objects) {
    match.status = MatchStatus::kTooFewObjects;
    return match;
  }
  const auto compatible = [&](const msgs::Object& p, const msgs::Object& q) {
    return VoteCompatible(p, q, options);
  };
  std::vector<std::pair<int, int>> cand;
  for (int i = 0; i < na; ++i) {
    for (int k = 0; k < nb; ++k) {
      if (compatible(a.objects[i], b.objects[k])) cand.emplace_back(i, k);
    }
  }
  match.num_candidates = static_cast<int>(cand.size());
  if (cand.empty()) {
    match.status = MatchStatus::kNoCandidates;
    return match;
  }
  const double thr = options.heading_vote_inlier_m, cell = options.heading_vote_cell_m;
  const auto support = [&](const Pose2& T) { return VoteSupport(a, b, T, options); };
  struct Peak {
    Pose2 T;
    int support = 0;
    double score = 0.0;  // support less the own sonar's misses
  };
  std::vector<Peak> peaks;
  const int steps = options.heading_vote_step_rad > 0.0
                        ? static_cast<int>(std::floor(options.heading_vote_turn_rad /
                                                      options.heading_vote_step_rad))
                        : 0;
  for (int s = -steps; s <= steps; ++s) {
    const double yaw = yaw_prior + s * options.heading_vote_step_rad;
    const double c = std::cos(yaw), sn = std::sin(yaw);
    std::map<std::pair<long, long>, std::vector<Point2>> cells;
    for (const auto& [i, k] : cand) {
      const Point2& pa = a.objects[i].center;
      const Point2& pb = b.objects[k].center;
      const Point2 t{pa.x_m - (c * pb.x_m - sn * pb.y_m), pa.y_m - (sn * pb.x_m + c * pb.y_m)};
      cells[{std::lround(std::floor(t.x_m / cell)), std::lround(std::floor(t.y_m / cell))}]
          .push_back(t);
    }
    // The densest 2 x 2 blocks of cells; each block's mean translation is a hypothesis.
    std::vector<std::pair<std::size_t, Point2>> blocks;
    for (const auto& [key, votes] : cells) {
      std::size_t n = 0;
      Point2 sum{0.0, 0.0};
      for (long dx = 0; dx <= 1; ++dx) {
        for (long dy = 0; dy <= 1; ++dy) {
          const auto it = cells.find({key.first + dx, key.second + dy});
          if (it == cells.end()) continue;
          n += it->second.size();
          for (const auto& t : it->second) sum.x_m += t.x_m, sum.y_m += t.y_m;
        }
      }
      if (n >= 2) blocks.push_back({n, {sum.x_m / double(n), sum.y_m / double(n)}});
    }
    std::sort(blocks.begin(), blocks.end(), [](const auto& l, const auto& r) {
      return l.first > r.first ||
             (l.first == r.first && (l.second.x_m < r.second.x_m || (l.second.x_m == r.second.x_m &&
                                                                     l.second.y_m < r.second.y_m)));
    });
    if (blocks.size() > 8) blocks.resize(8);
    for (const auto& [n, t] : blocks) {
      const Pose2 T{t.x_m, t.y_m, yaw};
      const int n_in = support(T);
      peaks.push_back({T, n_in, n_in - VoteMissPenalty(b, T, options, evidence)});
    }
  }
  if (scored) {
    for (const auto& p : peaks) scored->T.push_back(p.T), scored->score.push_back(p.score);
  }
  if (peaks.empty()) {
    match.status = MatchStatus::kTooFewInliers;
    return match;
  }
  std::size_t win = 0;
  for (std::size_t p = 1; p < peaks.size(); ++p) {
    if (peaks[p].score > peaks[win].score) win = p;
  }
  const auto distinct = [&](const Pose2& x, const Pose2& y) {
    double moved = 0.0;
    for (const auto& ob : b.objects)
      moved += Distance(Transform(x, ob.center), Transform(y, ob.center));
    return moved / double(nb) > options.distinct_m;
  };
  double runner_up = 0.0;
  for (const auto& p : peaks) {
    if (p.score > runner_up && distinct(p.T, peaks[win].T)) runner_up = p.score;
  }
  match.num_ransac_inliers = peaks[win].support;
  match.ambiguity = std::max(0.0, runner_up - 2.0) / std::max(1e-9, peaks[win].score - 2.0);
  const int min_inliers = std::max(options.min_inliers, options.heading_vote_min_inliers);
  if (peaks[win].score < min_inliers) {  // the score: the support less the own misses
    match.status = MatchStatus::kTooFewInliers;
    return match;
  }
  if (match.ambiguity >= options.max_vote_ambiguity) {
    match.status = MatchStatus::kAmbiguous;
    return match;
  }
  // Pairs: each b object with its nearest compatible a object within thr; refit twice.
  Pose2 T = peaks[win].T;
  std::vector<std::pair<int, int>> pairs;
  for (int round = 0; round < 2; ++round) {
    pairs.clear();
    std::vector<Point2> qa, qb;
    std::vector<char> used(static_cast<std::size_t>(na), 0);
    for (int k = 0; k < nb; ++k) {
      const Point2 q = Transform(T, b.objects[k].center);
      int best = -1;
      double best_d = thr;
      for (int i = 0; i < na; ++i) {
        const double d = Distance(a.objects[i].center, q);
        if (d < best_d && !used[std::size_t(i)] && compatible(a.objects[i], b.objects[k]))
          best = i, best_d = d;
      }
      if (best < 0) continue;
      used[std::size_t(best)] = 1;
      pairs.emplace_back(best, k);
      qa.push_back(a.objects[best].center);
      qb.push_back(b.objects[k].center);
    }
    if (static_cast<int>(pairs.size()) < min_inliers) {
      match.status = MatchStatus::kTooFewInliers;
      match.num_inliers = static_cast<int>(pairs.size());
      return match;
    }
    T = FitRigid(qa, qb);
  }
  match.by_votes = true;
  if (!HeadingAllows(yaw_prior, T.yaw_rad, options.max_heading_gap_rad)) {
    match.status = MatchStatus::kHeadingMismatch;
    return match;
  }
  SetMatched(a, b, T, pairs, &match);
  return match;
}

}  // namespace draco::objects::detail
