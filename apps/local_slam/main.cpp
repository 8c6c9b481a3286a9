// draco-local-slam MISSION_DIR: replays each robot of a recorded mission through the
// local-SLAM graph (config/graphs/local-slam.yaml) and prints its ATE against ground truth
// next to dead reckoning's (SE(2) Umeyama alignment, keyframe times).
//
//   draco-local-slam /tmp/marina                 every robot
//   draco-local-slam /tmp/marina --robot alpha   one robot
//   draco-local-slam /tmp/marina --set slam.loop_closure=false --out runs/no-loops
#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "app_version.hpp"
#include "data_path.hpp"
#include "draco/eval/trajectory.hpp"
#include "draco/graph/executor.hpp"
#include "draco/graph/graph.hpp"
#include "draco/graph/progress.hpp"
#include "draco/recording/recording.hpp"
#include "log_option.hpp"
#include "run_info.hpp"

namespace {
std::atomic<bool> g_stop{false};

extern "C" void OnSignal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-local-slam: single-robot local SLAM replay with ATE"};
  draco::app::AddLogLevelOption(app);
  std::string mission_dir;
  std::string robot;
  std::string graph_path;  // default: graphs/local-slam.yaml from the data search path
  std::string out_dir;
  std::vector<std::string> overrides;
  double max_ratio = 0.0;
  app.add_option("mission", mission_dir, "recorded mission folder")->required();
  app.add_option("--robot", robot, "one robot (default: every robot of the mission)");
  app.add_option("--graph", graph_path, "local-SLAM graph YAML (default: graphs/local-slam.yaml)");
  app.add_option("--out", out_dir, "run folder (default: runs/local-slam-<mission>)");
  app.add_option("--set", overrides, "override a parameter: component_id.param=value");
  app.add_option("--max-ratio", max_ratio,
                 "exit 2 when a robot's SLAM ATE exceeds this fraction of dead reckoning's");
  app.set_version_flag("--version", draco::app::VersionLine("draco-local-slam"));
  CLI11_PARSE(app, argc, argv);
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);

  try {
    const auto info = draco::recording::LoadMissionInfo(mission_dir);
    graph_path = draco::app::ResolveDataFile("graphs/local-slam.yaml", graph_path).path;
    if (out_dir.empty()) out_dir = "runs/local-slam-" + info.name;
    std::filesystem::create_directories(out_dir);
    auto run_info = draco::app::MakeRunInfo("draco-local-slam", argc, argv);
    run_info.AddFile("graph", graph_path);
    draco::app::WriteRunInfo(out_dir, run_info);
    std::vector<std::string> robots;
    for (const auto& r : info.robots) {
      if (robot.empty() || r.name == robot) robots.push_back(r.name);
    }
    if (robots.empty()) {
      draco::log::Error("draco-local-slam: mission " + mission_dir + " has no robot '" + robot +
                        "'");
      return 1;
    }
    struct Row {
      std::string robot;
      std::size_t keyframes;
      double path_m, dr_m, slam_m, wall_s;
    };
    std::vector<Row> rows;
    for (const auto& name : robots) {
      draco::graph::LoadOptions load;
      load.overrides = {"reader.recording=" + mission_dir, "reader.robot=" + name,
                        "slam.prefix=" + name + ".", "truth.file=" + name + ".ground_truth.tum"};
      load.overrides.insert(load.overrides.end(), overrides.begin(), overrides.end());
      auto graph = draco::graph::LoadGraphFile(graph_path, load);
      // What this robot ran, every parameter resolved.
      draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/" + name + ".graph.yaml",
                                               draco::graph::ResolvedYaml(*graph));
      draco::graph::RunOptions run;
      run.output_dir = out_dir;
      run.stop_requested = &g_stop;
      draco::graph::ProgressPrinter progress(
          "draco-local-slam: " + name, draco::recording::RobotReplayLengthS(mission_dir, name));
      run.progress = progress.Callback();
      const auto result = draco::graph::RunDeterministic(*graph, run);
      progress.Finish(draco::graph::Time::FromSeconds(result.stats.mission_s));
      draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/" + name + ".runtime_stats.json",
                                               result.stats.ToJson());
      if (!result.ok) {
        draco::log::Error("draco-local-slam: " + name + ": " + result.error);
        return 1;
      }
      if (result.interrupted) {
        draco::log::Warn("draco-local-slam: interrupted");
        return 1;
      }
      const auto est = draco::eval::ReadTum(out_dir + "/" + name + ".trajectory.tum");
      const auto dr = draco::eval::ReadTum(out_dir + "/" + name + ".dead_reckoning.tum");
      const auto truth = draco::eval::ReadTum(out_dir + "/" + name + ".ground_truth.tum");
      rows.push_back({name, est.size(), draco::eval::PathLengthM(est),
                      draco::eval::Ate(dr, truth).rmse_m, draco::eval::Ate(est, truth).rmse_m,
                      result.stats.wall_s});
    }
    std::printf("\nmission %s (%s), graph %s\n", info.name.c_str(), info.world.c_str(),
                graph_path.c_str());
    std::printf("%-10s %6s %8s %12s %13s %7s %8s\n", "robot", "kfs", "path m", "DR ATE m",
                "SLAM ATE m", "ratio", "wall s");
    bool over = false;
    for (const auto& r : rows) {
      const double ratio = r.dr_m > 0 ? r.slam_m / r.dr_m : 0.0;
      over |= max_ratio > 0 && ratio > max_ratio;
      std::printf("%-10s %6zu %8.1f %12.3f %13.3f %7.2f %8.1f\n", r.robot.c_str(), r.keyframes,
                  r.path_m, r.dr_m, r.slam_m, ratio, r.wall_s);
    }
    std::printf("outputs in %s\n", out_dir.c_str());
    return over ? 2 : 0;
  } catch (const draco::graph::GraphError& e) {
    draco::log::Error(e.what());
    return 1;
  } catch (const std::exception& e) {
    draco::log::Error(std::string("draco-local-slam: ") + e.what());
    return 1;
  }
}
