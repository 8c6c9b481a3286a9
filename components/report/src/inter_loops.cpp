// Inter-robot loops of a team run (team_run.hpp): reading a robot's loops and registrations,
// judging them against ground truth, the overlap sweep, the verdict CSV, the counts.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "csv.hpp"
#include "draco/report/team_run.hpp"

namespace draco::report {
namespace {

using internal::Csv;
using internal::ReadCsv;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kDeg = M_PI / 180.0;

double Ratio(int num, int den) {
  return den > 0 ? static_cast<double>(num) / static_cast<double>(den) : kNan;
}

}  // namespace

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

}  // namespace draco::report
