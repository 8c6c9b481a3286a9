// Evaluation of a team run folder (draco-fleet, draco-robot: files <robot>.*): team ATE with
// the paper's concatenation protocol (Table III layout), inter-robot loop closures judged
// against ground truth, loop-closure work per time step (Table II), message sizes per kind and
// traffic per robot (Table IV) and link traffic over time; the figures (team map, link
// traffic) and the report sections of these. See docs/results.md.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "draco/eval/trajectory.hpp"
#include "draco/report/run_report.hpp"

namespace draco::report {

// The acoustic modem's shared team budget and the per-robot traffic goal (issue 7).
inline constexpr double kTeamBudgetBps = 62500.0;
inline constexpr double kRobotGoalBps = 2000.0;

// A loop closure is a true positive when its relative pose is within these of the
// ground-truth relative pose of its two keyframes (the paper: 1.5 m, 15 deg).
struct LoopTruthOptions {
  double max_m = 1.5;
  double max_deg = 15.0;
};

// One row of <robot>.inter_loops.csv, and its verdict against ground truth.
struct InterLoop {
  std::uint64_t id = 0;
  int own_robot = 0;
  int own_keyframe = 0;
  int teammate_robot = 0;
  int teammate_keyframe = 0;
  double x_m = 0.0;  // teammate keyframe in the own keyframe's body frame
  double y_m = 0.0;
  double yaw_rad = 0.0;
  double overlap = 0.0;
  bool accepted = false;
  // Verdict: judged when both keyframes have a time and a ground truth at that time.
  bool judged = false;
  bool true_positive = false;
  double err_m = 0.0;    // |translation| of inv(truth relative pose) * loop pose
  double err_deg = 0.0;  // |yaw| of the same
};
// Throws std::runtime_error naming file and line on malformed input.
std::vector<InterLoop> ReadInterLoops(const std::string& csv_path);

// Ground-truth pose at time t (linear in position, shortest arc in yaw); false when t is
// outside the truth or further than max_gap_s from a sample.
bool TruthAt(const eval::Trajectory& truth, double t, eval::StampedPose2* out,
             double max_gap_s = 0.5);

// Judges every loop: keyframe k of robot r is row k of keyframes[r] (its trajectory.tum, in
// keyframe order); its ground truth is truth[r] at that time. The truth relative pose is
// inv(T_world_own) * T_world_teammate.
void JudgeInterLoops(std::vector<InterLoop>* loops, const std::vector<eval::Trajectory>& keyframes,
                     const std::vector<eval::Trajectory>& truth, const LoopTruthOptions& options);

// The loops CSV with the verdict: the input columns then true_positive (1/0), err_m, err_deg;
// the three verdict fields are empty for a loop that could not be judged.
std::string InterLoopsVerdictCsv(const std::vector<InterLoop>& loops);

// One row of <robot>.registrations.csv: every registration the scan exchange ran, at the
// configured window and at the windows logged for evaluation, with its overlap whatever the
// threshold; `loop.accepted` = ICP converged (status accepted or low overlap).
struct RegistrationRow {
  int window = 0;
  bool configured = false;
  InterLoop loop;
};
// Throws std::runtime_error naming file and line on malformed input.
std::vector<RegistrationRow> ReadRegistrations(const std::string& csv_path);

// The paper's Fig. 3: for each window and overlap threshold, the judged registrations whose ICP
// converged with overlap >= threshold, how many are true positives, and the precision.
struct SweepPoint {
  int window = 0;
  double threshold = 0.0;
  int registrations = 0;
  int true_positives = 0;
  double precision = 0.0;  // NaN when no registration passes
};
std::vector<SweepPoint> OverlapSweep(const std::vector<RegistrationRow>& rows,
                                     const std::vector<double>& thresholds);

// Loop counts before (every candidate) and after (accepted) the consistency filter.
struct LoopCounts {
  int candidates = 0;
  int accepted = 0;
  int judged = 0;           // candidates with a verdict
  int judged_accepted = 0;  // accepted with a verdict
  int tp_candidates = 0;    // true positives among the candidates
  int tp_accepted = 0;      // ... among the accepted
  // NaN when undefined.
  double PrecisionBefore() const;  // tp_candidates / judged
  double PrecisionAfter() const;   // tp_accepted / judged_accepted
  double RecallProxy() const;      // tp_accepted / tp_candidates: true loops the filter kept
};
LoopCounts CountLoops(const std::vector<InterLoop>& loops);

// Loop-closure work per agent step (<robot>.agent_steps.csv), mean and max over the steps.
struct WorkStat {
  double mean = 0.0;
  double max = 0.0;
};
struct StepWork {
  std::string robot;
  int steps = 0;
  int optimized = 0;  // steps that ran the two-step PGO
  WorkStat matches_tried, matches_found, requests_sent, scans_registered, candidates_added,
      loops_accepted, wall_ms;
};
// Throws std::runtime_error naming the file on malformed input.
StepWork ReadAgentSteps(const std::string& csv_path);

// One frame on the link (<robot>.link_traffic.csv).
struct TrafficFrame {
  double start_s = 0.0;
  double end_s = 0.0;
  std::string kind;
  double bits = 0.0;
  bool lost = false;
};
std::vector<TrafficFrame> ReadLinkTraffic(const std::string& csv_path);

// Bits on the link per window of window_s, per kind (frames binned by start time, lost frames
// included: they used the channel), as bits per second. Windows [0, w), [w, 2w), ... up to
// max(end_s, last frame start); a frame starting at the end goes into the last window; the last
// window, when end_s ends inside it, is divided by its shorter length.
struct TrafficSeries {
  double window_s = 10.0;
  std::vector<double> window_start_s;
  std::vector<std::string> kinds;        // in first-seen order
  std::vector<std::vector<double>> bps;  // [kind][window]
  std::vector<double> total_bps;         // [window]
};
TrafficSeries BinTraffic(const std::vector<TrafficFrame>& frames, double window_s,
                         double end_s = 0.0);

// Per robot of a team run.
struct RobotResult {
  std::string name;
  int keyframes = 0;
  double dr_ate_m = -1.0;     // own dead reckoning
  double local_ate_m = -1.0;  // own local SLAM
  double team_ate_m = -1.0;   // own + placed teammates, concatenated, one SE(2) alignment
  int placed = 0;             // robots in the estimate (own included)
  int candidates = 0;         // inter-robot loop candidates
  int accepted = 0;           // accepted by the consistency filter
  LoopCounts loops;           // with the verdict (judged = 0 without ground truth)
  double mission_s = 0.0;     // runtime_stats.json's mission time, at least the keyframe span
  // Link (from <robot>.link_stats.json)
  double bits_sent = 0.0;
  double mean_bps = 0.0;
  int restarts_seen = 0;                          // teammate restarts this robot noticed
  std::map<std::string, double> teammate_frames;  // frames received per teammate name
};
struct KindSizes {
  std::string kind;
  double frames = 0.0;
  double bits = 0.0;
  double max_bits = 0.0;
  double dropped = 0.0;
  double rejected = 0.0;
};
struct TeamResult {
  std::string run_dir;
  std::string mission_dir;        // ground truth from here when not empty
  std::vector<std::string> team;  // robot names by id
  std::vector<RobotResult> robots;
  std::vector<KindSizes> kinds;                // summed over robots
  std::vector<std::vector<InterLoop>> loops;   // per robot (as robots), with the verdict
  LoopCounts distinct_loops;                   // over the team, each loop once
  std::vector<StepWork> steps;                 // robots with agent_steps.csv
  std::vector<TrafficFrame> traffic;           // every robot's link_traffic.csv
  bool has_truth = false;                      // loops were judged
  std::vector<RegistrationRow> registrations;  // every robot's registrations.csv, judged
  std::vector<SweepPoint> sweep;               // OverlapSweep over them, 0.50 .. 0.95
  std::vector<std::string> problems;
};

// True when the folder holds <robot>.team.<robot>.tum files (a team run).
bool IsTeamRun(const std::string& run_dir);

// Robot names by id: the mission's robots (mission_dir given), else the robot_id of each
// <robot>.link_stats.json, else the <robot>.trajectory.tum names sorted.
std::vector<std::string> TeamOf(const std::string& run_dir, const std::string& mission_dir = "");

// Ground truth file of a robot (may not exist): as EvaluateTeamRun reads it.
std::string TeamTruthPath(const std::string& run_dir, const std::string& mission_dir,
                          const std::string& robot);

// Evaluates a team run. Ground truth of robot r: <mission_dir>/<r>/groundtruth.tum when
// mission_dir is given, else <run_dir>/<r>.ground_truth.tum (or ground_truth.tum). `team`
// empty: TeamOf(run_dir, mission_dir).
TeamResult EvaluateTeamRun(const std::string& run_dir, const std::string& mission_dir = "",
                           std::vector<std::string> team = {},
                           const LoopTruthOptions& loop_truth = {});

// Writes <run_dir>/<robot>.inter_loops_verdict.csv atomically for every robot with loops;
// returns the paths written.
std::vector<std::string> WriteLoopVerdicts(const TeamResult& result);

// Tables for a terminal: per robot (ATE, loops, traffic), message sizes per kind.
std::string FormatTeamResult(const TeamResult& result, const std::string& title);
// The same as Markdown (draco-fleet's fleet_report.md).
std::string TeamResultMarkdown(const TeamResult& result);

// Figures of a team run, written into the run folder: team_map.png (robot map_robot's frame;
// default the first robot), link_traffic.png (+ link_traffic_detail.png, scaled to the
// traffic) and, with judged registrations, fig3.png (precision and true positives against the
// overlap threshold per window) and the team occupancy grid (team_grid.png and
// team_grid.gridmap.gz: every placed robot's point map and keyframes as the team estimate
// placed them, grids.hpp). Returns them relative to the run folder.
std::vector<ReportFigure> RenderTeamFigures(const TeamResult& result, int map_robot = 0,
                                            const occupancy::GridOptions& grid = {});

// The team sections of report.md: Table III (team ATE), inter-robot loop closures, Table II,
// Table IV and link traffic; `figures` as RenderTeamFigures returned them.
std::string TeamReportMarkdown(const TeamResult& result, const std::vector<ReportFigure>& figures);

}  // namespace draco::report
