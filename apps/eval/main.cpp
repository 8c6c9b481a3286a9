// draco-eval RUN_DIR: accuracy of a run against ground truth, figures and the run report.
// For every "<robot>.trajectory.tum" in the run folder, with "<robot>.dead_reckoning.tum"
// beside it and a ground truth ("<robot>.ground_truth.tum" or "ground_truth.tum"), prints
// ATE RMSE (SE(2) Umeyama alignment) and RPE of the estimate and of dead reckoning at the
// same keyframe times. Then writes team_map.png, ate.png, the occupancy grids
// (<robot>.grid.png / .gridmap.gz, cell size --grid-cell-m) and report.md into the run folder
// (docs/results.md); with --mission, also sonar frames with their CFAR detections, and the
// grids take the sonar's range and aperture from its mission.yaml.
// A team run (draco-fleet, draco-robot: <robot>.team.<teammate>.tum present) adds team ATE with
// the concatenation protocol (Table III), inter-robot loops judged against ground truth
// (<robot>.inter_loops_verdict.csv), Table II, Table IV, traffic per robot, the team map in the
// first robot's frame, the team occupancy grid (team_grid.png / .gridmap.gz) and link traffic
// over time (link_traffic.png).
// Exit code 1 when nothing could be evaluated.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "app_version.hpp"
#include "draco/occupancy/grid.hpp"
#include "draco/recording/recording.hpp"
#include "draco/report/run_report.hpp"
#include "draco/report/team_run.hpp"
#include "frames.hpp"
#include "log_option.hpp"
#include "run_info.hpp"

namespace fs = std::filesystem;

namespace {

// "draco-eval: [2/5] team run ... (1.3 s)": the steps of a long evaluation on stderr.
class Steps {
 public:
  explicit Steps(int total) : total_(total), start_(std::chrono::steady_clock::now()) {}
  void Next(const std::string& what) {
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    char line[64];
    std::snprintf(line, sizeof line, "draco-eval: [%d/%d] ", ++done_, total_);
    char took[32];
    std::snprintf(took, sizeof took, " (%.1f s)", s);
    draco::log::Info(line + what + took);
  }

 private:
  int total_;
  int done_ = 0;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-eval: trajectory accuracy, figures and report of a run folder"};
  draco::app::AddLogLevelOption(app);
  std::string run_dir;
  double max_ratio = 0.0;
  bool no_report = false;
  draco::eval_app::FramesOptions frames;
  app.add_option("run_dir", run_dir, "run folder")->required()->check(CLI::ExistingDirectory);
  app.add_option("--max-ratio", max_ratio,
                 "fail (exit 2) when an estimate's ATE exceeds this fraction of dead reckoning's");
  app.add_option("--mission", frames.mission_dir,
                 "recorded mission of the run: adds sonar frames with CFAR detections")
      ->check(CLI::ExistingDirectory);
  app.add_option("--robot", frames.robot, "sonar frames of this robot only");
  app.add_option("--frames", frames.per_robot, "sonar frames per robot")->check(CLI::Range(0, 50));
  app.add_flag("--no-report", no_report, "print the table only (no figures, no report.md)");
  draco::occupancy::GridOptions grid;
  app.add_option("--grid-cell-m", grid.cell_size_m, "cell size of the occupancy grids [m]")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 100.0));
  app.set_version_flag("--version", draco::app::VersionLine("draco-eval"));
  CLI11_PARSE(app, argc, argv);

  if (!frames.mission_dir.empty() && !no_report) {
    try {
      const auto sonar = draco::recording::LoadMissionInfo(frames.mission_dir).sonar;
      grid.max_range_m = sonar.num_ranges * sonar.range_resolution_m;
      grid.fov_rad = sonar.horizontal_aperture_rad;
    } catch (const std::exception& e) {
      draco::log::Error(std::string("draco-eval: --mission: ") + e.what());
      return 1;
    }
  }
  const bool team_run = draco::report::IsTeamRun(run_dir);
  const bool with_frames = !no_report && !frames.mission_dir.empty() && frames.per_robot > 0;
  Steps steps(1 + (team_run ? 1 : 0) + (no_report ? 0 : 2) + (with_frames ? 1 : 0));
  steps.Next("accuracy per robot");
  const auto ev = draco::report::EvaluateRun(run_dir);
  for (const auto& p : ev.problems) draco::log::Warn("draco-eval: " + p);
  std::printf("%-12s %6s %9s %11s %11s %7s %11s %11s\n", "robot", "kfs", "path m", "DR ATE m",
              "SLAM ATE m", "ratio", "DR RPE m", "SLAM RPE m");
  bool over = false;
  for (const auto& r : ev.robots) {
    const double dr_ate = std::isfinite(r.dr_ate_m) ? r.dr_ate_m : -1.0;
    const double dr_rpe = std::isfinite(r.dr_rpe_m) ? r.dr_rpe_m : -1.0;
    const double ratio = dr_ate > 0 ? r.slam_ate_m / dr_ate : 0.0;
    if (max_ratio > 0 && ratio > max_ratio) over = true;
    std::printf("%-12s %6zu %9.1f %11.3f %11.3f %7.2f %11.3f %11.3f\n", r.robot.c_str(),
                r.keyframes, r.path_m, dr_ate, r.slam_ate_m, ratio, dr_rpe, r.slam_rpe_m);
  }
  if (ev.robots.empty()) {
    draco::log::Error("draco-eval: nothing to evaluate in " + run_dir);
    return 1;
  }
  draco::report::TeamResult team;
  if (team_run) {
    steps.Next("team run: team ATE, inter-robot loops, link");
    try {
      team = draco::report::EvaluateTeamRun(run_dir, frames.mission_dir);
    } catch (const std::exception& e) {
      draco::log::Error(std::string("draco-eval: team run: ") + e.what());
      return 1;
    }
    for (const auto& p : team.problems) draco::log::Warn("draco-eval: " + p);
    std::printf("\n%s", draco::report::FormatTeamResult(team, "team run").c_str());
    const auto& c = team.distinct_loops;
    if (team.has_truth) {
      auto pct = [](double v) {
        char b[32];
        std::snprintf(b, sizeof b, std::isfinite(v) ? "%.1f %%" : "-", 100.0 * v);
        return std::string(b);
      };
      std::printf(
          "\ninter-robot loops (each once, TP within 1.5 m and 15 deg of ground truth): %d "
          "candidates, %d TP (precision %s); %d accepted, %d TP (precision %s, recall proxy "
          "%s)\n",
          c.candidates, c.tp_candidates, pct(c.PrecisionBefore()).c_str(), c.accepted,
          c.tp_accepted, pct(c.PrecisionAfter()).c_str(), pct(c.RecallProxy()).c_str());
    }
  }
  if (!no_report) {
    try {
      draco::report::ReportContent content;
      content.command = "draco-eval " + run_dir;
      if (grid.cell_size_m != draco::occupancy::GridOptions{}.cell_size_m) {
        content.command += " --grid-cell-m " + std::to_string(grid.cell_size_m);
      }
      if (!frames.mission_dir.empty()) {
        content.command += " --mission " + frames.mission_dir;
        if (!frames.robot.empty()) content.command += " --robot " + frames.robot;
      }
      steps.Next("figures");
      if (team_run) {
        const auto team_figures = draco::report::RenderTeamFigures(team, 0, grid);
        for (const auto& f : team_figures) {
          if (f.path == "team_map.png" || f.path == "team_grid.png") content.figures.push_back(f);
        }
        for (const auto& f : draco::report::RenderRunFigures(ev, "local_maps.png", grid)) {
          content.figures.push_back(f);
        }
        content.sections.push_back(draco::report::TeamReportMarkdown(team, team_figures));
        for (const auto& p : draco::report::WriteLoopVerdicts(team)) {
          std::printf("loop verdicts: %s\n", p.c_str());
        }
      } else {
        content.figures = draco::report::RenderRunFigures(ev, "team_map.png", grid);
      }
      if (with_frames) {
        steps.Next("sonar frames with CFAR detections");
        content.frames = draco::eval_app::RenderFrames(run_dir, frames);
      }
      steps.Next("report.md");
      const std::string path = draco::report::WriteReport(ev, content);
      // The run folder's own run_info.json is the run's; the report's is report.run_info.json.
      draco::app::WriteRunInfo(run_dir, draco::app::MakeRunInfo("draco-eval", argc, argv),
                               "report.");
      std::printf("report: %s\n", fs::absolute(path).string().c_str());
    } catch (const std::exception& e) {
      draco::log::Error(std::string("draco-eval: report: ") + e.what());
      return 1;
    }
  }
  return over ? 2 : 0;
}
