// draco-fleet MISSION: runs a whole team on a recorded mission and reports it.
//   --mode dds     one draco-robot daemon per robot, separate processes over Cyclone DDS on
//                  loopback (dds/loopback.xml unless --dds-config or $CYCLONEDDS_URI say
//                  otherwise), in lock-step on the mission clock
//   --mode inproc  every robot in one process over the in-process bus (deterministic replay)
//   --mode both    (default) both, then compares them: accepted inter-robot loops and team
//                  ATE must agree within 10 %
//   --simulate M  (in-process only) no recording: every robot's sensors simulated from the
//                  mission YAML M while the team runs (sim.LiveRobot, graphs/robot-live.yaml);
//                  OUT/mission holds the mission's navigation and ground truth only
//                  (draco-sim --no-sonar), which the evaluation reads as from a recording
// Prints per robot: ATE (dead reckoning, local, team with the paper's concatenation), loops,
// traffic; and per message kind: mean and max bits. Writes OUT/<mode>/ (every robot's
// outputs) and OUT/fleet_report.md.
//
//   draco-fleet /tmp/marina --out runs/fleet-marina
//   draco-fleet /tmp/marina --mode dds --kill bravo --kill-after-s 20 --restart-after-s 2
//   draco-fleet --simulate config/missions/marina.yaml --mode inproc
#include <CLI/CLI.hpp>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <stdexcept>
#include <thread>

#include "app_version.hpp"
#include "data_path.hpp"
#include "dds_profile.hpp"
#include "draco/graph/executor.hpp"
#include "draco/graph/graph.hpp"
#include "draco/graph/progress.hpp"
#include "draco/recording/recording.hpp"
#include "draco/report/placements.hpp"
#include "draco/report/team_run.hpp"
#include "log_option.hpp"
#include "process.hpp"
#include "run_info.hpp"
#include "team_setup.hpp"

namespace {
namespace fs = std::filesystem;
using draco::fleet_app::RobotSetup;
using draco::fleet_app::Spawn;

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop = true; }

// A status line of the team run at info level (stderr), printf-style.
[[gnu::format(printf, 1, 2)]] void Status(const char* format, ...) {
  char line[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(line, sizeof line, format, args);
  va_end(args);
  std::string text(line);
  if (!text.empty() && text.back() == '\n') text.pop_back();
  draco::log::Info(text);
}

struct Options {
  std::string mission;      // the recorded mission (with --simulate: OUT/mission, no pings)
  std::string simulate;     // a mission YAML simulated live (in-process only)
  double duration_s = 0.0;  // --simulate: cap of each robot's duration (0: the mission's)
  std::string out;
  std::string graph;       // default: graphs/robot.yaml from the data search path
  std::string dds_config;  // --dds-config as given; then the file chosen ("": $CYCLONEDDS_URI)
  int domain = -1;         // < 0: the graph's link.domain_id
  std::vector<std::string> overrides;  // applied to every robot: component.param=value
  std::string kill;                    // robot to kill (dds)
  double kill_after_s = 0.0;           // wall seconds after start
  double restart_after_s = -1.0;       // wall seconds after the kill; < 0: never
  double timeout_s = 3600.0;
  double rate = 0.0;  // dds: pace the daemons at N x real time (0: lock-step only)
  int threads = 0;    // inproc: robots on up to this many threads (0: the cores, at most 4);
                      // dds: each daemon's --threads (0: the daemon's default)
};

// A mode's folder (<out>/inproc, <out>/dds) holds one run. An earlier run's files there are
// removed first: the evaluation reads <robot>.team.<mate>.tum for every teammate, so a file
// the new run does not write (a teammate it never placed) would be read as this run's. A
// folder holding anything else is refused, never emptied.
void PrepareModeFolder(const std::string& dir) {
  if (!fs::exists(dir)) return;
  if (!fs::is_directory(dir)) throw std::runtime_error(dir + " exists and is not a folder");
  if (fs::is_empty(dir)) return;
  bool earlier_run = false;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    const auto ends = [&](const std::string& tail) {
      return name.size() >= tail.size() &&
             name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
    };
    earlier_run = earlier_run || ends("runtime_stats.json") || ends(".trajectory.tum") ||
                  ends(".agent_steps.csv") || ends(".log");
  }
  if (!earlier_run) {
    throw std::runtime_error(dir +
                             " is not empty and holds no earlier draco-fleet run "
                             "(no runtime_stats.json, <robot>.trajectory.tum or <robot>.log): "
                             "give another --out");
  }
  Status("draco-fleet: replacing the earlier run in %s\n", dir.c_str());
  fs::remove_all(dir);
}

// The in-process team: one graph, every robot prefixed, one deterministic executor.
int RunInProcess(const Options& o, const draco::recording::MissionInfo& info,
                 const std::vector<std::string>& team, const std::string& out_dir) {
  PrepareModeFolder(out_dir);
  fs::create_directories(out_dir);
  draco::graph::LoadOptions load;
  for (std::size_t i = 0; i < team.size(); ++i) {
    RobotSetup s;
    s.mission_dir = o.mission;
    s.simulate = o.simulate;
    s.simulate_duration_s = o.duration_s;
    s.team = team;
    s.robot_id = static_cast<int>(i);
    s.world = info.world;
    s.transport = "inproc";
    s.bus = "team-" + std::to_string(::getpid());
    s.lockstep = false;
    const auto ov = draco::fleet_app::RobotOverrides(s, team[i] + "_");
    load.overrides.insert(load.overrides.end(), ov.begin(), ov.end());
    for (const auto& x : o.overrides) load.overrides.push_back(team[i] + "_" + x);
  }
  const std::string yaml = draco::fleet_app::ComposeTeamGraph(o.graph, team);
  auto graph = draco::graph::LoadGraphString(yaml, "team graph composed from " + o.graph, load,
                                             fs::path(o.graph).parent_path().string());
  // What ran, every parameter resolved (the daemons write theirs as <robot>.graph.yaml).
  draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/team.graph.yaml",
                                           draco::graph::ResolvedYaml(*graph));
  draco::graph::RunOptions run;
  run.output_dir = out_dir;
  run.stop_requested = &g_stop;
  run.island_threads =
      o.threads > 0 ? o.threads
                    : static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 4u));
  if (const double end_s = draco::fleet_app::MissionLengthS(o.mission, team); end_s > 0.0) {
    run.until = draco::graph::Time::FromSeconds(end_s);
  } else {
    draco::log::Warn("draco-fleet: no replay length from " + o.mission +
                     "/<robot>/ahrs.csv: running until every recording ends");
  }
  draco::graph::ProgressPrinter progress("draco-fleet: in-process team",
                                         draco::fleet_app::MissionLengthS(o.mission, team));
  run.progress = progress.Callback();
  const auto result = draco::graph::RunDeterministic(*graph, run);
  progress.Finish(draco::graph::Time::FromSeconds(result.stats.mission_s));
  draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/runtime_stats.json", result.stats.ToJson());
  if (!result.ok) {
    draco::log::Error("draco-fleet: in-process run failed: " + result.error);
    return 1;
  }
  if (result.interrupted) {
    draco::log::Warn("draco-fleet: interrupted");
    return 1;
  }
  Status("draco-fleet: in-process team done in %.1f s\n", result.stats.wall_s);
  return 0;
}

// One daemon per robot over DDS; optionally kills one mid-mission and restarts it.
int RunDds(const Options& o, const std::vector<std::string>& team, const std::string& out_dir) {
  PrepareModeFolder(out_dir);
  fs::create_directories(out_dir);
  const auto robot_bin = draco::fleet_app::SiblingApp("draco-robot", "fleet").string();
  if (!fs::exists(robot_bin)) {
    draco::log::Error("draco-fleet: " + robot_bin + " not found (build the draco-robot target)");
    return 1;
  }
  auto args_for = [&](const std::string& robot) {
    std::vector<std::string> a = {robot_bin,
                                  "--mission",
                                  o.mission,
                                  "--robot",
                                  robot,
                                  "--out",
                                  out_dir,
                                  "--graph",
                                  o.graph,
                                  "--rate",
                                  std::to_string(o.rate),
                                  "--quiet",
                                  "--log-level",
                                  std::string(draco::log::LevelName(draco::log::Global().level()))};
    // No --dds-config: the daemons read the same $CYCLONEDDS_URI.
    if (!o.dds_config.empty()) a.insert(a.end(), {"--dds-config", o.dds_config});
    if (o.domain >= 0) a.insert(a.end(), {"--domain", std::to_string(o.domain)});
    if (o.threads > 0) a.insert(a.end(), {"--threads", std::to_string(o.threads)});
    for (const auto& x : o.overrides) {
      a.push_back("--set");
      a.push_back(x);
    }
    return a;
  };
  // The daemons take their input from the command line only: a DRACO_BAG or DRACO_TEAM left in
  // the environment (draco-robot's stand-ins for --bag, --team) would contradict --mission.
  ::unsetenv("DRACO_BAG");
  ::unsetenv("DRACO_TEAM");
  std::map<std::string, pid_t> pids;
  std::map<std::string, int> codes;
  for (const auto& r : team) {
    const auto log = out_dir + "/" + r + ".log";
    std::error_code ec;
    fs::remove(log, ec);
    pids[r] = Spawn(args_for(r), log);
    Status("draco-fleet: started %s (pid %d, log %s)\n", r.c_str(), pids[r], log.c_str());
  }
  std::fflush(stdout);
  const auto start = std::chrono::steady_clock::now();
  bool killed = false, restarted = false, timed_out = false, stopping = false;
  double stop_sent_at = 0.0;
  constexpr double kStopGraceS = 15.0;
  double killed_at = 0.0;
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  double last_note = 0.0;
  while (!pids.empty()) {
    int status = 0;
    const pid_t done = ::waitpid(-1, &status, WNOHANG);
    if (done > 0) {
      for (auto it = pids.begin(); it != pids.end(); ++it) {
        if (it->second != done) continue;
        const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        // Only our SIGKILL counts as the kill: a daemon that finished just before it is done.
        const bool was_killed = killed && !restarted && it->first == o.kill &&
                                WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
        if (!was_killed) {
          codes[it->first] = code;
          Status("draco-fleet: %s finished (exit %d) after %.1f s\n", it->first.c_str(), code,
                 elapsed());
          pids.erase(it);
        } else {
          Status("draco-fleet: %s killed at %.1f s\n", it->first.c_str(), killed_at);
          it->second = -1;  // waiting for the restart
        }
        std::fflush(stdout);
        break;
      }
      continue;
    }
    if (g_stop && !stopping) {
      for (const auto& [r, pid] : pids) {
        if (pid > 0) ::kill(pid, SIGTERM);
      }
      stopping = true;  // wait for them to flush
      stop_sent_at = elapsed();
    }
    if (stopping && elapsed() - stop_sent_at > kStopGraceS) {
      for (const auto& [r, pid] : pids) {
        if (pid > 0) ::kill(pid, SIGKILL);  // did not stop within the grace period
      }
      stop_sent_at = 1e300;
    }
    if (!o.kill.empty() && !killed && elapsed() >= o.kill_after_s && pids.count(o.kill) &&
        pids[o.kill] > 0) {
      ::kill(pids[o.kill], SIGKILL);
      killed = true;
      killed_at = elapsed();
    }
    if (killed && !restarted && !stopping && o.restart_after_s >= 0 &&
        elapsed() >= killed_at + o.restart_after_s && pids.count(o.kill) && pids[o.kill] < 0) {
      pids[o.kill] = Spawn(args_for(o.kill), out_dir + "/" + o.kill + ".log");
      restarted = true;
      Status("draco-fleet: restarted %s (pid %d) at %.1f s\n", o.kill.c_str(), pids[o.kill],
             elapsed());
      std::fflush(stdout);
    }
    if (killed && (o.restart_after_s < 0 || stopping) && pids.count(o.kill) && pids[o.kill] < 0) {
      codes[o.kill] = 137;
      pids.erase(o.kill);
    }
    if (!timed_out && elapsed() > o.timeout_s) {
      timed_out = true;
      draco::log::Error("draco-fleet: timeout after " + std::to_string(o.timeout_s) +
                        " s; stopping the daemons");
      g_stop = true;  // SIGTERM now, SIGKILL after the grace period
    }
    if (elapsed() - last_note > 30.0) {
      last_note = elapsed();
      Status("draco-fleet: %zu daemon(s) running, %.0f s\n", pids.size(), elapsed());
      std::fflush(stdout);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  int worst = timed_out ? 1 : 0;
  for (const auto& [r, c] : codes) {
    if (c != 0 && !(r == o.kill && o.restart_after_s < 0)) worst = 1;
  }
  Status("draco-fleet: DDS team done in %.1f s\n", elapsed());
  return worst;
}

// --simulate: the mission's navigation and ground truth, no pings, as a recorded mission in
// dir (draco-sim --no-sonar: seconds), for the mission length and the evaluation. The robots'
// sensors come from sim.LiveRobot in the graph, which simulates the same records.
void WriteNavigationOnly(const Options& o, const std::string& dir) {
  const auto sim = draco::fleet_app::SiblingApp("draco-sim", "sim").string();
  if (!fs::exists(sim)) throw std::runtime_error(sim + " not found (build the draco-sim target)");
  std::vector<std::string> args = {sim, o.simulate, "--out", dir, "--no-sonar", "--no-pictures"};
  if (o.duration_s > 0.0) {
    char text[40];
    const auto end = std::to_chars(text, text + sizeof(text), o.duration_s).ptr;  // round trip
    args.insert(args.end(), {"--duration-s", std::string(text, end)});
  }
  const std::string log = o.out + "/sim.log";
  std::error_code ec;
  fs::remove(log, ec);
  Status("draco-fleet: navigation and ground truth of %s into %s (no pings)\n", o.simulate.c_str(),
         dir.c_str());
  if (draco::fleet_app::RunAndWait(args, log) != 0) {
    throw std::runtime_error("draco-sim --no-sonar failed (" + log + ")");
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-fleet: a whole team on a recorded mission, over DDS and/or in-process"};
  draco::app::AddLogLevelOption(app);
  Options o;
  std::string mode = "both";
  app.add_option("mission", o.mission, "recorded mission folder");
  app.add_option("--simulate", o.simulate,
                 "a mission YAML to simulate while the team runs, instead of a recorded mission "
                 "(in-process only; nothing of the pings on disk)");
  app.add_option("--duration-s", o.duration_s,
                 "--simulate: cap each robot's duration, as draco-sim --duration-s")
      ->check(CLI::PositiveNumber);
  app.add_option("--out", o.out,
                 "output folder (default runs/fleet-<mission>; --simulate: "
                 "runs/fleet-<mission file name>-live)");
  auto* mode_opt = app.add_option("--mode", mode, "dds, inproc or both (--simulate: inproc)")
                       ->check(CLI::IsMember({"dds", "inproc", "both"}));
  app.add_option("--graph", o.graph,
                 "robot graph YAML (default: graphs/robot.yaml; --simulate: "
                 "graphs/robot-live.yaml)");
  app.add_option("--domain", o.domain,
                 "DDS domain id (default: the graph's link.domain_id, 0 unless set there)")
      ->check(CLI::Range(0, 230));
  app.add_option("--dds-config", o.dds_config,
                 "Cyclone DDS XML file, or a shipped profile: loopback, lan, unicast (default: "
                 "$CYCLONEDDS_URI when set, else loopback)");
  app.add_option("--set", o.overrides, "override for every robot: component_id.param=value");
  app.add_option("--kill", o.kill, "dds: kill this robot's daemon (SIGKILL) mid-mission");
  app.add_option("--kill-after-s", o.kill_after_s, "... this many wall seconds after start");
  app.add_option("--restart-after-s", o.restart_after_s,
                 "... and restart it this many seconds later (default: never)");
  app.add_option("--rate", o.rate,
                 "dds: pace the daemons at N x real time (0: as fast as lock-step allows)");
  app.add_option("--timeout-s", o.timeout_s, "dds: stop the daemons after this many seconds");
  app.add_option("--threads", o.threads,
                 "inproc: run the robots on up to this many threads, the same outputs for any "
                 "number (default 0: the machine's cores, at most 4); dds: each daemon's "
                 "--threads (default: theirs)")
      ->check(CLI::Range(0, 64));
  app.set_version_flag("--version", draco::app::VersionLine("draco-fleet"));
  CLI11_PARSE(app, argc, argv);
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);

  if (o.mission.empty() == o.simulate.empty()) {
    draco::log::Error("draco-fleet: give a recorded mission folder or --simulate MISSION.yaml");
    return 2;
  }
  if (!o.simulate.empty()) {
    if (mode_opt->count() > 0 && mode != "inproc") {
      draco::log::Error("draco-fleet: --simulate runs the team in-process only (--mode inproc)");
      return 2;
    }
    mode = "inproc";
  } else if (o.duration_s > 0.0) {
    draco::log::Error("draco-fleet: --duration-s goes with --simulate");
    return 2;
  }

  try {
    if (!o.simulate.empty()) {
      if (o.out.empty()) o.out = "runs/fleet-" + fs::path(o.simulate).stem().string() + "-live";
      fs::create_directories(o.out);
      o.mission = o.out + "/mission";
      WriteNavigationOnly(o, o.mission);
    }
    const auto info = draco::recording::LoadMissionInfo(o.mission);
    std::vector<std::string> team;
    for (const auto& r : info.robots) team.push_back(r.name);
    if (!o.kill.empty() && std::find(team.begin(), team.end(), o.kill) == team.end()) {
      draco::log::Error("draco-fleet: --kill " + o.kill + ": no such robot in the mission");
      return 1;
    }
    if (o.out.empty()) o.out = "runs/fleet-" + info.name;
    o.graph = draco::app::ResolveDataFile(
                  o.simulate.empty() ? "graphs/robot.yaml" : "graphs/robot-live.yaml", o.graph)
                  .path;
    if (mode != "inproc") {
      const auto dds = draco::app::ChooseDdsConfigFromEnvironment(o.dds_config);
      o.dds_config = dds.file;
      Status("draco-fleet: %s\n", dds.Describe().c_str());
    }
    fs::create_directories(o.out);
    auto run_info = draco::app::MakeRunInfo("draco-fleet", argc, argv);
    run_info.AddFile("graph", o.graph);
    if (!o.simulate.empty()) run_info.AddFile("mission", o.simulate);
    if (mode != "inproc" && !o.dds_config.empty()) run_info.AddFile("dds_config", o.dds_config);
    draco::app::WriteRunInfo(o.out, run_info);
    std::string report =
        "# Fleet run: " + info.name + "\n\n" +
        (o.simulate.empty() ? "Mission `" + o.mission + "`"
                            : "Mission `" + o.simulate + "` simulated while the team ran (`" +
                                  o.mission + "`: its navigation and ground truth)") +
        ", graph `" + o.graph + "`.\n";
    std::map<std::string, draco::report::TeamResult> results;
    int rc = 0;
    for (const std::string m : {"inproc", "dds"}) {
      if (mode != "both" && mode != m) continue;
      if (g_stop) break;  // interrupted: do not start the next mode
      const std::string dir = o.out + "/" + m;
      const int code = m == "dds" ? RunDds(o, team, dir) : RunInProcess(o, info, team, dir);
      if (code != 0) rc = code;
      results[m] = draco::report::EvaluateTeamRun(dir, o.mission, team);
      const std::string title =
          m == "dds" ? "DDS, one daemon per robot (" + dir + ")" : "in-process (" + dir + ")";
      std::printf("\n%s", draco::report::FormatTeamResult(results[m], title).c_str());
      report += "\n## " + title + "\n\n" + draco::report::TeamResultMarkdown(results[m]);
      // Where each robot placed each teammate, judged against ground truth.
      const auto placements = draco::report::EvaluatePlacements(dir, o.mission, team);
      const std::string table = draco::report::PlacementsMarkdown(placements);
      draco::graph::WriteFileAtomicallyOrThrow(dir + "/placements_verdict.csv",
                                               draco::report::PlacementsCsv(placements));
      std::printf("\nPlacements (right: within 2 m and 5 deg of the truth)\n%s", table.c_str());
      report += "\n### Placements\n\n" + table;
    }
    if (results.size() == 2) {
      // Same result within 10 %: accepted loops and team ATE, per robot.
      std::printf("\nDDS against in-process (tolerance 10 %%)\n");
      report +=
          "\n## DDS against in-process\n\n| robot | accepted (inproc/dds) | team ATE m "
          "(inproc/dds) | within 10 % |\n|---|---|---|---|\n";
      bool all_ok = true;
      for (std::size_t i = 0; i < team.size(); ++i) {
        const auto& a = results["inproc"].robots[i];
        const auto& b = results["dds"].robots[i];
        const bool loops_ok = std::abs(a.accepted - b.accepted) <= 0.1 * std::max(a.accepted, 1);
        const bool ate_ok =
            (a.team_ate_m < 0 && b.team_ate_m < 0) ||
            std::abs(a.team_ate_m - b.team_ate_m) <= 0.1 * std::max(a.team_ate_m, 1e-3);
        all_ok = all_ok && loops_ok && ate_ok;
        std::printf("  %-9s accepted %d / %d, team ATE %.3f / %.3f m: %s\n", a.name.c_str(),
                    a.accepted, b.accepted, a.team_ate_m, b.team_ate_m,
                    loops_ok && ate_ok ? "same" : "DIFFERENT");
        char line[200];
        std::snprintf(line, sizeof line, "| %s | %d / %d | %.3f / %.3f | %s |\n", a.name.c_str(),
                      a.accepted, b.accepted, a.team_ate_m, b.team_ate_m,
                      loops_ok && ate_ok ? "yes" : "no");
        report += line;
      }
      if (!all_ok && rc == 0) rc = 3;
    }
    draco::graph::WriteFileAtomicallyOrThrow(o.out + "/fleet_report.md", report);
    std::printf("\nreport: %s/fleet_report.md\n", o.out.c_str());
    return rc;
  } catch (const draco::graph::GraphError& e) {
    draco::log::Error(e.what());
    return 1;
  } catch (const std::exception& e) {
    draco::log::Error(std::string("draco-fleet: ") + e.what());
    return 1;
  }
}
