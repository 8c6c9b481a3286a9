// The single-threaded, virtual-clock engine behind RunDeterministic() and the test harness.
// Internal to graph/.
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <queue>
#include <string>
#include <vector>

#include "draco/graph/executor.hpp"
#include "stats_recorder.hpp"

namespace draco::graph::internal {

class DeterministicEngine {
 public:
  // Runs every node of the graph.
  DeterministicEngine(Graph& graph, const RunOptions& options);
  // A message for subscribers another engine runs: (engine, producer, output, phase,
  // envelope). Called from this engine's thread.
  using Forward = std::function<void(int engine, std::uint32_t producer, std::size_t output,
                                     int phase, const Envelope& envelope)>;
  // Runs only `nodes`, recording into `recorder`, which other engines may share (each node's
  // entry is touched only by its own engine). engine_of[node] names the engine running each
  // node (empty: all are this one's); messages for another engine's nodes go to `forward`
  // and must not be stamped before the event that publishes them.
  DeterministicEngine(Graph& graph, const RunOptions& options, std::vector<std::uint32_t> nodes,
                      StatsRecorder* recorder, std::vector<int> engine_of = {}, int self = 0,
                      Forward forward = nullptr);
  // A message another engine forwarded (see Forward), queued as its own engine would.
  void Receive(std::uint32_t producer, std::size_t output, int phase, const Envelope& envelope);
  ~DeterministicEngine();
  DeterministicEngine(const DeterministicEngine&) = delete;
  DeterministicEngine& operator=(const DeterministicEngine&) = delete;

  // Calls Start() on every component in id order. False on a fatal error.
  bool StartAll();
  // Queues a message on one input as if an external producer had published it.
  void Inject(std::uint32_t node, std::size_t input, Time stamp,
              std::shared_ptr<const void> payload);
  // Processes events (timers fire only up to `limit`). Returns when idle, stopped or failed.
  void RunUntil(Time limit);
  // Calls Stop() on every component in id order and delivers what they publish.
  void StopAll();

  // Records every published envelope per (node, output) for the harness.
  void EnableTaps() { taps_enabled_ = true; }
  const std::vector<Envelope>& Tapped(std::uint32_t node, std::size_t output) const;

  // Stamp of the next event or timer; Time::Max() when none is left.
  Time NextEventTime() const;

  bool failed() const { return !error_.empty(); }
  bool interrupted() const { return interrupted_; }
  const std::string& error() const { return error_; }
  Time now() const { return now_; }
  RunStats Stats(double wall_s) const {
    return recorder_->Collect(graph_, "deterministic", wall_s, now_);
  }

 private:
  enum class Kind { kMessage, kSource };
  struct Event {
    Time stamp;
    int phase = 0;  // 0: normal delivery, 1: delayed inputs (after all normal ones at a stamp)
    std::uint32_t producer = 0;
    std::uint64_t seq = 0;
    std::uint64_t order = 0;  // insertion counter: final tie-breaker
    Kind kind = Kind::kMessage;
    std::size_t output = 0;
    Envelope envelope;
    // Injected messages name their single target input.
    bool injected = false;
    std::uint32_t target_node = 0;
    std::size_t target_input = 0;
  };
  struct Later {
    bool operator()(const Event& a, const Event& b) const {
      return std::tie(a.stamp.ns, a.phase, a.producer, a.seq, a.order) >
             std::tie(b.stamp.ns, b.phase, b.producer, b.seq, b.order);
    }
  };
  struct TimerState {
    std::uint32_t node;
    std::size_t timer;
    Time next;
  };

  void Emit(std::uint32_t producer, OutputPort& port, Time stamp,
            std::shared_ptr<const void> payload);
  void ScheduleSource(std::uint32_t node);
  void Dispatch(Event& event);
  bool FireNextTimerUpTo(Time t);  // the earliest timer due at or before t; false: none
  void Call(std::uint32_t node, Reason reason, const std::string& timer);
  void Pace(Time stamp);
  bool StopRequested();

  Graph& graph_;
  RunOptions options_;
  std::vector<std::uint32_t> nodes_;  // the nodes this engine runs, ascending
  std::vector<int> engine_of_;        // per node; empty: every node is this engine's
  int self_ = 0;
  Forward forward_;
  bool Mine(std::uint32_t node) const { return engine_of_.empty() || engine_of_[node] == self_; }
  double rate_ = 0.0;
  Time now_{};
  std::vector<Time> node_now_;
  std::vector<std::uint64_t> next_seq_;
  std::vector<std::shared_ptr<const std::string>> producer_ids_;
  std::priority_queue<Event, std::vector<Event>, Later> queue_;
  std::uint64_t order_ = 0;
  std::vector<TimerState> timers_;
  std::vector<bool> source_pending_;
  StatsRecorder own_recorder_;
  StatsRecorder* recorder_;
  std::string error_;
  bool interrupted_ = false;
  bool taps_enabled_ = false;
  std::map<std::pair<std::uint32_t, std::size_t>, std::vector<Envelope>> taps_;
  std::string output_dir_;
  bool paced_started_ = false;
  Time pace_origin_{};
  std::chrono::steady_clock::time_point wall_origin_;
};

}  // namespace draco::graph::internal
