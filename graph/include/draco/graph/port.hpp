// Ports: the typed, named connection points of a component, and the immutable message
// envelope that travels between them. Components use In<T> and Out<T> handles; the
// InputPort/OutputPort classes are the runtime's side and are not used by components.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <typeindex>
#include <vector>

#include "draco/graph/time.hpp"

namespace draco::graph {

// How an input keeps what arrives until the component takes it.
enum class Delivery {
  kQueue,   // FIFO of at most `depth` messages
  kLatest,  // only the newest message (a depth-1 queue that replaces)
};

// What happens when a queue is full (threaded executor; the deterministic executor runs
// each consumer as soon as its input arrives, so it only drops when a component leaves
// messages in its queue).
enum class DropPolicy {
  kDropOldest,  // make room by discarding the oldest queued message (counted)
  kDropNewest,  // discard the arriving message (counted)
  kBlock,       // the producer waits up to InputOptions::block_timeout_s, then drops newest
};

struct InputOptions {
  bool trigger = true;  // an arrival schedules Process()
  Delivery delivery = Delivery::kQueue;
  std::size_t depth = 16;
  DropPolicy drop = DropPolicy::kDropOldest;
  bool required = true;  // validation fails when left unconnected
  bool delayed = false;  // a feedback edge: cycles must pass through one
  double block_timeout_s = 1.0;
  std::string doc;
};

// A message as it travels: immutable payload shared by every consumer (never copied),
// stamped in mission time, with its producer and the producer's sequence number.
struct Envelope {
  Time stamp;
  std::uint32_t producer = 0;  // index of the producing node in the graph (id order)
  std::uint64_t seq = 0;       // per-producer publication counter
  std::shared_ptr<const void> payload;
  std::shared_ptr<const std::string> producer_id;
};

// A typed view of one received message.
template <class T>
struct Stamped {
  Time stamp;
  std::shared_ptr<const T> value;
  std::shared_ptr<const std::string> producer;

  const T& operator*() const { return *value; }
  const T* operator->() const { return value.get(); }
};

// Runtime side of an input. Thread-safe: producers push, the owning component pops.
class InputPort {
 public:
  InputPort(std::string name, std::type_index type, std::string type_name, InputOptions options)
      : name_(std::move(name)),
        type_(type),
        type_name_(std::move(type_name)),
        options_(std::move(options)) {}

  const std::string& name() const { return name_; }
  std::type_index type() const { return type_; }
  const std::string& type_name() const { return type_name_; }
  const InputOptions& options() const { return options_; }
  bool connected() const { return connected_; }
  void set_connected(bool c) { connected_ = c; }

  // Returns false when the message was dropped (or displaced an older one: still true).
  // may_block: the caller is a thread that may wait (threaded executor only).
  bool Push(Envelope envelope, bool may_block);
  std::optional<Envelope> Pop();
  std::optional<Envelope> Peek() const;
  std::size_t size() const;
  void Clear();

  std::uint64_t received() const;
  std::uint64_t dropped() const;

 private:
  std::string name_;
  std::type_index type_;
  std::string type_name_;
  InputOptions options_;
  bool connected_ = false;
  mutable std::mutex mutex_;
  std::condition_variable not_full_;
  std::deque<Envelope> buffer_;
  std::uint64_t received_ = 0;
  std::uint64_t dropped_ = 0;
};

// Runtime side of an output: the executor installs the emit function.
class OutputPort {
 public:
  using EmitFn = std::function<void(OutputPort&, Time, std::shared_ptr<const void>)>;

  OutputPort(std::string name, std::type_index type, std::string type_name, std::string doc)
      : name_(std::move(name)),
        type_(type),
        type_name_(std::move(type_name)),
        doc_(std::move(doc)) {}

  const std::string& name() const { return name_; }
  std::type_index type() const { return type_; }
  const std::string& type_name() const { return type_name_; }
  const std::string& doc() const { return doc_; }
  std::size_t index() const { return index_; }
  void set_index(std::size_t i) { index_ = i; }

  void set_emit(EmitFn emit) { emit_ = std::move(emit); }
  // Stamp used by Publish() without an explicit stamp: the time of the event being processed.
  void set_default_stamp(const Time* now) { now_ = now; }
  void Emit(std::optional<Time> stamp, std::shared_ptr<const void> payload);
  std::uint64_t published() const { return published_; }

 private:
  std::string name_;
  std::type_index type_;
  std::string type_name_;
  std::string doc_;
  std::size_t index_ = 0;
  EmitFn emit_;
  const Time* now_ = nullptr;
  std::uint64_t published_ = 0;
};

// Component-side handle of an input of type T.
template <class T>
class In {
 public:
  In() = default;
  explicit In(InputPort* port) : port_(port) {}

  bool connected() const { return port_ != nullptr && port_->connected(); }
  bool empty() const { return port_ == nullptr || port_->size() == 0; }
  std::size_t size() const { return port_ == nullptr ? 0 : port_->size(); }

  // Removes and returns the oldest queued message (or the latest value), if any.
  std::optional<Stamped<T>> Take() {
    if (port_ == nullptr) return std::nullopt;
    auto e = port_->Pop();
    if (!e) return std::nullopt;
    return Convert(*e);
  }
  // Removes and returns everything queued, oldest first.
  std::vector<Stamped<T>> TakeAll() {
    std::vector<Stamped<T>> out;
    while (auto m = Take()) out.push_back(std::move(*m));
    return out;
  }
  // Returns the oldest queued message without removing it.
  std::optional<Stamped<T>> Peek() const {
    if (port_ == nullptr) return std::nullopt;
    auto e = port_->Peek();
    if (!e) return std::nullopt;
    return Convert(*e);
  }

 private:
  static Stamped<T> Convert(const Envelope& e) {
    return Stamped<T>{e.stamp, std::static_pointer_cast<const T>(e.payload), e.producer_id};
  }
  InputPort* port_ = nullptr;
};

// Component-side handle of an output of type T.
template <class T>
class Out {
 public:
  Out() = default;
  explicit Out(OutputPort* port) : port_(port) {}

  // Publishes with the stamp of the event being processed.
  void Publish(T value) { Publish(std::make_shared<const T>(std::move(value))); }
  void Publish(std::shared_ptr<const T> value) { port_->Emit(std::nullopt, std::move(value)); }
  // Publishes with an explicit mission-time stamp.
  void PublishAt(Time stamp, T value) {
    PublishAt(stamp, std::make_shared<const T>(std::move(value)));
  }
  void PublishAt(Time stamp, std::shared_ptr<const T> value) {
    port_->Emit(stamp, std::move(value));
  }

 private:
  OutputPort* port_ = nullptr;
};

}  // namespace draco::graph
