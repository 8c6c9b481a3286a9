// draco-eval RUN_DIR: accuracy of a run against ground truth, figures and the run report.
// For every "<robot>.trajectory.tum" in the run folder, with "<robot>.dead_reckoning.tum"
// beside it and a ground truth ("<robot>.ground_truth.tum" or "ground_truth.tum"), prints
// ATE RMSE (SE(2) Umeyama alignment) and RPE of the estimate and of dead reckoning at the
// same keyframe times. Then writes team_map.png, ate.png and report.md into the run folder
// (docs/results.md); with --mission, also sonar frames with their CFAR detections.
// Exit code 1 when nothing could be evaluated.
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "draco/report/run_report.hpp"
#include "frames.hpp"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  CLI::App app{"draco-eval: trajectory accuracy, figures and report of a run folder"};
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
  CLI11_PARSE(app, argc, argv);

  const auto ev = draco::report::EvaluateRun(run_dir);
  for (const auto& p : ev.problems) std::cerr << "draco-eval: " << p << "\n";
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
    std::cerr << "draco-eval: nothing to evaluate in " << run_dir << "\n";
    return 1;
  }
  if (!no_report) {
    try {
      draco::report::ReportContent content;
      content.command = "draco-eval " + run_dir;
      if (!frames.mission_dir.empty()) {
        content.command += " --mission " + frames.mission_dir;
        if (!frames.robot.empty()) content.command += " --robot " + frames.robot;
      }
      content.figures = draco::report::RenderRunFigures(ev);
      if (!frames.mission_dir.empty() && frames.per_robot > 0) {
        content.frames = draco::eval_app::RenderFrames(run_dir, frames);
      }
      const std::string path = draco::report::WriteReport(ev, content);
      std::printf("report: %s\n", fs::absolute(path).string().c_str());
    } catch (const std::exception& e) {
      std::cerr << "draco-eval: report: " << e.what() << "\n";
      return 1;
    }
  }
  return over ? 2 : 0;
}
