// The acoustic modem model, between a robot's link endpoint and the transport. Same code over
// DDS and in-process, so both give the same behaviour above it.
//
// Sender side (AcousticChannel): frames wait in a priority queue (priority, then FIFO) and are
// transmitted one after another at the robot's share of the team budget (team_rate_bps /
// team_size), or, with turn-taking (tdma), at the full team rate during the robot's own slot
// of a round-robin cycle (slot i of team_size slots of slot_s each). A frame reaches the
// receivers latency_s after its last bit. A frame that waited longer than max_wait_s, or that
// does not fit in the queue, is dropped and counted; a transmitted frame is lost with
// loss_probability, decided by a hash of (seed, source, seq): the same on every run.
//
// Receiver side (Inbox): frames are held until their delivery time and handed out in
// (delivered_s, source, seq) order, whatever order the transport brought them in.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "draco/middleware/frame.hpp"

namespace draco::middleware {

struct ChannelOptions {
  double team_rate_bps = 62500.0;  // the whole team's budget (the paper's modem)
  int team_size = 3;
  bool tdma = false;       // half-duplex turn-taking
  double slot_s = 2.0;     // tdma slot length
  double latency_s = 0.1;  // after the last bit (propagation ~0.07 s per 100 m + modem)
  double loss_probability = 0.0;
  std::uint64_t loss_seed = 1;
  // Queued longer than this: dropped (expired). A scan reply that waited minutes still makes
  // loops (its keyframes do not go stale); on a 1 kbit/s team link 60 s expired a third of
  // them (docs/fleet.md, "What a slow link spends its bits on").
  double max_wait_s = 180.0;
  std::size_t max_queue_bits = 1 << 20;  // queue capacity; a frame that does not fit is dropped
};

inline constexpr int kMaxKinds = 16;

struct KindStats {
  std::uint64_t frames_sent = 0;  // transmitted (including lost ones)
  std::uint64_t bits_sent = 0;
  std::uint64_t max_bits = 0;
  std::uint64_t dropped_queue = 0;    // did not fit in the queue / too large
  std::uint64_t dropped_expired = 0;  // waited longer than max_wait_s
  std::uint64_t superseded = 0;       // taken from the queue for a newer frame (DropWaiting)
  std::uint64_t lost = 0;             // transmitted, lost in the water
  std::uint64_t frames_received = 0;  // receiver side
  std::uint64_t bits_received = 0;
  std::uint64_t rejected = 0;  // receiver side: failed to decode / out of bounds (counted by
                               // the endpoint through CountRejected)
};

// One transmitted frame, for the traffic-over-time figure.
struct TrafficRecord {
  double start_s = 0.0;
  double end_s = 0.0;
  std::uint8_t kind = 0;
  std::uint32_t bits = 0;
  bool lost = false;
};

struct LinkStats {
  std::array<KindStats, kMaxKinds> by_kind{};
  std::vector<TrafficRecord> traffic;  // every transmission, in order
  double busy_s = 0.0;                 // time the transmitter was sending
};

class AcousticChannel {
 public:
  AcousticChannel(std::uint16_t robot_id, const ChannelOptions& options);

  // Queues a frame (source and seq are set here; enqueued_s = now_s). Returns false when it
  // was dropped (too large or the queue is full); counted either way.
  bool Enqueue(Frame frame, double now_s);
  // Takes the frames of this kind for this destination that are still waiting (not being
  // transmitted) out of the queue, because a newer frame about to be queued carries what they
  // carry (an object-map update against the version the teammates acknowledged supersedes an
  // older one). Counted as superseded; returns how many.
  std::size_t DropWaiting(std::uint8_t kind, std::uint16_t destination);
  // Advances the transmitter to now_s: frames whose last bit left by now_s, with delivered_s
  // set, lost ones excluded (counted). Frames that expired in the queue are dropped.
  std::vector<Frame> Transmit(double now_s);

  std::size_t queued_frames() const { return queue_.size(); }
  std::size_t queued_bits() const { return queued_bits_; }
  const LinkStats& stats() const { return stats_; }
  const ChannelOptions& options() const { return options_; }
  // Receiver-side accounting (the endpoint calls these).
  void CountReceived(std::uint8_t kind, std::size_t bits);
  void CountRejected(std::uint8_t kind);

 private:
  std::uint16_t robot_id_;
  ChannelOptions options_;
  std::uint32_t next_seq_ = 0;
  std::deque<Frame> queue_;  // kept sorted by (priority, enqueue order)
  std::size_t queued_bits_ = 0;
  double transmitter_free_s_ = 0.0;  // when the current transmission ends
  LinkStats stats_;
};

// Receiver side: frames held until due.
class Inbox {
 public:
  // False when not held: a non-finite delivery time, or a frame with the same (delivered_s,
  // source, seq) already held (a duplicate).
  bool Add(Frame frame);
  // Frames with delivered_s <= now_s in (delivered_s, source, seq) order.
  std::vector<Frame> Due(double now_s);
  std::size_t size() const { return held_.size(); }

 private:
  std::map<std::tuple<double, std::uint16_t, std::uint32_t>, Frame> held_;
};

// The traffic records as CSV (start_s,end_s,kind,bits,lost); names[k] names kind k. (The
// statistics as JSON are written by the link endpoint, components/fleet.)
std::string TrafficCsv(const LinkStats& stats, const std::vector<std::string>& names);

}  // namespace draco::middleware
