// PrefetchingReader: a RobotReader read ahead on a thread of its own (recording.hpp).
#include <exception>
#include <thread>
#include <utility>

#include "draco/msgs/bounded_queue.hpp"
#include "draco/recording/recording.hpp"

namespace draco::recording {

struct PrefetchingReader::Impl {
  Impl(RobotReader r, std::size_t depth)
      : reader(std::move(r)), queue(depth), mission(reader.Mission()), robot(reader.Robot()) {}

  // Only this thread touches the reader once it runs.
  void Run() {
    while (true) {
      std::optional<Record> record;
      try {
        record = reader.Next();
      } catch (...) {
        queue.Finish(std::current_exception());
        return;
      }
      if (!record) {
        queue.Finish();
        return;
      }
      if (!queue.Push(std::move(*record))) return;  // closed: the reader is going away
    }
  }

  RobotReader reader;
  msgs::BoundedQueue<Record> queue;
  const MissionInfo mission;  // copies: the thread never shares the reader's
  const RobotInfo robot;
  std::thread thread;
};

PrefetchingReader::PrefetchingReader(RobotReader reader, std::size_t depth)
    : impl_(std::make_unique<Impl>(std::move(reader), depth)) {
  impl_->thread = std::thread([impl = impl_.get()] { impl->Run(); });
}

PrefetchingReader::~PrefetchingReader() {
  impl_->queue.Close();
  if (impl_->thread.joinable()) impl_->thread.join();
}

std::optional<Record> PrefetchingReader::Next() { return impl_->queue.Pop(); }

const MissionInfo& PrefetchingReader::Mission() const { return impl_->mission; }
const RobotInfo& PrefetchingReader::Robot() const { return impl_->robot; }

}  // namespace draco::recording
