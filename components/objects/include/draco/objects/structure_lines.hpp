// Matching object maps by the lines of long structures (an extension of DRACo-SLAM2 III-B).
//
// Why: a pier, a floating dock or a wall is one long object, and its mean-point centre moves by
// metres to tens of metres with the part a robot happened to see (measured on the marina:
// the same finger pier has centres 14 m apart in two robots' maps), so centre-distance graphs
// cannot match it. Its axis, though, is the same line for every robot: direction and lateral
// offset are viewpoint-invariant, only the extent along it is not. Two non-parallel axes meet
// at a corner whose position and angle are invariant too, so one corner of map a paired with
// one corner of map b with the same angle gives a whole SE(2) hypothesis (two, for the half
// turn of undirected lines). Each hypothesis is scored by its support: long objects of b whose
// axis lands on an axis of a (angle, lateral offset, extents that meet), plus compact objects
// whose centres land within a tolerance; one-to-one, greedy by residual. The best hypothesis
// is refined by least squares over its support (endpoints of b's axes onto a's lines, compact
// centres onto centres).
//
// Frames: T_a_b maps map-b coordinates into map a (p_a = T_a_b * p_b).
#pragma once

#include <cstdint>
#include <vector>

#include "draco/msgs/objects.hpp"
#include "draco/objects/geometry.hpp"

namespace draco::objects {

struct StructureLineOptions {
  // An object is a line when long and slender; otherwise compact when short.
  double min_length_m = 6.0;
  double min_aspect = 3.0;            // length / breadth
  double max_compact_length_m = 4.0;  // compact objects (piles, boats, stubs) for support
  // Corners: two axes at least this far from parallel, meeting at most max_reach_m beyond
  // either segment's end (far extrapolation turns a small angle error into metres).
  double min_corner_angle_rad = 0.349;  // 20 deg
  double max_reach_m = 10.0;
  // Support tests.
  double angle_tolerance_rad = 0.0873;  // 5 deg: corner angles and axis directions
  double lateral_tolerance_m = 1.5;     // b's axis centre from a's line, and back
  double max_gap_m = 5.0;               // extents along the line may miss each other by this
  double point_tolerance_m = 2.0;       // compact centres
  int max_lines = 16;                   // the longest lines make corners (cost is quartic)
};

struct StructureLine {
  int object = 0;        // index into the map's objects
  Point2 center;         // rectangle centre
  double yaw_rad = 0.0;  // in [0, pi)
  double half_length_m = 0.0;
};

struct StructureCorner {
  int line_i = 0, line_j = 0;  // indices into the line list
  Point2 point;                // where the axes meet
  double angle_rad = 0.0;      // from line i's direction to line j's, in [0, pi)
};

// Lines and compact objects of a map (object indices), and the corners of its lines.
std::vector<StructureLine> ExtractLines(const msgs::ObjectMap& map,
                                        const StructureLineOptions& options);
std::vector<int> CompactObjects(const msgs::ObjectMap& map, const StructureLineOptions& options);
std::vector<StructureCorner> Corners(const std::vector<StructureLine>& lines,
                                     const StructureLineOptions& options);

// One correspondence of the support: object indices and the residual (m: lateral offset of a
// line, centre distance of a compact object).
struct SupportPair {
  int object_a = 0, object_b = 0;
  bool line = false;
  double residual_m = 0.0;
};

struct LineHypothesis {
  Pose2 T_a_b;
  int support = 0;  // line pairs + compact pairs
  int line_support = 0;
  std::vector<SupportPair> pairs;
};

// Support of T_a_b (one-to-one, greedy by residual).
LineHypothesis ScoreStructure(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                              const Pose2& T_a_b, const StructureLineOptions& options);

// Least squares over a hypothesis' pairs (Gauss-Newton, a few iterations).
Pose2 RefineStructure(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                      const std::vector<SupportPair>& pairs, const Pose2& T_a_b);

struct LineMatchResult {
  bool found = false;         // at least one corner pair made a hypothesis
  LineHypothesis best;        // refined and re-scored
  int runner_up_support = 0;  // best hypothesis distinct from the winner
  int num_hypotheses = 0;
  int num_corners_a = 0, num_corners_b = 0;
};

// Every corner of a against every corner of b with the same angle (both half turns); the best
// supported hypothesis, refined, and the best distinct runner-up (distinct: yaw differs by
// more than distinct_rad or b's origin lands more than distinct_m away).
LineMatchResult MatchStructureLines(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                                    const StructureLineOptions& options, double distinct_m = 3.0,
                                    double distinct_rad = 0.1745);

}  // namespace draco::objects
