// Threaded executor: a pool of workers runs components whose triggering inputs have data;
// each component is serialized by its own mutex and scheduled at most once at a time.
// Sources run on their own threads (a blocked source never starves the pool). Mission time
// is driven by the sources: timers fire when the graph clock (the newest source stamp, or
// wall time x rate when paced) passes them.
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

#include "draco/graph/executor.hpp"
#include "stats_recorder.hpp"

namespace draco::graph {
namespace {

class ThreadedEngine {
 public:
  ThreadedEngine(Graph& graph, const RunOptions& options)
      : graph_(graph),
        options_(options),
        states_(graph.nodes.size()),
        recorder_(graph.nodes.size()),
        output_dir_(options.output_dir) {
    rate_ = options.use_graph_rate ? graph.settings.rate : options.rate;
    threads_ = options.threads > 0 ? options.threads : graph.settings.threads;
    for (const auto& n : graph_.nodes) {
      auto& st = states_[n->index];
      st.producer_id = std::make_shared<const std::string>(n->id);
      for (std::size_t t = 0; t < n->timers.size(); ++t)
        st.timer_next.push_back(n->timers[t].period);
      for (auto& out : n->outputs) {
        const std::uint32_t producer = n->index;
        out->set_default_stamp(&st.now);
        out->set_emit(
            [this, producer](OutputPort& port, Time stamp, std::shared_ptr<const void> payload) {
              Emit(producer, port, stamp, std::move(payload));
            });
      }
    }
  }

  ~ThreadedEngine() {
    for (const auto& n : graph_.nodes) {
      for (auto& out : n->outputs) {
        out->set_emit(nullptr);
        out->set_default_stamp(nullptr);
      }
    }
  }

  RunResult Run() {
    const auto t0 = std::chrono::steady_clock::now();
    wall_origin_ = t0;
    RunResult result;
    bool started = true;
    for (const auto& n : graph_.nodes) {
      if (!Call(n->index, Reason::kStart, "")) {
        started = false;
        break;
      }
    }
    if (started) {
      // Asked before the sources run: SourceEndTime() must not race their NextSourceTime().
      const Time end = options_.progress ? ExpectedEnd(graph_, options_) : Time::Max();
      for (int i = 0; i < threads_; ++i) workers_.emplace_back([this] { WorkerLoop(); });
      std::vector<std::thread> sources;
      for (const auto& n : graph_.nodes) {
        if (n->is_source) sources.emplace_back([this, idx = n->index] { SourceLoop(idx); });
      }
      std::thread clock;
      if (rate_ > 0.0) clock = std::thread([this] { ClockLoop(); });
      std::thread progress;
      if (options_.progress) progress = std::thread([this, end] { ProgressLoop(end); });
      for (auto& s : sources) s.join();
      progress_done_ = true;
      if (progress.joinable()) progress.join();
      WaitIdle();
      sources_done_ = true;
      if (clock.joinable()) clock.join();
      WaitIdle();
      const std::string run_error = Error();
      for (std::uint32_t node : graph_.TopologicalOrder()) {
        Call(node, Reason::kStop, "");
        WaitIdle();
      }
      {
        std::lock_guard<std::mutex> lock(error_mutex_);
        if (!run_error.empty()) error_ = run_error;
      }
      {
        std::lock_guard<std::mutex> lock(pool_mutex_);
        shutting_down_ = true;
      }
      pool_cv_.notify_all();
      for (auto& w : workers_) w.join();
    }
    result.error = Error();
    result.ok = result.error.empty();
    result.interrupted = interrupted_;
    result.stats = recorder_.Collect(
        graph_, "threaded",
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
        Time{clock_ns_.load()});
    return result;
  }

 private:
  struct NodeState {
    std::mutex exec_mutex;   // held during every call into the component
    std::mutex sched_mutex;  // guards scheduled/rerun/timers/latest
    bool scheduled = false;
    bool rerun = false;
    std::deque<std::string> pending_timers;
    std::vector<Time> timer_next;
    Time latest{};  // newest stamp delivered to this node
    Time now{};     // the component's current time (read by Out::Publish)
    std::uint64_t seq = 0;
    std::shared_ptr<const std::string> producer_id;
  };

  std::string Error() {
    std::lock_guard<std::mutex> lock(error_mutex_);
    return error_;
  }
  bool Stopping() {
    if (options_.stop_requested != nullptr && options_.stop_requested->load()) {
      interrupted_ = true;
      return true;
    }
    return !Error().empty();
  }

  void Emit(std::uint32_t producer, OutputPort& port, Time stamp,
            std::shared_ptr<const void> payload) {
    // Called under the producer's exec_mutex: seq is serialized.
    Envelope env{stamp, producer, states_[producer].seq++, std::move(payload),
                 states_[producer].producer_id};
    for (const Edge* e : graph_.Subscribers(producer, port.index())) {
      InputPort& in = *graph_.nodes[e->consumer]->inputs[e->input];
      if (!in.Push(env, /*may_block=*/true)) continue;
      {
        std::lock_guard<std::mutex> lock(states_[e->consumer].sched_mutex);
        if (stamp > states_[e->consumer].latest) states_[e->consumer].latest = stamp;
      }
      if (in.options().trigger) Schedule(e->consumer);
    }
  }

  void Schedule(std::uint32_t node) {
    {
      std::lock_guard<std::mutex> lock(states_[node].sched_mutex);
      if (states_[node].scheduled) {
        states_[node].rerun = true;
        return;
      }
      states_[node].scheduled = true;
    }
    {
      std::lock_guard<std::mutex> lock(pool_mutex_);
      ++outstanding_;
      tasks_.push_back(node);
    }
    pool_cv_.notify_one();
  }

  bool HasTriggeringData(std::uint32_t node) const {
    for (const auto& in : graph_.nodes[node]->inputs) {
      if (in->options().trigger && in->size() > 0) return true;
    }
    return false;
  }

  void RunNode(std::uint32_t node) {
    auto& st = states_[node];
    for (;;) {
      for (;;) {
        std::string timer;
        {
          std::lock_guard<std::mutex> lock(st.sched_mutex);
          if (st.pending_timers.empty()) break;
          timer = st.pending_timers.front();
          st.pending_timers.pop_front();
        }
        Call(node, Reason::kTimer, timer);
      }
      if (HasTriggeringData(node)) Call(node, Reason::kInput, "");
      std::lock_guard<std::mutex> lock(st.sched_mutex);
      if (st.rerun) {
        st.rerun = false;
        continue;
      }
      st.scheduled = false;
      return;
    }
  }

  void WorkerLoop() {
    for (;;) {
      std::uint32_t node = 0;
      {
        std::unique_lock<std::mutex> lock(pool_mutex_);
        pool_cv_.wait(lock, [&] { return shutting_down_ || !tasks_.empty(); });
        if (tasks_.empty()) return;
        node = tasks_.front();
        tasks_.pop_front();
      }
      RunNode(node);
      {
        std::lock_guard<std::mutex> lock(pool_mutex_);
        --outstanding_;
      }
      idle_cv_.notify_all();
    }
  }

  void WaitIdle() {
    std::unique_lock<std::mutex> lock(pool_mutex_);
    idle_cv_.wait(lock, [&] { return outstanding_ == 0; });
  }

  void Pace(Time stamp) {
    if (rate_ <= 0.0) return;
    std::call_once(pace_once_, [&] {
      pace_origin_ = stamp;
      pace_ready_ = true;
    });
    const double wall_s = (stamp - pace_origin_).Seconds() / rate_;
    std::this_thread::sleep_until(wall_origin_ +
                                  std::chrono::duration_cast<std::chrono::nanoseconds>(
                                      std::chrono::duration<double>(wall_s)));
  }

  void AdvanceClock(Time t) {
    std::int64_t prev = clock_ns_.load();
    while (t.ns > prev && !clock_ns_.compare_exchange_weak(prev, t.ns)) {
    }
    FireTimers(Time{clock_ns_.load()});
  }

  void FireTimers(Time clock) {
    for (const auto& n : graph_.nodes) {
      if (n->timers.empty()) continue;
      auto& st = states_[n->index];
      bool any = false;
      {
        std::lock_guard<std::mutex> lock(st.sched_mutex);
        for (std::size_t t = 0; t < n->timers.size(); ++t) {
          while (st.timer_next[t] <= clock) {
            st.pending_timers.push_back(n->timers[t].name);
            st.timer_next[t] = st.timer_next[t] + n->timers[t].period;
            any = true;
          }
        }
      }
      if (any) Schedule(n->index);
    }
  }

  void SourceLoop(std::uint32_t node) {
    Component& c = *graph_.nodes[node]->component;
    while (!Stopping()) {
      std::optional<Time> next;
      {
        std::lock_guard<std::mutex> lock(states_[node].exec_mutex);
        try {
          next = c.NextSourceTime();
        } catch (const std::exception& e) {
          SetError(graph_.nodes[node]->id + ": NextSourceTime threw: " + e.what());
          return;
        }
      }
      if (!next || *next > options_.until) return;
      Pace(*next);
      {
        std::lock_guard<std::mutex> lock(states_[node].sched_mutex);
        if (*next > states_[node].latest) states_[node].latest = *next;
      }
      Call(node, Reason::kSource, "");
      AdvanceClock(*next);
    }
  }

  void ClockLoop() {
    while (!sources_done_ && !Stopping()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      if (!pace_ready_) continue;
      const double wall_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_origin_).count();
      AdvanceClock(pace_origin_ + Time::FromSeconds(wall_s * rate_));
    }
  }

  // Tells RunOptions::progress the mission clock about every progress_period_s of wall time
  // until the sources are done; `end` was asked before the sources ran.
  void ProgressLoop(Time end) {
    auto last = std::chrono::steady_clock::now();
    while (!progress_done_ && !Stopping()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      const auto now = std::chrono::steady_clock::now();
      if (std::chrono::duration<double>(now - last).count() < options_.progress_period_s) continue;
      last = now;
      // The paced mission clock runs on with the wall clock past the last event: never
      // report beyond the expected end.
      options_.progress(RunProgress{std::min(Time{clock_ns_.load()}, end), end});
    }
  }

  void SetError(const std::string& message) {
    std::lock_guard<std::mutex> lock(error_mutex_);
    if (error_.empty()) error_ = message;
  }

  // Calls into the component under its exec mutex. Returns false on a fatal error.
  bool Call(std::uint32_t node, Reason reason, const std::string& timer) {
    Node& n = *graph_.nodes[node];
    auto& st = states_[node];
    std::lock_guard<std::mutex> exec(st.exec_mutex);
    {
      std::lock_guard<std::mutex> lock(st.sched_mutex);
      st.now = reason == Reason::kTimer ? Time{clock_ns_.load()} : st.latest;
    }
    Context ctx(n.id, &st.now, &output_dir_);
    ctx.SetStopFlag(options_.stop_requested);
    ctx.SetEvent(reason, timer);
    const std::string fatal =
        internal::InvokeComponent(n, ctx, reason, recorder_, options_.log_errors);
    if (!fatal.empty()) {
      SetError(fatal);
      return false;
    }
    return true;
  }

  Graph& graph_;
  RunOptions options_;
  double rate_ = 0.0;
  int threads_ = 2;
  std::vector<NodeState> states_;
  internal::StatsRecorder recorder_;
  std::string output_dir_;

  std::mutex pool_mutex_;
  std::condition_variable pool_cv_;
  std::condition_variable idle_cv_;
  std::deque<std::uint32_t> tasks_;
  std::size_t outstanding_ = 0;
  bool shutting_down_ = false;
  std::vector<std::thread> workers_;

  std::mutex error_mutex_;
  std::string error_;
  std::atomic<bool> interrupted_{false};
  std::atomic<bool> sources_done_{false};
  std::atomic<bool> progress_done_{false};
  std::atomic<std::int64_t> clock_ns_{0};
  std::once_flag pace_once_;
  std::atomic<bool> pace_ready_{false};
  Time pace_origin_{};
  std::chrono::steady_clock::time_point wall_origin_;
};

}  // namespace

RunResult RunThreaded(Graph& graph, const RunOptions& options) {
  ThreadedEngine engine(graph, options);
  return engine.Run();
}

}  // namespace draco::graph
