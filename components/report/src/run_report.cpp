#include "draco/report/run_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "draco/eval/trajectory.hpp"
#include "draco/report/figures.hpp"
#include "draco/report/files.hpp"
#include "draco/report/grids.hpp"

namespace fs = std::filesystem;

namespace draco::report {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
const std::string kTrajSuffix = ".trajectory.tum";

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

fs::path TruthPath(const fs::path& dir, const std::string& robot) {
  const fs::path own = dir / (robot + ".ground_truth.tum");
  return fs::exists(own) ? own : dir / "ground_truth.tum";
}

std::string Fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "–";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

void CountLoops(const fs::path& csv, RobotAccuracy* r) {
  std::ifstream f(csv);
  if (!f) return;
  std::string line;
  int rows = 0, accepted = 0;
  bool header = true;
  while (std::getline(f, line)) {
    if (header) {
      header = false;
      continue;
    }
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    ++rows;
    const auto comma = line.find_last_of(',');
    if (comma != std::string::npos && line.substr(comma + 1, 1) == "1") ++accepted;
  }
  r->intra_loops = rows;
  r->intra_loops_accepted = accepted;
}

}  // namespace

RobotRuntime ReadRuntimeStats(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open");
  RobotRuntime rt;
  try {
    const nlohmann::json j = nlohmann::json::parse(f);
    rt.wall_s = j.value("wall_s", 0.0);
    rt.mission_s = j.value("mission_s", 0.0);
    for (const auto& c : j.at("components")) {
      ComponentRuntime cr;
      cr.id = c.value("id", "");
      cr.type = c.value("type", "");
      cr.calls = c.value("calls", 0LL);
      cr.mean_ms = c.value("mean_ms", 0.0);
      cr.max_ms = c.value("max_ms", 0.0);
      cr.total_ms = c.value("total_ms", cr.mean_ms * static_cast<double>(cr.calls));
      rt.components.push_back(cr);
    }
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  return rt;
}

RunEvaluation EvaluateRun(const std::string& run_dir) {
  RunEvaluation ev;
  ev.run_dir = run_dir;
  const fs::path dir(run_dir);
  std::vector<std::string> robots;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (EndsWith(name, kTrajSuffix) && name.size() > kTrajSuffix.size()) {
      robots.push_back(name.substr(0, name.size() - kTrajSuffix.size()));
    }
  }
  std::sort(robots.begin(), robots.end());

  MethodRow dr_row{"Dead reckoning", "dead_reckoning", {}};
  MethodRow slam_row{"Local SLAM", "trajectory", {}};
  std::vector<MethodRow> variant_rows;
  for (const auto& v : kTableIIIVariants) variant_rows.push_back({v.label, v.tag, {}});

  for (const auto& robot : robots) {
    const fs::path truth_path = TruthPath(dir, robot);
    if (!fs::exists(truth_path)) {
      ev.problems.push_back(robot + ": no ground truth");
      continue;
    }
    try {
      const auto truth = eval::ReadTum(truth_path.string());
      const auto est = eval::ReadTum((dir / (robot + kTrajSuffix)).string());
      RobotAccuracy r;
      r.robot = robot;
      r.keyframes = est.size();
      r.path_m = eval::PathLengthM(est);
      r.slam_ate_m = eval::Ate(est, truth).rmse_m;
      const auto rpe = eval::Rpe(est, truth);
      r.slam_rpe_m = rpe.trans_rmse_m;
      r.slam_rpe_deg = rpe.rot_rmse_rad * 180.0 / M_PI;
      r.dr_ate_m = r.dr_rpe_m = kNan;
      const fs::path dr_path = dir / (robot + ".dead_reckoning.tum");
      if (fs::exists(dr_path)) {
        const auto dr = eval::ReadTum(dr_path.string());
        r.dr_ate_m = eval::Ate(dr, truth).rmse_m;
        r.dr_rpe_m = eval::Rpe(dr, truth).trans_rmse_m;
      }
      CountLoops(dir / (robot + ".intra_loops.csv"), &r);
      dr_row.ate_m.push_back(r.dr_ate_m);
      slam_row.ate_m.push_back(r.slam_ate_m);
      for (auto& row : variant_rows) {
        const fs::path p = dir / (robot + ".trajectory." + row.file_tag + ".tum");
        row.ate_m.push_back(fs::exists(p) ? eval::Ate(eval::ReadTum(p.string()), truth).rmse_m
                                          : kNan);
      }
      ev.robots.push_back(r);
    } catch (const std::exception& e) {
      ev.problems.push_back(robot + ": " + e.what());
    }
  }
  ev.methods.push_back(dr_row);
  ev.methods.push_back(slam_row);
  for (auto& row : variant_rows) {
    if (std::any_of(row.ate_m.begin(), row.ate_m.end(),
                    [](double v) { return std::isfinite(v); })) {
      ev.methods.push_back(row);
    }
  }

  // Runtime: per robot, then per component id over every robot.
  // A team run in one process (draco-fleet --mode inproc) writes one runtime_stats.json for
  // the whole team graph, its component ids prefixed "<robot>_": it is split by robot.
  std::map<std::string, std::size_t> index;
  std::optional<RobotRuntime> team_runtime;
  bool team_runtime_read = false;
  for (const auto& robot : robots) {
    const fs::path p = dir / (robot + ".runtime_stats.json");
    const fs::path team_path = dir / "runtime_stats.json";
    if (!fs::exists(p) && !fs::exists(team_path)) continue;
    try {
      RobotRuntime rt;
      if (fs::exists(p)) {
        rt = ReadRuntimeStats(p.string());
      } else {
        if (!team_runtime_read) {
          team_runtime_read = true;
          team_runtime = ReadRuntimeStats(team_path.string());
        }
        if (!team_runtime) continue;
        rt.wall_s = team_runtime->wall_s;
        rt.mission_s = team_runtime->mission_s;
        const std::string prefix = robot + "_";
        for (const auto& c : team_runtime->components) {
          if (c.id.rfind(prefix, 0) != 0) continue;
          rt.components.push_back(c);
          rt.components.back().id = c.id.substr(prefix.size());
        }
        if (rt.components.empty()) continue;
      }
      rt.robot = robot;
      for (const auto& c : rt.components) {
        auto [it, added] = index.emplace(c.id, ev.runtime_total.size());
        if (added) ev.runtime_total.push_back({c.id, c.type, 0, 0.0, 0.0, 0.0});
        auto& t = ev.runtime_total[it->second];
        t.calls += c.calls;
        t.total_ms += c.total_ms;
        t.max_ms = std::max(t.max_ms, c.max_ms);
      }
      ev.runtimes.push_back(std::move(rt));
    } catch (const std::exception& e) {
      ev.problems.push_back(e.what());
    }
  }
  for (auto& t : ev.runtime_total) {
    t.mean_ms = t.calls > 0 ? t.total_ms / static_cast<double>(t.calls) : 0.0;
  }
  return ev;
}

std::vector<ReportFigure> RenderRunFigures(const RunEvaluation& ev, const std::string& map_png,
                                           const occupancy::GridOptions& grid) {
  std::vector<ReportFigure> out;
  if (ev.robots.empty()) return out;
  const fs::path dir(ev.run_dir);
  TeamMap map;
  map.title = (map_png == "team_map.png" ? "Team map: " : "Local maps: ") +
              fs::path(ev.run_dir).filename().string() + " (local SLAM aligned to ground truth)";
  std::vector<ReportFigure> grids;
  for (const auto& r : ev.robots) {
    RobotLayer layer;
    layer.name = r.robot;
    const auto truth = eval::ReadTum(TruthPath(dir, r.robot).string());
    const auto est = eval::ReadTum((dir / (r.robot + kTrajSuffix)).string());
    const eval::Se2 T = eval::Ate(est, truth).T_truth_estimate;
    const eval::Trajectory aligned = eval::Transform(T, est);
    for (const auto& p : aligned) layer.estimate.push_back({p.x_m, p.y_m});
    for (const auto& p : truth) layer.truth.push_back({p.x_m, p.y_m});
    const std::string cloud = MapCloudPath(dir.string(), r.robot);
    if (!cloud.empty()) {
      const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
      for (const auto& p : ReadMapXy(cloud)) {
        layer.cloud.push_back({c * p.x - s * p.y + T.x_m, s * p.x + c * p.y + T.y_m});
      }
      if (auto f = WriteGridFigure({{aligned, layer.cloud}}, grid, dir, r.robot + ".grid",
                                   "Occupancy grid of " + r.robot +
                                       " (its map and local-SLAM keyframes, as in the map)")) {
        grids.push_back(*f);
      }
    }
    map.robots.push_back(std::move(layer));
  }
  RenderTeamMap(map, (dir / map_png).string());
  WriteTeamCloud(map, (dir / fs::path(map_png).replace_extension(".pcd")).string());
  out.push_back(
      {map_png, std::string(map_png == "team_map.png" ? "Team map" : "Local maps") +
                    ": each robot's local-SLAM trajectory (solid, aligned to ground truth by "
                    "SE(2) Umeyama), ground truth (dashed), point-cloud map (dots)."});
  out.insert(out.end(), grids.begin(), grids.end());

  std::vector<std::string> names;
  BarSeries dr{"dead reckoning", {}, Rgb{150, 150, 150}};
  BarSeries slam{"local SLAM", {}, RobotColour(0)};
  for (const auto& r : ev.robots) {
    names.push_back(r.robot);
    dr.values.push_back(r.dr_ate_m);
    slam.values.push_back(r.slam_ate_m);
  }
  ChartOptions o;
  o.title = "ATE RMSE per robot";
  o.x_label = "robot";
  o.y_label = "ATE RMSE [m]";
  o.width_px = std::max(500, 160 * static_cast<int>(names.size()) + 200);
  o.height_px = 420;
  RenderBarChart(names, {dr, slam}, o, (dir / "ate.png").string());
  out.push_back({"ate.png", "ATE RMSE per robot: dead reckoning vs local SLAM."});
  return out;
}

std::string ReportMarkdown(const RunEvaluation& ev, const ReportContent& content) {
  std::ostringstream md;
  md << "# Run report: " << fs::path(ev.run_dir).filename().string() << "\n\n";
  if (!content.command.empty()) md << "Produced by `" << content.command << "`.\n\n";

  for (const auto& f : content.figures) {
    if (f.path == "team_map.png")
      md << "![team map](" << f.path << ")\n\n*" << f.caption << "*\n\n";
  }
  // Occupancy grids beside the map: one row of pictures, captions below.
  std::string grid_row, grid_captions;
  for (const auto& f : content.figures) {
    if (!IsGridFigure(f.path)) continue;
    grid_row += "![" + f.path + "](" + f.path + ") ";
    grid_captions += "- *" + f.caption + "*\n";
  }
  if (!grid_row.empty()) {
    md << "Occupancy grids (free along each sonar beam up to its first return, occupied at "
          "returns):\n\n"
       << grid_row << "\n\n"
       << grid_captions << "\n";
  }

  md << "## Accuracy per robot\n\n"
     << "ATE: RMSE of positions after SE(2) Umeyama alignment to ground truth, at keyframe "
        "times. RPE: RMSE between consecutive keyframes. DR = dead reckoning at the same "
        "keyframe times.\n\n"
     << "| robot | keyframes | path m | intra loops (accepted) | DR ATE m | SLAM ATE m | SLAM/DR "
        "| DR RPE m | SLAM RPE m | SLAM RPE deg |\n"
     << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& r : ev.robots) {
    const double ratio = r.dr_ate_m > 0 ? r.slam_ate_m / r.dr_ate_m : kNan;
    md << "| " << r.robot << " | " << r.keyframes << " | " << Fixed(r.path_m, 1) << " | "
       << (r.intra_loops < 0 ? std::string("–")
                             : std::to_string(r.intra_loops) + " (" +
                                   std::to_string(r.intra_loops_accepted) + ")")
       << " | " << Fixed(r.dr_ate_m, 3) << " | " << Fixed(r.slam_ate_m, 3) << " | "
       << Fixed(ratio, 2) << " | " << Fixed(r.dr_rpe_m, 3) << " | " << Fixed(r.slam_rpe_m, 3)
       << " | " << Fixed(r.slam_rpe_deg, 2) << " |\n";
  }
  md << "\n";
  for (const auto& f : content.figures) {
    if (f.path == "ate.png") md << "![ATE per robot](" << f.path << ")\n\n";
  }

  md << "## ATE by method (Table III layout)\n\nATE RMSE in metres.\n\n| method |";
  for (const auto& r : ev.robots) md << " " << r.robot << " |";
  md << " mean |\n|---|";
  for (std::size_t i = 0; i <= ev.robots.size(); ++i) md << "---:|";
  md << "\n";
  for (const auto& row : ev.methods) {
    md << "| " << row.method << " |";
    double sum = 0.0;
    int n = 0;
    for (const double v : row.ate_m) {
      md << " " << Fixed(v, 3) << " |";
      if (std::isfinite(v)) {
        sum += v;
        ++n;
      }
    }
    md << " " << (n > 0 ? Fixed(sum / n, 3) : std::string("–")) << " |\n";
  }
  md << "\nRows for the team variants ({two-step, full} x {PCM, GCM}) appear when the run "
        "folder holds `<robot>.trajectory.<variant>.tum` (variants: ";
  for (std::size_t i = 0; i < std::size(kTableIIIVariants); ++i) {
    md << (i ? ", " : "") << "`" << kTableIIIVariants[i].tag << "`";
  }
  md << ").\n\n";

  for (const auto& section : content.sections) md << section;

  if (!ev.runtime_total.empty()) {
    md << "## Runtime per component (Table I layout)\n\nOver " << ev.runtimes.size()
       << " robot run(s); mean and max of one call.\n\n"
       << "| component | type | calls | mean ms | max ms |\n|---|---|---:|---:|---:|\n";
    for (const auto& c : ev.runtime_total) {
      md << "| " << c.id << " | " << c.type << " | " << c.calls << " | " << Fixed(c.mean_ms, 3)
         << " | " << Fixed(c.max_ms, 3) << " |\n";
    }
    md << "\n| robot | mission s | wall s | real-time factor |\n|---|---:|---:|---:|\n";
    for (const auto& r : ev.runtimes) {
      md << "| " << r.robot << " | " << Fixed(r.mission_s, 1) << " | " << Fixed(r.wall_s, 1)
         << " | " << (r.wall_s > 0 ? Fixed(r.mission_s / r.wall_s, 1) + "x" : std::string("–"))
         << " |\n";
    }
    md << "\n";
  }

  if (!content.frames.empty()) {
    md << "## Sonar frames with CFAR detections\n\n";
    for (const auto& f : content.frames) {
      md << "![" << f.caption << "](" << f.path << ")\n\n*" << f.caption << "*\n\n";
    }
  }
  for (const auto& f : content.figures) {
    if (f.path != "team_map.png" && f.path != "ate.png" && !IsGridFigure(f.path)) {
      md << "![" << f.caption << "](" << f.path << ")\n\n*" << f.caption << "*\n\n";
    }
  }
  if (!ev.problems.empty()) {
    md << "## Not evaluated\n\n";
    for (const auto& p : ev.problems) md << "- " << p << "\n";
    md << "\n";
  }
  return md.str();
}

std::string WriteReport(const RunEvaluation& ev, const ReportContent& content) {
  const std::string path = (fs::path(ev.run_dir) / "report.md").string();
  WriteFileAtomically(path, ReportMarkdown(ev, content));
  return path;
}

}  // namespace draco::report
