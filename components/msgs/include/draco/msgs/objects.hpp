// Object maps and object-graph matches (DRACo-SLAM2 section III-A and III-B). Plain structs
// (no Eigen fixed-size members), SI units in names. Object coordinates are in the robot's
// local (odometry) frame; T_a_b maps coordinates in frame b to frame a (p_a = T_a_b * p_b).
#pragma once

#include <cstdint>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::msgs {

// One cluster of the point-cloud map, described by its rotated minimum-area rectangle.
struct Object {
  std::uint32_t id = 0;    // stable while the cluster lives; a merge keeps the oldest id
  Point2 center;           // the reference's centre: the mean of the points
  Point2 rect_center;      // centre of the minimum-area rectangle
  double length_m = 0.0;   // long side l
  double breadth_m = 0.0;  // short side b
  double yaw_rad = 0.0;    // direction of the long side, in [0, pi)
  int num_points = 0;
  std::vector<int> keyframes;  // indices of the keyframes whose points are in the cluster
  // A local-SLAM point landmark, not a cluster: center = rect_center = its estimated centre,
  // length = breadth = its diameter, keyframes = the keyframes that saw it.
  bool landmark = false;  // == (id & kLandmarkIdBit) != 0: the link carries it in the id
};

// Object ids of landmarks: kLandmarkIdBit + the landmark's id (cluster ids stay below).
constexpr std::uint32_t kLandmarkIdBit = 0x40000000u;

struct ObjectMap {
  int robot_id = 0;
  double time_s = 0.0;
  std::vector<Object> objects;
  // Absolute heading of the map frame's x axis (counter-clockwise from the AHRS's reference,
  // east for the simulator): the AHRS's first reading. NaN: unknown (an AHRS without an
  // absolute reference). Two maps' headings bound the rotation between them.
  double map_heading_rad = kUnknownHeading;
};

enum class MatchStatus : std::uint8_t {
  kMatched = 0,
  kTooFewObjects,      // fewer than min_objects (or edges) in either graph
  kNoCandidates,       // no object pair with similar shapes, or no pair of consistent edges
  kTooFewAssignments,  // fewer than min_assignments from the assignment problem
  kTooFewInliers,      // RANSAC or the re-match kept fewer than min_inliers
  kContradicted,       // negative evidence: inliers - miss_weight * misses < min_inliers
  kAmbiguous,          // a distinct runner-up hypothesis scores close to the best
  kUnconfirmed,        // (MatchTracker) the transform has not won often enough yet
  kHeadingMismatch,    // the answer turns one map against the other beyond the headings' bound
};

struct ObjectPair {
  std::uint32_t id_a = 0;   // object id in map a (own)
  std::uint32_t id_b = 0;   // object id in map b (teammate)
  double residual_m = 0.0;  // |c_a - T_a_b * c_b| after the final fit
};

// Outcome of matching teammate map b against own map a.
struct ObjectMatch {
  int robot_a = 0;
  int robot_b = 0;
  MatchStatus status = MatchStatus::kTooFewObjects;
  Pose2 T_a_b;                    // valid when status == kMatched
  std::vector<ObjectPair> pairs;  // re-matched pairs (inliers of the final fit)
  int num_candidates = 0;         // object pairs (i, k) kept by the shape threshold
  int num_affinity_entries = 0;   // stored (symmetric) affinity entries
  int num_assignments = 0;        // assignments entering RANSAC
  int num_ransac_inliers = 0;
  int num_inliers = 0;      // pairs.size()
  double rmse_m = 0.0;      // of pairs
  double confidence = 0.0;  // num_inliers / min(n_a, n_b), in [0, 1]
  // Negative evidence (with coverages): objects placed by T_a_b inside the other robot's
  // observed area with no object of that robot near them, both ways.
  int num_misses = 0;
  // Support of the best hypothesis distinct from the winner over the winner's, each beyond a
  // two-point sample (0: none; graph_matcher.hpp).
  double ambiguity = 0.0;
  // Answer of the structure-line path (graph_matcher.hpp): pairs of long objects whose axes
  // coincide (their residual is the lateral offset) among the pairs.
  bool by_lines = false;
  int num_line_pairs = 0;
  // Answer of the landmark path (objects::MatcherOptions::landmarks): pairs of landmarks; on a
  // refusal, the landmark path's reason (the maps had too few clusters for the others).
  bool by_landmarks = false;
  // Answer of the translation votes under the maps' headings (MatcherOptions::heading_votes),
  // or their reason for refusing when the clusters were too few for the other paths.
  bool by_votes = false;
};

inline const char* MatchStatusName(MatchStatus status) {
  switch (status) {
    case MatchStatus::kMatched:
      return "matched";
    case MatchStatus::kTooFewObjects:
      return "too few objects";
    case MatchStatus::kNoCandidates:
      return "no candidate pairs";
    case MatchStatus::kTooFewAssignments:
      return "too few assignments";
    case MatchStatus::kTooFewInliers:
      return "too few inliers";
    case MatchStatus::kContradicted:
      return "contradicted";
    case MatchStatus::kAmbiguous:
      return "ambiguous";
    case MatchStatus::kUnconfirmed:
      return "unconfirmed";
    case MatchStatus::kHeadingMismatch:
      return "heading mismatch";
  }
  return "unknown";
}

}  // namespace draco::msgs
