#include "draco/eval/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace draco::eval {

double WrapAngle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a < 0) a += 2.0 * M_PI;
  return a - M_PI;
}

Trajectory ReadTum(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open TUM trajectory");
  Trajectory out;
  std::string line;
  int line_no = 0;
  while (std::getline(f, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream is(line);
    double v[8];
    for (double& x : v) {
      if (!(is >> x) || !std::isfinite(x)) {
        throw std::runtime_error(path + ":" + std::to_string(line_no) +
                                 ": expected 8 numbers 't x y z qx qy qz qw'");
      }
    }
    std::string extra;
    if (is >> extra) {
      throw std::runtime_error(path + ":" + std::to_string(line_no) +
                               ": more than 8 values on a line");
    }
    const double qx = v[4], qy = v[5], qz = v[6], qw = v[7];
    const double norm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
    if (norm < 1e-9) {
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": zero quaternion");
    }
    const double yaw = std::atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz));
    if (!out.empty() && v[0] < out.back().time_s) {
      throw std::runtime_error(path + ":" + std::to_string(line_no) +
                               ": time stamps must not decrease");
    }
    out.push_back(StampedPose2{v[0], v[1], v[2], yaw});
  }
  return out;
}

void WriteTum(const std::string& path, const Trajectory& trajectory) {
  const std::string tmp = path + ".partial";
  {
    std::ofstream f(tmp, std::ios::trunc);
    if (!f) throw std::runtime_error(path + ": cannot write");
    f << "# t x y z qx qy qz qw\n";
    char buf[256];
    for (const auto& p : trajectory) {
      std::snprintf(buf, sizeof(buf), "%.9f %.6f %.6f 0 0 0 %.9f %.9f\n", p.time_s, p.x_m, p.y_m,
                    std::sin(p.yaw_rad / 2.0), std::cos(p.yaw_rad / 2.0));
      f << buf;
    }
    if (!f.flush()) throw std::runtime_error(path + ": write failed");
  }
  std::filesystem::rename(tmp, path);
}

Association Associate(const Trajectory& estimate, const Trajectory& truth, double max_gap_s) {
  Association a;
  if (truth.empty()) return a;
  std::size_t j = 0;
  for (const auto& e : estimate) {
    while (j + 1 < truth.size() && truth[j + 1].time_s < e.time_s) ++j;
    if (e.time_s < truth.front().time_s || e.time_s > truth.back().time_s) continue;
    const StampedPose2& t0 = truth[j];
    const StampedPose2& t1 = j + 1 < truth.size() ? truth[j + 1] : truth[j];
    const double span = t1.time_s - t0.time_s;
    const bool on_sample = e.time_s == t0.time_s || e.time_s == t1.time_s;
    if (!on_sample && span > max_gap_s) continue;  // a hole in the ground truth
    const double u = span > 0 ? std::clamp((e.time_s - t0.time_s) / span, 0.0, 1.0) : 0.0;
    StampedPose2 g;
    g.time_s = e.time_s;
    g.x_m = t0.x_m + u * (t1.x_m - t0.x_m);
    g.y_m = t0.y_m + u * (t1.y_m - t0.y_m);
    g.yaw_rad = WrapAngle(t0.yaw_rad + u * WrapAngle(t1.yaw_rad - t0.yaw_rad));
    a.estimate.push_back(e);
    a.truth.push_back(g);
  }
  return a;
}

Se2 AlignUmeyama(const Trajectory& estimate, const Trajectory& truth) {
  const std::size_t n = std::min(estimate.size(), truth.size());
  if (n == 0) return {};
  double mex = 0, mey = 0, mtx = 0, mty = 0;
  for (std::size_t i = 0; i < n; ++i) {
    mex += estimate[i].x_m;
    mey += estimate[i].y_m;
    mtx += truth[i].x_m;
    mty += truth[i].y_m;
  }
  mex /= n;
  mey /= n;
  mtx /= n;
  mty /= n;
  // Optimal rotation angle: atan2(sum cross, sum dot) of centred pairs.
  double dot = 0, cross = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double ex = estimate[i].x_m - mex, ey = estimate[i].y_m - mey;
    const double tx = truth[i].x_m - mtx, ty = truth[i].y_m - mty;
    dot += ex * tx + ey * ty;
    cross += ex * ty - ey * tx;
  }
  const double theta = (dot == 0 && cross == 0) ? 0.0 : std::atan2(cross, dot);
  const double c = std::cos(theta), s = std::sin(theta);
  return Se2{mtx - (c * mex - s * mey), mty - (s * mex + c * mey), theta};
}

Trajectory Transform(const Se2& T, const Trajectory& trajectory) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  Trajectory out;
  out.reserve(trajectory.size());
  for (const auto& p : trajectory) {
    out.push_back(StampedPose2{p.time_s, c * p.x_m - s * p.y_m + T.x_m,
                               s * p.x_m + c * p.y_m + T.y_m, WrapAngle(p.yaw_rad + T.yaw_rad)});
  }
  return out;
}

AteResult Ate(const Trajectory& estimate, const Trajectory& truth, bool align, double max_gap_s) {
  const Association a = Associate(estimate, truth, max_gap_s);
  AteResult r;
  r.pairs = a.estimate.size();
  if (r.pairs == 0) return r;
  if (align) r.T_truth_estimate = AlignUmeyama(a.estimate, a.truth);
  const Trajectory aligned = Transform(r.T_truth_estimate, a.estimate);
  double sum2 = 0, sum = 0;
  for (std::size_t i = 0; i < r.pairs; ++i) {
    const double e = std::hypot(aligned[i].x_m - a.truth[i].x_m, aligned[i].y_m - a.truth[i].y_m);
    sum2 += e * e;
    sum += e;
    r.max_m = std::max(r.max_m, e);
  }
  r.rmse_m = std::sqrt(sum2 / r.pairs);
  r.mean_m = sum / r.pairs;
  return r;
}

RpeResult Rpe(const Trajectory& estimate, const Trajectory& truth, std::size_t delta,
              double max_gap_s) {
  const Association a = Associate(estimate, truth, max_gap_s);
  RpeResult r;
  if (delta == 0 || a.estimate.size() <= delta) return r;
  auto relative = [](const StampedPose2& p, const StampedPose2& q) {
    const double c = std::cos(p.yaw_rad), s = std::sin(p.yaw_rad);
    const double dx = q.x_m - p.x_m, dy = q.y_m - p.y_m;
    return Se2{c * dx + s * dy, -s * dx + c * dy, WrapAngle(q.yaw_rad - p.yaw_rad)};
  };
  double t2 = 0, r2 = 0;
  for (std::size_t i = 0; i + delta < a.estimate.size(); ++i) {
    const Se2 de = relative(a.estimate[i], a.estimate[i + delta]);
    const Se2 dt = relative(a.truth[i], a.truth[i + delta]);
    // error = inv(dt) * de
    const double c = std::cos(dt.yaw_rad), s = std::sin(dt.yaw_rad);
    const double ex = c * (de.x_m - dt.x_m) + s * (de.y_m - dt.y_m);
    const double ey = -s * (de.x_m - dt.x_m) + c * (de.y_m - dt.y_m);
    t2 += ex * ex + ey * ey;
    const double er = WrapAngle(de.yaw_rad - dt.yaw_rad);
    r2 += er * er;
    ++r.pairs;
  }
  r.trans_rmse_m = std::sqrt(t2 / r.pairs);
  r.rot_rmse_rad = std::sqrt(r2 / r.pairs);
  return r;
}

double PathLengthM(const Trajectory& trajectory) {
  double d = 0;
  for (std::size_t i = 1; i < trajectory.size(); ++i) {
    d += std::hypot(trajectory[i].x_m - trajectory[i - 1].x_m,
                    trajectory[i].y_m - trajectory[i - 1].y_m);
  }
  return d;
}

}  // namespace draco::eval
