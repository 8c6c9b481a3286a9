// draco-robot: the daemon of one robot. Replays the robot's recorded mission (or, with a
// graph of your own, whatever its reader reads) through the robot graph (local SLAM + team
// agent + fleet link) and talks to its teammates over Cyclone DDS. GUI-free; SIGINT/SIGTERM
// stop it cleanly and its outputs are flushed.
//
//   draco-robot --mission /tmp/marina --robot alpha --out runs/fleet/dds
//   draco-robot --mission /tmp/marina --robot bravo --domain 7 --set filter.method=pcm
//
// Outputs in --out, prefixed with the robot name: local SLAM (trajectory, dead reckoning,
// pose graph, map), team estimate (team.<robot>.tum for every robot placed, inter_loops.csv,
// objects.csv, agent_steps.csv), link_stats.json, link_traffic.csv, runtime_stats.json.
#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "app_version.hpp"
#include "data_path.hpp"
#include "dds_profile.hpp"
#include "draco/graph/executor.hpp"
#include "draco/graph/graph.hpp"
#include "draco/graph/progress.hpp"
#include "draco/recording/recording.hpp"
#include "log_option.hpp"
#include "run_info.hpp"
#include "team_setup.hpp"

namespace {
std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-robot: one robot's SLAM daemon (local SLAM, team stages, fleet link)"};
  draco::app::AddLogLevelOption(app);
  draco::fleet_app::RobotSetup setup;
  std::string robot;
  std::string graph_path;
  std::string dds_config;       // --dds-config as given
  std::string ros2_dds_config;  // --ros2-dds-config as given
  std::string team_list;
  std::string out_dir;
  std::vector<std::string> overrides;
  double rate = 0.0;
  int threads = 2;
  bool no_lockstep = false;
  bool quiet = false;
  // The DRACO_* variables stand in for options not given (systemd's environment file,
  // config/systemd/robot.env.example).
  auto* mission_opt = app.add_option("--mission", setup.mission_dir, "recorded mission folder")
                          ->envname("DRACO_MISSION");
  auto* bag_opt =
      app.add_option("--bag", setup.bag, "ROS 1 bag of this robot (instead of --mission)")
          ->check(CLI::ExistingFile)
          ->envname("DRACO_BAG");
  mission_opt->excludes(bag_opt);
  auto* team_opt = app.add_option("--team", team_list,
                                  "with --bag: the team's robot names in id order, e.g. "
                                  "alpha,bravo,charlie")
                       ->envname("DRACO_TEAM");
  team_opt->needs(bag_opt);
  bag_opt->needs(team_opt);
  app.add_option("--robot", robot, "robot name in the mission (or in --team)")
      ->required()
      ->envname("DRACO_ROBOT");
  app.add_option("--graph", graph_path,
                 "robot graph YAML (default graphs/robot.yaml, graphs/robot-bag.yaml with --bag, "
                 "from the data search path)");
  app.add_option("--out", out_dir, "output folder (default runs/robot-<mission>)");
  app.add_option("--transport", setup.transport,
                 "dds (default), udp (plain datagrams to --udp-peers: a slow acoustic modem) or "
                 "inproc (alone: no teammates)")
      ->check(CLI::IsMember({"dds", "udp", "inproc"}))
      ->envname("DRACO_TRANSPORT");
  app.add_option("--udp-peers", setup.udp_peers,
                 "with --transport udp: every teammate as host:port or host, comma-separated "
                 "(this robot may be listed too)")
      ->delimiter(',')
      ->envname("DRACO_UDP_PEERS");
  app.add_option("--udp-port", setup.udp_port,
                 "with --transport udp: the UDP port to listen on (default: the graph's "
                 "link.udp_port, 7470)")
      ->check(CLI::Range(1, 65535))
      ->envname("DRACO_UDP_PORT");
  app.add_option("--domain", setup.domain_id,
                 "DDS domain id (default: the graph's link.domain_id, 0 unless set there)")
      ->check(CLI::Range(0, 230))
      ->envname("DRACO_DOMAIN");
  app.add_option("--dds-config", dds_config,
                 "Cyclone DDS XML file, or a shipped profile: loopback, lan, unicast (default: "
                 "$CYCLONEDDS_URI when set, else loopback)")
      ->envname("DRACO_DDS_CONFIG");
  app.add_option("--ros2-domain", setup.ros2_domain_id,
                 "publish the team estimate and map as ROS 2 topics /draco/<robot>/... on this "
                 "DDS domain of the local network (ROS_DOMAIN_ID; not the link's domain)")
      ->check(CLI::Range(0, 232))
      ->envname("DRACO_ROS2_DOMAIN");
  app.add_option("--ros2-dds-config", ros2_dds_config,
                 "Cyclone DDS XML file or shipped profile for --ros2-domain (default: "
                 "$CYCLONEDDS_URI when set, else Cyclone's defaults: multicast on one LAN)")
      ->envname("DRACO_ROS2_DDS_CONFIG");
  app.add_option("--set", overrides, "override a parameter: component_id.param=value");
  app.add_option("--rate", rate, "pace the replay at N x real time (0: lock-step only)");
  app.add_flag("--no-lockstep", no_lockstep, "do not wait for teammates' mission clocks");
  app.add_option("--threads", threads,
                 "replays: run the local SLAM and the team stages on up to this many threads "
                 "(default 2; 0: one engine, one thread)")
      ->check(CLI::Range(0, 64));
  app.add_flag("--quiet", quiet, "no progress lines");
  app.set_version_flag("--version", draco::app::VersionLine("draco-robot"));
  CLI11_PARSE(app, argc, argv);
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);

  try {
    if (setup.mission_dir.empty() && setup.bag.empty()) {
      draco::log::Error("draco-robot: give --mission DIR or --bag FILE --team NAMES");
      return 1;
    }
    std::string source;
    if (setup.bag.empty()) {
      const auto info = draco::recording::LoadMissionInfo(setup.mission_dir);
      for (const auto& r : info.robots) setup.team.push_back(r.name);
      setup.world = info.world;
      source = "mission " + setup.mission_dir;
      if (out_dir.empty()) out_dir = "runs/robot-" + info.name;
      graph_path = draco::app::ResolveDataFile("graphs/robot.yaml", graph_path).path;
    } else {
      std::stringstream names(team_list);
      for (std::string n; std::getline(names, n, ',');) {
        if (!n.empty()) setup.team.push_back(n);
      }
      source = "--team " + team_list;
      if (out_dir.empty()) out_dir = "runs/robot-" + robot;
      graph_path = draco::app::ResolveDataFile("graphs/robot-bag.yaml", graph_path).path;
    }
    const auto it = std::find(setup.team.begin(), setup.team.end(), robot);
    if (it == setup.team.end()) {
      std::string names;
      for (const auto& n : setup.team) names += (names.empty() ? "" : " ") + n;
      draco::log::Error("draco-robot: " + source + " has no robot '" + robot +
                        "' (robots: " + names + ")");
      return 1;
    }
    setup.robot_id = static_cast<int>(it - setup.team.begin());
    setup.lockstep = !no_lockstep && setup.transport != "inproc";
    if (setup.transport == "udp" && setup.udp_peers.empty()) {
      draco::log::Error(
          "draco-robot: --transport udp needs --udp-peers (every teammate as "
          "host:port or host, comma-separated; or DRACO_UDP_PEERS)");
      return 1;
    }
    if (setup.transport == "dds") {
      const auto dds = draco::app::ChooseDdsConfigFromEnvironment(dds_config);
      setup.dds_config = dds.file;  // "": Cyclone reads $CYCLONEDDS_URI
      draco::log::Info("draco-robot: " + robot + ": " + dds.Describe());
    }
    if (setup.ros2_domain_id >= 0) {
      if (setup.transport == "dds" && setup.domain_id == setup.ros2_domain_id) {
        draco::log::Error("draco-robot: --ros2-domain " + std::to_string(setup.ros2_domain_id) +
                          " is the team link's domain; ROS 2 monitoring needs a domain of its "
                          "own (the link's traffic must not meet it)");
        return 1;
      }
      if (!ros2_dds_config.empty()) {
        setup.ros2_dds_config = draco::app::ChooseDdsConfig(ros2_dds_config, "").file;
      }
      draco::log::Info("draco-robot: " + robot + ": ROS 2 topics /draco/" + robot +
                       "/... on domain " + std::to_string(setup.ros2_domain_id));
    }
    std::filesystem::create_directories(out_dir);
    auto run_info = draco::app::MakeRunInfo("draco-robot", argc, argv);
    run_info.AddFile("graph", graph_path);
    if (setup.transport == "dds" && !setup.dds_config.empty()) {
      run_info.AddFile("dds_config", setup.dds_config);
    }
    draco::app::WriteRunInfo(out_dir, run_info, robot + ".");

    draco::graph::LoadOptions load;
    load.overrides = draco::fleet_app::RobotOverrides(setup, "");
    load.overrides.insert(load.overrides.end(), overrides.begin(), overrides.end());
    auto graph = draco::graph::LoadGraphFile(graph_path, load);
    // What runs, every parameter resolved (defaults, the graph file, the overrides).
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/" + robot + ".graph.yaml",
                                             draco::graph::ResolvedYaml(*graph));

    draco::graph::RunOptions run;
    run.output_dir = out_dir;
    run.stop_requested = &g_stop;
    run.island_threads = threads;
    // Every daemon of the team runs to the end of the longest replay (a robot whose recording
    // ended keeps its link and agent going), as the in-process team does.
    // (A bag's length is not known beforehand: the run ends with the bag.)
    if (setup.bag.empty()) {
      const double end_s = draco::fleet_app::MissionLengthS(setup.mission_dir, setup.team);
      if (end_s > 0.0) {
        run.until = draco::graph::Time::FromSeconds(end_s);
      } else {
        draco::log::Warn("draco-robot: no replay length from " + setup.mission_dir +
                         "/<robot>/ahrs.csv (missing or unreadable last line): running to the "
                         "end of the own recording");
      }
    }
    if (rate > 0.0) {
      run.rate = rate;
      run.use_graph_rate = false;
    }
    draco::graph::ProgressPrinter progress(
        "draco-robot: " + robot,
        setup.bag.empty() ? draco::fleet_app::MissionLengthS(setup.mission_dir, {robot}) : 0.0);
    if (!quiet) run.progress = progress.Callback();
    const auto result = draco::graph::RunDeterministic(*graph, run);
    if (!quiet) progress.Finish(draco::graph::Time::FromSeconds(result.stats.mission_s));
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/" + robot + ".runtime_stats.json",
                                             result.stats.ToJson());
    if (!result.ok) {
      draco::log::Error("draco-robot: " + robot + ": " + result.error);
      return 1;
    }
    if (result.interrupted) {
      draco::log::Warn("draco-robot: " + robot + ": stopped by a signal; outputs flushed in " +
                       out_dir);
      return 0;
    }
    char took[96];
    std::snprintf(took, sizeof took, " done (%.1f s of mission in %.1f s); outputs in ",
                  result.stats.mission_s, result.stats.wall_s);
    draco::log::Info("draco-robot: " + robot + took + out_dir);
    return 0;
  } catch (const draco::graph::GraphError& e) {
    draco::log::Error(e.what());
    return 1;
  } catch (const std::exception& e) {
    draco::log::Error(std::string("draco-robot: ") + e.what());
    return 1;
  }
}
