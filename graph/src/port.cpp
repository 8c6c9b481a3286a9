#include "draco/graph/port.hpp"

#include <chrono>

namespace draco::graph {

bool InputPort::Push(Envelope envelope, bool may_block) {
  std::unique_lock<std::mutex> lock(mutex_);
  ++received_;
  const std::size_t capacity =
      options_.delivery == Delivery::kLatest ? 1 : std::max<std::size_t>(options_.depth, 1);
  if (options_.delivery == Delivery::kLatest) {
    buffer_.clear();  // only the newest value is kept; replacing is not a drop
    buffer_.push_back(std::move(envelope));
    return true;
  }
  if (buffer_.size() >= capacity) {
    switch (options_.drop) {
      case DropPolicy::kDropOldest:
        buffer_.pop_front();
        ++dropped_;
        break;
      case DropPolicy::kDropNewest:
        ++dropped_;
        return false;
      case DropPolicy::kBlock:
        if (!may_block) break;  // deterministic executor: the consumer runs next, keep it
        if (!not_full_.wait_for(lock, std::chrono::duration<double>(options_.block_timeout_s),
                                [&] { return buffer_.size() < capacity; })) {
          ++dropped_;
          return false;
        }
        break;
    }
  }
  buffer_.push_back(std::move(envelope));
  return true;
}

std::optional<Envelope> InputPort::Pop() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (buffer_.empty()) return std::nullopt;
  Envelope e = std::move(buffer_.front());
  buffer_.pop_front();
  not_full_.notify_one();
  return e;
}

std::optional<Envelope> InputPort::Peek() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (buffer_.empty()) return std::nullopt;
  return buffer_.front();
}

std::size_t InputPort::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return buffer_.size();
}

void InputPort::Clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  buffer_.clear();
  not_full_.notify_all();
}

std::uint64_t InputPort::received() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return received_;
}

std::uint64_t InputPort::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

void OutputPort::Emit(std::optional<Time> stamp, std::shared_ptr<const void> payload) {
  ++published_;
  if (!emit_) return;  // declared but not running (e.g. `draco list`)
  const Time t = stamp ? *stamp : (now_ != nullptr ? *now_ : Time{});
  emit_(*this, t, std::move(payload));
}

}  // namespace draco::graph
