// RobotStream: SimulateRobot on a producer thread into a bounded queue (robot_stream.hpp).
// The shape of recording::PrefetchingReader: records move under one mutex, the work (the
// rendering of pings) runs outside it.
#include "draco/sim/robot_stream.hpp"

#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>

#include "draco/sim/simulator.hpp"
#include "draco/sim/sonar_model.hpp"

namespace draco::sim {

double StreamRecordTime(const StreamRecord& record) {
  return std::visit([](const auto& m) { return m.time_s; }, record);
}

namespace {
// Thrown by the sink to leave SimulateRobot when the stream is stopped.
struct Stopped {};
}  // namespace

struct RobotStream::Impl final : RobotSink {
  Impl(World w, Mission m, int index, std::size_t d, bool with_sonar)
      : world(std::move(w)),
        mission(std::move(m)),
        robot_index(index),
        depth(d < 1 ? 1 : d),
        sonar(with_sonar ? std::make_unique<SonarModel>(world, mission.sonar) : nullptr) {}

  void Run() {
    std::exception_ptr failure;
    try {
      SimulateRobot(world, mission, robot_index, sonar.get(), *this);
    } catch (const Stopped&) {
    } catch (...) {
      failure = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(mutex);
    error = failure;
    done = true;
    ready.notify_all();
  }

  // Waits for room (or stop) and queues the record; the producer's thread only.
  void Push(StreamRecord record) {
    std::unique_lock<std::mutex> lock(mutex);
    room.wait(lock, [&] { return stop || records.size() < depth; });
    if (stop) throw Stopped{};
    records.push_back(std::move(record));
    lock.unlock();
    ready.notify_one();
  }

  void OnPing(const msgs::SonarPing& ping, const TrajectorySample&) override { Push(ping); }
  void OnDvl(const msgs::DvlVelocity& dvl) override { Push(dvl); }
  void OnAhrs(const msgs::Ahrs& ahrs) override { Push(ahrs); }
  void OnDepth(const msgs::Depth& d) override { Push(d); }
  void OnGroundTruth(const msgs::GroundTruthPose& pose) override { Push(pose); }

  // Read by the producer only after construction (SonarModel keeps a reference to world).
  const World world;
  const Mission mission;
  const int robot_index;
  const std::size_t depth;
  const std::unique_ptr<const SonarModel> sonar;

  std::mutex mutex;
  std::condition_variable ready;  // a record, the end or an error is there
  std::condition_variable room;   // the queue has room, or stop
  std::deque<StreamRecord> records;
  bool done = false;
  bool stop = false;
  std::exception_ptr error;
  std::thread thread;
};

RobotStream::RobotStream(World world, Mission mission, int robot_index, std::size_t depth,
                         bool with_sonar)
    : impl_(std::make_unique<Impl>(std::move(world), std::move(mission), robot_index, depth,
                                   with_sonar)) {
  impl_->thread = std::thread([impl = impl_.get()] { impl->Run(); });
}

RobotStream::~RobotStream() { Stop(); }

void RobotStream::Stop() {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->stop = true;
    impl_->records.clear();
  }
  impl_->room.notify_all();
  if (impl_->thread.joinable()) impl_->thread.join();
}

std::optional<StreamRecord> RobotStream::Next() {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  impl_->ready.wait(lock, [&] { return !impl_->records.empty() || impl_->done || impl_->stop; });
  if (!impl_->records.empty()) {
    StreamRecord record = std::move(impl_->records.front());
    impl_->records.pop_front();
    lock.unlock();
    impl_->room.notify_one();
    return record;
  }
  if (impl_->error && !impl_->stop) std::rethrow_exception(impl_->error);
  return std::nullopt;
}

}  // namespace draco::sim
