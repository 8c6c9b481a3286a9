// Object-graph matching (see graph_matcher.hpp): MatchObjectMaps chooses between the spectral
// matcher on the clusters (spectral_match.cpp, spectral_relaxation.cpp, coverage.cpp), the
// structure lines, the landmarks and the heading votes (heading_votes.cpp); the heading prior.
#include "draco/objects/graph_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "draco/objects/geometry.hpp"
#include "graph_matcher_internal.hpp"

namespace draco::objects {
namespace {

using detail::MatchByHeadingVotes;
using detail::MatchSpectral;
using msgs::MatchStatus;
using msgs::ObjectMap;

msgs::ObjectMatch MatchClusters(const ObjectMap& a, const ObjectMap& b,
                                const MatcherOptions& options, const Coverage* coverage_a,
                                const Coverage* coverage_b) {
  msgs::ObjectMatch spectral = MatchSpectral(a, b, options, coverage_a, coverage_b);
  if (!options.structure_lines) return spectral;
  const LineMatchResult lines =
      MatchStructureLines(a, b, options.lines, options.distinct_m, options.distinct_rad);
  if (!lines.found || lines.best.support < options.min_line_support ||
      !HeadingAllows(HeadingYawPrior(a, b), lines.best.T_a_b.yaw_rad, options.max_heading_gap_rad))
    return spectral;
  const bool spectral_ok = spectral.status == MatchStatus::kMatched;
  if (spectral_ok &&
      ScoreStructure(a, b, spectral.T_a_b, options.lines).support >= lines.best.support) {
    return spectral;
  }
  msgs::ObjectMatch match = spectral;
  match.ambiguity =
      std::max(0, lines.runner_up_support - 2) / std::max(1e-9, double(lines.best.support - 2));
  if (options.max_line_ambiguity > 0.0 && match.ambiguity >= options.max_line_ambiguity) {
    if (spectral_ok) return spectral;
    match.status = MatchStatus::kAmbiguous;
    return match;
  }
  match.status = MatchStatus::kMatched;
  match.by_lines = true;
  match.T_a_b = lines.best.T_a_b;
  match.T_a_b.yaw_rad = NormalizeAngle(match.T_a_b.yaw_rad);
  match.pairs.clear();
  double sum2 = 0.0;
  for (const auto& p : lines.best.pairs) {
    match.pairs.push_back({a.objects[p.object_a].id, b.objects[p.object_b].id, p.residual_m});
    sum2 += p.residual_m * p.residual_m;
  }
  match.num_inliers = static_cast<int>(match.pairs.size());
  match.num_line_pairs = lines.best.line_support;
  match.rmse_m = match.pairs.empty() ? 0.0 : std::sqrt(sum2 / double(match.pairs.size()));
  const int n_min = std::max<int>(1, int(std::min(a.objects.size(), b.objects.size())));
  match.confidence = std::min(1.0, double(match.num_inliers) / double(n_min));
  return match;
}

}  // namespace

namespace {

msgs::ObjectMatch MatchWithoutVotes(const ObjectMap& a, const ObjectMap& b,
                                    const MatcherOptions& options, const Coverage* coverage_a,
                                    const Coverage* coverage_b);

}  // namespace

msgs::ObjectMatch MatchObjectMaps(const ObjectMap& a, const ObjectMap& b,
                                  const MatcherOptions& options, const Coverage* coverage_a,
                                  const Coverage* coverage_b, const PointCounts* points_a) {
  msgs::ObjectMatch m = MatchWithoutVotes(a, b, options, coverage_a, coverage_b);
  const auto prior = HeadingYawPrior(a, b);
  if (!prior || !options.heading_votes || !(options.max_heading_gap_rad > 0.0)) return m;
  const detail::VoteEvidence evidence{coverage_a, points_a};
  if (m.status != MatchStatus::kMatched) {
    msgs::ObjectMatch votes = MatchByHeadingVotes(a, b, *prior, options, evidence);
    if (votes.status == MatchStatus::kMatched) return votes;
    // Too few objects for the clusters' paths, but the votes (every object) ran: their
    // refusal is the reason to report.
    if (m.status == MatchStatus::kTooFewObjects && votes.status != MatchStatus::kTooFewObjects) {
      votes.by_votes = true;
      return votes;
    }
    return m;
  }
  if (!options.votes_cross_check) return m;
  detail::VotePeaks peaks;
  // The own sonar's misses count here only with vote_miss_cross_check (one-sided, they favour
  // hypotheses that put the teammate's map where the own sonar never looked: on tuning seed 22
  // they let through a landmark answer 17.7 m off that the support-only check refuses).
  const detail::VoteEvidence checked =
      options.vote_miss_cross_check ? evidence : detail::VoteEvidence{};
  msgs::ObjectMatch votes = MatchByHeadingVotes(a, b, *prior, options, checked, &peaks);
  if (peaks.score.empty()) return m;  // too few objects or no compatible pairs: no evidence
  // The answer's score against the best distinct translation's, beyond a two-point sample.
  const double answer_score = detail::VoteScore(a, b, m.T_a_b, options, checked);
  double rival = 0.0;
  for (std::size_t p = 0; p < peaks.score.size(); ++p) {
    if (peaks.score[p] > rival && detail::Distinct(b, peaks.T[p], m.T_a_b, options.distinct_m))
      rival = peaks.score[p];
  }
  const double ambiguity = std::max(0.0, rival - 2.0) / std::max(1e-9, answer_score - 2.0);
  if (rival < answer_score && ambiguity < options.cross_check_max_ambiguity) return m;
  if (votes.status == MatchStatus::kMatched &&
      detail::VoteScore(a, b, votes.T_a_b, options, checked) > answer_score)
    return votes;
  m.status = MatchStatus::kAmbiguous;
  m.ambiguity = ambiguity;
  return m;
}

namespace {

msgs::ObjectMatch MatchWithoutVotes(const ObjectMap& a, const ObjectMap& b,
                                    const MatcherOptions& options, const Coverage* coverage_a,
                                    const Coverage* coverage_b) {
  const auto has_landmark = [](const ObjectMap& m) {
    return std::any_of(m.objects.begin(), m.objects.end(),
                       [](const auto& o) { return o.landmark; });
  };
  if (!has_landmark(a) && !has_landmark(b)) {
    return MatchClusters(a, b, options, coverage_a, coverage_b);
  }
  // Clusters and landmarks apart.
  ObjectMap ca = a, cb = b;
  std::erase_if(ca.objects, [](const auto& o) { return o.landmark; });
  std::erase_if(cb.objects, [](const auto& o) { return o.landmark; });
  msgs::ObjectMatch clusters = MatchClusters(ca, cb, options, coverage_a, coverage_b);
  if (!options.landmarks) return clusters;
  std::vector<const msgs::Object*> la, lb;
  std::vector<msgs::Point2> pa, pb;
  for (const auto& o : a.objects) {
    if (o.landmark) la.push_back(&o), pa.push_back(o.center);
  }
  for (const auto& o : b.objects) {
    if (o.landmark) lb.push_back(&o), pb.push_back(o.center);
  }
  const auto accept = [&](const LandmarkMatchResult& m, double max_ambiguity) {
    return m.found && m.support >= options.min_landmark_support &&
           double(m.runner_up_support) < max_ambiguity * double(m.support);
  };
  LandmarkMatchOptions landmark = options.landmark;
  landmark.yaw_prior_rad = HeadingYawPrior(a, b);
  landmark.max_yaw_gap_rad = options.max_heading_gap_rad;
  // The landmarks' refusal, reported instead of the clusters' "too few objects".
  const auto refused = [&](const LandmarkMatchResult& m) {
    if (clusters.status != MatchStatus::kTooFewObjects ||
        std::min(la.size(), lb.size()) < std::size_t(options.min_landmark_support))
      return clusters;
    msgs::ObjectMatch out;
    out.robot_a = a.robot_id;
    out.robot_b = b.robot_id;
    out.by_landmarks = true;
    out.num_candidates = m.hypotheses;
    out.num_inliers = m.support;
    out.ambiguity = m.support > 0 ? double(m.runner_up_support) / double(m.support) : 0.0;
    out.status = m.found && m.support >= options.min_landmark_support ? MatchStatus::kAmbiguous
                                                                      : MatchStatus::kTooFewInliers;
    return out;
  };
  LandmarkMatchResult r = MatchLandmarkPoints(pa, pb, landmark);
  if (!accept(r, options.max_landmark_ambiguity)) {
    if (!(options.wide_landmark_tolerance_m > 0.0)) return refused(r);
    LandmarkMatchOptions wide = landmark;
    wide.tolerance_m = options.wide_landmark_tolerance_m;
    r = MatchLandmarkPoints(pa, pb, wide);
    if (!accept(r, options.wide_max_landmark_ambiguity)) return refused(r);
  }
  if (!HeadingAllows(HeadingYawPrior(a, b), r.T_a_b.yaw_rad, options.max_heading_gap_rad)) {
    if (clusters.status != MatchStatus::kTooFewObjects) return clusters;
    msgs::ObjectMatch out = refused(r);
    out.status = MatchStatus::kHeadingMismatch;
    return out;
  }
  msgs::ObjectMatch match;
  match.robot_a = a.robot_id;
  match.robot_b = b.robot_id;
  match.status = MatchStatus::kMatched;
  match.by_landmarks = true;
  match.T_a_b = r.T_a_b;
  for (const auto& [i, k] : r.pairs) {
    const msgs::Point2 p = Transform(r.T_a_b, pb[std::size_t(k)]);
    match.pairs.push_back(
        {la[std::size_t(i)]->id, lb[std::size_t(k)]->id,
         std::hypot(p.x_m - pa[std::size_t(i)].x_m, p.y_m - pa[std::size_t(i)].y_m)});
  }
  match.num_candidates = r.hypotheses;
  match.num_assignments = r.support;
  match.num_ransac_inliers = r.support;
  match.num_inliers = r.support;
  match.rmse_m = r.rmse_m;
  match.confidence = std::min(
      1.0, double(r.support) / double(std::max<std::size_t>(1, std::min(la.size(), lb.size()))));
  match.ambiguity = double(r.runner_up_support) / double(r.support);
  return match;
}

}  // namespace

std::optional<double> HeadingYawPrior(const ObjectMap& a, const ObjectMap& b) {
  if (!std::isfinite(a.map_heading_rad) || !std::isfinite(b.map_heading_rad)) return std::nullopt;
  return NormalizeAngle(b.map_heading_rad - a.map_heading_rad);
}

bool HeadingAllows(const std::optional<double>& yaw_prior_rad, double yaw_rad, double max_gap_rad) {
  if (!yaw_prior_rad || !(max_gap_rad > 0.0)) return true;
  return std::abs(NormalizeAngle(yaw_rad - *yaw_prior_rad)) <= max_gap_rad;
}

}  // namespace draco::objects
