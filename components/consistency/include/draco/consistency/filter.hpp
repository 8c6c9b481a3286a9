// Incremental consistency filter for inter-robot loop closures: PCM (per teammate, in that
// teammate's frame) or GCM (all teammates together in the own map frame), each a maximum
// clique of the pairwise-consistency graph that must reach a minimum size.
//
// Incremental mode (default): each new candidate is tested against the candidates already
// held (and the other new ones), and the maximum clique is updated by searching only for
// cliques that contain a new candidate and beat the current one, which gives the batch
// answer without re-solving. A tie keeps the current clique. Pair results are cached: pose
// estimates are those of the step in which the later loop arrived.
// Reference mode: as DRACo's code, the maximum clique over a queue of candidates is solved
// every step, accepted loops are never withdrawn, and the queue is cut to its last
// `reference_queue_keep` entries after each success.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include "draco/consistency/max_clique.hpp"
#include "draco/consistency/pairwise.hpp"
#include "draco/msgs/loops.hpp"

namespace draco::consistency {

enum class Method { kPcm, kGcm };
enum class QueueMode { kIncremental, kReference };
const char* MethodName(Method method);

struct FilterOptions {
  Method method = Method::kGcm;
  PairwiseOptions pairwise;  // covariance model and chi-square threshold
  int min_clique_size = 5;   // the reference's minimum
  // Clique search budget per Add(), in branch-and-bound nodes (deterministic); <= 0: none.
  // Mission-sized problems (1,000 candidates, 90 % outliers) need well under 10^5.
  std::int64_t max_clique_nodes = 2'000'000;
  // Wall-clock budget per Add(); <= 0 (default): none. Makes decisions depend on load.
  double time_budget_ms = 0.0;
  QueueMode queue = QueueMode::kIncremental;
  int reference_queue_keep = 5;
  // A clique is accepted only when its own keyframes span at least this many keyframes:
  // loops from one short stretch of the own trajectory (a correlated group, e.g. one
  // registration ambiguity repeated over consecutive keyframes) are not independent support.
  // 0: off.
  int min_clique_span_keyframes = 0;
  // GCM: a loop that disagrees with the map-to-map guess (TestMapPrior, same chi-square
  // threshold) gets no edge; loops whose map transform is unknown are not gated. PCM
  // ignores it (the reference's PCM has no prior).
  bool map_prior_gate = true;
  // PairTester when the PoseSource has open chains (same decisions, ~10x cheaper pair
  // tests); false: TestPair for every pair, the straightforward path.
  bool fast_pair_tests = true;
  // Incremental mode: clique searches on the kernel left by MaximumCliqueWithinKernel around
  // the current clique (the same sizes, ~the outliers' work instead of the whole group's);
  // false: MaximumCliqueWithin over every candidate.
  bool clique_kernel = true;
};

// Loop ids (msgs::InterRobotLoop::id), ascending.
struct Decision {
  std::vector<std::uint64_t> accepted;        // the current consistent set
  std::vector<std::uint64_t> newly_accepted;  // accepted now, not after the previous step
  std::vector<std::uint64_t> rejected;        // every candidate held and not accepted
  std::vector<std::uint64_t> retracted;       // accepted after the previous step, not now
  bool exact = true;  // false: a clique search ran out of budget and a heuristic answered
  std::int64_t pair_tests = 0;
  std::int64_t prior_gated = 0;  // candidates held that failed the map-prior test
  std::int64_t clique_nodes = 0;
};

class ConsistencyFilter {
 public:
  explicit ConsistencyFilter(const FilterOptions& options = {});
  // Adds candidates (all of one own robot) and decides. `poses` is read during the call.
  Decision Add(const std::vector<msgs::InterRobotLoop>& loops, const PoseSource& poses);
  const FilterOptions& options() const { return options_; }
  int NumCandidates() const { return static_cast<int>(loops_.size()); }

 private:
  struct Group {
    std::vector<int> members;  // indices into loops_, local index = position
    Graph graph;
    std::vector<int> clique;  // local indices, the current maximum clique
    std::vector<int> queue;   // reference mode: local indices still queued
  };

  // Own keyframe span (max - min) of a clique (local indices; default: the group's clique).
  int Span(const Group& group, const std::vector<int>& clique) const;
  int Span(const Group& group) const { return Span(group, group.clique); }

  FilterOptions options_;
  std::vector<PreparedLoop> loops_;  // prepared with the poses of their arrival step
  PairTester tester_;
  std::vector<bool> accepted_;
  std::vector<bool> gated_;      // failed the map-prior test at arrival
  std::map<int, Group> groups_;  // teammate (PCM) or -1 (GCM)
};

}  // namespace draco::consistency
