// In-process bus: process-wide named buses, one registry under one mutex. Send copies the
// frame into every other endpoint's inbox on the bus (or only the destination robot's) before
// it returns, so delivery order is send order and a replay is deterministic.
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "draco/middleware/transport.hpp"

namespace draco::middleware {
namespace {

class InProcessTransport;

struct Registry {
  std::mutex mutex;
  std::map<std::string, std::vector<InProcessTransport*>> buses;
};

Registry& TheRegistry() {
  static Registry registry;  // never destroyed before endpoints in static storage
  return registry;
}

bool Valid(const Frame& frame) {
  return frame.kind != 0 && frame.payload.size() <= kMaxPayloadBytes;
}

class InProcessTransport final : public Transport {
 public:
  InProcessTransport(std::string bus, std::uint16_t robot_id)
      : bus_(std::move(bus)), robot_id_(robot_id) {
    Registry& r = TheRegistry();
    std::lock_guard lock(r.mutex);
    r.buses[bus_].push_back(this);
  }

  ~InProcessTransport() override {
    Registry& r = TheRegistry();
    std::lock_guard lock(r.mutex);
    auto it = r.buses.find(bus_);
    if (it == r.buses.end()) return;
    std::erase(it->second, this);
    if (it->second.empty()) r.buses.erase(it);
  }

  bool Send(const Frame& frame) override {
    Registry& r = TheRegistry();
    std::lock_guard lock(r.mutex);
    if (!Valid(frame)) {
      ++counters_.send_failed;
      return false;
    }
    for (InProcessTransport* peer : r.buses[bus_]) {
      if (peer == this) continue;
      if (frame.destination != kBroadcast && frame.destination != peer->robot_id_) continue;
      Frame copy = frame;
      copy.source = robot_id_;
      peer->inbox_.push_back(std::move(copy));
    }
    ++counters_.frames_sent;
    return true;
  }

  std::vector<Frame> Receive() override {
    Registry& r = TheRegistry();
    std::lock_guard lock(r.mutex);
    std::vector<Frame> out;
    out.reserve(inbox_.size());
    for (Frame& f : inbox_) {
      if (f.source == robot_id_) {  // another endpoint with our robot id
        ++counters_.frames_own;
        continue;
      }
      ++counters_.frames_received;
      out.push_back(std::move(f));
    }
    inbox_.clear();
    return out;
  }

  std::string Describe() const override { return "inproc:" + bus_; }

  TransportCounters counters() const override {
    std::lock_guard lock(TheRegistry().mutex);
    return counters_;
  }

 private:
  std::string bus_;
  std::uint16_t robot_id_;
  std::deque<Frame> inbox_;     // guarded by the registry mutex
  TransportCounters counters_;  // guarded by the registry mutex
};

}  // namespace

std::unique_ptr<Transport> MakeInProcessTransport(const std::string& bus, std::uint16_t robot_id) {
  return std::make_unique<InProcessTransport>(bus, robot_id);
}

}  // namespace draco::middleware
