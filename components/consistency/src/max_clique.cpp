#include "draco/consistency/max_clique.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <deque>
#include <numeric>
#include <utility>

namespace draco::consistency {
namespace {

using Bits = std::vector<std::uint64_t>;
using Clock = std::chrono::steady_clock;

bool Any(const Bits& b) {
  return std::any_of(b.begin(), b.end(), [](std::uint64_t w) { return w != 0; });
}
void Set(Bits& b, int i) { b[static_cast<std::size_t>(i >> 6)] |= 1ull << (i & 63); }
void Clear(Bits& b, int i) { b[static_cast<std::size_t>(i >> 6)] &= ~(1ull << (i & 63)); }
bool Test(const Bits& b, int i) {
  return ((b[static_cast<std::size_t>(i >> 6)] >> (i & 63)) & 1u) != 0;
}
int Lowest(const Bits& b) {
  for (std::size_t w = 0; w < b.size(); ++w) {
    if (b[w] != 0) return static_cast<int>(w * 64) + std::countr_zero(b[w]);
  }
  return -1;
}
int Count(const Bits& b) {
  int c = 0;
  for (const std::uint64_t w : b) c += std::popcount(w);
  return c;
}

// Branch and bound on a compact local graph (vertices renumbered by decreasing degree so the
// greedy colouring gives tight bounds). Each depth has its own buffers: no allocation per
// node once the search has been as deep.
class Solver {
 public:
  Solver(std::vector<Bits> adjacency, int best_size, Clock::time_point deadline, bool budgeted,
         std::int64_t max_nodes)
      : adj_(std::move(adjacency)),
        words_(adj_.empty() ? 0 : static_cast<int>(adj_.front().size())),
        best_size_(best_size),
        deadline_(deadline),
        budgeted_(budgeted),
        max_nodes_(max_nodes) {}

  void Run() {
    Level& root = LevelAt(0);
    for (int v = 0; v < static_cast<int>(adj_.size()); ++v) Set(root.p, v);
    if (Any(root.p)) Expand(0);
  }
  const std::vector<int>& best() const { return best_; }
  bool aborted() const { return aborted_; }
  std::int64_t nodes() const { return nodes_; }

 private:
  struct Level {
    Bits p, q, u;  // the candidates; the colouring's scratch sets
    std::vector<int> order, colour;
  };

  Level& LevelAt(std::size_t depth) {
    while (levels_.size() <= depth) {
      Level l;
      l.p.assign(static_cast<std::size_t>(words_), 0);
      l.q = l.u = l.p;
      levels_.push_back(std::move(l));
    }
    return levels_[depth];
  }

  // Expands levels_[depth].p (with current_ the clique so far).
  void Expand(std::size_t depth) {
    ++nodes_;
    if (max_nodes_ > 0 && nodes_ > max_nodes_) aborted_ = true;
    if (budgeted_ && (nodes_ & 255) == 0 && Clock::now() > deadline_) aborted_ = true;
    if (aborted_) return;
    Level& level = levels_[depth];
    Level& child = LevelAt(depth + 1);
    Bits& p = level.p;
    // Greedy sequential colouring of P: vertices in colour order with their colour.
    level.order.clear();
    level.colour.clear();
    Bits& q = level.q;
    Bits& u = level.u;
    q = p;
    int k = 0;
    while (Any(q)) {
      ++k;
      u = q;
      for (int v = Lowest(u); v >= 0; v = Lowest(u)) {
        Clear(u, v);
        Clear(q, v);
        for (int w = 0; w < words_; ++w) u[static_cast<std::size_t>(w)] &= ~adj_[v][w];
        level.order.push_back(v);
        level.colour.push_back(k);
      }
    }
    for (int i = static_cast<int>(level.order.size()) - 1; i >= 0; --i) {
      const int size = static_cast<int>(current_.size());
      if (size + level.colour[static_cast<std::size_t>(i)] <= best_size_) return;
      const int v = level.order[static_cast<std::size_t>(i)];
      Bits& next = child.p;
      for (int w = 0; w < words_; ++w) {
        next[static_cast<std::size_t>(w)] = p[static_cast<std::size_t>(w)] & adj_[v][w];
      }
      current_.push_back(v);
      if (!Any(next)) {
        if (size + 1 > best_size_) {
          best_size_ = size + 1;
          best_ = current_;
        }
      } else {
        Expand(depth + 1);
      }
      current_.pop_back();
      Clear(p, v);
      if (aborted_) return;
    }
  }

  std::vector<Bits> adj_;
  int words_;
  int best_size_;
  Clock::time_point deadline_;
  bool budgeted_;
  std::int64_t max_nodes_;
  std::deque<Level> levels_;  // references stay valid as it grows
  std::vector<int> current_;
  std::vector<int> best_;
  bool aborted_ = false;
  std::int64_t nodes_ = 0;
};

}  // namespace

Graph::Graph(int num_vertices) {
  for (int i = 0; i < num_vertices; ++i) AddVertex();
}

int Graph::AddVertex() {
  const int v = n_++;
  if (n_ > words_ * 64) {
    ++words_;
    for (auto& row : rows_) row.push_back(0);
  }
  rows_.emplace_back(static_cast<std::size_t>(words_), 0);
  return v;
}

void Graph::AddEdge(int u, int v) {
  if (u == v) return;
  Set(rows_[static_cast<std::size_t>(u)], v);
  Set(rows_[static_cast<std::size_t>(v)], u);
}

bool Graph::HasEdge(int u, int v) const { return Test(rows_[static_cast<std::size_t>(u)], v); }

int Graph::Degree(int v) const { return Count(rows_[static_cast<std::size_t>(v)]); }

std::vector<int> GreedyClique(const Graph& graph, const std::vector<int>& candidates) {
  const std::size_t words = static_cast<std::size_t>(graph.NumWords());
  Bits cand(words, 0);
  for (const int v : candidates) Set(cand, v);
  auto degree_in = [&](int v, const Bits& set) {
    int c = 0;
    for (std::size_t w = 0; w < words; ++w) c += std::popcount(graph.Row(v)[w] & set[w]);
    return c;
  };
  // Starts by decreasing degree among the candidates (ties by index), each degree counted once.
  std::vector<std::pair<int, int>> by_degree;  // (-degree, vertex)
  by_degree.reserve(candidates.size());
  for (const int v : candidates) by_degree.emplace_back(-degree_in(v, cand), v);
  std::sort(by_degree.begin(), by_degree.end());
  std::vector<int> starts;
  starts.reserve(by_degree.size());
  for (const auto& entry : by_degree) starts.push_back(entry.second);
  constexpr std::size_t kMaxStarts = 16;
  if (starts.size() > kMaxStarts) starts.resize(kMaxStarts);
  std::vector<int> best;
  for (const int s : starts) {
    std::vector<int> clique{s};
    Bits p(words);
    for (std::size_t w = 0; w < words; ++w) p[w] = cand[w] & graph.Row(s)[w];
    while (Any(p)) {
      int pick = -1;
      int pick_degree = -1;
      for (std::size_t w = 0; w < words; ++w) {
        for (std::uint64_t bits = p[w]; bits != 0; bits &= bits - 1) {
          const int v = static_cast<int>(w * 64) + std::countr_zero(bits);
          const int d = degree_in(v, p);
          if (d > pick_degree) {
            pick_degree = d;
            pick = v;
          }
        }
      }
      clique.push_back(pick);
      for (std::size_t w = 0; w < words; ++w) p[w] &= graph.Row(pick)[w];
    }
    if (clique.size() > best.size()) best = clique;
  }
  std::sort(best.begin(), best.end());
  return best;
}

namespace {

// MaximumCliqueWithin with the candidates ordered by their degree within `order_set` (a
// superset of them; decreasing, ties by index).
CliqueResult SearchWithin(const Graph& graph, const std::vector<int>& required,
                          const std::vector<int>& candidates, const Bits* order_set,
                          const CliqueOptions& options) {
  const auto start = Clock::now();
  const bool budgeted = options.time_budget_ms > 0.0;
  const auto deadline =
      start + std::chrono::duration_cast<Clock::duration>(
                  std::chrono::duration<double, std::milli>(options.time_budget_ms));
  // Local renumbering by decreasing degree inside the candidate set.
  const int m = static_cast<int>(candidates.size());
  const std::size_t gw = static_cast<std::size_t>(graph.NumWords());
  Bits cand(gw, 0);
  for (const int v : candidates) Set(cand, v);
  const Bits& within = order_set != nullptr ? *order_set : cand;
  std::vector<int> degree(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) {
    int c = 0;
    for (std::size_t w = 0; w < gw; ++w) {
      c += std::popcount(graph.Row(candidates[static_cast<std::size_t>(i)])[w] & within[w]);
    }
    degree[static_cast<std::size_t>(i)] = c;
  }
  std::vector<int> local(static_cast<std::size_t>(m));
  std::iota(local.begin(), local.end(), 0);
  std::sort(local.begin(), local.end(), [&](int a, int b) {
    const int da = degree[static_cast<std::size_t>(a)];
    const int db = degree[static_cast<std::size_t>(b)];
    return da != db
               ? da > db
               : candidates[static_cast<std::size_t>(a)] < candidates[static_cast<std::size_t>(b)];
  });
  std::vector<int> to_global(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) {
    to_global[static_cast<std::size_t>(i)] =
        candidates[static_cast<std::size_t>(local[static_cast<std::size_t>(i)])];
  }
  const std::size_t lw = static_cast<std::size_t>((m + 63) / 64);
  std::vector<Bits> adj(static_cast<std::size_t>(m), Bits(lw, 0));
  for (int i = 0; i < m; ++i) {
    const auto& row = graph.Row(to_global[static_cast<std::size_t>(i)]);
    for (int j = i + 1; j < m; ++j) {
      if (Test(row, to_global[static_cast<std::size_t>(j)])) {
        Set(adj[static_cast<std::size_t>(i)], j);
        Set(adj[static_cast<std::size_t>(j)], i);
      }
    }
  }
  const int required_size = static_cast<int>(required.size());
  Solver solver(std::move(adj), std::max(0, options.lower_bound - required_size), deadline,
                budgeted, options.max_nodes);
  solver.Run();

  CliqueResult result;
  result.nodes = solver.nodes();
  result.searched = m;
  std::vector<int> found;
  for (const int v : solver.best()) found.push_back(to_global[static_cast<std::size_t>(v)]);
  if (solver.aborted()) {
    result.exact = false;
    std::vector<int> greedy = GreedyClique(graph, candidates);
    if (greedy.size() > found.size()) found = std::move(greedy);
  }
  if (!found.empty() && required_size + static_cast<int>(found.size()) > options.lower_bound) {
    result.vertices = required;
    result.vertices.insert(result.vertices.end(), found.begin(), found.end());
    std::sort(result.vertices.begin(), result.vertices.end());
  } else if (found.empty() && required_size > options.lower_bound) {
    result.vertices = required;
    std::sort(result.vertices.begin(), result.vertices.end());
  }
  return result;
}

}  // namespace

CliqueResult MaximumCliqueWithin(const Graph& graph, const std::vector<int>& required,
                                 const std::vector<int>& candidates, const CliqueOptions& options) {
  return SearchWithin(graph, required, candidates, nullptr, options);
}

CliqueResult MaximumCliqueWithinKernel(const Graph& graph, const std::vector<int>& required,
                                       const std::vector<int>& candidates,
                                       const std::vector<int>& known,
                                       const CliqueOptions& options) {
  const std::size_t words = static_cast<std::size_t>(graph.NumWords());
  Bits in_known(words, 0);
  for (const int v : known) Set(in_known, v);
  Bits known_cand(words, 0);  // candidates in `known`
  Bits outside(words, 0);     // candidates outside `known`, still possible
  for (const int v : candidates) Set(Test(in_known, v) ? known_cand : outside, v);
  // Candidate neighbours of each outside candidate: the known ones it is adjacent to plus the
  // outside ones left.
  const int needed = options.lower_bound - static_cast<int>(required.size());
  std::vector<int> outside_list;
  for (std::size_t w = 0; w < words; ++w) {
    for (std::uint64_t b = outside[w]; b != 0; b &= b - 1) {
      outside_list.push_back(static_cast<int>(w * 64) + std::countr_zero(b));
    }
  }
  std::vector<int> known_neighbours(outside_list.size());
  std::vector<int> outside_neighbours(outside_list.size());
  std::vector<int> position(outside_list.size());
  for (std::size_t i = 0; i < outside_list.size(); ++i) {
    const auto& row = graph.Row(outside_list[i]);
    int k = 0;
    int o = 0;
    for (std::size_t w = 0; w < words; ++w) {
      k += std::popcount(known_cand[w] & row[w]);
      o += std::popcount(outside[w] & row[w]);
    }
    known_neighbours[i] = k;
    outside_neighbours[i] = o;
  }
  // Drop outside candidates that cannot reach `needed` neighbours; each drop lowers its
  // outside neighbours' counts.
  std::vector<std::size_t> drop;
  std::vector<bool> dropped(outside_list.size(), false);
  auto index_of = [&](int v) {
    return static_cast<std::size_t>(std::lower_bound(outside_list.begin(), outside_list.end(), v) -
                                    outside_list.begin());
  };
  for (std::size_t i = 0; i < outside_list.size(); ++i) {
    if (known_neighbours[i] + outside_neighbours[i] < needed) {
      dropped[i] = true;
      drop.push_back(i);
    }
  }
  while (!drop.empty()) {
    const std::size_t i = drop.back();
    drop.pop_back();
    Clear(outside, outside_list[i]);
    const auto& row = graph.Row(outside_list[i]);
    for (std::size_t w = 0; w < words; ++w) {
      for (std::uint64_t b = outside[w] & row[w]; b != 0; b &= b - 1) {
        const std::size_t j = index_of(static_cast<int>(w * 64) + std::countr_zero(b));
        if (!dropped[j] && known_neighbours[j] + --outside_neighbours[j] < needed) {
          dropped[j] = true;
          drop.push_back(j);
        }
      }
    }
  }
  // Known candidates some outside candidate left is not adjacent to stay in the search.
  Bits searched = outside;
  for (std::size_t i = 0; i < outside_list.size(); ++i) {
    if (dropped[i]) continue;
    const auto& row = graph.Row(outside_list[i]);
    for (std::size_t w = 0; w < words; ++w) searched[w] |= known_cand[w] & ~row[w];
  }
  std::vector<int> all_required = required;
  std::vector<int> kernel;
  for (std::size_t w = 0; w < words; ++w) {
    for (std::uint64_t b = known_cand[w] & ~searched[w]; b != 0; b &= b - 1) {
      all_required.push_back(static_cast<int>(w * 64) + std::countr_zero(b));
    }
    for (std::uint64_t b = searched[w]; b != 0; b &= b - 1) {
      kernel.push_back(static_cast<int>(w * 64) + std::countr_zero(b));
    }
  }
  Bits all_candidates(words, 0);
  for (const int v : candidates) Set(all_candidates, v);
  return SearchWithin(graph, all_required, kernel, &all_candidates, options);
}

CliqueResult MaximumClique(const Graph& graph, const CliqueOptions& options) {
  std::vector<int> all(static_cast<std::size_t>(graph.NumVertices()));
  std::iota(all.begin(), all.end(), 0);
  return MaximumCliqueWithin(graph, {}, all, options);
}

namespace {

void BronKerbosch(const Graph& graph, std::vector<int>& r, Bits p, Bits x, std::vector<int>& best) {
  if (!Any(p)) {
    if (!Any(x) && r.size() > best.size()) best = r;
    return;
  }
  const std::size_t words = p.size();
  for (int v = Lowest(p); v >= 0; v = Lowest(p)) {
    Bits np(words);
    Bits nx(words);
    for (std::size_t w = 0; w < words; ++w) {
      np[w] = p[w] & graph.Row(v)[w];
      nx[w] = x[w] & graph.Row(v)[w];
    }
    r.push_back(v);
    BronKerbosch(graph, r, std::move(np), std::move(nx), best);
    r.pop_back();
    Clear(p, v);
    Set(x, v);
  }
}

}  // namespace

std::vector<int> MaximumCliqueBronKerboschNaive(const Graph& graph) {
  const std::size_t words = static_cast<std::size_t>(graph.NumWords());
  Bits p(words, 0);
  for (int v = 0; v < graph.NumVertices(); ++v) Set(p, v);
  std::vector<int> r;
  std::vector<int> best;
  BronKerbosch(graph, r, p, Bits(words, 0), best);
  std::sort(best.begin(), best.end());
  return best;
}

}  // namespace draco::consistency
