// Spectral relaxation of the object-graph matching QAP (graph_matcher.hpp): the sparse
// affinity matrix of candidate pairs, its principal eigenvector by power iteration (of the
// whole matrix, or per connected component), and the assignment weights (sparse, or the dense
// reference).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "draco/objects/graph_matcher.hpp"
#include "graph_matcher_internal.hpp"

namespace draco::objects {
namespace {

using detail::Distance;
using detail::Shape;
using msgs::ObjectMap;

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

std::vector<AffinityComponent> AffinityComponents(const SparseAffinity& affinity,
                                                  const MatcherOptions& options) {
  // Union-find over the entries; a component is named by its lowest candidate.
  const std::size_t n = affinity.candidates.size();
  std::vector<int> root(n);
  std::iota(root.begin(), root.end(), 0);
  const auto find = [&](int v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  std::vector<char> linked(n, 0);
  for (const auto& e : affinity.entries) {
    linked[e.r] = linked[e.c] = 1;
    const int x = find(int(e.r)), y = find(int(e.c));
    if (x != y) root[std::max(x, y)] = std::min(x, y);
  }
  std::vector<int> component_of(n, -1), local(n, -1);
  std::vector<AffinityComponent> out;
  for (std::size_t v = 0; v < n; ++v) {
    if (!linked[v]) continue;
    const int r = find(int(v));
    if (component_of[r] < 0) {
      component_of[r] = static_cast<int>(out.size());
      out.emplace_back();
    }
    AffinityComponent& c = out[component_of[r]];
    local[v] = static_cast<int>(c.members.size());
    c.members.push_back(static_cast<int>(v));
  }
  std::vector<std::vector<SparseAffinity::Entry>> entries(out.size());
  for (const auto& e : affinity.entries) {
    entries[component_of[find(int(e.r))]].push_back({static_cast<std::uint32_t>(local[e.r]),
                                                     static_cast<std::uint32_t>(local[e.c]), e.v_rc,
                                                     e.v_cr});
  }
  for (std::size_t k = 0; k < out.size(); ++k) {
    AffinityComponent& c = out[k];
    const std::size_t m = c.members.size();
    const auto mat_vec = [&](const std::vector<double>& x, std::vector<double>* y) {
      std::fill(y->begin(), y->end(), 0.0);
      for (const auto& e : entries[k]) {
        (*y)[e.r] += double(e.v_rc) * x[e.c];
        (*y)[e.c] += double(e.v_cr) * x[e.r];
      }
    };
    // Shifted by half the Rayleigh quotient: y = (M + rho/2 I) x keeps the iteration from
    // swinging on a bipartite component (where -lambda is an eigenvalue too).
    int it = 0;
    std::vector<double> x = PowerIteration(
        m, options,
        [&](const std::vector<double>& v, std::vector<double>* y) {
          mat_vec(v, y);
          const double rho = std::inner_product(v.begin(), v.end(), y->begin(), 0.0);
          for (std::size_t i = 0; i < m; ++i) (*y)[i] += 0.5 * rho * v[i];
        },
        &it);
    std::vector<double> y(m);
    mat_vec(x, &y);
    c.eigenvalue = std::inner_product(x.begin(), x.end(), y.begin(), 0.0);
    c.vector = std::move(x);
    c.iterations = it;
  }
  std::stable_sort(out.begin(), out.end(), [](const auto& p, const auto& q) {
    return p.eigenvalue > q.eigenvalue;  // built in order of the first member
  });
  return out;
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

std::vector<std::vector<double>> AssignmentHypotheses(const ObjectMap& a, const ObjectMap& b,
                                                      const MatcherOptions& options,
                                                      int* num_candidates, int* num_entries) {
  if (!options.spectral_components || options.dense) {
    return {AssignmentWeights(a, b, options, num_candidates, num_entries)};
  }
  const SparseAffinity affinity = BuildAffinity(a, b, options);
  if (num_candidates) *num_candidates = static_cast<int>(affinity.candidates.size());
  if (num_entries) *num_entries = static_cast<int>(affinity.entries.size());
  const std::vector<AffinityComponent> components = AffinityComponents(affinity, options);
  std::vector<std::vector<double>> out;
  if (components.empty() || !(components[0].eigenvalue > 0.0)) return out;
  const int nb = affinity.n_b;
  constexpr double kFillIn = 1e-6;  // other components only fill in what the leader leaves
  for (std::size_t h = 0; h < components.size(); ++h) {
    if (static_cast<int>(h) >= std::max(1, options.max_component_hypotheses)) break;
    const double lead = components[h].eigenvalue;
    if (h > 0 && lead < options.component_tie_ratio * components[0].eigenvalue) break;
    std::vector<double> w(std::size_t(affinity.n_a) * nb, 0.0);
    for (std::size_t c = 0; c < components.size(); ++c) {
      const double scale = c == h ? 1.0 : kFillIn * std::max(0.0, components[c].eigenvalue) / lead;
      for (std::size_t j = 0; j < components[c].members.size(); ++j) {
        const auto [i, k] = affinity.candidates[components[c].members[j]];
        w[std::size_t(i) * nb + k] = scale * components[c].vector[j];
      }
    }
    out.push_back(std::move(w));
  }
  return out;
}

}  // namespace draco::objects
