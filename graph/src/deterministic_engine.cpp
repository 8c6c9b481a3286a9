#include "deterministic_engine.hpp"

#include "islands.hpp"

#include <algorithm>
#include <exception>
#include <thread>

namespace draco::graph::internal {

namespace {

std::vector<std::uint32_t> AllNodes(const Graph& graph) {
  std::vector<std::uint32_t> all(graph.nodes.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<std::uint32_t>(i);
  return all;
}

}  // namespace

DeterministicEngine::DeterministicEngine(Graph& graph, const RunOptions& options)
    : DeterministicEngine(graph, options, AllNodes(graph), nullptr) {}

DeterministicEngine::DeterministicEngine(Graph& graph, const RunOptions& options,
                                         std::vector<std::uint32_t> nodes, StatsRecorder* recorder,
                                         std::vector<int> engine_of, int self, Forward forward)
    : graph_(graph),
      options_(options),
      nodes_(std::move(nodes)),
      engine_of_(std::move(engine_of)),
      self_(self),
      forward_(std::move(forward)),
      node_now_(graph.nodes.size()),
      next_seq_(graph.nodes.size() + 1, 0),
      source_pending_(graph.nodes.size(), false),
      own_recorder_(recorder == nullptr ? graph.nodes.size() : 0),
      recorder_(recorder == nullptr ? &own_recorder_ : recorder),
      output_dir_(options.output_dir) {
  std::sort(nodes_.begin(), nodes_.end());
  rate_ = options.use_graph_rate ? graph.settings.rate : options.rate;
  for (const auto& n : graph_.nodes) {
    producer_ids_.push_back(std::make_shared<const std::string>(n->id));
  }
  for (const std::uint32_t index : nodes_) {
    const auto& n = graph_.nodes[index];
    for (auto& out : n->outputs) {
      const std::uint32_t producer = n->index;
      out->set_default_stamp(&node_now_[producer]);
      out->set_emit(
          [this, producer](OutputPort& port, Time stamp, std::shared_ptr<const void> payload) {
            Emit(producer, port, stamp, std::move(payload));
          });
    }
    for (std::size_t t = 0; t < n->timers.size(); ++t) {
      timers_.push_back(TimerState{n->index, t, n->timers[t].period});
    }
  }
  producer_ids_.push_back(std::make_shared<const std::string>("(injected)"));
}

DeterministicEngine::~DeterministicEngine() {
  for (const std::uint32_t index : nodes_) {
    for (auto& out : graph_.nodes[index]->outputs) {
      out->set_emit(nullptr);
      out->set_default_stamp(nullptr);
    }
  }
}

const std::vector<Envelope>& DeterministicEngine::Tapped(std::uint32_t node,
                                                         std::size_t output) const {
  static const std::vector<Envelope> kEmpty;
  auto it = taps_.find({node, output});
  return it == taps_.end() ? kEmpty : it->second;
}

void DeterministicEngine::Emit(std::uint32_t producer, OutputPort& port, Time stamp,
                               std::shared_ptr<const void> payload) {
  Envelope env{stamp, producer, next_seq_[producer]++, std::move(payload), producer_ids_[producer]};
  if (taps_enabled_) taps_[{producer, port.index()}].push_back(env);
  bool has_normal = false;
  bool has_delayed = false;
  // Subscribers of other engines, per engine: (engine, phase) pairs, each once.
  std::vector<std::pair<int, int>> remote;
  for (const Edge* e : graph_.Subscribers(producer, port.index())) {
    const bool delayed = graph_.nodes[e->consumer]->inputs[e->input]->options().delayed;
    if (Mine(e->consumer)) {
      (delayed ? has_delayed : has_normal) = true;
    } else {
      const std::pair<int, int> key{engine_of_[e->consumer], delayed ? 1 : 0};
      if (std::find(remote.begin(), remote.end(), key) == remote.end()) remote.push_back(key);
    }
  }
  if (!remote.empty()) {
    // Another engine may already have run up to this engine's event time, never beyond.
    if (stamp < now_ && error_.empty()) {
      error_ = graph_.nodes[producer]->id + ": published a message stamped " +
               std::to_string(stamp.Seconds()) + " s, before its event time " +
               std::to_string(now_.Seconds()) +
               " s, to a consumer run on another thread; run on one thread (island_threads 1)";
    }
    std::sort(remote.begin(), remote.end());
    for (const auto& [engine, phase] : remote) forward_(engine, producer, port.index(), phase, env);
  }
  for (int phase = 0; phase < 2; ++phase) {
    if (!(phase == 0 ? has_normal : has_delayed)) continue;
    Receive(producer, port.index(), phase, env);
  }
}

void DeterministicEngine::Receive(std::uint32_t producer, std::size_t output, int phase,
                                  const Envelope& envelope) {
  Event ev;
  ev.stamp = envelope.stamp;
  ev.phase = phase;
  ev.producer = producer;
  ev.seq = envelope.seq;
  ev.order = order_++;
  ev.kind = Kind::kMessage;
  ev.output = output;
  ev.envelope = envelope;
  queue_.push(std::move(ev));
}

void DeterministicEngine::Inject(std::uint32_t node, std::size_t input, Time stamp,
                                 std::shared_ptr<const void> payload) {
  const auto injected = static_cast<std::uint32_t>(graph_.nodes.size());
  Event ev;
  ev.stamp = stamp;
  ev.producer = injected;
  ev.seq = next_seq_[injected]++;
  ev.order = order_++;
  ev.kind = Kind::kMessage;
  ev.envelope = Envelope{stamp, injected, ev.seq, std::move(payload), producer_ids_[injected]};
  ev.injected = true;
  ev.target_node = node;
  ev.target_input = input;
  queue_.push(std::move(ev));
}

bool DeterministicEngine::StartAll() {
  for (const std::uint32_t index : nodes_) {
    Call(index, Reason::kStart, "");
    if (failed()) return false;
  }
  for (const std::uint32_t index : nodes_) {
    if (graph_.nodes[index]->is_source) ScheduleSource(index);
  }
  return !failed();
}

Time DeterministicEngine::NextEventTime() const {
  Time next = queue_.empty() ? Time::Max() : queue_.top().stamp;
  for (const auto& ts : timers_) next = std::min(next, ts.next);
  return next;
}

void DeterministicEngine::ScheduleSource(std::uint32_t node) {
  if (source_pending_[node]) return;
  std::optional<Time> next;
  try {
    next = graph_.nodes[node]->component->NextSourceTime();
  } catch (const std::exception& e) {
    error_ = graph_.nodes[node]->id + ": NextSourceTime threw: " + e.what();
    return;
  }
  if (!next) return;
  Event ev;
  ev.stamp = *next;
  ev.producer = node;
  ev.seq = next_seq_[node];
  ev.order = order_++;
  ev.kind = Kind::kSource;
  queue_.push(std::move(ev));
  source_pending_[node] = true;
}

void DeterministicEngine::Call(std::uint32_t node, Reason reason, const std::string& timer) {
  Node& n = *graph_.nodes[node];
  node_now_[node] = now_;
  Context ctx(n.id, &node_now_[node], &output_dir_);
  ctx.SetStopFlag(options_.stop_requested);
  ctx.SetEvent(reason, timer);
  const std::string fatal =
      internal::InvokeComponent(n, ctx, reason, *recorder_, options_.log_errors);
  if (!fatal.empty() && error_.empty()) error_ = fatal;
}

void DeterministicEngine::Dispatch(Event& ev) {
  if (ev.kind == Kind::kSource) {
    source_pending_[ev.producer] = false;
    Call(ev.producer, Reason::kSource, "");
    if (!failed()) ScheduleSource(ev.producer);
    return;
  }
  // Deliver to every subscriber first, then run each triggered consumer once, in id order.
  std::vector<std::uint32_t> triggered;
  auto deliver = [&](std::uint32_t consumer, std::size_t input) {
    InputPort& in = *graph_.nodes[consumer]->inputs[input];
    in.Push(ev.envelope, /*may_block=*/false);
    if (in.options().trigger &&
        std::find(triggered.begin(), triggered.end(), consumer) == triggered.end()) {
      triggered.push_back(consumer);
    }
  };
  if (ev.injected) {
    deliver(ev.target_node, ev.target_input);
  } else {
    for (const Edge* e : graph_.Subscribers(ev.producer, ev.output)) {
      if (!Mine(e->consumer)) continue;
      const bool delayed = graph_.nodes[e->consumer]->inputs[e->input]->options().delayed;
      if (delayed == (ev.phase == 1)) deliver(e->consumer, e->input);
    }
  }
  std::sort(triggered.begin(), triggered.end());
  for (std::uint32_t c : triggered) {
    Call(c, Reason::kInput, "");
    if (failed()) return;
  }
}

bool DeterministicEngine::FireNextTimerUpTo(Time t) {
  TimerState* due = nullptr;
  for (auto& ts : timers_) {
    if (ts.next <= t && (due == nullptr || ts.next < due->next)) due = &ts;
  }
  if (due == nullptr) return false;
  if (due->next > now_) now_ = due->next;
  const Time fire = due->next;
  due->next = due->next + graph_.nodes[due->node]->timers[due->timer].period;
  Pace(fire);
  Call(due->node, Reason::kTimer, graph_.nodes[due->node]->timers[due->timer].name);
  return true;
}

void DeterministicEngine::Pace(Time stamp) {
  if (rate_ <= 0.0) return;
  if (!paced_started_) {
    paced_started_ = true;
    pace_origin_ = stamp;
    wall_origin_ = std::chrono::steady_clock::now();
    return;
  }
  const double wall_s = (stamp - pace_origin_).Seconds() / rate_;
  std::this_thread::sleep_until(wall_origin_ + std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                   std::chrono::duration<double>(wall_s)));
}

bool DeterministicEngine::StopRequested() {
  if (options_.stop_requested != nullptr && options_.stop_requested->load()) {
    interrupted_ = true;
    return true;
  }
  return false;
}

void DeterministicEngine::RunUntil(Time limit) {
  const Time end = options_.progress ? ExpectedEnd(graph_, options_) : Time::Max();
  auto last_progress = std::chrono::steady_clock::now();
  std::uint64_t events = 0;
  while (!failed() && !StopRequested()) {
    if (options_.progress && (++events & 255) == 0) {
      const auto now = std::chrono::steady_clock::now();
      if (std::chrono::duration<double>(now - last_progress).count() >=
          options_.progress_period_s) {
        last_progress = now;
        options_.progress(RunProgress{now_, end});
      }
    }
    if (queue_.empty() || queue_.top().stamp > limit) {
      // No event left before the limit: timers go on up to it, one at a time, and what each
      // publishes is delivered before the next fires.
      if (limit == Time::Max() || !FireNextTimerUpTo(limit)) break;
      continue;
    }
    // Timers due at or before the next event fire first, one at a time: what a timer publishes
    // may be stamped before that event and must be dispatched before it.
    if (FireNextTimerUpTo(queue_.top().stamp)) continue;
    Event ev = queue_.top();
    queue_.pop();
    if (ev.stamp > now_) now_ = ev.stamp;
    Pace(ev.stamp);
    Dispatch(ev);
  }
}

void DeterministicEngine::StopAll() {
  // Messages already in flight are delivered, then components stop producers first, and
  // what each Stop() publishes is delivered before its consumers stop. Sources stay silent.
  auto drain = [&] {
    while (!queue_.empty()) {
      Event ev = queue_.top();
      queue_.pop();
      if (ev.kind == Kind::kSource) continue;
      if (ev.stamp > now_) now_ = ev.stamp;
      Dispatch(ev);
    }
  };
  drain();
  for (std::uint32_t node : graph_.TopologicalOrder()) {
    if (!std::binary_search(nodes_.begin(), nodes_.end(), node)) continue;
    Call(node, Reason::kStop, "");
    drain();
  }
}

}  // namespace draco::graph::internal

namespace draco::graph {

RunResult RunDeterministic(Graph& graph, const RunOptions& options) {
  if (auto parallel = internal::RunIslands(graph, options)) return std::move(*parallel);
  const auto t0 = std::chrono::steady_clock::now();
  internal::DeterministicEngine engine(graph, options);
  RunResult result;
  if (engine.StartAll()) {
    engine.RunUntil(options.until);
  }
  const std::string start_or_run_error = engine.error();
  engine.StopAll();
  result.ok = !engine.failed();
  result.error = start_or_run_error.empty() ? engine.error() : start_or_run_error;
  result.interrupted = engine.interrupted();
  result.stats =
      engine.Stats(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return result;
}

RunResult Run(Graph& graph, const RunOptions& options) {
  return graph.settings.executor == "threaded" ? RunThreaded(graph, options)
                                               : RunDeterministic(graph, options);
}

}  // namespace draco::graph
