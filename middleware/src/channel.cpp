// The acoustic modem model: see channel.hpp for the rules.
//
// Transmitter timeline: Transmit(now_s) replays the transmitter from where it stopped. A
// transmission starts at t0 = max(transmitter free, earliest queued frame) (with tdma: moved
// into the robot's next own slot), sends the best frame (priority, then FIFO) among those
// queued by t0, and ends when all its bits have left (with tdma: airtime accumulates only in
// own slots). A started transmission is committed: it stays at the front of the queue, marked
// by its delivered_s (NaN while queued), until its last bit has left, so later calls pick it up
// whatever their now_s. Frames whose wait exceeded max_wait_s when the transmitter could have taken
// them are dropped as expired.
#include "draco/middleware/channel.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace draco::middleware {
namespace {

// Kinds outside [1, kMaxKinds) are counted under kind 0 (never a valid message kind).
std::size_t KindIndex(std::uint8_t kind) { return kind < kMaxKinds ? kind : 0; }

std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// Uniform in [0, 1), a pure function of (seed, source, seq).
double LossDraw(std::uint64_t seed, std::uint16_t source, std::uint32_t seq) {
  const std::uint64_t h =
      SplitMix64(SplitMix64(seed) ^ ((static_cast<std::uint64_t>(source) << 32) | seq));
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

void AppendDouble(std::string& out, double v) {
  if (!std::isfinite(v)) {
    out += "null";
    return;
  }
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, res.ptr);
}

// Queued frames carry delivered_s = NaN; the frame being transmitted has its delivery time.
bool InFlight(const Frame& f) { return !std::isnan(f.delivered_s); }

}  // namespace

AcousticChannel::AcousticChannel(std::uint16_t robot_id, const ChannelOptions& options)
    : robot_id_(robot_id), options_(options) {
  if (!(options_.team_rate_bps > 0.0)) {
    throw std::invalid_argument("AcousticChannel: team_rate_bps must be > 0");
  }
  if (options_.team_size < 1)
    throw std::invalid_argument("AcousticChannel: team_size must be >= 1");
  if (options_.tdma && !(options_.slot_s > 0.0)) {
    throw std::invalid_argument("AcousticChannel: slot_s must be > 0 with tdma");
  }
  if (options_.latency_s < 0.0 || options_.max_wait_s < 0.0) {
    throw std::invalid_argument("AcousticChannel: latency_s and max_wait_s must be >= 0");
  }
}

bool AcousticChannel::Enqueue(Frame frame, double now_s) {
  KindStats& ks = stats_.by_kind[KindIndex(frame.kind)];
  const std::size_t bits = LinkBits(frame);
  if (frame.payload.size() > kMaxPayloadBytes || frame.kind == 0 || frame.kind >= kMaxKinds ||
      queued_bits_ + bits > options_.max_queue_bits) {
    ++ks.dropped_queue;
    return false;
  }
  frame.source = robot_id_;
  frame.seq = next_seq_++;
  frame.enqueued_s = now_s;
  frame.delivered_s = std::numeric_limits<double>::quiet_NaN();  // set when transmission starts
  // Sorted by priority, FIFO within a priority; an in-flight frame (at the front) stays first.
  auto it = queue_.begin();
  if (it != queue_.end() && InFlight(*it)) ++it;
  it = std::upper_bound(it, queue_.end(), frame.priority,
                        [](std::uint8_t p, const Frame& f) { return p < f.priority; });
  queue_.insert(it, std::move(frame));
  queued_bits_ += bits;
  return true;
}

std::size_t AcousticChannel::DropWaiting(std::uint8_t kind, std::uint16_t destination) {
  std::size_t n = 0;
  for (auto it = queue_.begin(); it != queue_.end();) {
    if (!InFlight(*it) && it->kind == kind && it->destination == destination) {
      queued_bits_ -= LinkBits(*it);
      it = queue_.erase(it);
      ++n;
    } else {
      ++it;
    }
  }
  stats_.by_kind[KindIndex(kind)].superseded += n;
  return n;
}

std::vector<Frame> AcousticChannel::Transmit(double now_s) {
  std::vector<Frame> out;
  const double own_rate =
      options_.tdma ? options_.team_rate_bps : options_.team_rate_bps / options_.team_size;
  const double cycle_s = options_.slot_s * options_.team_size;
  const double slot_offset_s = options_.slot_s * (robot_id_ % options_.team_size);
  // tdma: the own slot [start, end) containing t, or the next one.
  auto own_slot = [&](double t) {
    const double k = std::floor((t - slot_offset_s) / cycle_s);
    double start = k * cycle_s + slot_offset_s;
    if (t >= start + options_.slot_s) start += cycle_s;
    return std::pair<double, double>(start, start + options_.slot_s);
  };
  auto earliest_start = [&](double t) {
    if (!options_.tdma) return t;
    const auto [start, end] = own_slot(t);
    return std::max(t, start);
  };
  auto finish_time = [&](double start, double airtime) {
    if (!options_.tdma) return start + airtime;
    double t = start;
    for (;;) {
      const auto [slot_start, slot_end] = own_slot(t);
      t = std::max(t, slot_start);
      if (airtime <= slot_end - t) return t + airtime;
      airtime -= slot_end - t;
      t = slot_end;  // own_slot(slot_end) is the next cycle's slot
    }
  };

  for (;;) {
    if (queue_.empty()) break;
    Frame& head = queue_.front();
    if (InFlight(head)) {
      if (transmitter_free_s_ > now_s) break;
      const bool lost =
          LossDraw(options_.loss_seed, head.source, head.seq) < options_.loss_probability;
      queued_bits_ -= LinkBits(head);
      if (!lost) out.push_back(std::move(head));
      queue_.pop_front();
      continue;
    }
    double earliest_enqueue = std::numeric_limits<double>::infinity();
    for (const Frame& f : queue_) earliest_enqueue = std::min(earliest_enqueue, f.enqueued_s);
    const double t0 = earliest_start(std::max(transmitter_free_s_, earliest_enqueue));
    if (t0 > now_s) break;
    // Frames that waited longer than max_wait_s before the transmitter could take them.
    bool expired_any = false;
    for (auto it = queue_.begin(); it != queue_.end();) {
      if (t0 - it->enqueued_s > options_.max_wait_s) {
        ++stats_.by_kind[KindIndex(it->kind)].dropped_expired;
        queued_bits_ -= LinkBits(*it);
        it = queue_.erase(it);
        expired_any = true;
      } else {
        ++it;
      }
    }
    if (expired_any) continue;  // the earliest frame may have changed
    auto chosen = std::find_if(queue_.begin(), queue_.end(),
                               [&](const Frame& f) { return f.enqueued_s <= t0; });
    Frame frame = std::move(*chosen);
    queue_.erase(chosen);
    const std::size_t bits = LinkBits(frame);
    const double airtime = static_cast<double>(bits) / own_rate;
    const double end = finish_time(t0, airtime);
    const bool lost =
        LossDraw(options_.loss_seed, frame.source, frame.seq) < options_.loss_probability;
    KindStats& ks = stats_.by_kind[KindIndex(frame.kind)];
    ++ks.frames_sent;
    ks.bits_sent += bits;
    ks.max_bits = std::max<std::uint64_t>(ks.max_bits, bits);
    if (lost) ++ks.lost;
    stats_.busy_s += airtime;
    stats_.traffic.push_back(TrafficRecord{.start_s = t0,
                                           .end_s = end,
                                           .kind = frame.kind,
                                           .bits = static_cast<std::uint32_t>(bits),
                                           .lost = lost});
    transmitter_free_s_ = end;
    frame.delivered_s = end + options_.latency_s;
    queue_.push_front(std::move(frame));
  }
  // Frames still waiting at now_s that have waited too long (an in-flight frame is committed).
  for (auto it = queue_.begin(); it != queue_.end();) {
    if (!InFlight(*it) && now_s - it->enqueued_s > options_.max_wait_s) {
      ++stats_.by_kind[KindIndex(it->kind)].dropped_expired;
      queued_bits_ -= LinkBits(*it);
      it = queue_.erase(it);
    } else {
      ++it;
    }
  }
  return out;
}

void AcousticChannel::CountReceived(std::uint8_t kind, std::size_t bits) {
  KindStats& ks = stats_.by_kind[KindIndex(kind)];
  ++ks.frames_received;
  ks.bits_received += bits;
}

void AcousticChannel::CountRejected(std::uint8_t kind) {
  ++stats_.by_kind[KindIndex(kind)].rejected;
}

bool Inbox::Add(Frame frame) {
  if (!std::isfinite(frame.delivered_s)) return false;  // would break the ordering
  auto key = std::make_tuple(frame.delivered_s, frame.source, frame.seq);
  return held_.try_emplace(key, std::move(frame)).second;  // a duplicate keeps the first
}

std::vector<Frame> Inbox::Due(double now_s) {
  std::vector<Frame> out;
  auto it = held_.begin();
  while (it != held_.end() && std::get<0>(it->first) <= now_s) {
    out.push_back(std::move(it->second));
    it = held_.erase(it);
  }
  return out;
}

std::string TrafficCsv(const LinkStats& stats, const std::vector<std::string>& names) {
  std::string out = "start_s,end_s,kind,bits,lost\n";
  for (const TrafficRecord& r : stats.traffic) {
    AppendDouble(out, r.start_s);
    out += ',';
    AppendDouble(out, r.end_s);
    out += ',';
    const std::string name = r.kind < names.size() ? names[r.kind] : "";
    out += name.empty() ? std::to_string(r.kind) : name;
    out += ',' + std::to_string(r.bits) + ',' + (r.lost ? "1" : "0") + '\n';
  }
  return out;
}

}  // namespace draco::middleware
