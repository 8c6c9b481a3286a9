// Placements of a team run judged against ground truth (placements.hpp).
#include "draco/report/placements.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>

#include "csv.hpp"
#include "draco/eval/trajectory.hpp"
#include "draco/report/team_run.hpp"

namespace draco::report {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = M_PI / 180.0;

struct Se2 {
  double x = 0.0, y = 0.0, yaw = 0.0;
};
Se2 Compose(const Se2& a, const Se2& b) {
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, eval::WrapAngle(a.yaw + b.yaw)};
}
Se2 Inverse(const Se2& a) {
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  return {-(c * a.x + s * a.y), -(-s * a.x + c * a.y), -a.yaw};
}

eval::Trajectory ReadIfExists(const fs::path& p) {
  return fs::exists(p) ? eval::ReadTum(p.string()) : eval::Trajectory{};
}

struct Row {
  double time_s = 0.0;
  bool placed = false;
  Se2 T;
};

// Error of T_est against T_true: RMS over the teammate's keyframe positions (its map frame),
// and |yaw difference| in degrees.
std::pair<double, double> Error(const Se2& est, const Se2& truth, const eval::Trajectory& kfs) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const auto& p : kfs) {
    const Se2 q{p.x_m, p.y_m, 0.0};
    const Se2 a = Compose(est, q), b = Compose(truth, q);
    sum += (a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y);
    ++n;
  }
  if (n == 0) {
    sum = (est.x - truth.x) * (est.x - truth.x) + (est.y - truth.y) * (est.y - truth.y);
    n = 1;
  }
  return {std::sqrt(sum / static_cast<double>(n)),
          std::abs(eval::WrapAngle(est.yaw - truth.yaw)) / kDeg};
}

// Object centres of <robot>.objects.csv (its map frame); nullopt when the file is missing.
// A malformed file throws (internal::ReadCsv names the file and line).
std::optional<std::vector<std::pair<double, double>>> ReadObjectCentres(const fs::path& p) {
  if (!fs::exists(p)) return std::nullopt;
  const auto csv = internal::ReadCsv(p.string());
  const std::size_t x = csv.Col("center_x_m"), y = csv.Col("center_y_m");
  std::vector<std::pair<double, double>> out;
  for (std::size_t r = 0; r < csv.rows.size(); ++r) {
    out.emplace_back(csv.Number(r, x), csv.Number(r, y));
  }
  return out;
}

}  // namespace

PlacementResult EvaluatePlacements(const std::string& run_dir, const std::string& mission_dir,
                                   const std::vector<std::string>& team,
                                   const PlacementJudgeOptions& options) {
  PlacementResult out;
  const fs::path dir(run_dir);
  const std::size_t n = team.size();
  std::vector<eval::Trajectory> keyframes(n), truth(n);
  std::vector<Se2> T_world_map(n);
  std::vector<bool> usable(n, false);
  std::vector<std::vector<std::pair<double, double>>> true_xy(n);
  // Final object centres in the world (each map placed by its T_world_map); nullopt: none.
  std::vector<std::optional<std::vector<std::pair<double, double>>>> objects_world(n);
  for (std::size_t i = 0; i < n; ++i) {
    try {
      keyframes[i] = ReadIfExists(dir / (team[i] + ".trajectory.tum"));
      truth[i] = ReadIfExists(TeamTruthPath(run_dir, mission_dir, team[i]));
      if (keyframes[i].size() < 2 || truth[i].empty()) {
        out.problems.push_back(team[i] + ": no keyframe trajectory or no ground truth");
        continue;
      }
      const auto assoc = eval::Associate(keyframes[i], truth[i]);
      if (assoc.estimate.size() < 2) {
        out.problems.push_back(team[i] + ": keyframes and ground truth do not overlap in time");
        continue;
      }
      const auto T = eval::AlignUmeyama(assoc.estimate, assoc.truth);
      T_world_map[i] = {T.x_m, T.y_m, T.yaw_rad};
      for (const auto& p : assoc.truth) true_xy[i].push_back({p.x_m, p.y_m});
      out.end_s = std::max(out.end_s, keyframes[i].back().time_s);
      usable[i] = true;
      objects_world[i] = ReadObjectCentres(dir / (team[i] + ".objects.csv"));
      if (objects_world[i]) {
        for (auto& [x, y] : *objects_world[i]) {
          const Se2 w = Compose(T_world_map[i], {x, y, 0.0});
          x = w.x;
          y = w.y;
        }
      }
    } catch (const std::exception& e) {
      out.problems.push_back(team[i] + ": " + e.what());
    }
  }
  // Oracle: own local SLAM, then every teammate's placed by the true transform, concatenated
  // in time (segments shifted apart) and aligned once, as EvaluateTeamRun does.
  out.oracle_team_ate_m.assign(n, -1.0);
  for (std::size_t i = 0; i < n; ++i) {
    if (!usable[i]) continue;
    eval::Trajectory est_all, truth_all;
    int segment = 0;
    for (std::size_t j = 0; j < n; ++j) {
      const std::size_t k = j == 0 ? i : (j <= i ? j - 1 : j);  // own first, then the others
      if (!usable[k]) continue;
      const Se2 T = Compose(Inverse(T_world_map[i]), T_world_map[k]);
      constexpr double kSegmentOffsetS = 1e5;
      for (const auto& p : keyframes[k]) {
        const Se2 q = Compose(T, {p.x_m, p.y_m, p.yaw_rad});
        est_all.push_back({p.time_s + segment * kSegmentOffsetS, q.x, q.y, q.yaw});
      }
      for (auto p : truth[k]) {
        p.time_s += segment * kSegmentOffsetS;
        truth_all.push_back(p);
      }
      ++segment;
    }
    try {
      out.oracle_team_ate_m[i] = eval::Ate(est_all, truth_all).rmse_m;
    } catch (const std::exception& e) {
      out.problems.push_back(team[i] + ": oracle ATE: " + e.what());
    }
  }
  std::map<std::string, std::size_t> id_of;
  for (std::size_t i = 0; i < n; ++i) id_of[team[i]] = i;

  for (std::size_t i = 0; i < n; ++i) {
    std::map<std::size_t, std::vector<Row>> rows;  // by teammate
    const fs::path p = dir / (team[i] + ".placements.csv");
    if (fs::exists(p)) {
      try {
        const auto csv = internal::ReadCsv(p.string());
        const std::size_t t = csv.Col("time_s"), mate = csv.Col("teammate"),
                          placed = csv.Col("placed"), x = csv.Col("x_m"), y = csv.Col("y_m"),
                          yaw = csv.Col("yaw_rad");
        for (std::size_t r = 0; r < csv.rows.size(); ++r) {
          if (mate >= csv.rows[r].size()) continue;
          const auto it = id_of.find(csv.rows[r][mate]);
          if (it == id_of.end()) {
            out.problems.push_back(p.string() + ":" + std::to_string(csv.line_numbers[r]) +
                                   ": unknown teammate '" + csv.rows[r][mate] + "'");
            continue;
          }
          rows[it->second].push_back({csv.Number(r, t),
                                      csv.Number(r, placed) != 0.0,
                                      {csv.Number(r, x), csv.Number(r, y), csv.Number(r, yaw)}});
        }
      } catch (const std::exception& e) {
        out.problems.push_back(e.what());
      }
    }
    for (std::size_t j = 0; j < n; ++j) {
      if (j == i) continue;
      PairPlacement pp;
      pp.own = team[i];
      pp.teammate = team[j];
      if (usable[i] && usable[j]) {
        int near = 0;
        for (const auto& [xj, yj] : true_xy[j]) {
          for (const auto& [xi, yi] : true_xy[i]) {
            if (std::hypot(xj - xi, yj - yi) <= options.overlap_radius_m) {
              ++near;
              break;
            }
          }
        }
        pp.path_overlap = true_xy[j].empty() ? 0.0 : static_cast<double>(near) / true_xy[j].size();
        if (objects_world[i] && objects_world[j]) {
          pp.shared_objects = 0;
          for (const auto& [xa, ya] : *objects_world[i]) {
            for (const auto& [xb, yb] : *objects_world[j]) {
              if (std::hypot(xa - xb, ya - yb) <= options.shared_object_radius_m) {
                ++pp.shared_objects;
                break;
              }
            }
          }
        }
        pp.eligible = pp.path_overlap >= options.min_path_overlap &&
                      pp.shared_objects >= options.min_shared_objects;
      }
      const auto it = rows.find(j);
      if (it == rows.end() || !usable[i] || !usable[j]) {
        out.pairs.push_back(pp);
        continue;
      }
      const Se2 T_true = Compose(Inverse(T_world_map[i]), T_world_map[j]);
      const auto& rs = it->second;
      pp.changes = static_cast<int>(rs.size());
      for (std::size_t r = 0; r < rs.size(); ++r) {
        const double until = r + 1 < rs.size() ? rs[r + 1].time_s : out.end_s;
        if (!rs[r].placed) {
          pp.final_placed = false;
          continue;
        }
        const auto [err_m, err_deg] = Error(rs[r].T, T_true, keyframes[j]);
        const bool right = err_m <= options.right_m && err_deg <= options.right_deg;
        if (pp.first_placed_s < 0.0) pp.first_placed_s = rs[r].time_s;
        if (right && pp.first_right_s < 0.0) pp.first_right_s = rs[r].time_s;
        if (!right) {
          if (pp.first_wrong_s < 0.0) pp.first_wrong_s = rs[r].time_s;
          pp.wrong_duration_s += std::max(0.0, until - rs[r].time_s);
          pp.max_wrong_err_m = std::max(pp.max_wrong_err_m, err_m);
        }
        pp.final_placed = true;
        pp.final_right = right;
        pp.final_err_m = err_m;
        pp.final_err_deg = err_deg;
      }
      out.pairs.push_back(pp);
    }
  }
  return out;
}

std::string PlacementsCsv(const PlacementResult& result) {
  std::string s =
      "own,teammate,path_overlap,verdict,final_err_m,final_err_deg,first_placed_s,first_right_s,"
      "first_wrong_s,wrong_duration_s,max_wrong_err_m,changes,shared_objects,eligible\n";
  char line[400];
  for (const auto& p : result.pairs) {
    std::snprintf(line, sizeof line, "%s,%s,%.3f,%s,%.3f,%.2f,%.1f,%.1f,%.1f,%.1f,%.2f,%d,%d,%d\n",
                  p.own.c_str(), p.teammate.c_str(), p.path_overlap, p.Verdict(), p.final_err_m,
                  p.final_err_deg, p.first_placed_s, p.first_right_s, p.first_wrong_s,
                  p.wrong_duration_s, p.max_wrong_err_m, p.changes, p.shared_objects,
                  p.eligible ? 1 : 0);
    s += line;
  }
  return s;
}

std::string PlacementsMarkdown(const PlacementResult& result) {
  std::string s =
      "| own | teammate | path overlap | shared objects | final | error (m / deg) | first right "
      "(s) "
      "| wrong for (s) | worst wrong (m) |\n|---|---|---|---|---|---|---|---|---|\n";
  char line[400];
  for (const auto& p : result.pairs) {
    char err[64] = "-", first[32] = "-", wrong[32] = "-", worst[32] = "-";
    if (p.final_placed)
      std::snprintf(err, sizeof err, "%.2f / %.1f", p.final_err_m, p.final_err_deg);
    if (p.first_right_s >= 0.0) std::snprintf(first, sizeof first, "%.0f", p.first_right_s);
    if (p.wrong_duration_s > 0.0) {
      std::snprintf(wrong, sizeof wrong, "%.0f", p.wrong_duration_s);
      std::snprintf(worst, sizeof worst, "%.1f", p.max_wrong_err_m);
    }
    char shared[32] = "-";
    if (p.shared_objects >= 0) std::snprintf(shared, sizeof shared, "%d", p.shared_objects);
    std::snprintf(line, sizeof line, "| %s | %s | %.0f %% | %s | %s | %s | %s | %s | %s |\n",
                  p.own.c_str(), p.teammate.c_str(), 100.0 * p.path_overlap, shared, p.Verdict(),
                  err, first, wrong, worst);
    s += line;
  }
  return s;
}

}  // namespace draco::report
