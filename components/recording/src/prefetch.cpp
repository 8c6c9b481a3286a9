// PrefetchingReader: a RobotReader read ahead on a thread of its own (recording.hpp).
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>

#include "draco/recording/recording.hpp"

namespace draco::recording {

struct PrefetchingReader::Impl {
  Impl(RobotReader r, std::size_t d)
      : reader(std::move(r)),
        depth(d < 1 ? 1 : d),
        mission(reader.Mission()),
        robot(reader.Robot()) {}

  void Run() {
    while (true) {
      {
        std::unique_lock<std::mutex> lock(mutex);
        room.wait(lock, [&] { return stop || records.size() < depth; });
        if (stop) return;
      }
      // Reading happens outside the lock: only this thread touches the reader.
      std::optional<Record> record;
      std::exception_ptr failure;
      try {
        record = reader.Next();
      } catch (...) {
        failure = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(mutex);
      if (failure || !record) {
        error = failure;
        done = true;
        ready.notify_all();
        return;
      }
      records.push_back(std::move(*record));
      ready.notify_all();
    }
  }

  RobotReader reader;
  const std::size_t depth;
  const MissionInfo mission;  // copies: the thread never shares the reader's
  const RobotInfo robot;
  std::mutex mutex;
  std::condition_variable ready;  // a record, the end or an error is there
  std::condition_variable room;   // the queue has room, or stop
  std::deque<Record> records;
  bool done = false;
  bool stop = false;
  std::exception_ptr error;
  std::thread thread;
};

PrefetchingReader::PrefetchingReader(RobotReader reader, std::size_t depth)
    : impl_(std::make_unique<Impl>(std::move(reader), depth)) {
  impl_->thread = std::thread([impl = impl_.get()] { impl->Run(); });
}

PrefetchingReader::~PrefetchingReader() {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->stop = true;
  }
  impl_->room.notify_all();
  if (impl_->thread.joinable()) impl_->thread.join();
}

std::optional<Record> PrefetchingReader::Next() {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  impl_->ready.wait(lock, [&] { return !impl_->records.empty() || impl_->done; });
  if (!impl_->records.empty()) {
    Record record = std::move(impl_->records.front());
    impl_->records.pop_front();
    lock.unlock();
    impl_->room.notify_one();
    return record;
  }
  if (impl_->error) std::rethrow_exception(impl_->error);
  return std::nullopt;
}

const MissionInfo& PrefetchingReader::Mission() const { return impl_->mission; }
const RobotInfo& PrefetchingReader::Robot() const { return impl_->robot; }

}  // namespace draco::recording
