// A bounded queue between one producer thread and one consumer: the producer's work (reading a
// recording, rendering pings) runs outside the lock, only the hand-over takes it. Used by
// recording::PrefetchingReader and sim::RobotStream.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <utility>

namespace draco::msgs {

template <class T>
class BoundedQueue {
 public:
  // At most `capacity` items wait (at least one).
  explicit BoundedQueue(std::size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}

  // Producer: waits for room and queues the item; false when the consumer closed the queue
  // (the item is dropped: the producer should stop).
  bool Push(T item) {
    std::unique_lock<std::mutex> lock(mutex_);
    room_.wait(lock, [&] { return closed_ || items_.size() < capacity_; });
    if (closed_) return false;
    items_.push_back(std::move(item));
    lock.unlock();
    ready_.notify_one();
    return true;
  }

  // Producer: no more items. A non-null `error` is rethrown by Pop once the items are taken.
  void Finish(std::exception_ptr error = nullptr) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      finished_ = true;
      error_ = std::move(error);
    }
    ready_.notify_all();
  }

  // Consumer: waits for the next item; std::nullopt at the end or once closed. Rethrows the
  // producer's error after its items (not once closed).
  std::optional<T> Pop() {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [&] { return !items_.empty() || finished_ || closed_; });
    if (!items_.empty()) {
      T item = std::move(items_.front());
      items_.pop_front();
      lock.unlock();
      room_.notify_one();
      return item;
    }
    if (error_ && !closed_) std::rethrow_exception(error_);
    return std::nullopt;
  }

  // Consumer: drops the waiting items and wakes the producer (its Push returns false from now
  // on). Idempotent.
  void Close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
      items_.clear();
    }
    room_.notify_all();
    ready_.notify_all();
  }

 private:
  const std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable ready_;  // an item, the end or close
  std::condition_variable room_;   // room, or close
  std::deque<T> items_;
  bool finished_ = false;
  bool closed_ = false;
  std::exception_ptr error_;
};

}  // namespace draco::msgs
