// The deterministic executor on several threads (executor.hpp): engines for the graph's
// islands, conservative synchronisation, the outputs of one thread.
//
// Parts. An island (nodes no edge leaves) whose components all stay inside the graph is one
// part. One with components that reach other islands outside the graph (they declare
// Component::CrossIslandDelay(): the bus) splits in two: downstream, every node such a
// component reaches (itself included); upstream, the rest (a robot's local SLAM), which no
// edge from downstream enters. Each part runs on its own engine and thread.
//
// Horizons. An engine's horizon is the earliest stamp it may still process: its next event
// or timer, a message forwarded to it and not yet taken, or its upstream part's horizon
// (Time::Max() once nothing is left before `until`). An engine processes events at stamps
// below its limit:
//  - its upstream part's horizon (messages between engines are never stamped before the
//    event that publishes them: checked);
//  - for a part with bus components: every other such part's horizon plus the smallest
//    delay (an effect through the bus of an event at s shows nowhere before s + delay);
//  - for an upstream part: its downstream part's horizon plus kMaxLead (a memory bound).
// The engine with the smallest horizon can always go on, so the run never deadlocks; each
// engine processes its events in (stamp, phase, producer, sequence) order once every message
// for it at that stamp exists, so the outputs do not depend on the number of threads. (One
// engine for the whole graph can order messages of one stamp differently: it runs a message
// before one that a later event of the same stamp publishes.)
#include "islands.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <numeric>
#include <string>
#include <thread>

#include "deterministic_engine.hpp"

namespace draco::graph::internal {
namespace {

// How far an upstream part may run ahead of its downstream part, mission time.
const Time kMaxLead = Time::FromSeconds(30.0);

std::uint32_t Root(std::vector<std::uint32_t>& parent, std::uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

// At most `n` engines run at once (RunOptions::island_threads). A mutex and a condition
// variable, not std::counting_semaphore: libstdc++ 12's release() wakes waiters only when the
// count was 0 (GCC bug 98033), which can leave a waiter asleep with a slot free (a team
// replay of tuning world 4 stalled at one mission time until a debugger attached).
class Slots {
 public:
  explicit Slots(int n) : free_(std::max(1, n)) {}
  void Acquire() {
    std::unique_lock lock(mutex_);
    freed_.wait(lock, [&] { return free_ > 0; });
    --free_;
  }
  void Release() {
    {
      std::lock_guard lock(mutex_);
      ++free_;
    }
    freed_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable freed_;
  int free_;
};

Time SaturatingAdd(Time a, Time b) {
  if (a.ns > Time::Max().ns - b.ns) return Time::Max();
  return a + b;
}

struct Part {
  std::vector<std::uint32_t> nodes;
  int upstream = -1;    // the part feeding this one (same island)
  int downstream = -1;  // the part this one feeds
  bool bus = false;     // holds components that declare a CrossIslandDelay()
};

std::vector<Part> Parts(const Graph& graph) {
  std::vector<Part> parts;
  for (auto& island : Islands(graph)) {
    std::vector<char> reached(graph.nodes.size(), 0);
    std::vector<std::uint32_t> stack;
    for (const std::uint32_t n : island) {
      if (graph.nodes[n]->component->CrossIslandDelay()) reached[n] = 1, stack.push_back(n);
    }
    if (stack.empty()) {
      parts.push_back(Part{std::move(island)});
      continue;
    }
    while (!stack.empty()) {
      const std::uint32_t n = stack.back();
      stack.pop_back();
      for (const Edge& e : graph.edges) {
        if (e.producer == n && !reached[e.consumer])
          reached[e.consumer] = 1, stack.push_back(e.consumer);
      }
    }
    Part up, down;
    for (const std::uint32_t n : island) (reached[n] ? down : up).nodes.push_back(n);
    down.bus = true;
    if (!up.nodes.empty()) {
      up.downstream = static_cast<int>(parts.size()) + 1;
      down.upstream = static_cast<int>(parts.size());
      parts.push_back(std::move(up));
    }
    parts.push_back(std::move(down));
  }
  return parts;
}

}  // namespace

std::vector<std::vector<std::uint32_t>> Islands(const Graph& graph) {
  std::vector<std::uint32_t> parent(graph.nodes.size());
  std::iota(parent.begin(), parent.end(), 0u);
  for (const Edge& e : graph.edges) {
    const std::uint32_t a = Root(parent, e.producer), b = Root(parent, e.consumer);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<std::vector<std::uint32_t>> islands;
  std::vector<int> slot(graph.nodes.size(), -1);
  for (std::uint32_t n = 0; n < graph.nodes.size(); ++n) {  // ordered by their lowest node
    const std::uint32_t r = Root(parent, n);
    if (slot[r] < 0) {
      slot[r] = static_cast<int>(islands.size());
      islands.emplace_back();
    }
    islands[std::size_t(slot[r])].push_back(n);
  }
  return islands;
}

std::optional<RunResult> RunIslands(Graph& graph, const RunOptions& options) {
  const double rate = options.use_graph_rate ? graph.settings.rate : options.rate;
  if (options.island_threads < 1 || rate > 0.0 || options.until == Time::Max()) {
    return std::nullopt;
  }
  // The smallest declared delay (parameters are set at load, before Start()).
  std::optional<Time> delay;
  for (const auto& n : graph.nodes) {
    if (const auto d = n->component->CrossIslandDelay()) delay = delay ? std::min(*delay, *d) : *d;
  }
  if (delay && delay->ns <= 0) return std::nullopt;  // no lookahead: one thread
  const std::vector<Part> parts = Parts(graph);
  if (parts.size() < 2) return std::nullopt;

  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = parts.size();
  std::vector<int> engine_of(graph.nodes.size(), 0);
  for (std::size_t p = 0; p < n; ++p) {
    for (const std::uint32_t node : parts[p].nodes) engine_of[node] = static_cast<int>(p);
  }
  // Shared state, under `mutex`: messages forwarded between engines, each engine's next event.
  struct Forwarded {
    std::uint32_t producer;
    std::size_t output;
    int phase;
    Envelope envelope;
  };
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::vector<Forwarded>> inbox(n);
  std::vector<Time> inbox_min(n, Time::Max());
  std::vector<Time> next(n, Time::Max());
  bool abort = false;
  std::size_t finished = 0;
  const auto forward = [&](int engine, std::uint32_t producer, std::size_t output, int phase,
                           const Envelope& envelope) {
    std::lock_guard lock(mutex);
    inbox[std::size_t(engine)].push_back({producer, output, phase, envelope});
    inbox_min[std::size_t(engine)] = std::min(inbox_min[std::size_t(engine)], envelope.stamp);
  };

  StatsRecorder recorder(graph.nodes.size());
  RunOptions engine_options = options;
  engine_options.progress = nullptr;  // reported here, from the calling thread
  std::vector<std::unique_ptr<DeterministicEngine>> engines;
  for (std::size_t p = 0; p < n; ++p) {
    engines.push_back(std::make_unique<DeterministicEngine>(
        graph, engine_options, parts[p].nodes, &recorder, engine_of, static_cast<int>(p), forward));
  }
  RunResult result;
  bool started = true;
  for (auto& e : engines) {  // Start() part by part, each part's nodes in id order
    if (!e->StartAll()) {
      started = false;
      break;
    }
  }

  if (started) {
    const Time lookahead = delay.value_or(Time::Max());
    const auto Clip = [&](Time t) { return t > options.until ? Time::Max() : t; };
    // Under the mutex: the earliest stamp engine p may still process.
    std::function<Time(std::size_t)> Horizon = [&](std::size_t p) {
      Time h = std::min(next[p], inbox_min[p]);
      if (parts[p].upstream >= 0) h = std::min(h, Horizon(std::size_t(parts[p].upstream)));
      return Clip(h);
    };
    const auto Limit = [&](std::size_t p) {  // under the mutex; events below it may run
      Time limit = Time::Max();
      if (parts[p].upstream >= 0) limit = std::min(limit, Horizon(std::size_t(parts[p].upstream)));
      if (parts[p].bus) {
        for (std::size_t j = 0; j < n; ++j) {
          if (j != p && parts[j].bus) limit = std::min(limit, SaturatingAdd(Horizon(j), lookahead));
        }
      }
      if (parts[p].downstream >= 0) {
        limit = std::min(limit, SaturatingAdd(Horizon(std::size_t(parts[p].downstream)), kMaxLead));
      }
      return limit;
    };
    for (std::size_t p = 0; p < n; ++p) next[p] = Clip(engines[p]->NextEventTime());
    Slots busy(options.island_threads);
    std::vector<std::thread> threads;
    for (std::size_t p = 0; p < n; ++p) {
      threads.emplace_back([&, p] {
        DeterministicEngine& engine = *engines[p];
        for (;;) {
          Time until;
          std::vector<Forwarded> taken;
          {
            std::unique_lock lock(mutex);
            if (Horizon(p) == Time::Max()) break;
            changed.wait(lock, [&] { return abort || Limit(p) > Horizon(p); });
            if (abort || Horizon(p) == Time::Max()) break;
            const Time limit = Limit(p);
            until = limit == Time::Max()
                        ? options.until
                        : std::min(options.until, limit - Time::FromNanoseconds(1));
            taken.swap(inbox[p]);
            inbox_min[p] = Time::Max();
          }
          busy.Acquire();
          for (const auto& f : taken) engine.Receive(f.producer, f.output, f.phase, f.envelope);
          engine.RunUntil(until);
          busy.Release();
          std::lock_guard lock(mutex);
          if (engine.failed() || engine.interrupted()) abort = true;
          next[p] = Clip(engine.NextEventTime());
          changed.notify_all();
        }
        std::lock_guard lock(mutex);
        next[p] = Time::Max();
        ++finished;
        changed.notify_all();
      });
    }
    {
      const Time end = options.progress ? ExpectedEnd(graph, options) : Time::Max();
      std::unique_lock lock(mutex);
      const auto period = std::chrono::duration<double>(std::max(0.01, options.progress_period_s));
      while (finished < n) {
        changed.wait_for(lock, period);
        if (options.progress && finished < n) {
          Time reached = Time::Max();
          for (std::size_t p = 0; p < n; ++p) reached = std::min(reached, Horizon(p));
          if (reached == Time::Max()) reached = options.until;
          lock.unlock();
          options.progress(RunProgress{reached, end});
          lock.lock();
        }
      }
    }
    for (auto& t : threads) t.join();
  }
  // The first error in part order; then part by part, upstream first: the messages forwarded
  // to it, then Stop() (in-flight messages delivered, components stopped in topological
  // order), what it publishes going to the parts after it.
  std::string error;
  for (auto& e : engines) {
    if (e->failed() && error.empty()) error = e->error();
    result.interrupted = result.interrupted || e->interrupted();
  }
  for (std::size_t p = 0; p < n; ++p) {
    std::vector<Forwarded> taken;
    taken.swap(inbox[p]);
    for (const auto& f : taken) engines[p]->Receive(f.producer, f.output, f.phase, f.envelope);
    engines[p]->StopAll();
  }
  for (auto& e : engines) {
    if (e->failed() && error.empty()) error = e->error();
  }
  result.ok = error.empty();
  result.error = error;
  Time now{};
  for (auto& e : engines) now = std::max(now, e->now());
  const std::string executor = "deterministic, " + std::to_string(n) + " parts on " +
                               std::to_string(options.island_threads) + " threads";
  result.stats = recorder.Collect(
      graph, executor, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
      now);
  return result;
}

}  // namespace draco::graph::internal
