// RobotStream: SimulateRobot on a producer thread into a bounded queue (robot_stream.hpp);
// the rendering of pings runs outside the queue's lock.
#include "draco/sim/robot_stream.hpp"

#include <exception>
#include <thread>
#include <utility>

#include "draco/msgs/bounded_queue.hpp"
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
  Impl(World w, Mission m, int index, std::size_t depth, bool with_sonar)
      : world(std::move(w)),
        mission(std::move(m)),
        robot_index(index),
        sonar(with_sonar ? std::make_unique<SonarModel>(world, mission.sonar) : nullptr),
        queue(depth) {}

  void Run() {
    try {
      SimulateRobot(world, mission, robot_index, sonar.get(), *this);
      queue.Finish();
    } catch (const Stopped&) {
    } catch (...) {
      queue.Finish(std::current_exception());
    }
  }

  // Waits for room and queues the record; leaves SimulateRobot once the stream is stopped.
  void Push(StreamRecord record) {
    if (!queue.Push(std::move(record))) throw Stopped{};
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
  const std::unique_ptr<const SonarModel> sonar;
  msgs::BoundedQueue<StreamRecord> queue;
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
  impl_->queue.Close();
  if (impl_->thread.joinable()) impl_->thread.join();
}

std::optional<StreamRecord> RobotStream::Next() { return impl_->queue.Pop(); }

}  // namespace draco::sim
