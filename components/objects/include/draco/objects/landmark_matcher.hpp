// Map matching on point landmarks (docs/front-end.md, "Landmark matching").
//
// The local SLAM's point landmarks (compact isolated objects: boulders, dolphins, guide piles,
// boat ends; components/slam) are estimated as object centres, with the near-face offset of
// a sonar view removed by their radius state, so two robots that saw the same object from
// different sides hold nearly the same point. Where the DBSCAN object maps of two robots share
// almost nothing (robots that see opposite faces of a pier), their landmark sets still do.
//
// Exhaustive two-point consensus: every pair (i, j) of map a's points between
// min_pair_distance_m and max_pair_distance_m apart, against every ordered pair (k, l) of map b's
// whose distance agrees within tolerance_m, gives the rigid T_a_b taking k -> i and l -> j; its
// support is the number of b points that land within tolerance_m of an a point (one a point per b
// point, greedy by distance). The best hypothesis is refined by a least-squares fit to its inliers
// and re-scored; the runner-up is the best hypothesis distinct from it (more than distinct_m
// apart at b's centroid, or distinct_rad in yaw; reported when at least half the best
// support, else 0 or a lower bound). Deterministic: no sampling.
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::objects {

struct LandmarkMatchOptions {
  double tolerance_m = 1.0;
  double min_pair_distance_m = 3.0;
  // Pairs are local: at constant density the hypotheses then grow as n^2, not n^4.
  double max_pair_distance_m = 40.0;
  int max_points = 150;  // per map; the first ones are used (callers order by evidence)
  double distinct_m = 3.0;
  double distinct_rad = 0.1745;  // 10 deg
  // With the maps' absolute headings known: hypotheses turned more than max_yaw_gap_rad from
  // yaw_prior_rad are not scored (neither the answer nor its runner-up can be one of them).
  std::optional<double> yaw_prior_rad;
  double max_yaw_gap_rad = 0.0;  // <= 0: no prior
};

struct LandmarkMatchResult {
  bool found = false;  // at least one hypothesis with support >= 2
  msgs::Pose2 T_a_b;
  std::vector<std::pair<int, int>> pairs;  // (index in a, index in b), the inliers of T_a_b
  int support = 0;                         // pairs.size()
  int runner_up_support = 0;               // best distinct hypothesis (0: none)
  double rmse_m = 0.0;
  int hypotheses = 0;  // pair-of-pairs hypotheses scored
};

LandmarkMatchResult MatchLandmarkPoints(const std::vector<msgs::Point2>& a,
                                        const std::vector<msgs::Point2>& b,
                                        const LandmarkMatchOptions& options = {});

}  // namespace draco::objects
