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
  int searched = 0;           // candidates the branch and bound ran on (each node costs ~this)
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

// MaximumCliqueWithin(graph, required, candidates, options), searched on a kernel: `known` is
// any clique of the graph (the caller's current one), and a large clique of a nearly complete
// candidate set costs the search little. Exact reductions, in this order:
//  - a candidate outside `known` with fewer than lower_bound - |required| candidate
//    neighbours cannot be in a clique larger than lower_bound: it is dropped (repeatedly);
//  - a member of `known` adjacent to every candidate left is in every maximum clique that
//    holds `required` (adding it to a clique keeps it one): it joins `required`.
// The rest (the candidates outside `known` and the members they are not adjacent to) is
// searched as MaximumCliqueWithin searches, ordered by degree within all the candidates as
// there. The size found is the same; between equal-size cliques the search order is the
// same but the colouring bounds differ, so another may be returned (on the filter's graphs,
// the marina's and the tests', it never was). Cost O(outside x words) for the reductions
// plus a search over the rest, where MaximumCliqueWithin alone builds an O(candidates^2)
// adjacency and colours all candidates at every node (a clique of c vertices: ~c nodes).
CliqueResult MaximumCliqueWithinKernel(const Graph& graph, const std::vector<int>& required,
                                       const std::vector<int>& candidates,
                                       const std::vector<int>& known,
                                       const CliqueOptions& options = {});

// Greedy: from each vertex, repeatedly add the candidate with the most candidate neighbours.
std::vector<int> GreedyClique(const Graph& graph, const std::vector<int>& candidates);

// Reference peer: Bron-Kerbosch without pivoting (exponential; small graphs only).
std::vector<int> MaximumCliqueBronKerboschNaive(const Graph& graph);

}  // namespace draco::consistency
