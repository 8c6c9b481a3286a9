// Maximum clique of an undirected graph: exact branch and bound with greedy-colouring bounds
// over bitsets (Tomita's MCQ/MCS family, as in San Segundo's BBMC), under a node budget
// (deterministic) and optionally a time budget, after either of which a greedy heuristic
// answers and the result says so. Also a naive Bron-Kerbosch (no
// pivot), the benchmark's peer.
#pragma once

#include <cstdint>
#include <vector>

namespace draco::consistency {

// Undirected graph on vertices 0..n-1, adjacency as bit rows; vertices can be appended.
class Graph {
 public:
  explicit Graph(int num_vertices = 0);
  int NumVertices() const { return n_; }
  int AddVertex();  // returns its index
  void AddEdge(int u, int v);
  bool HasEdge(int u, int v) const;
  int Degree(int v) const;
  const std::vector<std::uint64_t>& Row(int v) const { return rows_[static_cast<std::size_t>(v)]; }
  int NumWords() const { return words_; }

 private:
  int n_ = 0;
  int words_ = 0;
  std::vector<std::vector<std::uint64_t>> rows_;
};

struct CliqueOptions {
  // Wall-clock budget; <= 0: none (the default: a budget on the clock makes the answer
  // depend on machine load).
  double time_budget_ms = 0.0;
  // Only cliques strictly larger than this are searched for (an empty result means none).
  int lower_bound = 0;
  // Branch-and-bound nodes after which the search stops; <= 0: none.
  std::int64_t max_nodes = 0;
};

struct CliqueResult {
  std::vector<int> vertices;  // ascending
  bool exact = true;          // false: a budget ran out, a heuristic answered
  std::int64_t nodes = 0;     // branch-and-bound nodes visited
};

// Maximum clique of the whole graph.
CliqueResult MaximumClique(const Graph& graph, const CliqueOptions& options = {});

// Maximum clique within `candidates` (vertex indices, any order) whose members are all
// adjacent to every vertex of `required` (not checked: the caller passes a valid set).
// The returned vertices are the required ones plus the found ones; options.lower_bound
// counts both.
CliqueResult MaximumCliqueWithin(const Graph& graph, const std::vector<int>& required,
                                 const std::vector<int>& candidates,
                                 const CliqueOptions& options = {});

// Greedy: from each vertex, repeatedly add the candidate with the most candidate neighbours.
std::vector<int> GreedyClique(const Graph& graph, const std::vector<int>& candidates);

// Reference peer: Bron-Kerbosch without pivoting (exponential; small graphs only).
std::vector<int> MaximumCliqueBronKerboschNaive(const Graph& graph);

}  // namespace draco::consistency
