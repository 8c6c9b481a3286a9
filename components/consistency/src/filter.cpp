#include "draco/consistency/filter.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace draco::consistency {

const char* MethodName(Method method) { return method == Method::kPcm ? "PCM" : "GCM"; }

ConsistencyFilter::ConsistencyFilter(const FilterOptions& options) : options_(options) {}

int ConsistencyFilter::Span(const Group& group, const std::vector<int>& clique) const {
  if (clique.empty()) return 0;
  int lo = 0;
  int hi = 0;
  bool first = true;
  for (const int v : clique) {
    const int k = loops_[static_cast<std::size_t>(group.members[static_cast<std::size_t>(v)])]
                      .loop.own_keyframe;
    lo = first ? k : std::min(lo, k);
    hi = first ? k : std::max(hi, k);
    first = false;
  }
  return hi - lo;
}

Decision ConsistencyFilter::Add(const std::vector<msgs::InterRobotLoop>& loops,
                                const PoseSource& poses) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto remaining_ms = [&]() {
    if (options_.time_budget_ms <= 0.0) return 0.0;
    const double used = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    return std::max(1e-6, options_.time_budget_ms - used);
  };
  std::int64_t nodes_used = 0;
  auto clique_options = [&](int lower_bound) {
    CliqueOptions co;
    co.time_budget_ms = remaining_ms();
    co.lower_bound = lower_bound;
    if (options_.max_clique_nodes > 0) {
      co.max_nodes = std::max<std::int64_t>(1, options_.max_clique_nodes - nodes_used);
    }
    return co;
  };
  // Incremental searches: around the group's current clique (options_.clique_kernel).
  const auto search = [&](const Group& group, const std::vector<int>& required,
                          const std::vector<int>& candidates, const CliqueOptions& co) {
    return options_.clique_kernel
               ? MaximumCliqueWithinKernel(group.graph, required, candidates, group.clique, co)
               : MaximumCliqueWithin(group.graph, required, candidates, co);
  };
  Decision decision;
  const bool reference = options_.queue == QueueMode::kReference;

  // 1. Prepare the new candidates, place them in their groups and test them against the
  // held ones.
  for (const msgs::InterRobotLoop& loop : loops) {
    if (!loops_.empty() && loop.own_robot != loops_.front().loop.own_robot) {
      throw std::invalid_argument("ConsistencyFilter: loops of different own robots");
    }
  }
  const std::size_t first_index = loops_.size();
  const bool gate = options_.map_prior_gate && options_.method == Method::kGcm;
  for (const msgs::InterRobotLoop& loop : loops) {
    loops_.push_back(Prepare(loop, poses));
    accepted_.push_back(false);
    bool gated = false;
    if (gate) {
      const PairwiseResult r = TestMapPrior(loops_.back(), poses, options_.pairwise);
      gated = r.evaluated && !r.consistent;
    }
    gated_.push_back(gated);
  }
  const bool fast =
      options_.fast_pair_tests && !loops.empty() && tester_.Reset(loops_, poses, options_.pairwise);
  std::map<int, int> first_new;  // group -> first new local index
  std::vector<int> against;      // local indices
  for (std::size_t index = first_index; index < loops_.size(); ++index) {
    const msgs::InterRobotLoop& loop = loops_[index].loop;
    const int key = options_.method == Method::kPcm ? loop.teammate_robot : -1;
    Group& group = groups_[key];
    const int local = group.graph.AddVertex();
    group.members.push_back(static_cast<int>(index));
    first_new.emplace(key, local);
    against.clear();
    if (reference) {
      against = group.queue;
    } else {
      for (int u = 0; u < local; ++u) against.push_back(u);
    }
    if (gated_[index]) against.clear();
    for (const int u : against) {
      const int held = group.members[static_cast<std::size_t>(u)];
      if (gated_[static_cast<std::size_t>(held)]) continue;
      ++decision.pair_tests;
      const bool consistent = fast ? tester_.Consistent(held, static_cast<int>(index))
                                   : TestPair(loops_[static_cast<std::size_t>(held)], loops_[index],
                                              poses, options_.pairwise)
                                         .consistent;
      if (consistent) group.graph.AddEdge(u, local);
    }
    if (reference) group.queue.push_back(local);
  }

  // 2. Update each touched group's clique.
  const std::vector<bool> before = accepted_;
  for (const auto& [key, first] : first_new) {
    Group& group = groups_[key];
    const int n = group.graph.NumVertices();
    if (reference) {
      const CliqueResult r = MaximumCliqueWithin(group.graph, {}, group.queue, clique_options(0));
      nodes_used += r.nodes;
      decision.exact = decision.exact && r.exact;
      decision.clique_nodes += r.nodes;
      if (static_cast<int>(r.vertices.size()) >= options_.min_clique_size &&
          Span(group, r.vertices) >= options_.min_clique_span_keyframes) {
        for (const int v : r.vertices) {
          accepted_[static_cast<std::size_t>(group.members[static_cast<std::size_t>(v)])] = true;
        }
        const int keep =
            std::min(options_.reference_queue_keep, static_cast<int>(group.queue.size()));
        group.queue.erase(group.queue.begin(), group.queue.end() - keep);
      }
      continue;
    }
    const int current = static_cast<int>(group.clique.size());
    if (n - first >= first) {
      // Mostly new: one search over the whole group, for a clique beating the current one.
      std::vector<int> all(static_cast<std::size_t>(n));
      for (int u = 0; u < n; ++u) all[static_cast<std::size_t>(u)] = u;
      const CliqueResult r = search(group, {}, all, clique_options(current));
      nodes_used += r.nodes;
      decision.exact = decision.exact && r.exact;
      decision.clique_nodes += r.nodes;
      if (!r.vertices.empty()) group.clique = r.vertices;
    } else {
      // A better clique holds a new vertex; with v its first new member, the others are
      // neighbours of v among the old vertices and the new ones after v.
      for (int v = first; v < n; ++v) {
        std::vector<int> candidates;
        for (int u = 0; u < n; ++u) {
          if ((u < first || u > v) && group.graph.HasEdge(u, v)) candidates.push_back(u);
        }
        if (static_cast<int>(candidates.size()) + 1 <= static_cast<int>(group.clique.size())) {
          continue;
        }
        const CliqueResult r =
            search(group, {v}, candidates, clique_options(static_cast<int>(group.clique.size())));
        nodes_used += r.nodes;
        decision.exact = decision.exact && r.exact;
        decision.clique_nodes += r.nodes;
        if (!r.vertices.empty()) group.clique = r.vertices;
      }
    }
    // Incremental acceptance is the current clique (when large enough), per group.
    for (const int m : group.members) accepted_[static_cast<std::size_t>(m)] = false;
    if (static_cast<int>(group.clique.size()) >= options_.min_clique_size &&
        Span(group) >= options_.min_clique_span_keyframes) {
      for (const int v : group.clique) {
        accepted_[static_cast<std::size_t>(group.members[static_cast<std::size_t>(v)])] = true;
      }
    }
  }

  for (std::size_t i = 0; i < loops_.size(); ++i) {
    decision.prior_gated += gated_[i] ? 1 : 0;
    const std::uint64_t id = loops_[i].loop.id;
    const bool was = i < before.size() && before[i];
    if (accepted_[i]) {
      decision.accepted.push_back(id);
    } else {
      decision.rejected.push_back(id);
    }
    if (accepted_[i] && !was) decision.newly_accepted.push_back(id);
    if (!accepted_[i] && was) decision.retracted.push_back(id);
  }
  for (auto* v :
       {&decision.accepted, &decision.newly_accepted, &decision.rejected, &decision.retracted}) {
    std::sort(v->begin(), v->end());
  }
  return decision;
}

}  // namespace draco::consistency
