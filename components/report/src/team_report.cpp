// Figures and report sections of a team run: the team map in one robot's frame, link traffic
// over time, and the tables (Table III team ATE, inter-robot loops, Table II, Table IV).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "draco/report/figures.hpp"
#include "draco/report/files.hpp"
#include "draco/report/grids.hpp"
#include "draco/report/team_run.hpp"

namespace fs = std::filesystem;

namespace draco::report {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

std::string Fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "–";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}
// Negative = not measured (RobotResult's convention).
std::string Metres(double v) { return v < 0 ? std::string("–") : Fixed(v, 3); }
std::string Percent(double v) { return std::isfinite(v) ? Fixed(100.0 * v, 1) + " %" : "–"; }

eval::Trajectory ReadIfExists(const fs::path& p) {
  if (!fs::exists(p)) return {};
  return eval::ReadTum(p.string());
}

// <robot>.objects.csv: id,center_x_m,center_y_m,length_m,breadth_m,yaw_rad,num_points.
std::vector<ObjectRect> ReadObjects(const fs::path& p) {
  std::vector<ObjectRect> out;
  std::ifstream f(p);
  std::string line;
  std::getline(f, line);
  while (std::getline(f, line)) {
    double v[6];
    if (std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3], &v[4],
                    &v[5]) != 6) {
      continue;
    }
    ObjectRect o;
    o.centre = {v[1], v[2]};
    o.length_m = v[3];
    o.breadth_m = v[4];
    o.yaw_rad = v[5];
    out.push_back(o);
  }
  return out;
}

eval::Se2 Compose(const eval::Se2& a, const eval::Se2& b) {
  const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
  return {a.x_m + c * b.x_m - s * b.y_m, a.y_m + s * b.x_m + c * b.y_m,
          eval::WrapAngle(a.yaw_rad + b.yaw_rad)};
}
Xy Apply(const eval::Se2& T, double x, double y) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {T.x_m + c * x - s * y, T.y_m + s * x + c * y};
}

}  // namespace

std::vector<ReportFigure> RenderTeamFigures(const TeamResult& t, int map_robot,
                                            const occupancy::GridOptions& grid) {
  std::vector<ReportFigure> out;
  const fs::path dir(t.run_dir);
  const std::size_t n = t.team.size();
  if (n == 0) return out;
  const std::size_t m = static_cast<std::size_t>(std::clamp(map_robot, 0, static_cast<int>(n) - 1));
  const std::string& M = t.team[m];

  // ---- Team map in robot M's frame, aligned to ground truth as the concatenation protocol.
  std::vector<eval::Trajectory> placed(n), truth(n), own(n);
  eval::Trajectory est_all, truth_all;
  for (std::size_t j = 0; j < n; ++j) {
    placed[j] = ReadIfExists(dir / (M + ".team." + t.team[j] + ".tum"));
    truth[j] = ReadIfExists(TeamTruthPath(t.run_dir, t.mission_dir, t.team[j]));
    own[j] = ReadIfExists(dir / (t.team[j] + ".trajectory.tum"));
    if (placed[j].empty() || truth[j].empty()) continue;
    const double offset = 1e5 * static_cast<double>(j);
    for (auto p : placed[j]) {
      p.time_s += offset;
      est_all.push_back(p);
    }
    for (auto p : truth[j]) {
      p.time_s += offset;
      truth_all.push_back(p);
    }
  }
  const bool aligned = !est_all.empty();
  const eval::Se2 T_world_M =
      aligned ? eval::Ate(est_all, truth_all).T_truth_estimate : eval::Se2{};
  TeamMap map;
  map.title = "Team map of " + M + " (" + fs::path(t.run_dir).filename().string() + ")" +
              (aligned ? ", aligned to ground truth" : "");
  int placed_count = 0;
  std::vector<GridLayer> grid_layers;
  for (std::size_t j = 0; j < n; ++j) {
    RobotLayer layer;
    layer.name = t.team[j];
    layer.colour = RobotColour(static_cast<int>(j));
    if (!placed[j].empty()) {
      ++placed_count;
      for (const auto& p : eval::Transform(T_world_M, placed[j])) {
        layer.estimate.push_back({p.x_m, p.y_m});
      }
      // Robot j's own map frame placed in M's frame: its local keyframes against where M
      // placed them.
      eval::Se2 T_M_j;
      if (j != m && own[j].size() >= 2) T_M_j = eval::AlignUmeyama(own[j], placed[j]);
      const eval::Se2 T = Compose(T_world_M, T_M_j);
      const std::string cloud = MapCloudPath(dir.string(), t.team[j]);
      if (!cloud.empty()) {
        for (const auto& p : ReadMapXy(cloud)) layer.cloud.push_back(Apply(T, p.x, p.y));
        grid_layers.push_back({eval::Transform(T_world_M, placed[j]), layer.cloud});
      }
      for (auto o : ReadObjects(dir / (t.team[j] + ".objects.csv"))) {
        o.centre = Apply(T, o.centre.x, o.centre.y);
        o.yaw_rad += T.yaw_rad;
        o.robot = static_cast<int>(map.robots.size());
        map.objects.push_back(o);
      }
    }
    if (aligned) {
      for (const auto& p : truth[j]) layer.truth.push_back({p.x_m, p.y_m});
    }
    if (layer.estimate.empty() && layer.truth.empty()) continue;
    map.robots.push_back(std::move(layer));
  }
  // Accepted inter-robot loops, each once, between the two keyframes as M placed them.
  std::map<std::tuple<int, int, int, int>, bool> drawn;
  int loops_drawn = 0;
  for (const auto& loops : t.loops) {
    for (const auto& l : loops) {
      if (!l.accepted) continue;
      const auto key =
          l.own_robot <= l.teammate_robot
              ? std::make_tuple(l.own_robot, l.own_keyframe, l.teammate_robot, l.teammate_keyframe)
              : std::make_tuple(l.teammate_robot, l.teammate_keyframe, l.own_robot, l.own_keyframe);
      if (!drawn.emplace(key, true).second) continue;
      auto at = [&](int robot, int kf, Xy* xy) {
        if (robot < 0 || robot >= static_cast<int>(n)) return false;
        const auto r = static_cast<std::size_t>(robot);
        if (kf < 0 || kf >= static_cast<int>(own[r].size()) || placed[r].empty()) return false;
        eval::StampedPose2 p;
        if (!TruthAt(placed[r], own[r][static_cast<std::size_t>(kf)].time_s, &p, 1e-3)) {
          return false;
        }
        *xy = Apply(T_world_M, p.x_m, p.y_m);
        return true;
      };
      LoopLine line;
      if (!at(l.own_robot, l.own_keyframe, &line.a) ||
          !at(l.teammate_robot, l.teammate_keyframe, &line.b)) {
        continue;
      }
      line.correct = !l.judged || l.true_positive;
      map.inter_robot_loops.push_back(line);
      ++loops_drawn;
    }
  }
  if (!map.robots.empty()) {
    RenderTeamMap(map, (dir / "team_map.png").string());
    WriteTeamCloud(map, (dir / "team_map.pcd").string());
    out.push_back(
        {"team_map.png",
         "Team map in " + M + "'s map frame (" + std::to_string(placed_count) + " of " +
             std::to_string(n) + " robots placed): each robot's trajectory as " + M +
             " estimated it (solid, own colour), " +
             (aligned ? "one SE(2) alignment of all of them to ground truth (dashed), "
                      : "no ground truth, ") +
             "point clouds and object rectangles placed by the same estimate, " +
             std::to_string(loops_drawn) +
             " accepted inter-robot loop closures (purple; thin and dashed when false against "
             "ground truth)."});
  }

  if (auto f = WriteGridFigure(grid_layers, grid, dir, "team_grid",
                               "Team occupancy grid in " + M +
                                   "'s map frame: every placed robot's map and keyframes as " + M +
                                   "'s team estimate placed them (as in the team map)")) {
    out.push_back(*f);
  }

  // ---- The paper's Fig. 3 from the registrations the run logged.
  if (!t.sweep.empty()) {
    ChartPanel precision, tps;
    std::map<int, std::size_t> series_of;
    for (const auto& p : t.sweep) {
      if (!series_of.count(p.window)) {
        series_of[p.window] = precision.series.size();
        for (auto* panel : {&precision, &tps}) {
          Series s;
          s.label = "window " + std::to_string(p.window);
          s.colour = RobotColour(static_cast<int>(series_of.size() - 1));
          s.markers = true;
          panel->series.push_back(s);
        }
      }
      const std::size_t k = series_of[p.window];
      if (!std::isnan(p.precision)) {
        precision.series[k].x.push_back(p.threshold);
        precision.series[k].y.push_back(p.precision);
      }
      tps.series[k].x.push_back(p.threshold);
      tps.series[k].y.push_back(p.true_positives);
    }
    precision.options.title = "Precision of inter-robot registrations";
    precision.options.x_label = "overlap threshold";
    precision.options.y_label = "precision";
    precision.options.y_min = 0.0;
    precision.options.y_max = 1.0;
    tps.options.title = "True positives (1.5 m, 15 deg)";
    tps.options.x_label = "overlap threshold";
    tps.options.y_label = "true positives";
    RenderLineChartPanels({precision, tps}, (dir / "fig3.png").string());
    out.push_back({"fig3.png",
                   "The paper's Fig. 3 on this run: precision and true positives of the "
                   "inter-robot registrations (before outlier rejection) against the overlap "
                   "threshold, per registration window; every robot's registrations.csv."});
  }

  // ---- Link traffic over time per kind, all robots.
  if (!t.traffic.empty()) {
    double end_s = 0.0;
    for (const auto& r : t.robots) end_s = std::max(end_s, r.mission_s);
    const TrafficSeries ts = BinTraffic(t.traffic, 10.0, end_s);
    std::vector<Series> series;
    double peak = 0.0;
    for (std::size_t k = 0; k < ts.kinds.size(); ++k) {
      Series s;
      s.label = ts.kinds[k];
      s.colour = RobotColour(static_cast<int>(k));
      for (std::size_t w = 0; w < ts.window_start_s.size(); ++w) {
        s.x.push_back(ts.window_start_s[w] + ts.window_s / 2);
        s.y.push_back(ts.bps[k][w] / 1000.0);
      }
      series.push_back(std::move(s));
    }
    Series total;
    total.label = "all kinds";
    total.colour = Rgb{0, 0, 0};
    for (std::size_t w = 0; w < ts.window_start_s.size(); ++w) {
      total.x.push_back(ts.window_start_s[w] + ts.window_s / 2);
      total.y.push_back(ts.total_bps[w] / 1000.0);
      peak = std::max(peak, ts.total_bps[w]);
    }
    series.push_back(total);
    const double goal_bps = kRobotGoalBps * static_cast<double>(t.robots.size());
    ChartOptions o;
    o.x_label = "mission time [s]";
    o.y_label = "link traffic [kbit/s], 10 s windows";
    o.x_min = 0.0;
    o.title = "Link traffic per message kind, all robots, against the modem budget";
    o.references = {
        {"team budget " + Fixed(kTeamBudgetBps / 1000, 1) + " kbps", kTeamBudgetBps / 1000},
        {"goal " + Fixed(kRobotGoalBps / 1000, 0) + " kbps x " + std::to_string(t.robots.size()) +
             " robots",
         goal_bps / 1000, Rgb{230, 140, 0}}};
    RenderLineChart(series, o, (dir / "link_traffic.png").string());
    out.push_back({"link_traffic.png",
                   "Link traffic over the mission per message kind (bits of every robot's frames "
                   "by start time, 10 s windows), against the team modem budget and the traffic "
                   "goal. Peak window: " +
                       Fixed(peak / 1000, 2) + " kbps (" + Percent(peak / kTeamBudgetBps) +
                       " of the budget)."});
    o.title = "Link traffic per message kind, all robots (detail)";
    o.references.clear();
    if (goal_bps <= 1.5 * peak) o.references.push_back({"goal", goal_bps / 1000, Rgb{230, 140, 0}});
    RenderLineChart(series, o, (dir / "link_traffic_detail.png").string());
    out.push_back({"link_traffic_detail.png", "The same, scaled to the traffic."});
  }
  return out;
}

std::string TeamReportMarkdown(const TeamResult& t, const std::vector<ReportFigure>& figures) {
  std::ostringstream md;
  auto figure = [&](const std::string& path) {
    for (const auto& f : figures) {
      if (f.path == path)
        md << "![" << f.path << "](" << f.path << ")\n\n*" << f.caption << "*\n\n";
    }
  };
  const std::size_t n = t.robots.size();

  // ---- Table III
  md << "## Team ATE (Table III layout)\n\n"
     << "ATE RMSE in metres after SE(2) Umeyama alignment. Dead reckoning and local SLAM: the "
        "robot's own trajectory. Team: the paper's concatenation protocol: the robot's team "
        "estimate of itself, then of each teammate it placed (`<robot>.team.<teammate>.tum`, in "
        "its own map frame), concatenated against the ground truth concatenated the same way, "
        "one alignment.\n\n| method |";
  for (const auto& r : t.robots) md << " " << r.name << " |";
  md << " mean |\n|---|";
  for (std::size_t i = 0; i <= n; ++i) md << "---:|";
  md << "\n";
  auto row = [&](const std::string& label, auto get) {
    md << "| " << label << " |";
    double sum = 0.0;
    int k = 0;
    for (const auto& r : t.robots) {
      const double v = get(r);
      md << " " << Metres(v) << " |";
      if (v >= 0) {
        sum += v;
        ++k;
      }
    }
    md << " " << (k > 0 ? Fixed(sum / k, 3) : std::string("–")) << " |\n";
  };
  row("Dead reckoning", [](const RobotResult& r) { return r.dr_ate_m; });
  row("Local SLAM", [](const RobotResult& r) { return r.local_ate_m; });
  row("Team (concatenated)", [](const RobotResult& r) { return r.team_ate_m; });
  md << "| robots placed |";
  for (const auto& r : t.robots) md << " " << r.placed << " of " << t.team.size() << " |";
  md << " |\n\n";

  // ---- Inter-robot loops
  md << "## Inter-robot loop closures\n\n";
  if (t.has_truth) {
    md << "A loop is a true positive (TP) when its relative pose is within 1.5 m and 15 deg of "
          "the ground-truth relative pose of its two keyframes (ground truth at the keyframe "
          "times of `<robot>.trajectory.tum`, row = keyframe index). Before the filter: every "
          "candidate (registration accepted); after: accepted by the consistency filter. "
          "Recall proxy: true positives the filter kept / true positives among the candidates. "
          "Each robot records the loops it found and those its teammates accepted with it; the "
          "last row counts each loop once. Verdicts per loop: `<robot>.inter_loops_verdict.csv`."
          "\n\n"
       << "| robot | candidates | TP | precision before | accepted | TP accepted | precision "
          "after | recall proxy |\n|---|---:|---:|---:|---:|---:|---:|---:|\n";
    auto loop_row = [&](const std::string& name, const LoopCounts& c) {
      md << "| " << name << " | " << c.candidates << " | " << c.tp_candidates << " | "
         << Percent(c.PrecisionBefore()) << " | " << c.accepted << " | " << c.tp_accepted << " | "
         << Percent(c.PrecisionAfter()) << " | " << Percent(c.RecallProxy()) << " |\n";
    };
    for (const auto& r : t.robots) loop_row(r.name, r.loops);
    loop_row("team (each loop once)", t.distinct_loops);
    int unjudged = 0;
    for (const auto& r : t.robots) unjudged += r.loops.candidates - r.loops.judged;
    if (unjudged > 0) {
      md << "\n"
         << unjudged
         << " loop row(s) could not be judged (keyframe or ground truth "
            "missing) and are left out of the precision.\n";
    }
    md << "\n";
  } else {
    md << "No ground truth (run `draco-eval` with `--mission`): counts only.\n\n"
       << "| robot | candidates | accepted |\n|---|---:|---:|\n";
    for (const auto& r : t.robots) {
      md << "| " << r.name << " | " << r.candidates << " | " << r.accepted << " |\n";
    }
    md << "| team (each loop once) | " << t.distinct_loops.candidates << " | "
       << t.distinct_loops.accepted << " |\n\n";
  }

  // ---- Fig. 3 as a table
  if (!t.sweep.empty()) {
    md << "### Registrations against the overlap threshold (the paper's Fig. 3)\n\n"
       << "Every registration the scan exchanges ran (ICP converged, judged against ground "
          "truth), at the configured window and at the windows logged for evaluation; "
          "precision / true positives of those with overlap >= the threshold, before outlier "
          "rejection. Per robot: `<robot>.registrations.csv`.\n\n| threshold |";
    std::set<int> windows;
    for (const auto& p : t.sweep) windows.insert(p.window);
    for (const int w : windows) md << " window " << w << " |";
    md << "\n|---:|";
    for (std::size_t i = 0; i < windows.size(); ++i) md << "---:|";
    md << "\n";
    std::map<double, std::map<int, const SweepPoint*>> rows;
    for (const auto& p : t.sweep) rows[p.threshold][p.window] = &p;
    for (const auto& [threshold, by_window] : rows) {
      md << "| " << Fixed(threshold, 2) << " |";
      for (const int w : windows) {
        const auto it = by_window.find(w);
        if (it == by_window.end()) {
          md << " |";
          continue;
        }
        const SweepPoint& p = *it->second;
        md << " " << (std::isnan(p.precision) ? std::string("-") : Fixed(p.precision, 2)) << " / "
           << p.true_positives << " |";
      }
      md << "\n";
    }
    md << "\n";
    figure("fig3.png");
  }

  // ---- Table II
  if (!t.steps.empty()) {
    md << "## Loop-closure work per time step (Table II layout)\n\n"
       << "Per agent step (one per second of mission time), mean / max over the mission: object "
          "maps matched, matches found, scans requested, scans registered, loop candidates "
          "added, loops accepted, wall time of the step.\n\n"
       << "| robot | steps | matches tried | matches found | scan requests | scans registered | "
          "candidates | loops accepted | PGO steps | wall ms |\n"
       << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    auto ms = [](const WorkStat& s, int d) { return Fixed(s.mean, d) + " / " + Fixed(s.max, d); };
    for (const auto& w : t.steps) {
      md << "| " << w.robot << " | " << w.steps << " | " << ms(w.matches_tried, 2) << " | "
         << ms(w.matches_found, 2) << " | " << ms(w.requests_sent, 2) << " | "
         << ms(w.scans_registered, 2) << " | " << ms(w.candidates_added, 2) << " | "
         << ms(w.loops_accepted, 2) << " | " << w.optimized << " | " << ms(w.wall_ms, 2) << " |\n";
    }
    md << "\n";
  }

  // ---- Table IV
  if (!t.kinds.empty()) {
    md << "## Message sizes (Table IV layout)\n\n"
       << "Per message kind, summed over the robots: frames sent, mean and max bits of a frame "
          "as it crossed the link, frames dropped (queue, expired, lost) and frames rejected by "
          "the receiver. The paper: object map 1.35 kbit mean, point clouds 9.69 kbit mean; "
          "goals (issue 7): object map <= 0.7 kbit mean, scan reply <= 4 kbit mean.\n\n"
       << "| message | frames | mean bits | max bits | dropped | rejected | goal (mean) |\n"
       << "|---|---:|---:|---:|---:|---:|---|\n";
    for (const auto& k : t.kinds) {
      const double mean = k.frames > 0 ? k.bits / k.frames : kNan;
      std::string goal;
      const double limit = k.kind == "object_map" ? 700.0 : k.kind == "scan_reply" ? 4000.0 : 0.0;
      if (limit > 0) {
        goal = "<= " + Fixed(limit, 0) +
               (!std::isfinite(mean) ? ": no frames"
                : mean > limit       ? ": **missed**"
                                     : ": met");
      }
      md << "| " << k.kind << " | " << Fixed(k.frames, 0) << " | " << Fixed(mean, 0) << " | "
         << Fixed(k.max_bits, 0) << " | " << Fixed(k.dropped, 0) << " | " << Fixed(k.rejected, 0)
         << " | " << goal << " |\n";
    }
    md << "\n## Traffic per robot\n\n"
       << "Bits sent over the mission time; goal: a robot's mean <= " << Fixed(kRobotGoalBps, 0)
       << " bps; the modem's team budget: " << Fixed(kTeamBudgetBps, 0) << " bps.\n\n"
       << "| robot | sent kbit | mission s | mean bps | of the goal | of the team budget |\n"
       << "|---|---:|---:|---:|---:|---:|\n";
    double team_bps = 0.0, team_kbit = 0.0;
    for (const auto& r : t.robots) {
      team_bps += r.mean_bps;
      team_kbit += r.bits_sent / 1000.0;
      md << "| " << r.name << " | " << Fixed(r.bits_sent / 1000.0, 1) << " | "
         << Fixed(r.mission_s, 1) << " | " << Fixed(r.mean_bps, 0) << " | "
         << Percent(r.mean_bps / kRobotGoalBps) << " | " << Percent(r.mean_bps / kTeamBudgetBps)
         << " |\n";
    }
    md << "| team | " << Fixed(team_kbit, 1) << " | | " << Fixed(team_bps, 0) << " | "
       << Percent(team_bps / (kRobotGoalBps * static_cast<double>(n))) << " | "
       << Percent(team_bps / kTeamBudgetBps) << " |\n\n";
  }
  if (!t.traffic.empty()) {
    md << "## Link traffic over time\n\n";
    figure("link_traffic.png");
    figure("link_traffic_detail.png");
  }
  return md.str();
}

}  // namespace draco::report
