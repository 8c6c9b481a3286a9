// Evaluation of a team run folder: ATE (concatenation protocol), inter-robot loops against
// ground truth, agent work per step, message sizes, link traffic. Moved here from
// apps/fleet/team_setup.cpp (draco-fleet) and extended for draco-eval.
#include "draco/report/team_run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "csv.hpp"
#include "draco/recording/recording.hpp"
#include "draco/report/files.hpp"

namespace fs = std::filesystem;

namespace draco::report {
namespace {

using internal::Csv;
using internal::ReadCsv;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kDeg = M_PI / 180.0;

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

eval::Trajectory ReadIfExists(const fs::path& p) {
  if (!fs::exists(p)) return {};
  return eval::ReadTum(p.string());
}

double Ratio(int num, int den) {
  return den > 0 ? static_cast<double>(num) / static_cast<double>(den) : kNan;
}

// Message kinds in the order of docs/fleet.md; unknown kinds after them, by name.
int KindRank(const std::string& kind) {
  static const char* kOrder[] = {"object_map", "keyframe_poses", "scan_request",
                                 "scan_reply", "loop_closures",  "heartbeat"};
  for (int i = 0; i < static_cast<int>(std::size(kOrder)); ++i) {
    if (kind == kOrder[i]) return i;
  }
  return static_cast<int>(std::size(kOrder));
}

WorkStat Stat(const Csv& csv, const std::string& column) {
  WorkStat s;
  if (csv.rows.empty()) return s;
  const std::size_t c = csv.Col(column);
  double sum = 0.0;
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    const double v = csv.Number(i, c);
    sum += v;
    s.max = std::max(s.max, v);
  }
  s.mean = sum / static_cast<double>(csv.rows.size());
  return s;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Inter-robot loops

std::vector<InterLoop> ReadInterLoops(const std::string& csv_path) {
  const Csv csv = ReadCsv(csv_path);
  std::vector<InterLoop> out;
  if (csv.rows.empty()) return out;
  const std::size_t id = csv.Col("id"), own_r = csv.Col("own_robot"),
                    own_k = csv.Col("own_keyframe"), mate_r = csv.Col("teammate_robot"),
                    mate_k = csv.Col("teammate_keyframe"), x = csv.Col("x_m"), y = csv.Col("y_m"),
                    yaw = csv.Col("yaw_rad"), overlap = csv.Col("overlap"),
                    acc = csv.Col("accepted");
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    InterLoop l;
    l.id = static_cast<std::uint64_t>(csv.Number(i, id));
    l.own_robot = static_cast<int>(csv.Number(i, own_r));
    l.own_keyframe = static_cast<int>(csv.Number(i, own_k));
    l.teammate_robot = static_cast<int>(csv.Number(i, mate_r));
    l.teammate_keyframe = static_cast<int>(csv.Number(i, mate_k));
    l.x_m = csv.Number(i, x);
    l.y_m = csv.Number(i, y);
    l.yaw_rad = csv.Number(i, yaw);
    l.overlap = csv.Number(i, overlap);
    l.accepted = csv.Number(i, acc) != 0.0;
    out.push_back(l);
  }
  return out;
}

std::vector<RegistrationRow> ReadRegistrations(const std::string& csv_path) {
  const Csv csv = ReadCsv(csv_path);
  std::vector<RegistrationRow> out;
  if (csv.rows.empty()) return out;
  const std::size_t window = csv.Col("window"), configured = csv.Col("configured"),
                    own_r = csv.Col("own_robot"), own_k = csv.Col("own_keyframe"),
                    mate_r = csv.Col("teammate_robot"), mate_k = csv.Col("teammate_keyframe"),
                    x = csv.Col("x_m"), y = csv.Col("y_m"), yaw = csv.Col("yaw_rad"),
                    overlap = csv.Col("overlap"), status = csv.Col("status");
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    RegistrationRow r;
    r.window = static_cast<int>(csv.Number(i, window));
    r.configured = csv.Number(i, configured) != 0.0;
    r.loop.own_robot = static_cast<int>(csv.Number(i, own_r));
    r.loop.own_keyframe = static_cast<int>(csv.Number(i, own_k));
    r.loop.teammate_robot = static_cast<int>(csv.Number(i, mate_r));
    r.loop.teammate_keyframe = static_cast<int>(csv.Number(i, mate_k));
    r.loop.x_m = csv.Number(i, x);
    r.loop.y_m = csv.Number(i, y);
    r.loop.yaw_rad = csv.Number(i, yaw);
    r.loop.overlap = csv.Number(i, overlap);
    const std::string& st = csv.rows[i][status];
    r.loop.accepted = st == "accepted" || st == "low overlap";
    out.push_back(r);
  }
  return out;
}

std::vector<SweepPoint> OverlapSweep(const std::vector<RegistrationRow>& rows,
                                     const std::vector<double>& thresholds) {
  std::set<int> windows;
  for (const auto& r : rows) windows.insert(r.window);
  std::vector<SweepPoint> out;
  for (const int w : windows) {
    for (const double t : thresholds) {
      SweepPoint p;
      p.window = w;
      p.threshold = t;
      for (const auto& r : rows) {
        if (r.window != w || !r.loop.accepted || !r.loop.judged || r.loop.overlap < t - 1e-9) {
          continue;
        }
        ++p.registrations;
        if (r.loop.true_positive) ++p.true_positives;
      }
      p.precision = p.registrations > 0 ? static_cast<double>(p.true_positives) / p.registrations
                                        : std::numeric_limits<double>::quiet_NaN();
      out.push_back(p);
    }
  }
  return out;
}

bool TruthAt(const eval::Trajectory& truth, double t, eval::StampedPose2* out, double max_gap_s) {
  if (truth.empty() || t < truth.front().time_s - 1e-9 || t > truth.back().time_s + 1e-9) {
    return false;
  }
  auto it = std::lower_bound(truth.begin(), truth.end(), t,
                             [](const eval::StampedPose2& p, double v) { return p.time_s < v; });
  if (it == truth.end()) it = std::prev(it);
  if (it->time_s <= t + 1e-9 || it == truth.begin()) {
    if (std::abs(it->time_s - t) > max_gap_s) return false;
    *out = *it;
    out->time_s = t;
    return true;
  }
  const auto& b = *it;
  const auto& a = *std::prev(it);
  if (t - a.time_s > max_gap_s && b.time_s - t > max_gap_s) return false;
  const double f = (t - a.time_s) / (b.time_s - a.time_s);
  out->time_s = t;
  out->x_m = a.x_m + f * (b.x_m - a.x_m);
  out->y_m = a.y_m + f * (b.y_m - a.y_m);
  out->yaw_rad = eval::WrapAngle(a.yaw_rad + f * eval::WrapAngle(b.yaw_rad - a.yaw_rad));
  return true;
}

void JudgeInterLoops(std::vector<InterLoop>* loops, const std::vector<eval::Trajectory>& keyframes,
                     const std::vector<eval::Trajectory>& truth, const LoopTruthOptions& o) {
  auto truth_of = [&](int robot, int kf, eval::StampedPose2* p) {
    if (robot < 0 || robot >= static_cast<int>(keyframes.size()) ||
        robot >= static_cast<int>(truth.size())) {
      return false;
    }
    const auto& kfs = keyframes[static_cast<std::size_t>(robot)];
    if (kf < 0 || kf >= static_cast<int>(kfs.size())) return false;
    return TruthAt(truth[static_cast<std::size_t>(robot)], kfs[static_cast<std::size_t>(kf)].time_s,
                   p);
  };
  for (auto& l : *loops) {
    eval::StampedPose2 a, b;
    l.judged = truth_of(l.own_robot, l.own_keyframe, &a) &&
               truth_of(l.teammate_robot, l.teammate_keyframe, &b);
    l.true_positive = false;
    l.err_m = l.err_deg = 0.0;
    if (!l.judged) continue;
    // Truth relative pose inv(T_world_a) * T_world_b, then its error against the loop.
    const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
    const double dx = b.x_m - a.x_m, dy = b.y_m - a.y_m;
    const double rel_x = c * dx + s * dy, rel_y = -s * dx + c * dy;
    const double rel_yaw = eval::WrapAngle(b.yaw_rad - a.yaw_rad);
    l.err_m = std::hypot(l.x_m - rel_x, l.y_m - rel_y);
    l.err_deg = std::abs(eval::WrapAngle(l.yaw_rad - rel_yaw)) / kDeg;
    l.true_positive = l.err_m <= o.max_m && l.err_deg <= o.max_deg;
  }
}

std::string InterLoopsVerdictCsv(const std::vector<InterLoop>& loops) {
  std::string s =
      "id,own_robot,own_keyframe,teammate_robot,teammate_keyframe,x_m,y_m,yaw_rad,overlap,"
      "accepted,true_positive,err_m,err_deg\n";
  for (const auto& l : loops) {
    char line[320];
    std::snprintf(line, sizeof line, "%llu,%d,%d,%d,%d,%.4f,%.4f,%.5f,%.3f,%d,",
                  static_cast<unsigned long long>(l.id), l.own_robot, l.own_keyframe,
                  l.teammate_robot, l.teammate_keyframe, l.x_m, l.y_m, l.yaw_rad, l.overlap,
                  l.accepted ? 1 : 0);
    s += line;
    if (l.judged) {
      std::snprintf(line, sizeof line, "%d,%.3f,%.2f\n", l.true_positive ? 1 : 0, l.err_m,
                    l.err_deg);
      s += line;
    } else {
      s += ",,\n";
    }
  }
  return s;
}

double LoopCounts::PrecisionBefore() const { return Ratio(tp_candidates, judged); }
double LoopCounts::PrecisionAfter() const { return Ratio(tp_accepted, judged_accepted); }
double LoopCounts::RecallProxy() const { return Ratio(tp_accepted, tp_candidates); }

LoopCounts CountLoops(const std::vector<InterLoop>& loops) {
  LoopCounts c;
  for (const auto& l : loops) {
    ++c.candidates;
    c.accepted += l.accepted;
    if (!l.judged) continue;
    ++c.judged;
    c.judged_accepted += l.accepted;
    c.tp_candidates += l.true_positive;
    c.tp_accepted += l.true_positive && l.accepted;
  }
  return c;
}

// ---------------------------------------------------------------------------------------
// Agent steps, link traffic

StepWork ReadAgentSteps(const std::string& csv_path) {
  const Csv csv = ReadCsv(csv_path);
  StepWork w;
  w.steps = static_cast<int>(csv.rows.size());
  if (csv.rows.empty()) return w;
  w.matches_tried = Stat(csv, "matches_tried");
  w.matches_found = Stat(csv, "matches_found");
  w.requests_sent = Stat(csv, "requests_sent");
  w.scans_registered = Stat(csv, "scans_registered");
  w.candidates_added = Stat(csv, "candidates_added");
  w.loops_accepted = Stat(csv, "loops_accepted");
  w.wall_ms = Stat(csv, "wall_ms");
  const std::size_t opt = csv.Col("optimized");
  for (std::size_t i = 0; i < csv.rows.size(); ++i) w.optimized += csv.Number(i, opt) != 0.0;
  return w;
}

std::vector<TrafficFrame> ReadLinkTraffic(const std::string& csv_path) {
  const Csv csv = ReadCsv(csv_path);
  std::vector<TrafficFrame> out;
  if (csv.rows.empty()) return out;
  const std::size_t start = csv.Col("start_s"), end = csv.Col("end_s"), kind = csv.Col("kind"),
                    bits = csv.Col("bits"), lost = csv.Col("lost");
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    TrafficFrame f;
    f.start_s = csv.Number(i, start);
    f.end_s = csv.Number(i, end);
    if (kind >= csv.rows[i].size()) throw std::runtime_error(csv_path + ": too few columns");
    f.kind = csv.rows[i][kind];
    f.bits = csv.Number(i, bits);
    f.lost = csv.Number(i, lost) != 0.0;
    out.push_back(std::move(f));
  }
  return out;
}

TrafficSeries BinTraffic(const std::vector<TrafficFrame>& frames, double window_s, double end_s) {
  TrafficSeries t;
  if (!(window_s > 0)) throw std::invalid_argument("BinTraffic: window_s must be positive");
  t.window_s = window_s;
  double last_s = std::max(end_s, 0.0);
  for (const auto& f : frames) last_s = std::max(last_s, f.start_s);
  const std::size_t windows =
      frames.empty() && last_s <= 0
          ? 0
          : std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(last_s / window_s - 1e-9)));
  std::vector<double> length(windows, window_s);
  for (std::size_t w = 0; w < windows; ++w) {
    t.window_start_s.push_back(static_cast<double>(w) * window_s);
    // The last window, when the mission ends inside it, is as long as what is left.
    if (end_s > t.window_start_s[w]) length[w] = std::min(window_s, end_s - t.window_start_s[w]);
  }
  t.total_bps.assign(windows, 0.0);
  std::map<std::string, std::size_t> index;
  std::vector<std::string> seen;
  for (const auto& f : frames) {
    if (index.emplace(f.kind, 0).second) seen.push_back(f.kind);
  }
  std::stable_sort(seen.begin(), seen.end(), [](const std::string& a, const std::string& b) {
    return KindRank(a) < KindRank(b) || (KindRank(a) == KindRank(b) && a < b);
  });
  for (std::size_t k = 0; k < seen.size(); ++k) index[seen[k]] = k;
  t.kinds = seen;
  t.bps.assign(seen.size(), std::vector<double>(windows, 0.0));
  for (const auto& f : frames) {
    if (f.start_s < 0) continue;
    const auto w =
        std::min(windows - 1, static_cast<std::size_t>(std::floor(f.start_s / window_s)));
    t.bps[index[f.kind]][w] += f.bits / length[w];
    t.total_bps[w] += f.bits / length[w];
  }
  return t;
}

// ---------------------------------------------------------------------------------------
// The team run

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

// ---------------------------------------------------------------------------------------
// Tables for draco-fleet (unchanged layout)

std::string FormatTeamResult(const TeamResult& t, const std::string& title) {
  std::ostringstream o;
  char line[256];
  o << title << "\n";
  std::snprintf(line, sizeof line, "%-9s %5s %8s %8s %8s %6s %6s %6s %9s %8s\n", "robot", "kfs",
                "DR m", "local m", "team m", "placed", "cand", "accept", "sent kbit", "mean bps");
  o << line;
  for (const auto& r : t.robots) {
    std::snprintf(line, sizeof line, "%-9s %5d %8.3f %8.3f %8.3f %6d %6d %6d %9.1f %8.0f\n",
                  r.name.c_str(), r.keyframes, r.dr_ate_m, r.local_ate_m, r.team_ate_m, r.placed,
                  r.candidates, r.accepted, r.bits_sent / 1000.0, r.mean_bps);
    o << line;
  }
  std::snprintf(line, sizeof line, "\n%-15s %7s %10s %9s %8s %8s\n", "message", "frames",
                "mean bits", "max bits", "dropped", "rejected");
  o << line;
  for (const auto& k : t.kinds) {
    std::snprintf(line, sizeof line, "%-15s %7.0f %10.0f %9.0f %8.0f %8.0f\n", k.kind.c_str(),
                  k.frames, k.frames > 0 ? k.bits / k.frames : 0.0, k.max_bits, k.dropped,
                  k.rejected);
    o << line;
  }
  return o.str();
}

std::string TeamResultMarkdown(const TeamResult& t) {
  std::ostringstream o;
  char line[256];
  o << "| robot | keyframes | DR ATE m | local ATE m | team ATE m | robots placed | candidates "
       "| accepted | sent kbit | mean bps |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : t.robots) {
    std::snprintf(line, sizeof line,
                  "| %s | %d | %.3f | %.3f | %.3f | %d | %d | %d | %.1f | %.0f |\n", r.name.c_str(),
                  r.keyframes, r.dr_ate_m, r.local_ate_m, r.team_ate_m, r.placed, r.candidates,
                  r.accepted, r.bits_sent / 1000.0, r.mean_bps);
    o << line;
  }
  o << "\n| message | frames | mean bits | max bits | dropped | rejected "
       "|\n|---|---|---|---|---|---|\n";
  for (const auto& k : t.kinds) {
    std::snprintf(line, sizeof line, "| %s | %.0f | %.0f | %.0f | %.0f | %.0f |\n", k.kind.c_str(),
                  k.frames, k.frames > 0 ? k.bits / k.frames : 0.0, k.max_bits, k.dropped,
                  k.rejected);
    o << line;
  }
  return o.str();
}

}  // namespace draco::report
