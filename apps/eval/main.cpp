// draco-eval RUN_DIR: accuracy of a run against ground truth.
// For every "<prefix>trajectory.tum" in the run folder, with "<prefix>dead_reckoning.tum"
// beside it and a ground truth ("<prefix>ground_truth.tum" or "ground_truth.tum"), prints
// ATE RMSE (SE(2) Umeyama alignment) and RPE of the estimate and of dead reckoning at the
// same keyframe times. Exit code 1 when nothing could be evaluated.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>

#include "draco/eval/trajectory.hpp"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  CLI::App app{"draco-eval: trajectory accuracy of a run folder"};
  std::string run_dir;
  double max_ratio = 0.0;
  app.add_option("run_dir", run_dir, "run folder")->required()->check(CLI::ExistingDirectory);
  app.add_option("--max-ratio", max_ratio,
                 "fail (exit 2) when an estimate's ATE exceeds this fraction of dead reckoning's");
  CLI11_PARSE(app, argc, argv);

  std::vector<fs::path> estimates;
  for (const auto& entry : fs::directory_iterator(run_dir)) {
    const std::string name = entry.path().filename().string();
    if (name.size() >= 14 && name.compare(name.size() - 14, 14, "trajectory.tum") == 0) {
      estimates.push_back(entry.path());
    }
  }
  std::sort(estimates.begin(), estimates.end());
  std::printf("%-12s %6s %9s %11s %11s %7s %11s %11s\n", "robot", "kfs", "path m", "DR ATE m",
              "SLAM ATE m", "ratio", "DR RPE m", "SLAM RPE m");
  int evaluated = 0;
  bool over = false;
  for (const auto& path : estimates) {
    const std::string name = path.filename().string();
    const std::string prefix = name.substr(0, name.size() - 14);
    const fs::path dr_path = path.parent_path() / (prefix + "dead_reckoning.tum");
    fs::path truth_path = path.parent_path() / (prefix + "ground_truth.tum");
    if (!fs::exists(truth_path)) truth_path = path.parent_path() / "ground_truth.tum";
    if (!fs::exists(truth_path)) {
      std::cerr << "draco-eval: no ground truth for " << path << "\n";
      continue;
    }
    try {
      const auto est = draco::eval::ReadTum(path.string());
      const auto truth = draco::eval::ReadTum(truth_path.string());
      const auto slam = draco::eval::Ate(est, truth);
      const auto slam_rpe = draco::eval::Rpe(est, truth);
      double dr_ate = -1.0, dr_rpe = -1.0;
      if (fs::exists(dr_path)) {
        const auto dr = draco::eval::ReadTum(dr_path.string());
        dr_ate = draco::eval::Ate(dr, truth).rmse_m;
        dr_rpe = draco::eval::Rpe(dr, truth).trans_rmse_m;
      }
      const double ratio = dr_ate > 0 ? slam.rmse_m / dr_ate : 0.0;
      if (max_ratio > 0 && ratio > max_ratio) over = true;
      std::printf("%-12s %6zu %9.1f %11.3f %11.3f %7.2f %11.3f %11.3f\n",
                  prefix.empty() ? "(robot)" : prefix.substr(0, prefix.size() - 1).c_str(),
                  est.size(), draco::eval::PathLengthM(est), dr_ate, slam.rmse_m, ratio, dr_rpe,
                  slam_rpe.trans_rmse_m);
      ++evaluated;
    } catch (const std::exception& e) {
      std::cerr << "draco-eval: " << e.what() << "\n";
    }
  }
  if (evaluated == 0) {
    std::cerr << "draco-eval: nothing to evaluate in " << run_dir << "\n";
    return 1;
  }
  return over ? 2 : 0;
}
