// The deterministic executor on several threads (executor.hpp): one DeterministicEngine per
// island, conservative synchronisation by the components' CrossIslandDelay().
//
// Island i may process its events at stamps below safe_i = min over the other islands j of
// (progress_j + delay), where progress_j is the stamp of j's next event (Time::Max() once j
// has nothing left before `until`). An effect of j's event at s reaches another island no
// earlier than s + delay, and every event of j before progress_j has been processed, so
// whatever i may observe by safe_i already happened: i sees what the single thread shows it.
// The island with the earliest next event can always go on (safe > its next event), so the
// run never deadlocks. Each island runs on its own thread; a semaphore keeps at most
// island_threads of them busy.
#include "islands.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <numeric>
#include <semaphore>
#include <thread>

#include "deterministic_engine.hpp"

namespace draco::graph::internal {
namespace {

std::uint32_t Root(std::vector<std::uint32_t>& parent, std::uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

Time SaturatingAdd(Time a, Time b) {
  if (a.ns > Time::Max().ns - b.ns) return Time::Max();
  return a + b;
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
  if (options.island_threads <= 1 || rate > 0.0 || options.until == Time::Max()) {
    return std::nullopt;
  }
  const auto islands = Islands(graph);
  if (islands.size() < 2) return std::nullopt;
  // The smallest declared delay (parameters are set at load, before Start()).
  std::optional<Time> delay;
  for (const auto& n : graph.nodes) {
    if (const auto d = n->component->CrossIslandDelay()) delay = delay ? std::min(*delay, *d) : *d;
  }
  if (delay && delay->ns <= 0) return std::nullopt;  // no lookahead: one thread

  const auto t0 = std::chrono::steady_clock::now();
  StatsRecorder recorder(graph.nodes.size());
  RunOptions engine_options = options;
  engine_options.progress = nullptr;  // reported here, from the calling thread
  std::vector<std::unique_ptr<DeterministicEngine>> engines;
  for (const auto& nodes : islands) {
    engines.push_back(
        std::make_unique<DeterministicEngine>(graph, engine_options, nodes, &recorder));
  }
  RunResult result;
  bool started = true;
  for (auto& e : engines) {  // Start() in island order, each island's nodes in id order
    if (!e->StartAll()) {
      started = false;
      break;
    }
  }

  if (started) {
    const Time lookahead = delay.value_or(Time::Max());
    const std::size_t n = engines.size();
    std::mutex mutex;
    std::condition_variable changed;
    std::vector<Time> progress(n);
    bool abort = false;
    std::size_t finished = 0;
    const auto ProgressOf = [&](std::size_t i) {
      const Time next = engines[i]->NextEventTime();
      return next > options.until ? Time::Max() : next;
    };
    for (std::size_t i = 0; i < n; ++i) progress[i] = ProgressOf(i);
    const auto SafeFor = [&](std::size_t i) {  // under the mutex
      Time safe = Time::Max();
      for (std::size_t j = 0; j < n; ++j) {
        if (j != i) safe = std::min(safe, SaturatingAdd(progress[j], lookahead));
      }
      return safe;
    };
    std::counting_semaphore<> busy(std::max(1, options.island_threads));
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < n; ++i) {
      threads.emplace_back([&, i] {
        DeterministicEngine& engine = *engines[i];
        for (;;) {
          Time limit;
          {
            std::unique_lock lock(mutex);
            const Time next = progress[i];
            if (next == Time::Max()) break;
            changed.wait(lock, [&] { return abort || SafeFor(i) > next; });
            if (abort) break;
            const Time safe = SafeFor(i);
            limit = safe == Time::Max() ? options.until
                                        : std::min(options.until, safe - Time::FromNanoseconds(1));
          }
          busy.acquire();
          engine.RunUntil(limit);
          busy.release();
          std::lock_guard lock(mutex);
          if (engine.failed() || engine.interrupted()) abort = true;
          progress[i] = ProgressOf(i);
          changed.notify_all();
        }
        std::lock_guard lock(mutex);
        progress[i] = Time::Max();
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
          Time reached = *std::min_element(progress.begin(), progress.end());
          if (reached == Time::Max()) reached = options.until;
          lock.unlock();
          options.progress(RunProgress{reached, end});
          lock.lock();
        }
      }
    }
    for (auto& t : threads) t.join();
  }
  // The first error in island order; then Stop() island by island, as one thread would.
  std::string error;
  for (auto& e : engines) {
    if (e->failed() && error.empty()) error = e->error();
    result.interrupted = result.interrupted || e->interrupted();
  }
  for (auto& e : engines) e->StopAll();
  for (auto& e : engines) {
    if (e->failed() && error.empty()) error = e->error();
  }
  result.ok = error.empty();
  result.error = error;
  Time now{};
  for (auto& e : engines) now = std::max(now, e->now());
  result.stats = recorder.Collect(
      graph, "deterministic",
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), now);
  return result;
}

}  // namespace draco::graph::internal
