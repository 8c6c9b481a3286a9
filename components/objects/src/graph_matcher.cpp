// Object-graph matching (see graph_matcher.hpp).
#include "draco/objects/graph_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>

#include "draco/objects/assignment.hpp"
#include "draco/objects/geometry.hpp"

namespace draco::objects {
namespace {

using msgs::MatchStatus;
using msgs::ObjectMap;

double Distance(const Point2& p, const Point2& q) {
  const double dx = p.x_m - q.x_m, dy = p.y_m - q.y_m;
  return std::sqrt(dx * dx + dy * dy);  // not hypot: no overflow here, and 5x faster
}

// Shape term of one vertex pair: the code's s(i,k) = exp(-2 (|dl| + |db|)); the paper's
// exp(-(|dl| + |db|)); kRelative: the code's with the difference divided by
// 1 + relative_shape_per_m * max(l_i, l_k) (partial views of large objects differ more).
double Shape(const msgs::Object& p, const msgs::Object& q, const MatcherOptions& o) {
  const double d = std::abs(p.length_m - q.length_m) + std::abs(p.breadth_m - q.breadth_m);
  switch (o.affinity) {
    case AffinityForm::kPaper:
      return std::exp(-d);
    case AffinityForm::kRelative:
      return std::exp(-2.0 * d / (1.0 + o.relative_shape_per_m * std::max(p.length_m, q.length_m)));
    case AffinityForm::kCode:
      break;
  }
  return std::exp(-2.0 * d);
}

struct EdgeB {
  float w;
  std::uint16_t k, l;
};

}  // namespace

SparseAffinity BuildAffinity(const ObjectMap& a, const ObjectMap& b,
                             const MatcherOptions& options) {
  if (a.objects.size() > 65535 || b.objects.size() > 65535) {
    throw std::invalid_argument("BuildAffinity: at most 65535 objects per map");
  }
  SparseAffinity out;
  const int na = static_cast<int>(a.objects.size()), nb = static_cast<int>(b.objects.size());
  out.n_a = na;
  out.n_b = nb;
  out.candidate_of.assign(std::size_t(na) * nb, -1);
  std::vector<double> shape(std::size_t(na) * nb, 0.0);
  for (int i = 0; i < na; ++i) {
    for (int k = 0; k < nb; ++k) {
      const double s = Shape(a.objects[i], b.objects[k], options);
      if (s < options.min_shape_similarity) continue;
      out.candidate_of[std::size_t(i) * nb + k] = static_cast<std::int32_t>(out.candidates.size());
      out.candidates.emplace_back(i, k);
      shape[std::size_t(i) * nb + k] = s;
    }
  }
  if (out.candidates.empty()) return out;
  // Map b's directed edges, sorted by weight.
  std::vector<EdgeB> edges_b;
  edges_b.reserve(std::size_t(nb) * (nb > 0 ? nb - 1 : 0));
  for (int k = 0; k < nb; ++k) {
    for (int l = 0; l < nb; ++l) {
      if (k == l) continue;
      edges_b.push_back({static_cast<float>(Distance(b.objects[k].center, b.objects[l].center)),
                         static_cast<std::uint16_t>(k), static_cast<std::uint16_t>(l)});
    }
  }
  std::sort(edges_b.begin(), edges_b.end(), [](const EdgeB& x, const EdgeB& y) {
    return x.w < y.w || (x.w == y.w && (x.k < y.k || (x.k == y.k && x.l < y.l)));
  });
  const double window = std::log(1.0 / options.min_affinity) / options.mu_per_m;
  const bool code = options.affinity != AffinityForm::kPaper;  // symmetric forms
  // Each unordered pair {i, j} of map a with each ordered pair (k, l) of map b gives the
  // symmetric pair of entries ((i,k), (j,l)) and ((j,l), (i,k)).
  for (int i = 0; i < na; ++i) {
    for (int j = i + 1; j < na; ++j) {
      const double w = Distance(a.objects[i].center, a.objects[j].center);
      auto it = std::lower_bound(edges_b.begin(), edges_b.end(), static_cast<float>(w - window),
                                 [](const EdgeB& e, float v) { return e.w < v; });
      for (; it != edges_b.end() && it->w <= w + window; ++it) {
        const std::int32_t r = out.candidate_of[std::size_t(i) * nb + it->k];
        const std::int32_t c = out.candidate_of[std::size_t(j) * nb + it->l];
        if (r < 0 || c < 0) continue;
        const double e = std::exp(-options.mu_per_m * std::abs(w - double(it->w)));
        const double s_ik = shape[std::size_t(i) * nb + it->k];
        const double s_jl = shape[std::size_t(j) * nb + it->l];
        const double v_rc = code ? e * s_ik * s_jl : e * s_ik;
        const double v_cr = code ? v_rc : e * s_jl;
        if (std::max(v_rc, v_cr) < options.min_affinity) continue;
        out.entries.push_back({static_cast<std::uint32_t>(r), static_cast<std::uint32_t>(c),
                               static_cast<float>(v_rc), static_cast<float>(v_cr)});
      }
    }
  }
  return out;
}

namespace {

// Power iteration y = M x / |M x| from the uniform vector; mat_vec(x, y) sets y = M x.
template <class MatVec>
std::vector<double> PowerIteration(std::size_t n, const MatcherOptions& options, MatVec mat_vec,
                                   int* iterations) {
  std::vector<double> x(n, n > 0 ? 1.0 / std::sqrt(double(n)) : 0.0), y(n);
  int it = 0;
  for (; it < options.max_power_iterations; ++it) {
    mat_vec(x, &y);
    double norm = 0.0;
    for (const double v : y) norm += v * v;
    norm = std::sqrt(norm);
    if (norm == 0.0) break;  // no entries: keep the uniform vector
    double change = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      y[i] /= norm;
      change = std::max(change, std::abs(y[i] - x[i]));
    }
    x.swap(y);
    if (change < options.power_tolerance) {
      ++it;
      break;
    }
  }
  if (iterations) *iterations = it;
  return x;
}

}  // namespace

std::vector<double> PrincipalEigenvector(const SparseAffinity& affinity,
                                         const MatcherOptions& options, int* iterations) {
  return PowerIteration(
      affinity.candidates.size(), options,
      [&](const std::vector<double>& x, std::vector<double>* y) {
        std::fill(y->begin(), y->end(), 0.0);
        double* out = y->data();
        for (const auto& e : affinity.entries) {
          out[e.r] += double(e.v_rc) * x[e.c];
          out[e.c] += double(e.v_cr) * x[e.r];
        }
      },
      iterations);
}

std::vector<double> AssignmentWeights(const ObjectMap& a, const ObjectMap& b,
                                      const MatcherOptions& options, int* num_candidates,
                                      int* num_entries) {
  const int na = static_cast<int>(a.objects.size()), nb = static_cast<int>(b.objects.size());
  std::vector<double> weights(std::size_t(na) * nb, 0.0);
  if (options.dense) {
    // The reference: every (i,k) x (j,l) entry of the (n_a n_b)^2 matrix.
    const std::size_t n = std::size_t(na) * nb;
    if (n > 4096) throw std::invalid_argument("AssignmentWeights: dense needs n_a n_b <= 4096");
    std::vector<double> m(n * n, 0.0);
    const bool code = options.affinity != AffinityForm::kPaper;  // symmetric forms
    for (int i = 0; i < na; ++i) {
      for (int k = 0; k < nb; ++k) {
        const double s_ik = Shape(a.objects[i], b.objects[k], options);
        for (int j = 0; j < na; ++j) {
          if (j == i) continue;
          const double w_ij = Distance(a.objects[i].center, a.objects[j].center);
          for (int l = 0; l < nb; ++l) {
            if (l == k) continue;
            const double w_kl = Distance(b.objects[k].center, b.objects[l].center);
            const double e = std::exp(-options.mu_per_m * std::abs(w_ij - w_kl));
            m[(std::size_t(i) * nb + k) * n + std::size_t(j) * nb + l] =
                code ? e * s_ik * Shape(a.objects[j], b.objects[l], options) : e * s_ik;
          }
        }
      }
    }
    const auto x = PowerIteration(
        n, options,
        [&](const std::vector<double>& v, std::vector<double>* y) {
          for (std::size_t r = 0; r < n; ++r) {
            double sum = 0.0;
            const double* row = &m[r * n];
            for (std::size_t c = 0; c < n; ++c) sum += row[c] * v[c];
            (*y)[r] = sum;
          }
        },
        nullptr);
    for (std::size_t c = 0; c < n; ++c) weights[c] = std::abs(x[c]);
    if (num_candidates) *num_candidates = static_cast<int>(n);
    if (num_entries) *num_entries = static_cast<int>(n * n);
    return weights;
  }
  const SparseAffinity affinity = BuildAffinity(a, b, options);
  const auto x = PrincipalEigenvector(affinity, options);
  for (std::size_t c = 0; c < affinity.candidates.size(); ++c) {
    const auto [i, k] = affinity.candidates[c];
    weights[std::size_t(i) * nb + k] = std::abs(x[c]);
  }
  if (num_candidates) *num_candidates = static_cast<int>(affinity.candidates.size());
  if (num_entries) *num_entries = static_cast<int>(affinity.entries.size());
  return weights;
}

Coverage::Coverage(const std::vector<Pose2>& poses, const CoverageOptions& o) {
  if (poses.empty()) return;
  cell_m_ = o.cell_m;
  double x0 = poses[0].x_m, x1 = x0, y0 = poses[0].y_m, y1 = y0;
  for (const auto& p : poses) {
    x0 = std::min(x0, p.x_m), x1 = std::max(x1, p.x_m);
    y0 = std::min(y0, p.y_m), y1 = std::max(y1, p.y_m);
  }
  x0_ = x0 - o.range_m;
  y0_ = y0 - o.range_m;
  nx_ = static_cast<int>(std::ceil((x1 - x0 + 2 * o.range_m) / cell_m_)) + 1;
  ny_ = static_cast<int>(std::ceil((y1 - y0 + 2 * o.range_m) / cell_m_)) + 1;
  cells_.assign(std::size_t(nx_) * ny_, 0);
  const int r = static_cast<int>(std::ceil(o.range_m / cell_m_));
  const double cos_half = std::cos(std::min(o.half_aperture_rad, M_PI));
  for (const auto& p : poses) {
    const double hx = std::cos(p.yaw_rad), hy = std::sin(p.yaw_rad);
    const int cx = static_cast<int>((p.x_m - x0_) / cell_m_);
    const int cy = static_cast<int>((p.y_m - y0_) / cell_m_);
    for (int iy = std::max(0, cy - r); iy <= std::min(ny_ - 1, cy + r); ++iy) {
      for (int ix = std::max(0, cx - r); ix <= std::min(nx_ - 1, cx + r); ++ix) {
        std::uint8_t& cell = cells_[std::size_t(iy) * nx_ + ix];
        if (cell) continue;
        const double dx = x0_ + (ix + 0.5) * cell_m_ - p.x_m;
        const double dy = y0_ + (iy + 0.5) * cell_m_ - p.y_m;
        const double d2 = dx * dx + dy * dy;
        if (d2 > o.range_m * o.range_m) continue;
        // Within half_aperture of the heading: cos(bearing - yaw) >= cos(half_aperture).
        if (hx * dx + hy * dy < std::sqrt(d2) * cos_half) continue;
        cell = 1;
      }
    }
  }
}

bool Coverage::Observed(const Point2& p) const {
  if (cells_.empty()) return false;
  const double fx = (p.x_m - x0_) / cell_m_, fy = (p.y_m - y0_) / cell_m_;
  if (fx < 0 || fy < 0 || fx >= nx_ || fy >= ny_) return false;
  return cells_[std::size_t(fy) * nx_ + std::size_t(fx)] != 0;
}

double Coverage::ObservedFraction() const {
  if (cells_.empty()) return 0.0;
  std::size_t n = 0;
  for (const auto c : cells_) n += c;
  return double(n) / double(cells_.size());
}

int CountMisses(const ObjectMap& from, const ObjectMap& to, const Pose2& T_to_from,
                const Coverage& to_coverage, double distance_m) {
  int misses = 0;
  for (const auto& o : from.objects) {
    const Point2 q = Transform(T_to_from, o.center);
    if (!to_coverage.Observed(q)) continue;
    bool near = false;
    for (const auto& t : to.objects) {
      if (Distance(t.center, q) < distance_m) {
        near = true;
        break;
      }
    }
    misses += !near;
  }
  return misses;
}

namespace {

Pose2 Inverse(const Pose2& T) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {-(c * T.x_m + s * T.y_m), s * T.x_m - c * T.y_m, -T.yaw_rad};
}

struct Hypothesis {
  Pose2 T;
  int inliers = -1;
  int misses = 0;
  double score = -std::numeric_limits<double>::infinity();  // inliers - miss_weight * misses
  double cost = std::numeric_limits<double>::infinity();
};

// Inliers (residual < threshold) and the truncated squared cost (MSAC) of T.
Hypothesis Score(const Pose2& T, const std::vector<Point2>& pa, const std::vector<Point2>& pb,
                 double threshold, std::vector<char>* inlier) {
  Hypothesis h{T, 0, 0, 0.0, 0.0};
  if (inlier) inlier->assign(pa.size(), 0);
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  for (std::size_t i = 0; i < pa.size(); ++i) {
    const Point2 q{T.x_m + c * pb[i].x_m - s * pb[i].y_m, T.y_m + s * pb[i].x_m + c * pb[i].y_m};
    const double r = Distance(pa[i], q);
    if (r < threshold) {
      ++h.inliers;
      if (inlier) (*inlier)[i] = 1;
    }
    h.cost += std::min(r * r, threshold * threshold);
  }
  h.score = h.inliers;
  return h;
}

bool Better(const Hypothesis& x, const Hypothesis& y) {
  return x.score > y.score || (x.score == y.score && x.cost < y.cost);
}

msgs::ObjectMatch MatchSpectral(const ObjectMap& a, const ObjectMap& b,
                                const MatcherOptions& options, const Coverage* coverage_a,
                                const Coverage* coverage_b) {
  msgs::ObjectMatch match;
  match.robot_a = a.robot_id;
  match.robot_b = b.robot_id;
  const std::optional<double> yaw_prior = HeadingYawPrior(a, b);
  const auto heading_ok = [&](const Pose2& T) {
    return HeadingAllows(yaw_prior, T.yaw_rad, options.max_heading_gap_rad);
  };
  const int na = static_cast<int>(a.objects.size()), nb = static_cast<int>(b.objects.size());
  const int edges = std::min(na * (na - 1), nb * (nb - 1)) / 2;
  if (std::min(na, nb) < options.min_objects || edges < options.min_edges) {
    match.status = MatchStatus::kTooFewObjects;
    return match;
  }
  // 1. Spectral relaxation of the QAP.
  const std::vector<double> weights =
      AssignmentWeights(a, b, options, &match.num_candidates, &match.num_affinity_entries);
  if (match.num_candidates == 0 || match.num_affinity_entries == 0) {
    match.status = MatchStatus::kNoCandidates;
    return match;
  }
  // 2. Linear assignment on the negated weights.
  std::vector<double> cost(weights.size());
  for (std::size_t c = 0; c < weights.size(); ++c) cost[c] = -weights[c];
  const std::vector<int> col = SolveAssignment(cost, na, nb);
  std::vector<Point2> pa, pb;
  for (int i = 0; i < na; ++i) {
    if (col[i] < 0) continue;
    if (!options.keep_zero_weight_assignments && weights[std::size_t(i) * nb + col[i]] <= 0.0) {
      continue;
    }
    pa.push_back(a.objects[i].center);
    pb.push_back(b.objects[col[i]].center);
  }
  match.num_assignments = static_cast<int>(pa.size());
  if (match.num_assignments < options.min_assignments) {
    match.status = MatchStatus::kTooFewAssignments;
    return match;
  }
  // Negative evidence of a transform, both ways.
  const bool negative = options.miss_weight > 0.0 && (coverage_a || coverage_b);
  const auto misses = [&](const Pose2& T) {
    int m = 0;
    if (coverage_a && !coverage_a->empty()) {
      m += CountMisses(b, a, T, *coverage_a, options.miss_distance_m);
    }
    if (coverage_b && !coverage_b->empty()) {
      m += CountMisses(a, b, Inverse(T), *coverage_b, options.miss_distance_m);
    }
    return m;
  };
  const auto charge = [&](Hypothesis* h) {
    if (!negative) return;
    h->misses = misses(h->T);
    h->score = h->inliers - options.miss_weight * h->misses;
  };
  // 3. RANSAC over pairs of assignments (every pair when there are few).
  const std::size_t n = pa.size();
  const double thr = options.ransac_threshold_m;
  Hypothesis best;
  const bool ambiguity = options.max_ambiguity_ratio > 0.0;
  auto try_sample = [&](std::size_t s, std::size_t t) {
    const double da = Distance(pa[s], pa[t]), db = Distance(pb[s], pb[t]);
    if (da < 1e-6 || std::abs(da - db) > thr) return;  // a rigid motion keeps distances
    const Pose2 T = FitRigid({pa[s], pa[t]}, {pb[s], pb[t]});
    if (!heading_ok(T)) return;
    Hypothesis h = Score(T, pa, pb, thr, nullptr);
    charge(&h);
    if (Better(h, best)) best = h;
  };
  const std::size_t all_pairs = n * (n - 1) / 2;
  if (all_pairs <= static_cast<std::size_t>(std::max(0, options.ransac_iterations))) {
    for (std::size_t s = 0; s < n; ++s) {
      for (std::size_t t = s + 1; t < n; ++t) try_sample(s, t);
    }
  } else {
    std::mt19937_64 rng(options.seed);
    for (int it = 0; it < options.ransac_iterations; ++it) {
      const std::size_t s = rng() % n;
      std::size_t t = rng() % (n - 1);
      if (t >= s) ++t;
      try_sample(s, t);
    }
  }
  if (best.inliers < 0) best.inliers = 0;
  if (best.inliers >= 2) {  // refit on the inliers while that does not lose any
    std::vector<char> inlier;
    Score(best.T, pa, pb, thr, &inlier);
    std::vector<Point2> qa, qb;
    for (std::size_t i = 0; i < n; ++i) {
      if (inlier[i]) qa.push_back(pa[i]), qb.push_back(pb[i]);
    }
    Hypothesis refit = Score(FitRigid(qa, qb), pa, pb, thr, nullptr);
    charge(&refit);
    if (!Better(best, refit) && heading_ok(refit.T)) best = refit;
  }
  match.num_ransac_inliers = best.inliers;
  if (best.inliers < options.min_inliers) {
    match.status = MatchStatus::kTooFewInliers;
    return match;
  }
  // Verification over all objects (negative evidence, ambiguity). RANSAC above only sees the
  // one-to-one assignment, which along a row of identical piles holds one shift only; here the
  // hypotheses also come from pairs of each object's top eigenvector candidates, and each is
  // scored by its support (b objects landing within the threshold of an a object) minus
  // miss_weight x misses. The best-supported hypothesis replaces RANSAC's when it is distinct
  // and better; the ambiguity is the runner-up's support beyond a two-point sample over the
  // winner's.
  if (negative || ambiguity) {
    const auto support = [&](const Pose2& T) {
      int n_in = 0;
      for (const auto& ob : b.objects) {
        const Point2 q = Transform(T, ob.center);
        for (const auto& oa : a.objects) {
          if (Distance(oa.center, q) < thr) {
            ++n_in;
            break;
          }
        }
      }
      return n_in - (negative ? options.miss_weight * misses(T) : 0.0);
    };
    const auto distinct = [&](const Pose2& x, const Pose2& y) {
      if (std::abs(NormalizeAngle(x.yaw_rad - y.yaw_rad)) > options.distinct_rad) return true;
      double moved = 0.0;
      for (const auto& ob : b.objects)
        moved += Distance(Transform(x, ob.center), Transform(y, ob.center));
      return moved / double(nb) > options.distinct_m;
    };
    // Candidate correspondences: the top verify_candidates b objects of each a object.
    std::vector<std::pair<Point2, Point2>> corr;
    std::vector<std::pair<int, int>> corr_ik;
    for (int i = 0; i < na; ++i) {
      std::vector<int> ks;
      for (int k = 0; k < nb; ++k) {
        if (weights[std::size_t(i) * nb + k] > 0.0) ks.push_back(k);
      }
      std::sort(ks.begin(), ks.end(), [&](int x, int y) {
        return weights[std::size_t(i) * nb + x] > weights[std::size_t(i) * nb + y] ||
               (weights[std::size_t(i) * nb + x] == weights[std::size_t(i) * nb + y] && x < y);
      });
      if (static_cast<int>(ks.size()) > options.verify_candidates)
        ks.resize(options.verify_candidates);
      for (const int k : ks) {
        corr.emplace_back(a.objects[i].center, b.objects[k].center);
        corr_ik.emplace_back(i, k);
      }
    }
    std::vector<Pose2> hyps{best.T};
    const auto add = [&](std::size_t u, std::size_t v) {
      if (corr_ik[u].first == corr_ik[v].first || corr_ik[u].second == corr_ik[v].second) return;
      const double da = Distance(corr[u].first, corr[v].first);
      const double db = Distance(corr[u].second, corr[v].second);
      if (da < 1e-6 || std::abs(da - db) > thr) return;
      const Pose2 T = FitRigid({corr[u].first, corr[v].first}, {corr[u].second, corr[v].second});
      if (heading_ok(T)) hyps.push_back(T);
    };
    const std::size_t m = corr.size();
    if (m * (m - 1) / 2 <= static_cast<std::size_t>(std::max(0, options.verify_iterations))) {
      for (std::size_t u = 0; u < m; ++u) {
        for (std::size_t v = u + 1; v < m; ++v) add(u, v);
      }
    } else if (m >= 2) {
      std::mt19937_64 rng(options.seed + 1);
      for (int it = 0; it < options.verify_iterations; ++it) {
        const std::size_t u = rng() % m;
        std::size_t v = rng() % (m - 1);
        if (v >= u) ++v;
        add(u, v);
      }
    }
    std::vector<double> score(hyps.size());
    std::size_t win = 0;
    for (std::size_t h = 0; h < hyps.size(); ++h) {
      score[h] = support(hyps[h]);
      if (score[h] > score[win] && distinct(hyps[h], hyps[0])) win = h;
    }
    if (win != 0) best.T = hyps[win];
    double runner_up = 0.0;
    for (std::size_t h = 0; h < hyps.size(); ++h) {
      if (score[h] > runner_up && distinct(hyps[h], hyps[win])) runner_up = score[h];
    }
    match.ambiguity = std::max(0.0, runner_up - 2.0) / std::max(1e-9, score[win] - 2.0);
    if (ambiguity && match.ambiguity >= options.max_ambiguity_ratio) {
      match.status = MatchStatus::kAmbiguous;
      return match;
    }
  }
  // 4. Re-match every object in the aligned frame on centre distance; refit (twice, so the
  // second assignment sees the refined transform).
  Pose2 T = best.T;
  std::vector<std::pair<int, int>> pairs;
  for (int round = 0; round < 2; ++round) {
    std::vector<Point2> moved_b(nb);
    for (int k = 0; k < nb; ++k) moved_b[k] = Transform(T, b.objects[k].center);
    std::vector<double> d(std::size_t(na) * nb);
    for (int i = 0; i < na; ++i) {
      for (int k = 0; k < nb; ++k)
        d[std::size_t(i) * nb + k] = Distance(a.objects[i].center, moved_b[k]);
    }
    // Gated cost: every pair beyond the gate costs the same, so far pairs never pull the
    // assignment away from near ones (with plain distances, two rows of piles shifted by
    // one pile have equal-cost assignments that pair no pile with its neighbour).
    std::vector<double> gated(d.size());
    for (std::size_t c = 0; c < d.size(); ++c)
      gated[c] = std::min(d[c], options.rematch_distance_m);
    const std::vector<int> rematch = SolveAssignment(gated, na, nb);
    std::vector<std::pair<int, int>> kept;
    std::vector<Point2> qa, qb;
    for (int i = 0; i < na; ++i) {
      if (rematch[i] < 0 || d[std::size_t(i) * nb + rematch[i]] >= options.rematch_distance_m) {
        continue;
      }
      kept.emplace_back(i, rematch[i]);
      qa.push_back(a.objects[i].center);
      qb.push_back(b.objects[rematch[i]].center);
    }
    if (static_cast<int>(kept.size()) < options.min_inliers) {
      match.status = MatchStatus::kTooFewInliers;
      match.num_inliers = static_cast<int>(kept.size());
      return match;
    }
    T = FitRigid(qa, qb);
    if (kept == pairs) break;
    pairs = std::move(kept);
  }
  // 5. Outcome (the headings' bound and negative evidence of the final transform first).
  if (!heading_ok(T)) {
    match.status = MatchStatus::kHeadingMismatch;
    match.num_inliers = static_cast<int>(pairs.size());
    return match;
  }
  if (negative) {
    match.num_misses = misses(T);
    if (double(pairs.size()) - options.miss_weight * match.num_misses < options.min_inliers) {
      match.status = MatchStatus::kContradicted;
      match.num_inliers = static_cast<int>(pairs.size());
      return match;
    }
  }
  match.status = MatchStatus::kMatched;
  match.T_a_b = T;
  match.T_a_b.yaw_rad = NormalizeAngle(T.yaw_rad);
  double sum2 = 0.0;
  for (const auto& [i, k] : pairs) {
    const double r = Distance(a.objects[i].center, Transform(T, b.objects[k].center));
    match.pairs.push_back({a.objects[i].id, b.objects[k].id, r});
    sum2 += r * r;
  }
  match.num_inliers = static_cast<int>(pairs.size());
  match.rmse_m = std::sqrt(sum2 / double(pairs.size()));
  match.confidence = double(match.num_inliers) / double(std::min(na, nb));
  return match;
}

// Objects the translation votes may pair: both landmarks, or both clusters of similar shape.
bool VoteCompatible(const msgs::Object& p, const msgs::Object& q, const MatcherOptions& options) {
  if (p.landmark != q.landmark) return false;
  return p.landmark || Shape(p, q, options) >= options.min_shape_similarity;
}

// Support of T_a_b as the votes count it: b objects landing within heading_vote_inlier_m of a
// compatible a object.
int VoteSupport(const ObjectMap& a, const ObjectMap& b, const Pose2& T,
                const MatcherOptions& options) {
  int n = 0;
  for (const auto& ob : b.objects) {
    const Point2 q = Transform(T, ob.center);
    for (const auto& oa : a.objects) {
      if (Distance(oa.center, q) < options.heading_vote_inlier_m &&
          VoteCompatible(oa, ob, options)) {
        ++n;
        break;
      }
    }
  }
  return n;
}

// Two transforms are distinct when they move b's objects apart by more than distinct_m on
// average.
bool Distinct(const ObjectMap& b, const Pose2& x, const Pose2& y, double distinct_m) {
  if (b.objects.empty()) return false;
  double moved = 0.0;
  for (const auto& ob : b.objects)
    moved += Distance(Transform(x, ob.center), Transform(y, ob.center));
  return moved / double(b.objects.size()) > distinct_m;
}

// Every hypothesis the votes scored (the densest blocks at each rotation), for a cross-check.
struct VotePeaks {
  std::vector<Pose2> T;
  std::vector<int> support;
};

// Translation votes under a known rotation (MatcherOptions::heading_votes).
msgs::ObjectMatch MatchByHeadingVotes(const ObjectMap& a, const ObjectMap& b, double yaw_prior,
                                      const MatcherOptions& options, VotePeaks* scored = nullptr) {
  msgs::ObjectMatch match;
  match.robot_a = a.robot_id;
  match.robot_b = b.robot_id;
  const int na = static_cast<int>(a.objects.size()), nb = static_cast<int>(b.objects.size());
  if (std::min(na, nb) < options.min_objects) {
    match.status = MatchStatus::kTooFewObjects;
    return match;
  }
  const auto compatible = [&](const msgs::Object& p, const msgs::Object& q) {
    return VoteCompatible(p, q, options);
  };
  std::vector<std::pair<int, int>> cand;
  for (int i = 0; i < na; ++i) {
    for (int k = 0; k < nb; ++k) {
      if (compatible(a.objects[i], b.objects[k])) cand.emplace_back(i, k);
    }
  }
  match.num_candidates = static_cast<int>(cand.size());
  if (cand.empty()) {
    match.status = MatchStatus::kNoCandidates;
    return match;
  }
  const double thr = options.heading_vote_inlier_m, cell = options.heading_vote_cell_m;
  const auto support = [&](const Pose2& T) { return VoteSupport(a, b, T, options); };
  struct Peak {
    Pose2 T;
    int support = 0;
  };
  std::vector<Peak> peaks;
  const int steps = options.heading_vote_step_rad > 0.0
                        ? static_cast<int>(std::floor(options.heading_vote_turn_rad /
                                                      options.heading_vote_step_rad))
                        : 0;
  for (int s = -steps; s <= steps; ++s) {
    const double yaw = yaw_prior + s * options.heading_vote_step_rad;
    const double c = std::cos(yaw), sn = std::sin(yaw);
    std::map<std::pair<long, long>, std::vector<Point2>> cells;
    for (const auto& [i, k] : cand) {
      const Point2& pa = a.objects[i].center;
      const Point2& pb = b.objects[k].center;
      const Point2 t{pa.x_m - (c * pb.x_m - sn * pb.y_m), pa.y_m - (sn * pb.x_m + c * pb.y_m)};
      cells[{std::lround(std::floor(t.x_m / cell)), std::lround(std::floor(t.y_m / cell))}]
          .push_back(t);
    }
    // The densest 2 x 2 blocks of cells; each block's mean translation is a hypothesis.
    std::vector<std::pair<std::size_t, Point2>> blocks;
    for (const auto& [key, votes] : cells) {
      std::size_t n = 0;
      Point2 sum{0.0, 0.0};
      for (long dx = 0; dx <= 1; ++dx) {
        for (long dy = 0; dy <= 1; ++dy) {
          const auto it = cells.find({key.first + dx, key.second + dy});
          if (it == cells.end()) continue;
          n += it->second.size();
          for (const auto& t : it->second) sum.x_m += t.x_m, sum.y_m += t.y_m;
        }
      }
      if (n >= 2) blocks.push_back({n, {sum.x_m / double(n), sum.y_m / double(n)}});
    }
    std::sort(blocks.begin(), blocks.end(), [](const auto& l, const auto& r) {
      return l.first > r.first ||
             (l.first == r.first && (l.second.x_m < r.second.x_m || (l.second.x_m == r.second.x_m &&
                                                                     l.second.y_m < r.second.y_m)));
    });
    if (blocks.size() > 8) blocks.resize(8);
    for (const auto& [n, t] : blocks) {
      const Pose2 T{t.x_m, t.y_m, yaw};
      peaks.push_back({T, support(T)});
    }
  }
  if (scored) {
    for (const auto& p : peaks) scored->T.push_back(p.T), scored->support.push_back(p.support);
  }
  if (peaks.empty()) {
    match.status = MatchStatus::kTooFewInliers;
    return match;
  }
  std::size_t win = 0;
  for (std::size_t p = 1; p < peaks.size(); ++p) {
    if (peaks[p].support > peaks[win].support) win = p;
  }
  const auto distinct = [&](const Pose2& x, const Pose2& y) {
    double moved = 0.0;
    for (const auto& ob : b.objects)
      moved += Distance(Transform(x, ob.center), Transform(y, ob.center));
    return moved / double(nb) > options.distinct_m;
  };
  int runner_up = 0;
  for (const auto& p : peaks) {
    if (p.support > runner_up && distinct(p.T, peaks[win].T)) runner_up = p.support;
  }
  match.num_ransac_inliers = peaks[win].support;
  match.ambiguity = std::max(0, runner_up - 2) / std::max(1e-9, double(peaks[win].support - 2));
  const int min_inliers = std::max(options.min_inliers, options.heading_vote_min_inliers);
  if (peaks[win].support < min_inliers) {
    match.status = MatchStatus::kTooFewInliers;
    return match;
  }
  if (match.ambiguity >= options.max_vote_ambiguity) {
    match.status = MatchStatus::kAmbiguous;
    return match;
  }
  // Pairs: each b object with its nearest compatible a object within thr; refit twice.
  Pose2 T = peaks[win].T;
  std::vector<std::pair<int, int>> pairs;
  for (int round = 0; round < 2; ++round) {
    pairs.clear();
    std::vector<Point2> qa, qb;
    std::vector<char> used(static_cast<std::size_t>(na), 0);
    for (int k = 0; k < nb; ++k) {
      const Point2 q = Transform(T, b.objects[k].center);
      int best = -1;
      double best_d = thr;
      for (int i = 0; i < na; ++i) {
        const double d = Distance(a.objects[i].center, q);
        if (d < best_d && !used[std::size_t(i)] && compatible(a.objects[i], b.objects[k]))
          best = i, best_d = d;
      }
      if (best < 0) continue;
      used[std::size_t(best)] = 1;
      pairs.emplace_back(best, k);
      qa.push_back(a.objects[best].center);
      qb.push_back(b.objects[k].center);
    }
    if (static_cast<int>(pairs.size()) < min_inliers) {
      match.status = MatchStatus::kTooFewInliers;
      match.num_inliers = static_cast<int>(pairs.size());
      return match;
    }
    T = FitRigid(qa, qb);
  }
  match.by_votes = true;
  if (!HeadingAllows(yaw_prior, T.yaw_rad, options.max_heading_gap_rad)) {
    match.status = MatchStatus::kHeadingMismatch;
    return match;
  }
  match.status = MatchStatus::kMatched;
  match.T_a_b = T;
  match.T_a_b.yaw_rad = NormalizeAngle(T.yaw_rad);
  double sum2 = 0.0;
  for (const auto& [i, k] : pairs) {
    const double r = Distance(a.objects[i].center, Transform(T, b.objects[k].center));
    match.pairs.push_back({a.objects[i].id, b.objects[k].id, r});
    sum2 += r * r;
  }
  match.num_inliers = static_cast<int>(pairs.size());
  match.rmse_m = std::sqrt(sum2 / double(pairs.size()));
  match.confidence = double(match.num_inliers) / double(std::min(na, nb));
  return match;
}

}  // namespace

namespace {

msgs::ObjectMatch MatchClusters(const ObjectMap& a, const ObjectMap& b,
                                const MatcherOptions& options, const Coverage* coverage_a,
                                const Coverage* coverage_b) {
  msgs::ObjectMatch spectral = MatchSpectral(a, b, options, coverage_a, coverage_b);
  if (!options.structure_lines) return spectral;
  const LineMatchResult lines =
      MatchStructureLines(a, b, options.lines, options.distinct_m, options.distinct_rad);
  if (!lines.found || lines.best.support < options.min_line_support ||
      !HeadingAllows(HeadingYawPrior(a, b), lines.best.T_a_b.yaw_rad, options.max_heading_gap_rad))
    return spectral;
  const bool spectral_ok = spectral.status == MatchStatus::kMatched;
  if (spectral_ok &&
      ScoreStructure(a, b, spectral.T_a_b, options.lines).support >= lines.best.support) {
    return spectral;
  }
  msgs::ObjectMatch match = spectral;
  match.ambiguity =
      std::max(0, lines.runner_up_support - 2) / std::max(1e-9, double(lines.best.support - 2));
  if (options.max_line_ambiguity > 0.0 && match.ambiguity >= options.max_line_ambiguity) {
    if (spectral_ok) return spectral;
    match.status = MatchStatus::kAmbiguous;
    return match;
  }
  match.status = MatchStatus::kMatched;
  match.by_lines = true;
  match.T_a_b = lines.best.T_a_b;
  match.T_a_b.yaw_rad = NormalizeAngle(match.T_a_b.yaw_rad);
  match.pairs.clear();
  double sum2 = 0.0;
  for (const auto& p : lines.best.pairs) {
    match.pairs.push_back({a.objects[p.object_a].id, b.objects[p.object_b].id, p.residual_m});
    sum2 += p.residual_m * p.residual_m;
  }
  match.num_inliers = static_cast<int>(match.pairs.size());
  match.num_line_pairs = lines.best.line_support;
  match.rmse_m = match.pairs.empty() ? 0.0 : std::sqrt(sum2 / double(match.pairs.size()));
  const int n_min = std::max<int>(1, int(std::min(a.objects.size(), b.objects.size())));
  match.confidence = std::min(1.0, double(match.num_inliers) / double(n_min));
  return match;
}

}  // namespace

namespace {

msgs::ObjectMatch MatchWithoutVotes(const ObjectMap& a, const ObjectMap& b,
                                    const MatcherOptions& options, const Coverage* coverage_a,
                                    const Coverage* coverage_b);

}  // namespace

msgs::ObjectMatch MatchObjectMaps(const ObjectMap& a, const ObjectMap& b,
                                  const MatcherOptions& options, const Coverage* coverage_a,
                                  const Coverage* coverage_b) {
  msgs::ObjectMatch m = MatchWithoutVotes(a, b, options, coverage_a, coverage_b);
  const auto prior = HeadingYawPrior(a, b);
  if (!prior || !options.heading_votes || !(options.max_heading_gap_rad > 0.0)) return m;
  if (m.status != MatchStatus::kMatched) {
    msgs::ObjectMatch votes = MatchByHeadingVotes(a, b, *prior, options);
    return votes.status == MatchStatus::kMatched ? votes : m;
  }
  if (!options.votes_cross_check) return m;
  VotePeaks peaks;
  msgs::ObjectMatch votes = MatchByHeadingVotes(a, b, *prior, options, &peaks);
  if (peaks.support.empty()) return m;  // too few objects or no compatible pairs: no evidence
  // The answer's support against the best distinct translation's, beyond a two-point sample.
  const int answer_support = VoteSupport(a, b, m.T_a_b, options);
  int rival = 0;
  for (std::size_t p = 0; p < peaks.support.size(); ++p) {
    if (peaks.support[p] > rival && Distinct(b, peaks.T[p], m.T_a_b, options.distinct_m))
      rival = peaks.support[p];
  }
  const double ambiguity = std::max(0, rival - 2) / std::max(1e-9, double(answer_support - 2));
  if (rival < answer_support && ambiguity < options.cross_check_max_ambiguity) return m;
  if (votes.status == MatchStatus::kMatched &&
      VoteSupport(a, b, votes.T_a_b, options) > answer_support)
    return votes;
  m.status = MatchStatus::kAmbiguous;
  m.ambiguity = ambiguity;
  return m;
}

namespace {

msgs::ObjectMatch MatchWithoutVotes(const ObjectMap& a, const ObjectMap& b,
                                    const MatcherOptions& options, const Coverage* coverage_a,
                                    const Coverage* coverage_b) {
  const auto has_landmark = [](const ObjectMap& m) {
    return std::any_of(m.objects.begin(), m.objects.end(),
                       [](const auto& o) { return o.landmark; });
  };
  if (!has_landmark(a) && !has_landmark(b)) {
    return MatchClusters(a, b, options, coverage_a, coverage_b);
  }
  // Clusters and landmarks apart.
  ObjectMap ca = a, cb = b;
  std::erase_if(ca.objects, [](const auto& o) { return o.landmark; });
  std::erase_if(cb.objects, [](const auto& o) { return o.landmark; });
  msgs::ObjectMatch clusters = MatchClusters(ca, cb, options, coverage_a, coverage_b);
  if (!options.landmarks) return clusters;
  std::vector<const msgs::Object*> la, lb;
  std::vector<msgs::Point2> pa, pb;
  for (const auto& o : a.objects) {
    if (o.landmark) la.push_back(&o), pa.push_back(o.center);
  }
  for (const auto& o : b.objects) {
    if (o.landmark) lb.push_back(&o), pb.push_back(o.center);
  }
  const auto accept = [&](const LandmarkMatchResult& m, double max_ambiguity) {
    return m.found && m.support >= options.min_landmark_support &&
           double(m.runner_up_support) < max_ambiguity * double(m.support);
  };
  LandmarkMatchResult r = MatchLandmarkPoints(pa, pb, options.landmark);
  if (!accept(r, options.max_landmark_ambiguity)) {
    if (!(options.wide_landmark_tolerance_m > 0.0)) return clusters;
    LandmarkMatchOptions wide = options.landmark;
    wide.tolerance_m = options.wide_landmark_tolerance_m;
    r = MatchLandmarkPoints(pa, pb, wide);
    if (!accept(r, options.wide_max_landmark_ambiguity)) return clusters;
  }
  if (!HeadingAllows(HeadingYawPrior(a, b), r.T_a_b.yaw_rad, options.max_heading_gap_rad))
    return clusters;
  msgs::ObjectMatch match;
  match.robot_a = a.robot_id;
  match.robot_b = b.robot_id;
  match.status = MatchStatus::kMatched;
  match.by_landmarks = true;
  match.T_a_b = r.T_a_b;
  for (const auto& [i, k] : r.pairs) {
    const msgs::Point2 p = Transform(r.T_a_b, pb[std::size_t(k)]);
    match.pairs.push_back(
        {la[std::size_t(i)]->id, lb[std::size_t(k)]->id,
         std::hypot(p.x_m - pa[std::size_t(i)].x_m, p.y_m - pa[std::size_t(i)].y_m)});
  }
  match.num_candidates = r.hypotheses;
  match.num_assignments = r.support;
  match.num_ransac_inliers = r.support;
  match.num_inliers = r.support;
  match.rmse_m = r.rmse_m;
  match.confidence = std::min(
      1.0, double(r.support) / double(std::max<std::size_t>(1, std::min(la.size(), lb.size()))));
  match.ambiguity = double(r.runner_up_support) / double(r.support);
  return match;
}

}  // namespace

std::optional<double> HeadingYawPrior(const ObjectMap& a, const ObjectMap& b) {
  if (!std::isfinite(a.map_heading_rad) || !std::isfinite(b.map_heading_rad)) return std::nullopt;
  return NormalizeAngle(b.map_heading_rad - a.map_heading_rad);
}

bool HeadingAllows(const std::optional<double>& yaw_prior_rad, double yaw_rad, double max_gap_rad) {
  if (!yaw_prior_rad || !(max_gap_rad > 0.0)) return true;
  return std::abs(NormalizeAngle(yaw_rad - *yaw_prior_rad)) <= max_gap_rad;
}

// Tracks are compared by T_a_b itself (where b's origin lands, and the yaw).
msgs::ObjectMatch MatchTracker::Update(const msgs::ObjectMatch& match) {
  if (match.status != MatchStatus::kMatched) return match;
  Track* track = nullptr;
  for (auto& t : tracks_) {
    const double dx = t.T.x_m - match.T_a_b.x_m, dy = t.T.y_m - match.T_a_b.y_m;
    if (std::sqrt(dx * dx + dy * dy) <= options_.same_m &&
        std::abs(NormalizeAngle(t.T.yaw_rad - match.T_a_b.yaw_rad)) <= options_.same_rad) {
      track = &t;
      break;
    }
  }
  if (!track) {
    tracks_.push_back({match.T_a_b, 0});
    track = &tracks_.back();
  }
  track->T = match.T_a_b;  // follow the newest answer as the maps grow
  ++track->votes;
  int others = 0;
  for (const auto& t : tracks_) {
    if (&t != track) others = std::max(others, t.votes);
  }
  msgs::ObjectMatch out = match;
  if (track->votes < options_.min_votes || track->votes < options_.dominance * others) {
    out.status = MatchStatus::kUnconfirmed;
  }
  return out;
}

}  // namespace draco::objects
