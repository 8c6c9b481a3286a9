// draco: the command-line front of the runtime.
//   draco list                       every registered component: ports, parameters, units, docs
//   draco validate GRAPH [--set ..]  load and validate a graph; errors name file and line
//   draco dot GRAPH                  Graphviz of a graph (docs/ pictures)
//   draco run [GRAPH] [--set ..]     run a graph (default: the embedded default graph)
//   draco rawlog --out FILE [--mission DIR --robot NAME] [--trajectory TUM]
//                                    an MRPT rawlog of a recorded robot (dead-reckoning odometry,
//                                    sonar first returns as 2D range scans) and/or a trajectory
//                                    (docs/results.md, "MRPT rawlogs")
#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "app_version.hpp"
#include "data_path.hpp"
#include "draco/graph/executor.hpp"
#include "draco/graph/graph.hpp"
#include "draco/graph/progress.hpp"
#include "draco/rawlog/export.hpp"
#include "draco/rawlog/rawlog.hpp"
#include "log_option.hpp"
#include "run_info.hpp"

namespace {

std::atomic<bool> g_stop{false};

extern "C" void OnSignal(int) { g_stop = true; }

std::unique_ptr<draco::graph::Graph> Load(const std::string& path,
                                          const std::vector<std::string>& overrides) {
  draco::graph::LoadOptions options;
  options.overrides = overrides;
  return draco::graph::LoadGraphFile(path, options);
}

std::string DefaultRunDir(const std::string& graph_name) {
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", std::localtime(&now));
  return "runs/" + graph_name + "-" + stamp;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco: distributed sonar SLAM runtime"};
  draco::app::AddLogLevelOption(app);
  app.fallthrough();  // --log-level after the subcommand too
  app.set_version_flag("--version", draco::app::VersionLine("draco"));
  app.require_subcommand(1);

  app.add_subcommand("list", "list every registered component with ports and parameters");

  std::string graph_path;
  std::vector<std::string> overrides;
  auto* validate = app.add_subcommand("validate", "load and validate a graph file");
  validate->add_option("graph", graph_path, "graph YAML")->required();
  validate->add_option("--set", overrides, "override a parameter: component_id.param=value");

  auto* dot = app.add_subcommand("dot", "print a graph as Graphviz dot");
  dot->add_option("graph", graph_path, "graph YAML")->required();
  dot->add_option("--set", overrides, "override a parameter: component_id.param=value");

  std::string out_dir;
  std::string executor;
  double rate = -1.0;
  int threads = 0;
  double until_s = -1.0;
  auto* run = app.add_subcommand("run", "run a graph");
  run->add_option("graph", graph_path,
                  "graph YAML (default: graphs/default.yaml from the data search path)");
  run->add_option("--set", overrides, "override a parameter: component_id.param=value");
  run->add_option("--out", out_dir, "run folder (default: runs/<graph>-<time>)");
  run->add_option("--executor", executor, "deterministic or threaded (default: the graph's)")
      ->check(CLI::IsMember({"deterministic", "threaded"}));
  run->add_option("--rate", rate, "N x real time; 0 as fast as possible (default: the graph's)");
  run->add_option("--threads", threads, "threaded executor workers (default: the graph's)");
  run->add_option("--until", until_s, "stop at this mission time [s]");

  std::string rawlog_out, rawlog_mission, rawlog_robot, rawlog_trajectory;
  auto* rawlog = app.add_subcommand(
      "rawlog", "write an MRPT rawlog of a recorded robot and/or an estimated trajectory");
  rawlog->add_option("--out", rawlog_out, "rawlog file to write (gzip-compressed)")->required();
  auto* mission_opt = rawlog->add_option("--mission", rawlog_mission, "recorded mission folder")
                          ->check(CLI::ExistingDirectory);
  auto* robot_opt = rawlog->add_option("--robot", rawlog_robot, "robot of the mission");
  mission_opt->needs(robot_opt);
  robot_opt->needs(mission_opt);
  rawlog
      ->add_option("--trajectory", rawlog_trajectory,
                   "TUM trajectory (e.g. RUN/alpha.trajectory.tum) added as robot poses")
      ->check(CLI::ExistingFile);

  CLI11_PARSE(app, argc, argv);

  if (app.got_subcommand("rawlog")) {
    if (rawlog_mission.empty() && rawlog_trajectory.empty()) {
      draco::log::Error("draco rawlog: give --mission and --robot, --trajectory, or both");
      return 2;
    }
    try {
      namespace rl = draco::rawlog;
      rl::ExportStats stats;
      std::vector<rl::Entry> entries;
      if (!rawlog_mission.empty()) {
        entries = rl::MissionEntries(rawlog_mission, rawlog_robot, &stats);
      }
      if (!rawlog_trajectory.empty()) {
        auto poses = rl::TrajectoryEntries(rawlog_trajectory);
        stats.poses = static_cast<int>(poses.size());
        entries = rl::MergeByTime(std::move(entries), poses);
      }
      rl::WriteRawlog(rawlog_out, entries);
      std::printf("%s: %d odometry, %d range scans (%d beams with a return), %d poses\n",
                  rawlog_out.c_str(), stats.odometry, stats.scans, stats.valid_beams, stats.poses);
      return 0;
    } catch (const std::exception& e) {
      draco::log::Error(std::string("draco rawlog: ") + e.what());
      return 1;
    }
  }

  try {
    if (app.got_subcommand("list")) {
      std::cout << draco::graph::DescribeRegistry();
      return 0;
    }
    if (app.got_subcommand("validate")) {
      auto graph = Load(graph_path, overrides);
      std::cout << graph_path << ": ok, " << graph->nodes.size() << " components, "
                << graph->edges.size() << " connections, executor " << graph->settings.executor
                << "\n";
      return 0;
    }
    if (app.got_subcommand("dot")) {
      std::cout << draco::graph::ToDot(*Load(graph_path, overrides));
      return 0;
    }
    if (graph_path.empty()) graph_path = draco::app::ResolveDataFile("graphs/default.yaml").path;
    auto graph = Load(graph_path, overrides);
    if (!executor.empty()) graph->settings.executor = executor;
    draco::graph::RunOptions options;
    if (rate >= 0.0) {
      options.use_graph_rate = false;
      options.rate = rate;
    }
    options.threads = threads;
    if (until_s >= 0.0) options.until = draco::graph::Time::FromSeconds(until_s);
    options.output_dir = out_dir.empty() ? DefaultRunDir(graph->settings.name) : out_dir;
    std::filesystem::create_directories(options.output_dir);
    auto run_info = draco::app::MakeRunInfo("draco", argc, argv);
    run_info.AddFile("graph", graph_path);
    draco::app::WriteRunInfo(options.output_dir, run_info);
    // What runs, every parameter resolved: `draco run` of this file runs it again.
    draco::graph::WriteFileAtomicallyOrThrow(options.output_dir + "/graph.yaml",
                                             draco::graph::ResolvedYaml(*graph));
    options.stop_requested = &g_stop;
    std::signal(SIGINT, OnSignal);
    std::signal(SIGTERM, OnSignal);

    draco::log::Info("draco: running " + graph_path + " (" + std::to_string(graph->nodes.size()) +
                     " components, " + graph->settings.executor + " executor) into " +
                     options.output_dir);
    draco::graph::ProgressPrinter progress("draco: " + graph->settings.name, 0.0);
    options.progress = progress.Callback();
    const auto result = draco::graph::Run(*graph, options);
    progress.Finish(draco::graph::Time::FromSeconds(result.stats.mission_s));
    std::cout << result.stats.ToTable();
    const std::string stats_path = options.output_dir + "/runtime_stats.json";
    if (!draco::graph::WriteFileAtomically(stats_path, result.stats.ToJson())) {
      draco::log::Error("draco: cannot write " + stats_path);
      return 1;
    }
    std::cout << "run folder: " << options.output_dir << "\n";
    if (result.interrupted) draco::log::Warn("draco: interrupted; outputs flushed");
    if (!result.ok) {
      draco::log::Error("draco: run failed: " + result.error);
      return 1;
    }
    return 0;
  } catch (const draco::graph::GraphError& e) {
    draco::log::Error(e.what());
    return 1;
  } catch (const std::exception& e) {
    draco::log::Error(std::string("draco: ") + e.what());
    return 1;
  }
}
