// Placements of a team run judged against ground truth: for every ordered pair (own robot,
// teammate), where the own robot placed the teammate over the mission (<own>.placements.csv,
// written by team.TwoStepOptimizer) against the pair's true map-to-map transform.
//
// The true T_own_teammate is inv(T_world_ownmap) * T_world_teammatemap, each robot's
// T_world_map the SE(2) alignment of its local-SLAM keyframe trajectory (<robot>.trajectory.tum)
// to its ground truth. A placement's error is the RMS distance between the teammate's keyframes
// placed by the estimate and by the truth (what a user sees on the team map: the teammate's
// whole trajectory off by that much), and the yaw difference.
#pragma once

#include <string>
#include <vector>

namespace draco::report {

struct PlacementJudgeOptions {
  double right_m = 2.0;  // a placement within right_m and right_deg is right, else wrong
  double right_deg = 5.0;
  double overlap_radius_m = 10.0;  // path overlap: teammate keyframes this close to own path
  // A pair is eligible (the "pairs that share >= 5 objects and >= 30 % path overlap")
  // when both hold: the paths overlap by min_path_overlap, and min_shared_objects of the own
  // robot's final object map (<own>.objects.csv) have a teammate object within
  // shared_object_radius_m in the world (each map placed by its T_world_map), as
  // draco-frontend-eval counts them.
  double min_path_overlap = 0.3;
  int min_shared_objects = 5;
  double shared_object_radius_m = 2.0;
};

struct PairPlacement {
  std::string own;
  std::string teammate;
  // Fraction of the teammate's keyframes (true positions) within overlap_radius_m of the own
  // robot's true keyframe positions.
  double path_overlap = 0.0;
  // Own objects with a teammate object within shared_object_radius_m in the world; -1 when
  // either robot's objects.csv is missing or unreadable (then the pair is not eligible).
  int shared_objects = -1;
  bool eligible = false;         // path_overlap and shared_objects both reach the options' minimums
  int changes = 0;               // rows of placements.csv for this teammate
  double first_placed_s = -1.0;  // mission time of the first placement (-1: never)
  double first_right_s = -1.0;   // ... of the first right placement
  double first_wrong_s = -1.0;   // ... of the first wrong placement
  double wrong_duration_s = 0.0;  // mission time spent placed wrong
  double max_wrong_err_m = 0.0;   // largest error of a wrong placement
  // At the end of the run.
  bool final_placed = false;
  bool final_right = false;
  double final_err_m = -1.0;
  double final_err_deg = -1.0;
  const char* Verdict() const { return !final_placed ? "none" : final_right ? "right" : "wrong"; }
};

struct PlacementResult {
  std::vector<PairPlacement> pairs;  // own-major, teammates in team order
  // Per robot (team order): the paper's concatenated team ATE when every teammate's local SLAM
  // is placed by the true map-to-map transform (what a perfect merge of these local SLAMs
  // gives; -1 without ground truth).
  std::vector<double> oracle_team_ate_m;
  double end_s = 0.0;  // mission end (last keyframe of any robot)
  std::vector<std::string> problems;
};

// team: robot names by id (as TeamOf). Ground truth from <mission_dir>/<robot>/groundtruth.tum
// (TeamTruthPath). A robot without placements.csv has no placements (every pair "none").
PlacementResult EvaluatePlacements(const std::string& run_dir, const std::string& mission_dir,
                                   const std::vector<std::string>& team,
                                   const PlacementJudgeOptions& options = {});

// The pairs as CSV (one row per ordered pair) and as a Markdown table.
std::string PlacementsCsv(const PlacementResult& result);
std::string PlacementsMarkdown(const PlacementResult& result);

}  // namespace draco::report
