// Pieces the object-graph matcher's files share (graph_matcher.hpp), private to
// draco_objects: the centre distance and shape term of the affinity, and the two matchers
// MatchObjectMaps chooses between (spectral_match.cpp, heading_votes.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "draco/objects/geometry.hpp"
#include "draco/objects/graph_matcher.hpp"

namespace draco::objects::detail {

inline double Distance(const Point2& p, const Point2& q) {
  const double dx = p.x_m - q.x_m, dy = p.y_m - q.y_m;
  return std::sqrt(dx * dx + dy * dy);  // not hypot: no overflow here, and 5x faster
}

// Shape term of one vertex pair: the code's s(i,k) = exp(-2 (|dl| + |db|)); the paper's
// exp(-(|dl| + |db|)); kRelative: the code's with the difference divided by
// 1 + relative_shape_per_m * max(l_i, l_k) (partial views of large objects differ more).
inline double Shape(const msgs::Object& p, const msgs::Object& q, const MatcherOptions& o) {
  const double d = std::abs(p.length_m - q.length_m) + std::abs(p.breadth_m - q.breadth_m);
  switch (o.affinity) {
    case AffinityForm::kPaper:
      return std::exp(-d);
    case AffinityForm::kRelative:
      return std::exp(-2.0 * d / (1.0 + o.relative_shape_per_m * std::max(p.length_m, q.length_m)));
    case AffinityForm::kCode:
      break;
  }
  return std::exp(-2.0 * d);
}

// A match's answer from its transform and object pairs (indices into a and b): status
// kMatched, the pairs with their residuals, inliers, RMSE and confidence.
inline void SetMatched(const msgs::ObjectMap& a, const msgs::ObjectMap& b, const Pose2& T,
                       const std::vector<std::pair<int, int>>& pairs, msgs::ObjectMatch* match) {
  match->status = msgs::MatchStatus::kMatched;
  match->T_a_b = T;
  match->T_a_b.yaw_rad = NormalizeAngle(T.yaw_rad);
  double sum2 = 0.0;
  for (const auto& [i, k] : pairs) {
    const double r = Distance(a.objects[i].center, Transform(T, b.objects[k].center));
    match->pairs.push_back({a.objects[i].id, b.objects[k].id, r});
    sum2 += r * r;
  }
  match->num_inliers = static_cast<int>(pairs.size());
  match->rmse_m = std::sqrt(sum2 / double(pairs.size()));
  const auto n = static_cast<double>(std::min(a.objects.size(), b.objects.size()));
  match->confidence = double(match->num_inliers) / n;
}

// The spectral matcher (spectral_match.cpp): spectral relaxation of the QAP, linear
// assignment, RANSAC, verification over all objects, re-matching in the aligned frame.
msgs::ObjectMatch MatchSpectral(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                                const MatcherOptions& options, const Coverage* coverage_a,
                                const Coverage* coverage_b);

// Every hypothesis the translation votes scored (the densest blocks at each rotation), for
// the cross-check of another path's answer (MatcherOptions::votes_cross_check).
struct VotePeaks {
  std::vector<Pose2> T;
  std::vector<double> score;  // support, less the own sonar's misses (VoteEvidence)
};

// The own sonar's negative evidence for the votes (MatcherOptions::vote_miss_weight): off
// when the weight is 0 or either pointer is null.
struct VoteEvidence {
  const Coverage* coverage_a = nullptr;
  const PointCounts* points_a = nullptr;
  bool On(const MatcherOptions& options) const {
    return options.vote_miss_weight > 0.0 && coverage_a && points_a && !coverage_a->empty();
  }
};

// Translation votes under a known rotation (heading_votes.cpp); scored, when given, receives
// every hypothesis they scored.
msgs::ObjectMatch MatchByHeadingVotes(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                                      double yaw_prior, const MatcherOptions& options,
                                      const VoteEvidence& evidence, VotePeaks* scored = nullptr);

// vote_miss_weight x the teammate objects T_a_b places where the own sonar looked and saw
// (almost) nothing; 0 when the evidence is off.
double VoteMissPenalty(const msgs::ObjectMap& b, const Pose2& T, const MatcherOptions& options,
                       const VoteEvidence& evidence);
// VoteSupport less VoteMissPenalty.
double VoteScore(const msgs::ObjectMap& a, const msgs::ObjectMap& b, const Pose2& T,
                 const MatcherOptions& options, const VoteEvidence& evidence);

// Objects the votes may pair: both landmarks, or both clusters of similar shape.
bool VoteCompatible(const msgs::Object& p, const msgs::Object& q, const MatcherOptions& options);

// Support of T_a_b as the votes count it: b objects landing within heading_vote_inlier_m of a
// compatible a object.
int VoteSupport(const msgs::ObjectMap& a, const msgs::ObjectMap& b, const Pose2& T,
                const MatcherOptions& options);

// Two transforms are distinct when they move b's objects apart by more than distinct_m on
// average.
bool Distinct(const msgs::ObjectMap& b, const Pose2& x, const Pose2& y, double distinct_m);

}  // namespace draco::objects::detail
