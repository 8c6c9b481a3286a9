// The deterministic executor on several threads (islands.cpp). Internal to graph/.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "draco/graph/executor.hpp"

namespace draco::graph::internal {

// The graph's islands: node sets no edge leaves, each ascending, ordered by their lowest node.
std::vector<std::vector<std::uint32_t>> Islands(const Graph& graph);

// Runs the graph one engine per part (islands.cpp) on up to options.island_threads threads,
// with the same outputs for any number of threads; nullopt when that does not apply
// (island_threads 0, a paced run, no finite `until`, fewer than two parts, a zero
// CrossIslandDelay()).
std::optional<RunResult> RunIslands(Graph& graph, const RunOptions& options);

}  // namespace draco::graph::internal
