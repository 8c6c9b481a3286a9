// Per-component timing and error counters shared by both executors. Internal to graph/.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "draco/graph/executor.hpp"

namespace draco::graph::internal {

class StatsRecorder {
 public:
  explicit StatsRecorder(std::size_t nodes) : per_node_(nodes) {}

  // Thread-safe per node: each node's entry is only touched by its own (serialized) calls.
  void Record(std::uint32_t node, double ms) {
    auto& s = per_node_[node];
    ++s.calls;
    s.total_ms += ms;
    if (ms > s.max_ms) s.max_ms = ms;
    if (s.samples.size() < kMaxSamples) s.samples.push_back(static_cast<float>(ms));
  }
  void RecordError(std::uint32_t node) { ++per_node_[node].errors; }
  RunStats Collect(const Graph& graph, const std::string& executor, double wall_s,
                   Time mission_end) const;

 private:
  static constexpr std::size_t kMaxSamples = 1 << 20;
  struct PerNode {
    std::uint64_t calls = 0;
    std::uint64_t errors = 0;
    double total_ms = 0.0;
    double max_ms = 0.0;
    std::vector<float> samples;
  };
  std::vector<PerNode> per_node_;
};

// Calls the component for `reason` with `ctx` (exceptions become errors), records the
// processing time of Process() calls, counts and logs (rate-limited) recoverable errors.
// Returns the message that must stop the run ("id: message": a fatal status, or any error
// from Start()), or "" when the run goes on. Shared by both executors.
std::string InvokeComponent(Node& node, Context& ctx, Reason reason, StatsRecorder& recorder,
                            bool log_errors);

}  // namespace draco::graph::internal
