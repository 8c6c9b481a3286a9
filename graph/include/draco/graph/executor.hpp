// Executors run a validated Graph. Both call the same components through the same
// contract; they differ in scheduling:
//  - deterministic: pending messages merged by (stamp, producer id, sequence); a virtual
//    clock; as fast as possible or paced at N x real time. Identical inputs give identical
//    outputs. With island_threads >= 1 the graph runs as parts on up to that many threads
//    (islands.cpp): islands (node sets no edge leaves) that exchange data only through
//    components declaring a Component::CrossIslandDelay(), each such island split into the
//    nodes those components reach and the rest; the outputs do not depend on the number of
//    threads.
//  - threaded: a thread pool; each component serialized (never runs concurrently with
//    itself); bounded input queues with their declared drop policy and drop counters.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "draco/graph/graph.hpp"

namespace draco::graph {

struct InputStats {
  std::string name;
  std::uint64_t received = 0;
  std::uint64_t dropped = 0;
};

struct ComponentStats {
  std::string id;
  std::string type;
  std::uint64_t calls = 0;
  std::uint64_t errors = 0;
  double mean_ms = 0.0;
  double p99_ms = 0.0;
  double max_ms = 0.0;
  double total_ms = 0.0;
  std::vector<InputStats> inputs;
  std::uint64_t dropped() const;
};

struct RunStats {
  std::string executor;
  double wall_s = 0.0;
  double mission_s = 0.0;                  // mission time of the last event
  std::vector<ComponentStats> components;  // graph order (by id)
  std::string ToTable() const;
  std::string ToJson() const;
};

// What RunOptions::progress is told.
struct RunProgress {
  Time mission_time;       // reached
  Time end = Time::Max();  // the run's expected end; Time::Max() when unknown (ExpectedEnd)
};

struct RunOptions {
  double rate = 0.0;  // 0: as fast as possible; N: N x real time (overrides the graph's)
  bool use_graph_rate = true;
  int threads = 0;  // 0: the graph's setting
  // Deterministic executor: 0, one engine for the whole graph; N >= 1, the graph's parts on
  // up to N threads, when it has two or more, the run is as fast as possible (rate 0) and
  // `until` is finite (otherwise one engine).
  int island_threads = 0;
  std::string output_dir;
  Time until = Time::Max();                           // stop after this mission time
  const std::atomic<bool>* stop_requested = nullptr;  // e.g. set by a SIGINT handler
  bool log_errors = true;
  // Called by either executor (from one thread) about every progress_period_s of wall time
  // with the mission time reached and the expected end (for progress displays, e.g.
  // ProgressPrinter; it cannot change the run).
  std::function<void(const RunProgress&)> progress;
  double progress_period_s = 0.5;
};

// The run's expected end: `until` when the sources' recordings end later or do not say;
// else the latest end the sources know (Component::SourceEndTime(), asked after Start());
// Time::Max() when neither is known.
Time ExpectedEnd(const Graph& graph, const RunOptions& options);

struct RunResult {
  bool ok = true;
  bool interrupted = false;
  std::string error;  // first fatal error, "component_id: message"
  RunStats stats;
};

RunResult RunDeterministic(Graph& graph, const RunOptions& options = {});
RunResult RunThreaded(Graph& graph, const RunOptions& options = {});
// Runs with the executor the graph names (settings.executor).
RunResult Run(Graph& graph, const RunOptions& options = {});

// Writes text to path atomically (temporary file + rename): an interrupted write never
// leaves a file that looks whole. Throws std::runtime_error naming the path and the reason.
void WriteFileAtomicallyOrThrow(const std::string& path, const std::string& text);
// Same, reporting failure as false (a Stop() turns it into a Fatal status).
[[nodiscard]] bool WriteFileAtomically(const std::string& path, const std::string& text);

}  // namespace draco::graph
