// Evaluation of a run folder and its report (report.md): accuracy per robot (ATE, RPE,
// keyframes, intra-robot loops), the ATE table by method (the paper's Table III layout), the
// runtime table per component (Table I layout), figures and sonar frames. See docs/results.md.
#pragma once

#include <string>
#include <vector>

#include "draco/occupancy/grid.hpp"

namespace draco::report {

// Per robot, from <robot>.trajectory.tum, <robot>.dead_reckoning.tum, <robot>.ground_truth.tum
// (or ground_truth.tum) and <robot>.intra_loops.csv. NaN where an input is missing.
struct RobotAccuracy {
  std::string robot;
  std::size_t keyframes = 0;
  double path_m = 0.0;
  int intra_loops = -1;           // rows of intra_loops.csv; -1 when the file is missing
  int intra_loops_accepted = -1;  // rows with accepted = 1
  double dr_ate_m = 0.0;
  double slam_ate_m = 0.0;
  double dr_rpe_m = 0.0;
  double slam_rpe_m = 0.0;
  double slam_rpe_deg = 0.0;
};

// One row of the ATE table by method: ATE RMSE per robot (same order as RunEvaluation::robots;
// NaN when that robot has no trajectory for the method).
struct MethodRow {
  std::string method;  // "Dead reckoning", "Local SLAM", "Two-step PCM", ...
  std::string file_tag;
  std::vector<double> ate_m;
};

// Team-SLAM variants of Table III, read from <robot>.trajectory.<tag>.tum when present.
struct Variant {
  const char* tag;
  const char* label;
};
inline constexpr Variant kTableIIIVariants[] = {{"two-step-pcm", "Two-step PCM"},
                                                {"two-step-gcm", "Two-step GCM"},
                                                {"full-pcm", "Full PCM"},
                                                {"full-gcm", "Full GCM"}};

struct ComponentRuntime {
  std::string id;
  std::string type;
  long long calls = 0;
  double mean_ms = 0.0;
  double max_ms = 0.0;
  double total_ms = 0.0;
};

struct RobotRuntime {
  std::string robot;
  double wall_s = 0.0;
  double mission_s = 0.0;
  std::vector<ComponentRuntime> components;
};

struct RunEvaluation {
  std::string run_dir;
  std::vector<RobotAccuracy> robots;
  std::vector<MethodRow> methods;
  std::vector<RobotRuntime> runtimes;
  std::vector<ComponentRuntime> runtime_total;  // per component id over every robot
  std::vector<std::string> problems;            // files that could not be evaluated
};

// Reads a runtime_stats.json (graph RunStats). Throws std::runtime_error naming the file.
RobotRuntime ReadRuntimeStats(const std::string& path);

// Evaluates every "<robot>.trajectory.tum" of the folder that has a ground truth.
RunEvaluation EvaluateRun(const std::string& run_dir);

// Figures and frames to embed, as paths relative to the run folder.
struct ReportFigure {
  std::string path;
  std::string caption;
};
struct ReportContent {
  std::string command;  // how the report was produced
  std::vector<ReportFigure> figures;
  std::vector<ReportFigure> frames;
  // Further Markdown sections (the team run's tables and figures), after the ATE table.
  std::vector<std::string> sections;
};

// Renders the local map (each robot's local SLAM aligned to ground truth, with ground truth and
// point clouds; team_map.png unless map_png says otherwise, e.g. local_maps.png in a team run
// whose team_map.png is the team estimate) and ate.png (dead reckoning vs local SLAM per robot)
// into the run folder; returns them. report.md shows team_map.png first. Also each robot's
// occupancy grid from its point map and keyframes in the same frame (<robot>.grid.png and
// <robot>.grid.gridmap.gz, grids.hpp), shown in report.md beside the map.
std::vector<ReportFigure> RenderRunFigures(const RunEvaluation& evaluation,
                                           const std::string& map_png = "team_map.png",
                                           const occupancy::GridOptions& grid = {});

std::string ReportMarkdown(const RunEvaluation& evaluation, const ReportContent& content);

// Writes <run_dir>/report.md atomically; returns its path.
std::string WriteReport(const RunEvaluation& evaluation, const ReportContent& content);

}  // namespace draco::report
