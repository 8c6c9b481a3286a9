// Evaluation of a team run folder: ATE (concatenation protocol), inter-robot loops against
// ground truth, agent work per step, message sizes, link traffic. Moved here from
// apps/fleet/team_setup.cpp (draco-fleet) and extended for draco-eval. The loops are read and
// judged in inter_loops.cpp, the agent steps in agent_steps.cpp, the link traffic in
// link_traffic.cpp; the tables are in team_tables.cpp.
#include "draco/report/team_run.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <tuple>

#include "draco/recording/recording.hpp"
#include "draco/report/files.hpp"
#include "message_kinds.hpp"

namespace fs = std::filesystem;

namespace draco::report {
namespace {

using internal::KindRank;

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

eval::Trajectory ReadIfExists(const fs::path& p) {
  if (!fs::exists(p)) return {};
  return eval::ReadTum(p.string());
}

}  // namespace

std::string TeamTruthPath(const std::string& run_dir, const std::string& mission_dir,
                          const std::string& robot) {
  if (!mission_dir.empty()) return (fs::path(mission_dir) / robot / "groundtruth.tum").string();
  const fs::path own = fs::path(run_dir) / (robot + ".ground_truth.tum");
  return (fs::exists(own) ? own : fs::path(run_dir) / "ground_truth.tum").string();
}

bool IsTeamRun(const std::string& run_dir) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(run_dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.find(".team.") != std::string::npos && EndsWith(name, ".tum")) return true;
  }
  return false;
}

std::vector<std::string> TeamOf(const std::string& run_dir, const std::string& mission_dir) {
  std::vector<std::string> team;
  if (!mission_dir.empty()) {
    for (const auto& r : recording::LoadMissionInfo(mission_dir).robots) team.push_back(r.name);
    return team;
  }
  const std::string suffix = ".trajectory.tum";
  for (const auto& e : fs::directory_iterator(run_dir)) {
    const std::string name = e.path().filename().string();
    if (EndsWith(name, suffix) && name.size() > suffix.size()) {
      team.push_back(name.substr(0, name.size() - suffix.size()));
    }
  }
  std::sort(team.begin(), team.end());
  // Ids from the link statistics, when every robot has a distinct one.
  std::vector<std::pair<int, std::string>> ids;
  for (const auto& r : team) {
    std::ifstream f(fs::path(run_dir) / (r + ".link_stats.json"));
    if (!f) return team;
    try {
      ids.push_back({nlohmann::json::parse(f).at("robot_id").get<int>(), r});
    } catch (const std::exception&) {
      return team;
    }
  }
  std::sort(ids.begin(), ids.end());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (ids[i].first != static_cast<int>(i)) return team;
  }
  for (std::size_t i = 0; i < ids.size(); ++i) team[i] = ids[i].second;
  return team;
}

TeamResult EvaluateTeamRun(const std::string& run_dir, const std::string& mission_dir,
                           std::vector<std::string> team, const LoopTruthOptions& loop_truth) {
  constexpr double kSegmentOffsetS = 1e5;
  TeamResult out;
  out.run_dir = run_dir;
  out.mission_dir = mission_dir;
  if (team.empty()) team = TeamOf(run_dir, mission_dir);
  out.team = team;
  std::map<std::string, KindSizes> kinds;
  const fs::path dir(run_dir);
  const std::size_t n = team.size();
  std::vector<eval::Trajectory> truth(n), keyframes(n);
  for (std::size_t i = 0; i < n; ++i) {
    try {
      truth[i] = ReadIfExists(TeamTruthPath(run_dir, mission_dir, team[i]));
      keyframes[i] = ReadIfExists(dir / (team[i] + ".trajectory.tum"));
    } catch (const std::exception& e) {
      out.problems.push_back(team[i] + ": " + e.what());
    }
    if (!truth[i].empty()) out.has_truth = true;
  }
  std::map<std::tuple<int, int, int, int>, InterLoop> distinct;
  for (std::size_t i = 0; i < n; ++i) {
    const std::string& name = team[i];
    RobotResult r;
    r.name = name;
    const auto& local = keyframes[i];
    r.keyframes = static_cast<int>(local.size());
    if (!local.empty()) r.mission_s = local.back().time_s - local.front().time_s;
    // Mission time: the robot's runtime statistics (a daemon's), else the team's (in-process).
    fs::path rt = dir / (name + ".runtime_stats.json");
    if (!fs::exists(rt)) rt = dir / "runtime_stats.json";
    if (fs::exists(rt)) {
      try {
        r.mission_s = std::max(r.mission_s, ReadRuntimeStats(rt.string()).mission_s);
      } catch (const std::exception& e) {
        out.problems.push_back(e.what());
      }
    }
    try {
      if (!local.empty() && !truth[i].empty()) {
        r.local_ate_m = eval::Ate(local, truth[i]).rmse_m;
        const auto dr = ReadIfExists(dir / (name + ".dead_reckoning.tum"));
        if (!dr.empty()) r.dr_ate_m = eval::Ate(dr, truth[i]).rmse_m;
      }
      // The paper's protocol: own trajectory, then the teammates' in mission order, each
      // segment shifted in time, one SE(2) alignment.
      eval::Trajectory est_all, truth_all;
      int segment = 0;
      std::vector<std::size_t> order{i};
      for (std::size_t j = 0; j < n; ++j) {
        if (j != i) order.push_back(j);
      }
      for (const std::size_t j : order) {
        const auto est = ReadIfExists(dir / (name + ".team." + team[j] + ".tum"));
        if (est.empty() || truth[j].empty()) continue;
        ++r.placed;
        for (auto p : est) {
          p.time_s += segment * kSegmentOffsetS;
          est_all.push_back(p);
        }
        for (auto p : truth[j]) {
          p.time_s += segment * kSegmentOffsetS;
          truth_all.push_back(p);
        }
        ++segment;
      }
      if (!est_all.empty()) r.team_ate_m = eval::Ate(est_all, truth_all).rmse_m;
    } catch (const std::exception& e) {
      out.problems.push_back(name + ": " + e.what());
    }

    std::vector<InterLoop> loops;
    if (const fs::path p = dir / (name + ".inter_loops.csv"); fs::exists(p)) {
      try {
        loops = ReadInterLoops(p.string());
      } catch (const std::exception& e) {
        out.problems.push_back(e.what());
      }
    }
    JudgeInterLoops(&loops, keyframes, truth, loop_truth);
    r.loops = CountLoops(loops);
    r.candidates = r.loops.candidates;
    r.accepted = r.loops.accepted;
    for (const auto& l : loops) {
      // The same loop as both robots record it: keyed by its two keyframes, in robot order.
      auto key =
          l.own_robot <= l.teammate_robot
              ? std::make_tuple(l.own_robot, l.own_keyframe, l.teammate_robot, l.teammate_keyframe)
              : std::make_tuple(l.teammate_robot, l.teammate_keyframe, l.own_robot, l.own_keyframe);
      auto [it, added] = distinct.emplace(key, l);
      if (!added) it->second.accepted = it->second.accepted || l.accepted;
    }
    out.loops.push_back(std::move(loops));

    if (const fs::path p = dir / (name + ".registrations.csv"); fs::exists(p)) {
      try {
        auto rows = ReadRegistrations(p.string());
        std::vector<InterLoop> judged;
        for (const auto& row : rows) judged.push_back(row.loop);
        JudgeInterLoops(&judged, keyframes, truth, loop_truth);
        for (std::size_t k = 0; k < rows.size(); ++k) {
          rows[k].loop = judged[k];
          out.registrations.push_back(rows[k]);
        }
      } catch (const std::exception& e) {
        out.problems.push_back(e.what());
      }
    }

    if (const fs::path p = dir / (name + ".agent_steps.csv"); fs::exists(p)) {
      try {
        StepWork w = ReadAgentSteps(p.string());
        w.robot = name;
        out.steps.push_back(w);
      } catch (const std::exception& e) {
        out.problems.push_back(e.what());
      }
    }
    if (const fs::path p = dir / (name + ".link_traffic.csv"); fs::exists(p)) {
      try {
        for (auto& f : ReadLinkTraffic(p.string())) out.traffic.push_back(std::move(f));
      } catch (const std::exception& e) {
        out.problems.push_back(e.what());
      }
    }
    if (std::ifstream f(dir / (name + ".link_stats.json")); f) {
      try {
        const nlohmann::json j = nlohmann::json::parse(f);
        for (const auto& [kind, v] : j.at("kinds").items()) {
          auto& k = kinds[kind];
          k.kind = kind;
          k.frames += v.value("frames_sent", 0.0);
          k.bits += v.value("bits_sent", 0.0);
          k.max_bits = std::max(k.max_bits, v.value("max_bits", 0.0));
          k.dropped += v.value("dropped_queue", 0.0) + v.value("dropped_expired", 0.0) +
                       v.value("lost", 0.0);
          k.rejected += v.value("rejected", 0.0);
          r.bits_sent += v.value("bits_sent", 0.0);
        }
        if (j.contains("teammates")) {
          for (const auto& t : j["teammates"]) {
            const int id = t.value("robot_id", -1);
            const std::string tn = id >= 0 && id < static_cast<int>(n)
                                       ? team[static_cast<std::size_t>(id)]
                                       : std::to_string(id);
            r.teammate_frames[tn] = t.value("frames_received", 0.0);
            r.restarts_seen += t.value("restarts", 0);
          }
        }
      } catch (const std::exception& e) {
        out.problems.push_back((dir / (name + ".link_stats.json")).string() + ": " + e.what());
      }
    }
    if (r.mission_s > 0) r.mean_bps = r.bits_sent / r.mission_s;
    out.robots.push_back(r);
  }
  std::vector<InterLoop> unique;
  for (const auto& [key, l] : distinct) unique.push_back(l);
  out.distinct_loops = CountLoops(unique);
  if (out.has_truth && !out.registrations.empty()) {
    std::vector<double> thresholds;
    for (int i = 0; i <= 9; ++i) thresholds.push_back(0.5 + 0.05 * i);
    out.sweep = OverlapSweep(out.registrations, thresholds);
  }
  for (auto& [name, k] : kinds) out.kinds.push_back(k);
  std::stable_sort(out.kinds.begin(), out.kinds.end(), [](const KindSizes& a, const KindSizes& b) {
    return KindRank(a.kind) < KindRank(b.kind);
  });
  std::stable_sort(
      out.traffic.begin(), out.traffic.end(),
      [](const TrafficFrame& a, const TrafficFrame& b) { return a.start_s < b.start_s; });
  return out;
}

std::vector<std::string> WriteLoopVerdicts(const TeamResult& t) {
  std::vector<std::string> written;
  for (std::size_t i = 0; i < t.robots.size() && i < t.loops.size(); ++i) {
    const fs::path src = fs::path(t.run_dir) / (t.robots[i].name + ".inter_loops.csv");
    if (!fs::exists(src)) continue;
    const std::string path =
        (fs::path(t.run_dir) / (t.robots[i].name + ".inter_loops_verdict.csv")).string();
    WriteFileAtomically(path, InterLoopsVerdictCsv(t.loops[i]));
    written.push_back(path);
  }
  return written;
}

}  // namespace draco::report
