// Matching object maps by the lines of long structures (see structure_lines.hpp).
#include "draco/objects/structure_lines.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

namespace draco::objects {
namespace {

constexpr double kPi = std::numbers::pi;

// Angle difference of undirected lines, in (-pi/2, pi/2].
double LineAngleDiff(double a, double b) {
  double d = std::fmod(a - b, kPi);
  if (d > kPi / 2) d -= kPi;
  if (d <= -kPi / 2) d += kPi;
  return d;
}

double Wrap0Pi(double a) {
  double d = std::fmod(a, kPi);
  if (d < 0) d += kPi;
  return d;
}

Point2 Dir(double yaw) { return {std::cos(yaw), std::sin(yaw)}; }

double Dot(const Point2& p, const Point2& q) { return p.x_m * q.x_m + p.y_m * q.y_m; }
Point2 Sub(const Point2& p, const Point2& q) { return {p.x_m - q.x_m, p.y_m - q.y_m}; }

bool IsLine(const msgs::Object& o, const StructureLineOptions& opt) {
  return o.length_m >= opt.min_length_m && o.length_m >= opt.min_aspect * o.breadth_m;
}

// A line of map b moved into map a.
struct MovedLine {
  Point2 center;
  double yaw_rad;
  double half_length_m;
};

// Line pair test: residual (rms lateral offset of b's endpoints from a's line) or < 0 when
// the pair does not match.
double LineResidual(const StructureLine& la, const MovedLine& lb, const StructureLineOptions& o) {
  if (std::abs(LineAngleDiff(la.yaw_rad, lb.yaw_rad)) > o.angle_tolerance_rad) return -1.0;
  const Point2 da = Dir(la.yaw_rad), na{-da.y_m, da.x_m};
  const Point2 db = Dir(lb.yaw_rad), nb{-db.y_m, db.x_m};
  // Lateral offsets, both ways (centres: a's centre from b's line too, so a short b segment
  // far along a long a line is tested where it lies).
  const double off_b = Dot(na, Sub(lb.center, la.center));
  const double off_a = Dot(nb, Sub(la.center, lb.center));
  if (std::abs(off_b) > o.lateral_tolerance_m || std::abs(off_a) > o.lateral_tolerance_m) {
    return -1.0;
  }
  // Extents along a's direction must meet (within max_gap_m).
  const double sb = Dot(da, Sub(lb.center, la.center));
  const double hb = lb.half_length_m * std::abs(Dot(da, db));
  const double gap = std::abs(sb) - la.half_length_m - hb;
  if (gap > o.max_gap_m) return -1.0;
  const Point2 e1{lb.center.x_m + lb.half_length_m * db.x_m,
                  lb.center.y_m + lb.half_length_m * db.y_m};
  const Point2 e2{lb.center.x_m - lb.half_length_m * db.x_m,
                  lb.center.y_m - lb.half_length_m * db.y_m};
  const double r1 = Dot(na, Sub(e1, la.center)), r2 = Dot(na, Sub(e2, la.center));
  return std::sqrt(0.5 * (r1 * r1 + r2 * r2));
}

struct Prepared {
  std::vector<StructureLine> lines;
  std::vector<int> compact;
};

Prepared Prepare(const msgs::ObjectMap& m, const StructureLineOptions& o) {
  return {ExtractLines(m, o), CompactObjects(m, o)};
}

// Support of T (greedy one-to-one by residual); pairs filled when asked.
LineHypothesis Score(const msgs::ObjectMap& a, const Prepared& pa, const msgs::ObjectMap& b,
                     const Prepared& pb, const Pose2& T, const StructureLineOptions& o,
                     bool with_pairs) {
  LineHypothesis h;
  h.T_a_b = T;
  struct Cand {
    double r;
    int ia, ib;  // indices into the line / compact lists
    bool line;
  };
  std::vector<Cand> cands;
  for (std::size_t k = 0; k < pb.lines.size(); ++k) {
    const auto& l = pb.lines[k];
    const MovedLine m{Transform(T, l.center), l.yaw_rad + T.yaw_rad, l.half_length_m};
    for (std::size_t i = 0; i < pa.lines.size(); ++i) {
      const double r = LineResidual(pa.lines[i], m, o);
      if (r >= 0.0) cands.push_back({r, int(i), int(k), true});
    }
  }
  for (std::size_t k = 0; k < pb.compact.size(); ++k) {
    const Point2 q = Transform(T, b.objects[pb.compact[k]].center);
    for (std::size_t i = 0; i < pa.compact.size(); ++i) {
      const Point2 d = Sub(a.objects[pa.compact[i]].center, q);
      const double r = std::sqrt(Dot(d, d));
      if (r < o.point_tolerance_m) cands.push_back({r, int(i), int(k), false});
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& x, const Cand& y) {
    return x.r < y.r ||
           (x.r == y.r && (x.line > y.line ||
                           (x.line == y.line && (x.ia < y.ia || (x.ia == y.ia && x.ib < y.ib)))));
  });
  std::vector<char> used_la(pa.lines.size(), 0), used_lb(pb.lines.size(), 0);
  std::vector<char> used_ca(pa.compact.size(), 0), used_cb(pb.compact.size(), 0);
  for (const auto& c : cands) {
    auto& ua = c.line ? used_la[c.ia] : used_ca[c.ia];
    auto& ub = c.line ? used_lb[c.ib] : used_cb[c.ib];
    if (ua || ub) continue;
    ua = ub = 1;
    ++h.support;
    if (c.line) ++h.line_support;
    if (with_pairs) {
      h.pairs.push_back({c.line ? pa.lines[c.ia].object : pa.compact[c.ia],
                         c.line ? pb.lines[c.ib].object : pb.compact[c.ib], c.line, c.r});
    }
  }
  return h;
}

double MeanDisplacement(const msgs::ObjectMap& b, const Pose2& x, const Pose2& y) {
  if (b.objects.empty()) return 0.0;
  double s = 0.0;
  for (const auto& o : b.objects) {
    const Point2 d = Sub(Transform(x, o.center), Transform(y, o.center));
    s += std::sqrt(Dot(d, d));
  }
  return s / double(b.objects.size());
}

}  // namespace

std::vector<StructureLine> ExtractLines(const msgs::ObjectMap& map,
                                        const StructureLineOptions& options) {
  std::vector<StructureLine> lines;
  for (std::size_t i = 0; i < map.objects.size(); ++i) {
    const auto& o = map.objects[i];
    if (!IsLine(o, options)) continue;
    lines.push_back({int(i), o.rect_center, Wrap0Pi(o.yaw_rad), 0.5 * o.length_m});
  }
  // The longest first (ties: map order), at most max_lines.
  std::stable_sort(lines.begin(), lines.end(), [](const StructureLine& x, const StructureLine& y) {
    return x.half_length_m > y.half_length_m;
  });
  if (static_cast<int>(lines.size()) > options.max_lines) lines.resize(options.max_lines);
  return lines;
}

std::vector<int> CompactObjects(const msgs::ObjectMap& map, const StructureLineOptions& options) {
  std::vector<int> out;
  for (std::size_t i = 0; i < map.objects.size(); ++i) {
    const auto& o = map.objects[i];
    if (!IsLine(o, options) && o.length_m <= options.max_compact_length_m) out.push_back(int(i));
  }
  return out;
}

std::vector<StructureCorner> Corners(const std::vector<StructureLine>& lines,
                                     const StructureLineOptions& options) {
  std::vector<StructureCorner> out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    for (std::size_t j = i + 1; j < lines.size(); ++j) {
      const auto& li = lines[i];
      const auto& lj = lines[j];
      const double angle = Wrap0Pi(lj.yaw_rad - li.yaw_rad);
      if (std::min(angle, kPi - angle) < options.min_corner_angle_rad) continue;
      // li.c + s di = lj.c + u dj
      const Point2 di = Dir(li.yaw_rad), dj = Dir(lj.yaw_rad);
      const double det = di.x_m * (-dj.y_m) - di.y_m * (-dj.x_m);
      if (std::abs(det) < 1e-9) continue;
      const Point2 r = Sub(lj.center, li.center);
      const double s = (r.x_m * (-dj.y_m) - r.y_m * (-dj.x_m)) / det;
      const double u = (di.x_m * r.y_m - di.y_m * r.x_m) / det;
      if (std::abs(s) > li.half_length_m + options.max_reach_m ||
          std::abs(u) > lj.half_length_m + options.max_reach_m) {
        continue;
      }
      out.push_back(
          {int(i), int(j), {li.center.x_m + s * di.x_m, li.center.y_m + s * di.y_m}, angle});
    }
  }
  return out;
}

LineHypothesis ScoreStructure(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                              const Pose2& T_a_b, const StructureLineOptions& options) {
  return Score(a, Prepare(a, options), b, Prepare(b, options), T_a_b, options, true);
}

Pose2 RefineStructure(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                      const std::vector<SupportPair>& pairs, const Pose2& T_a_b) {
  Pose2 T = T_a_b;
  for (int it = 0; it < 5; ++it) {
    double H[3][3] = {}, g[3] = {};
    const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
    const auto add = [&](const double J[3], double r) {
      for (int u = 0; u < 3; ++u) {
        g[u] += J[u] * r;
        for (int v = 0; v < 3; ++v) H[u][v] += J[u] * J[v];
      }
    };
    for (const auto& p : pairs) {
      const auto& oa = a.objects[p.object_a];
      const auto& ob = b.objects[p.object_b];
      if (p.line) {
        const Point2 da = Dir(oa.yaw_rad), na{-da.y_m, da.x_m};
        const Point2 db = Dir(ob.yaw_rad);
        for (const double sign : {1.0, -1.0}) {
          const Point2 e{ob.rect_center.x_m + sign * 0.5 * ob.length_m * db.x_m,
                         ob.rect_center.y_m + sign * 0.5 * ob.length_m * db.y_m};
          const Point2 q{T.x_m + c * e.x_m - s * e.y_m, T.y_m + s * e.x_m + c * e.y_m};
          const Point2 dq{-s * e.x_m - c * e.y_m, c * e.x_m - s * e.y_m};
          const double J[3] = {na.x_m, na.y_m, Dot(na, dq)};
          add(J, Dot(na, Sub(q, oa.rect_center)));
        }
      } else {
        const Point2& e = ob.center;
        const Point2 q{T.x_m + c * e.x_m - s * e.y_m, T.y_m + s * e.x_m + c * e.y_m};
        const Point2 dq{-s * e.x_m - c * e.y_m, c * e.x_m - s * e.y_m};
        const double Jx[3] = {1.0, 0.0, dq.x_m}, Jy[3] = {0.0, 1.0, dq.y_m};
        add(Jx, q.x_m - oa.center.x_m);
        add(Jy, q.y_m - oa.center.y_m);
      }
    }
    // Damped (a lone pair of parallel lines leaves the motion along them free).
    const double trace = H[0][0] + H[1][1] + H[2][2];
    for (int u = 0; u < 3; ++u) H[u][u] += 1e-6 * trace + 1e-12;
    // Solve H d = -g (3x3, Cramer).
    const auto det3 = [](const double M[3][3]) {
      return M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
             M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
             M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]);
    };
    const double D = det3(H);
    if (!(std::abs(D) > 0.0)) break;
    double d[3];
    for (int col = 0; col < 3; ++col) {
      double M[3][3];
      for (int u = 0; u < 3; ++u)
        for (int v = 0; v < 3; ++v) M[u][v] = v == col ? -g[u] : H[u][v];
      d[col] = det3(M) / D;
    }
    T.x_m += d[0];
    T.y_m += d[1];
    T.yaw_rad = NormalizeAngle(T.yaw_rad + d[2]);
    if (std::abs(d[0]) + std::abs(d[1]) < 1e-6 && std::abs(d[2]) < 1e-8) break;
  }
  return T;
}

LineMatchResult MatchStructureLines(const msgs::ObjectMap& a, const msgs::ObjectMap& b,
                                    const StructureLineOptions& options, double distinct_m,
                                    double distinct_rad) {
  LineMatchResult result;
  const Prepared pa = Prepare(a, options), pb = Prepare(b, options);
  const auto ca = Corners(pa.lines, options), cb = Corners(pb.lines, options);
  result.num_corners_a = static_cast<int>(ca.size());
  result.num_corners_b = static_cast<int>(cb.size());
  std::vector<LineHypothesis> hyps;
  for (const auto& x : ca) {
    for (const auto& y0 : cb) {
      for (int flip = 0; flip < 2; ++flip) {
        // b's corner with its lines in either order (angle from the first to the second).
        const int k = flip ? y0.line_j : y0.line_i, l = flip ? y0.line_i : y0.line_j;
        const double angle_b = flip ? Wrap0Pi(kPi - y0.angle_rad) : y0.angle_rad;
        if (std::abs(LineAngleDiff(x.angle_rad, angle_b)) > options.angle_tolerance_rad) continue;
        const double th_i = pa.lines[x.line_i].yaw_rad - pb.lines[k].yaw_rad;
        const double th_j = pa.lines[x.line_j].yaw_rad - pb.lines[l].yaw_rad;
        const double theta0 = th_i + 0.5 * LineAngleDiff(th_j, th_i);
        for (int half = 0; half < 2; ++half) {
          const double theta = NormalizeAngle(theta0 + half * kPi);
          const double c = std::cos(theta), s = std::sin(theta);
          const Point2& p = y0.point;
          const Pose2 T{x.point.x_m - (c * p.x_m - s * p.y_m),
                        x.point.y_m - (s * p.x_m + c * p.y_m), theta};
          hyps.push_back(Score(a, pa, b, pb, T, options, false));
        }
      }
    }
  }
  result.num_hypotheses = static_cast<int>(hyps.size());
  if (hyps.empty()) return result;
  result.found = true;
  // Best: most support, then most line support, then generation order (deterministic).
  std::size_t win = 0;
  for (std::size_t h = 1; h < hyps.size(); ++h) {
    if (hyps[h].support > hyps[win].support ||
        (hyps[h].support == hyps[win].support && hyps[h].line_support > hyps[win].line_support)) {
      win = h;
    }
  }
  // Refine on the support, re-score; keep the refinement while the support does not drop.
  LineHypothesis best = Score(a, pa, b, pb, hyps[win].T_a_b, options, true);
  for (int round = 0; round < 3; ++round) {
    const Pose2 T = RefineStructure(a, b, best.pairs, best.T_a_b);
    LineHypothesis next = Score(a, pa, b, pb, T, options, true);
    if (next.support < best.support) break;
    const bool same = next.pairs.size() == best.pairs.size() &&
                      std::equal(next.pairs.begin(), next.pairs.end(), best.pairs.begin(),
                                 [](const SupportPair& x, const SupportPair& y) {
                                   return x.object_a == y.object_a && x.object_b == y.object_b;
                                 });
    best = std::move(next);
    if (same) break;
  }
  for (const auto& h : hyps) {
    if (h.support <= result.runner_up_support) continue;
    const bool distinct =
        std::abs(NormalizeAngle(h.T_a_b.yaw_rad - best.T_a_b.yaw_rad)) > distinct_rad ||
        MeanDisplacement(b, h.T_a_b, best.T_a_b) > distinct_m;
    if (distinct) result.runner_up_support = h.support;
  }
  result.best = std::move(best);
  return result;
}

}  // namespace draco::objects
