// draco-worlds: the generalization benchmark. For each seed: a generated harbour world and
// mission (draco-sim generate), its recording (draco-sim), the whole team in one process with
// the daemons' graph (draco-fleet --mode inproc), then where every robot placed every teammate
// judged against ground truth (report::EvaluatePlacements) and the team's loops and ATE
// (report::EvaluateTeamRun). Writes OUT/worlds.csv (a row per world), OUT/pairs.csv (a row
// per ordered pair) and OUT/worlds.md (the tables and the totals); each world's folder keeps
// its scenario (world.yaml, mission.yaml, world.png) and run outputs; the recording is deleted
// after the run unless --keep-missions (a mission is 1-3 GB).
//
//   draco-worlds --seeds 101-130 --out runs/worlds
//   draco-worlds --seeds 1-3 --out runs/worlds-smoke --robots 3 --duration-s 300
//   draco-worlds --mission runs/missions/marina --out runs/worlds   # a recorded mission as a row
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "app_version.hpp"
#include "draco/graph/executor.hpp"
#include "draco/report/placements.hpp"
#include "draco/report/team_run.hpp"
#include "log_option.hpp"
#include "process.hpp"
#include "run_info.hpp"

namespace {
namespace fs = std::filesystem;

using draco::fleet_app::RunAndWait;

std::vector<std::uint64_t> ParseSeeds(const std::string& text) {
  std::vector<std::uint64_t> out;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ',')) {
    const auto dash = part.find('-');
    try {
      if (dash == std::string::npos) {
        out.push_back(std::stoull(part));
      } else {
        const auto a = std::stoull(part.substr(0, dash)), b = std::stoull(part.substr(dash + 1));
        if (b < a || b - a > 10000) throw std::invalid_argument("range");
        for (auto s = a; s <= b; ++s) out.push_back(s);
      }
    } catch (const std::exception&) {
      throw std::runtime_error("--seeds: '" + part + "' is not a seed or a range a-b");
    }
  }
  return out;
}

// The last "[error]" line of a step's log, without its time stamp ("" when none), so the
// console says why a world did not run.
std::string LastError(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line)) {
    const auto at = line.find("[error] ");
    if (at != std::string::npos) last = line.substr(at + 8);
  }
  if (last.size() > 300) last = last.substr(0, 297) + "...";
  return last;
}

std::map<std::string, std::string> ReadKeyValues(const fs::path& p) {
  std::map<std::string, std::string> out;
  std::ifstream f(p);
  std::string line;
  while (std::getline(f, line)) {
    const auto c = line.find(':');
    if (c == std::string::npos) continue;
    auto v = line.substr(c + 1);
    v.erase(0, v.find_first_not_of(' '));
    out[line.substr(0, c)] = v;
  }
  return out;
}

struct WorldRow {
  std::string name;
  std::string periodic = "-";
  int robots = 0;
  int pairs = 0, right = 0, wrong = 0, none = 0;
  int wrong_ever = 0;  // pairs placed wrong at some time
  int eligible = 0;    // pairs sharing >= 5 objects with path overlap >= 30 %
  int eligible_right = 0;
  int accepted = 0, accepted_true = 0, candidates_true = 0;
  double precision = NAN, recall = NAN;
  double team_ate_m = NAN, dr_ate_m = NAN, oracle_ate_m = NAN, local_ate_m = NAN;
  int local_worse = 0;         // robots whose local SLAM ATE exceeds their dead reckoning's
  double first_right_s = NAN;  // median over pairs placed right
  double bits = 0.0;
  double bits_per_true_loop = NAN;
  double wall_s = 0.0;
  std::string status = "ok";
};

double Mean(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  double s = 0.0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}

WorldRow Evaluate(const std::string& name, const std::string& run_dir,
                  const std::string& mission_dir, const std::string& periodic,
                  std::string* pairs_csv) {
  WorldRow w;
  w.name = name;
  w.periodic = periodic;
  const auto team = draco::report::TeamOf(run_dir, mission_dir);
  const auto tr = draco::report::EvaluateTeamRun(run_dir, mission_dir, team);
  const auto pl = draco::report::EvaluatePlacements(run_dir, mission_dir, team);
  w.robots = static_cast<int>(team.size());
  std::vector<double> team_ate, dr_ate, oracle, local, first_right;
  for (std::size_t i = 0; i < tr.robots.size(); ++i) {
    const auto& r = tr.robots[i];
    if (r.team_ate_m >= 0) team_ate.push_back(r.team_ate_m);
    if (r.dr_ate_m >= 0) dr_ate.push_back(r.dr_ate_m);
    if (r.local_ate_m >= 0) local.push_back(r.local_ate_m);
    if (r.local_ate_m >= 0 && r.dr_ate_m >= 0 && r.local_ate_m > r.dr_ate_m) ++w.local_worse;
    if (i < pl.oracle_team_ate_m.size() && pl.oracle_team_ate_m[i] >= 0)
      oracle.push_back(pl.oracle_team_ate_m[i]);
    w.bits += r.bits_sent;
  }
  w.team_ate_m = Mean(team_ate);
  w.dr_ate_m = Mean(dr_ate);
  w.oracle_ate_m = Mean(oracle);
  w.local_ate_m = Mean(local);
  w.accepted = tr.distinct_loops.judged_accepted;
  w.accepted_true = tr.distinct_loops.tp_accepted;
  w.candidates_true = tr.distinct_loops.tp_candidates;
  w.precision = tr.distinct_loops.PrecisionAfter();
  w.recall = tr.distinct_loops.RecallProxy();
  if (w.accepted_true > 0) w.bits_per_true_loop = w.bits / w.accepted_true;
  for (const auto& p : pl.pairs) {
    ++w.pairs;
    const std::string v = p.Verdict();
    w.right += v == "right";
    w.wrong += v == "wrong";
    w.none += v == "none";
    w.wrong_ever += p.first_wrong_s >= 0.0;
    if (p.eligible) {
      ++w.eligible;
      w.eligible_right += v == "right";
    }
    if (p.final_right && p.first_right_s >= 0.0) first_right.push_back(p.first_right_s);
  }
  if (!first_right.empty()) {
    std::sort(first_right.begin(), first_right.end());
    w.first_right_s = first_right[first_right.size() / 2];
  }
  std::string csv = draco::report::PlacementsCsv(pl);
  csv.erase(0, csv.find('\n') + 1);  // header once, in the caller
  std::stringstream in(csv);
  std::string line;
  while (std::getline(in, line)) *pairs_csv += name + "," + line + "\n";
  for (const auto& p : pl.problems) draco::log::Warn("draco-worlds: " + name + ": " + p);
  return w;
}

// This process's --log-level, for the apps it starts.
std::string LogLevel() { return std::string(draco::log::LevelName(draco::log::Global().level())); }

std::string Fmt(double v, const char* f = "%.2f") {
  if (std::isnan(v)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string WorldsCsv(const std::vector<WorldRow>& rows) {
  std::string s =
      "world,status,periodic,robots,pairs,right,wrong,none,wrong_ever,eligible,eligible_right,"
      "accepted,accepted_true,precision,recall,team_ate_m,oracle_ate_m,dr_ate_m,local_ate_m,"
      "local_worse_than_dr,first_right_s,bits,bits_per_true_loop,wall_s\n";
  for (const auto& w : rows) {
    s += w.name + "," + w.status + "," + w.periodic + "," + std::to_string(w.robots) + "," +
         std::to_string(w.pairs) + "," + std::to_string(w.right) + "," + std::to_string(w.wrong) +
         "," + std::to_string(w.none) + "," + std::to_string(w.wrong_ever) + "," +
         std::to_string(w.eligible) + "," + std::to_string(w.eligible_right) + "," +
         std::to_string(w.accepted) + "," + std::to_string(w.accepted_true) + "," +
         Fmt(w.precision, "%.4f") + "," + Fmt(w.recall, "%.4f") + "," + Fmt(w.team_ate_m, "%.3f") +
         "," + Fmt(w.oracle_ate_m, "%.3f") + "," + Fmt(w.dr_ate_m, "%.3f") + "," +
         Fmt(w.local_ate_m, "%.3f") + "," + std::to_string(w.local_worse) + "," +
         Fmt(w.first_right_s, "%.0f") + "," + Fmt(w.bits, "%.0f") + "," +
         Fmt(w.bits_per_true_loop, "%.0f") + "," + Fmt(w.wall_s, "%.0f") + "\n";
  }
  return s;
}

std::string WorldsMarkdown(const std::vector<WorldRow>& rows) {
  std::string s =
      "| world | periodic | robots | pairs right / wrong / none | wrong at some time | "
      "eligible right | loops accepted (true) | precision | recall | team / oracle / DR ATE m | "
      "local SLAM worse than DR | first right s | bits per true loop |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  WorldRow t;
  t.name = "**all**";
  double min_precision = NAN;
  for (const auto& w : rows) {
    s += "| " + w.name + (w.status == "ok" ? "" : " (" + w.status + ")") + " | " + w.periodic +
         " | " + std::to_string(w.robots) + " | " + std::to_string(w.right) + " / " +
         std::to_string(w.wrong) + " / " + std::to_string(w.none) + " | " +
         std::to_string(w.wrong_ever) + " | " + std::to_string(w.eligible_right) + " / " +
         std::to_string(w.eligible) + " | " + std::to_string(w.accepted) + " (" +
         std::to_string(w.accepted_true) + ") | " + Fmt(w.precision, "%.3f") + " | " +
         Fmt(w.recall, "%.2f") + " | " + Fmt(w.team_ate_m) + " / " + Fmt(w.oracle_ate_m) + " / " +
         Fmt(w.dr_ate_m) + " | " + std::to_string(w.local_worse) + " | " +
         Fmt(w.first_right_s, "%.0f") + " | " + Fmt(w.bits_per_true_loop, "%.0f") + " |\n";
    t.pairs += w.pairs;
    t.right += w.right;
    t.wrong += w.wrong;
    t.none += w.none;
    t.wrong_ever += w.wrong_ever;
    t.eligible += w.eligible;
    t.eligible_right += w.eligible_right;
    t.accepted += w.accepted;
    t.accepted_true += w.accepted_true;
    t.candidates_true += w.candidates_true;
    t.robots += w.robots;
    t.local_worse += w.local_worse;
    if (!std::isnan(w.precision))
      min_precision =
          std::isnan(min_precision) ? w.precision : std::min(min_precision, w.precision);
  }
  const double precision = t.accepted ? static_cast<double>(t.accepted_true) / t.accepted : NAN;
  const double recall =
      t.candidates_true ? static_cast<double>(t.accepted_true) / t.candidates_true : NAN;
  s += "| " + t.name + " | | | " + std::to_string(t.right) + " / " + std::to_string(t.wrong) +
       " / " + std::to_string(t.none) + " | " + std::to_string(t.wrong_ever) + " | " +
       std::to_string(t.eligible_right) + " / " + std::to_string(t.eligible) + " | " +
       std::to_string(t.accepted) + " (" + std::to_string(t.accepted_true) + ") | " +
       Fmt(precision, "%.3f") + " (lowest " + Fmt(min_precision, "%.3f") + ") | " +
       Fmt(recall, "%.2f") + " | | " + std::to_string(t.local_worse) + " of " +
       std::to_string(t.robots) + " | | |\n";
  char summary[600];
  std::snprintf(
      summary, sizeof summary,
      "\nOrdered pairs: %d; placed right %d, placed wrong at the end %d (%.1f %%), "
      "placed wrong at some time %d, not placed %d. Pairs that share >= 5 objects and whose "
      "paths overlap >= 30 %%: %d of %d placed right. Robots whose local SLAM ends worse than "
      "their dead reckoning (ATE): %d of %d.\n",
      t.pairs, t.right, t.wrong, t.pairs ? 100.0 * t.wrong / t.pairs : 0.0, t.wrong_ever, t.none,
      t.eligible_right, t.eligible, t.local_worse, t.robots);
  return s + summary;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-worlds: the team on generated worlds (the generalization benchmark)"};
  draco::app::AddLogLevelOption(app);
  std::string seeds_text, out = "runs/worlds", style;
  std::vector<std::string> missions, overrides;
  int robots = 0;
  double duration_s = 0.0;
  bool keep = false, judge_only = false;
  app.add_option("--seeds", seeds_text, "seeds: 101-130 or 1,5,9 (draco-sim generate)");
  app.add_option("--mission", missions, "a recorded mission folder to run as a row too");
  app.add_option("--out", out, "output folder")->capture_default_str();
  app.add_option("--style", style, "generator style YAML (default: the generator's)");
  app.add_option("--robots", robots, "robots per generated mission (default: the style's)");
  app.add_option("--duration-s", duration_s, "cap each robot's mission (draco-sim)");
  int ping_quantization_step = 1;
  app.add_option("--ping-quantization-step", ping_quantization_step,
                 "record generated missions with lossy pings (draco-sim; default 1: exact)")
      ->check(CLI::Range(1, 128));
  app.add_option("--set", overrides, "component.param=value for every robot (draco-fleet)");
  app.add_flag("--keep-missions", keep, "keep the recordings (1-3 GB each)");
  app.add_flag("--judge", judge_only,
               "judge the runs already in --out again (same --seeds/--mission), run nothing");
  app.set_version_flag("--version", draco::app::VersionLine("draco-worlds"));
  CLI11_PARSE(app, argc, argv);
  try {
    const auto seeds = seeds_text.empty() ? std::vector<std::uint64_t>{} : ParseSeeds(seeds_text);
    if (seeds.empty() && missions.empty()) {
      draco::log::Error("draco-worlds: nothing to run (give --seeds and/or --mission)");
      return 2;
    }
    // Next to draco-worlds when installed, in their build-tree folders otherwise.
    const std::string sim = draco::fleet_app::SiblingApp("draco-sim", "sim").string();
    const std::string fleet = draco::fleet_app::SiblingApp("draco-fleet", "fleet").string();
    for (const auto& b : {sim, fleet}) {
      if (!fs::exists(b)) throw std::runtime_error(b + " not found (build it)");
    }
    fs::create_directories(out);
    auto run_info = draco::app::MakeRunInfo("draco-worlds", argc, argv);
    if (!style.empty()) run_info.AddFile("style", style);
    if (!judge_only) draco::app::WriteRunInfo(out, run_info);  // --judge keeps the run's
    std::vector<WorldRow> rows;
    std::string pairs_csv =
        "world,own,teammate,path_overlap,verdict,final_err_m,final_err_deg,first_placed_s,"
        "first_right_s,first_wrong_s,wrong_duration_s,max_wrong_err_m,changes,shared_objects,"
        "eligible\n";
    const auto write = [&] {
      draco::graph::WriteFileAtomicallyOrThrow(out + "/worlds.csv", WorldsCsv(rows));
      draco::graph::WriteFileAtomicallyOrThrow(out + "/pairs.csv", pairs_csv);
      std::string md = "# Generalization benchmark\n\n`draco-worlds";
      for (int i = 1; i < argc; ++i) md += std::string(" ") + argv[i];
      md += "`\n\n" + WorldsMarkdown(rows);
      draco::graph::WriteFileAtomicallyOrThrow(out + "/worlds.md", md);
    };
    struct Job {
      std::string name;
      std::uint64_t seed = 0;
      std::string mission;  // recorded mission (no generation)
    };
    std::vector<Job> jobs;
    // A row's name is its folder under --out: a mission folder named "mission" (as
    // --keep-missions leaves them) takes its parent's name, and a repeated name gets -2, -3.
    std::map<std::string, int> used;
    for (const auto& m : missions) {
      const fs::path path = fs::path(m).lexically_normal();
      fs::path base = path.filename().empty() ? path.parent_path() : path;
      std::string name = base.filename().string();
      if (name == "mission" && !base.parent_path().filename().empty())
        name = base.parent_path().filename().string();
      if (const int n = ++used[name]; n > 1) name += "-" + std::to_string(n);
      jobs.push_back({name, 0, m});
    }
    for (const auto s : seeds) {
      std::string name = "seed-" + std::to_string(s);
      if (const int n = ++used[name]; n > 1) name += "-" + std::to_string(n);
      jobs.push_back({name, s, ""});
    }
    int done = 0;
    for (const auto& job : jobs) {
      const auto t0 = std::chrono::steady_clock::now();
      const fs::path dir = fs::path(out) / job.name;
      fs::create_directories(dir);
      const std::string log = (dir / "log.txt").string();
      std::string mission_dir = job.mission;
      std::string periodic = "-";
      WorldRow w;
      w.name = job.name;
      std::printf("[%d/%zu] %s: ", done + 1, jobs.size(), job.name.c_str());
      std::fflush(stdout);
      if (judge_only) {
        periodic = ReadKeyValues(dir / "scenario" / "scenario.txt")["periodic"];
        if (periodic.empty()) periodic = "-";
        // Ground truth from the kept recording, else the copies the run wrote.
        if (mission_dir.empty() && fs::exists(dir / "mission" / "mission.yaml"))
          mission_dir = (dir / "mission").string();
        if (!fs::exists(dir / "run" / "inproc")) w.status = "no run to judge";
      } else if (mission_dir.empty()) {
        const std::string scenario = (dir / "scenario").string();
        std::vector<std::string> gen{sim,     "generate", "--seed", std::to_string(job.seed),
                                     "--out", scenario};
        if (!style.empty()) gen.insert(gen.end(), {"--style", style});
        if (robots > 0) gen.insert(gen.end(), {"--robots", std::to_string(robots)});
        if (RunAndWait(gen, log) != 0) w.status = "generate failed";
        periodic = ReadKeyValues(dir / "scenario" / "scenario.txt")["periodic"];
        if (periodic.empty()) periodic = "-";
        mission_dir = (dir / "mission").string();
        if (w.status == "ok" && !fs::exists(fs::path(mission_dir) / "mission.yaml")) {
          std::printf("simulating, ");
          std::fflush(stdout);
          std::vector<std::string> args{sim, scenario + "/mission.yaml", "--out", mission_dir,
                                        "--no-pictures"};
          if (duration_s > 0) args.insert(args.end(), {"--duration-s", std::to_string(duration_s)});
          if (ping_quantization_step > 1) {
            args.insert(args.end(),
                        {"--ping-quantization-step", std::to_string(ping_quantization_step)});
          }
          if (RunAndWait(args, log) != 0) w.status = "simulation failed";
        }
      }
      const std::string run = (dir / "run").string();
      // draco-worlds' own: an earlier run's files must not be judged.
      if (!judge_only) fs::remove_all(run);
      if (w.status == "ok" && !judge_only) {
        std::printf("team, ");
        std::fflush(stdout);
        std::vector<std::string> args{fleet,   mission_dir, "--mode",      "inproc",
                                      "--out", run,         "--log-level", LogLevel()};
        for (const auto& o : overrides) args.insert(args.end(), {"--set", o});
        if (RunAndWait(args, log) != 0) w.status = "team run failed";
      }
      if (w.status == "ok") {
        w = Evaluate(job.name, run + "/inproc", mission_dir, periodic, &pairs_csv);
      } else {
        w.periodic = periodic;
      }
      if (job.mission.empty() && !keep && !judge_only) fs::remove_all(mission_dir);
      w.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      rows.push_back(w);
      ++done;
      std::printf("%s: right %d, wrong %d, none %d; loops %d (%d true); %.0f s\n", w.status.c_str(),
                  w.right, w.wrong, w.none, w.accepted, w.accepted_true, w.wall_s);
      write();
      if (w.status != "ok" && w.status != "no run to judge") {
        const std::string why = LastError(log);
        std::printf("  %s (%s)\n", why.empty() ? "no error logged" : why.c_str(), log.c_str());
        // An override no component takes fails every world alike: stop here.
        if (w.status == "team run failed" && why.rfind("--set ", 0) == 0) {
          std::fflush(stdout);
          draco::log::Error("draco-worlds: stopped: a --set override fails every team run");
          return 2;
        }
      }
    }
    std::printf("\n%s\n%s/worlds.md\n", WorldsMarkdown(rows).c_str(), out.c_str());
    return 0;
  } catch (const std::exception& e) {
    draco::log::Error(std::string("draco-worlds: ") + e.what());
    return 1;
  }
}
