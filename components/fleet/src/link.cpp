#include "draco/fleet/link.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include <nlohmann/json.hpp>

#include "draco/log/log.hpp"

namespace draco::fleet {
namespace {

using middleware::Frame;
using msgs::FleetKind;

constexpr std::uint8_t kClockKind = 15;  // lock-step clock frames (replay only): not link traffic
constexpr std::size_t kClockBytes = 4 + 8 + 1 + 8;

// The channel sends the lowest value first, FIFO within a value. Heartbeats (liveness and the
// map acknowledgements that stop resends) and loops and requests (small) first; scan replies,
// object maps and keyframe poses share one level, in the order they were queued: replies below
// maps starve on a slow link (at 1 kbit/s for the team 309 of 411 replies expired in the queue
// on the marina, docs/fleet.md "What a slow link spends its bits on").
int Priority(FleetKind kind) {
  switch (kind) {
    case FleetKind::kHeartbeat:
      return 0;
    case FleetKind::kLoopClosures:
    case FleetKind::kScanRequest:
      return 1;
    case FleetKind::kScanReply:
    case FleetKind::kObjectMap:
    case FleetKind::kKeyframePoses:
      return 2;
  }
  return 2;
}

void PutU64(std::vector<std::uint8_t>* out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out->push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
std::uint64_t GetU64(const std::vector<std::uint8_t>& in, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(in[at + i]) << (8 * i);
  return v;
}

std::uint32_t DrawIncarnation() {
  const auto t = std::chrono::system_clock::now().time_since_epoch().count();
  std::uint64_t x = static_cast<std::uint64_t>(t) ^ (static_cast<std::uint64_t>(::getpid()) << 32);
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  const auto v = static_cast<std::uint32_t>(x);
  return v == 0 ? 1u : v;
}

}  // namespace

LinkEndpoint::LinkEndpoint(const LinkOptions& options,
                           std::unique_ptr<middleware::Transport> transport)
    : options_(options),
      transport_(std::move(transport)),
      channel_(static_cast<std::uint16_t>(options.robot_id), options.channel),
      object_encoder_(options.object_delta),
      pose_encoder_(options.pose_delta) {
  if (!transport_) throw std::invalid_argument("LinkEndpoint: no transport");
  if (options_.tick_s <= 0.0) throw std::invalid_argument("LinkEndpoint: tick_s must be > 0");
  if (options_.incarnation == 0) options_.incarnation = DrawIncarnation();
  heartbeat_period_s_ = options_.heartbeat_period_s;
  if (options_.robot_id < 0 || options_.robot_id > 63) {
    throw std::invalid_argument("LinkEndpoint: robot id " + std::to_string(options_.robot_id) +
                                " outside 0..63");
  }
  for (int id : options_.team) {
    if (id == options_.robot_id) continue;
    if (id < 0 || id > std::min(63, options_.bounds.max_robot_id)) {
      throw std::invalid_argument("LinkEndpoint: robot id " + std::to_string(id) + " outside 0.." +
                                  std::to_string(options_.bounds.max_robot_id));
    }
    teammates_[id].robot_id = id;
  }
}

LinkEndpoint::~LinkEndpoint() = default;

middleware::TransportCounters LinkEndpoint::transport_counters() const {
  return transport_->counters();
}

TeammateLinkState* LinkEndpoint::Teammate(int robot_id) {
  auto it = teammates_.find(robot_id);
  return it == teammates_.end() ? nullptr : &it->second;
}

msgs::FleetHeader LinkEndpoint::Header(FleetKind kind, double now_s) {
  msgs::FleetHeader h;
  h.robot_id = options_.robot_id;
  h.incarnation = options_.incarnation;
  h.seq = ++seq_[static_cast<int>(kind)];
  h.time_s = now_s;
  return h;
}

void LinkEndpoint::Queue(FleetKind kind, int destination, std::vector<std::uint8_t> payload,
                         double now_s) {
  Frame f;
  f.destination =
      destination < 0 ? middleware::kBroadcast : static_cast<std::uint16_t>(destination);
  f.kind = static_cast<std::uint8_t>(kind);
  f.priority = static_cast<std::uint8_t>(Priority(kind));
  f.payload = std::move(payload);
  channel_.Enqueue(std::move(f), now_s);
}

void LinkEndpoint::QueueOutgoing(const msgs::FleetOutgoing& given, double now_s) {
  // The newest own map and poses are kept, so a teammate that joins or restarts after they
  // stopped changing (e.g. our recording ended) still gets them.
  msgs::FleetOutgoing out = given;
  if (out.has_transforms) transforms_ = out.transforms;  // sent with every heartbeat
  if (out.has_poses) {
    for (auto& p : out.poses) p.num_points = std::min(p.num_points, options_.bounds.max_points);
    last_poses_ = out.poses;
    has_last_poses_ = true;
  } else if (send_full_poses_ && has_last_poses_) {
    out.has_poses = true;
    out.poses = last_poses_;
  }
  if (out.has_object_map) {
    // Objects the encoding cannot carry (beyond the coordinate or side bounds, or past the
    // count bound: the smallest go) are left out, so one odd object never stops map sharing.
    const Bounds& b = options_.bounds;
    auto& objects = out.object_map.objects;
    const auto unsendable = [&b](const msgs::Object& o) {
      return !(std::abs(o.center.x_m) <= b.max_abs_coordinate_m &&
               std::abs(o.center.y_m) <= b.max_abs_coordinate_m && o.length_m >= 0.0 &&
               o.length_m <= b.max_object_side_m && o.breadth_m >= 0.0 &&
               o.breadth_m <= b.max_object_side_m);
    };
    const std::size_t before = objects.size();
    objects.erase(std::remove_if(objects.begin(), objects.end(), unsendable), objects.end());
    if (objects.size() > static_cast<std::size_t>(b.max_objects)) {
      std::stable_sort(objects.begin(), objects.end(),
                       [](const auto& x, const auto& y) { return x.num_points > y.num_points; });
      objects.resize(static_cast<std::size_t>(b.max_objects));
      std::sort(objects.begin(), objects.end(),
                [](const auto& x, const auto& y) { return x.id < y.id; });
    }
    counters_.objects_left_out += before - objects.size();
    last_map_ = out.object_map;
    has_last_map_ = true;
  } else if (has_last_map_) {
    // A listening teammate that does not hold our newest map (joined, restarted, lost the
    // full map, or missed the last updates while its link was down and our map stopped
    // changing since): send it again, at most every resend_map_s (a delta from the version it
    // holds when that is still known).
    for (const auto& [id, t] : teammates_) {
      if (t.known && !t.left && !t.silent && t.acked_own_version != object_encoder_.version() &&
          now_s - t.last_map_sent_s >= resend_map_s()) {
        out.has_object_map = true;
        out.object_map = last_map_;
      }
    }
  }
  bool anyone = false;
  for (const auto& [id, t] : teammates_) anyone = anyone || (t.known && !t.left);
  if (out.has_poses) own_keyframes_ = static_cast<int>(out.poses.size());
  if (!anyone) return;  // nobody listening yet: keep the deltas for the first contact
  // One message that breaks a bound is counted and not sent; the others go.
  auto queue = [&](FleetKind kind, int destination, const auto& message) {
    try {
      Queue(kind, destination, Encode(message, options_.codec), now_s);
    } catch (const std::exception& e) {
      ++counters_.encode_errors;
      counters_.last_encode_error = std::string(msgs::FleetKindName(kind)) + ": " + e.what();
    }
  };
  if (out.has_poses) {
    msgs::KeyframePoses update;
    if (pose_encoder_.MakeUpdate(out.poses, send_full_poses_, &update)) {
      update.header = Header(FleetKind::kKeyframePoses, now_s);
      queue(FleetKind::kKeyframePoses, -1, update);
    }
    send_full_poses_ = false;
  }
  if (out.has_object_map) {
    // Delta against the version every listening teammate holds; full when they differ.
    std::uint32_t base = 0;
    bool first = true;
    for (const auto& [id, t] : teammates_) {
      if (!t.known || t.left || t.silent) continue;  // a silent one's stale ack would force full
      if (first) {
        base = t.acked_own_version;
        first = false;
      } else if (t.acked_own_version != base) {
        base = 0;
      }
    }
    msgs::ObjectMapUpdate update;
    if (object_encoder_.MakeUpdate(out.object_map, base, &update)) {
      // An update still waiting in the queue is older and against the same or an older
      // acknowledged version: this one carries all it carries (a slow link sends the newest
      // map, not every map).
      if (options_.supersede_maps) {
        channel_.DropWaiting(static_cast<std::uint8_t>(FleetKind::kObjectMap),
                             middleware::kBroadcast);
      }
      update.header = Header(FleetKind::kObjectMap, now_s);
      queue(FleetKind::kObjectMap, -1, update);
      for (auto& [id, t] : teammates_) t.last_map_sent_s = now_s;
    }
  }
  for (auto r : out.requests) {
    r.header = Header(FleetKind::kScanRequest, now_s);
    queue(FleetKind::kScanRequest, r.target_robot, r);
  }
  for (auto r : out.replies) {
    r.header = Header(FleetKind::kScanReply, now_s);
    queue(FleetKind::kScanReply, r.requester_robot, r);
  }
  for (const auto& all : out.loops) {
    // At most max_loops per message: a large batch (a filter rebuild) goes in several.
    const std::size_t chunk = static_cast<std::size_t>(std::max(1, options_.bounds.max_loops));
    for (std::size_t begin = 0; begin < all.loops.size() || begin == 0; begin += chunk) {
      auto l = all;
      l.loops.assign(all.loops.begin() + static_cast<std::ptrdiff_t>(begin),
                     all.loops.begin() +
                         static_cast<std::ptrdiff_t>(std::min(all.loops.size(), begin + chunk)));
      l.header = Header(FleetKind::kLoopClosures, now_s);
      queue(FleetKind::kLoopClosures, l.target_robot, l);
    }
  }
}

void LinkEndpoint::SendClock(double now_s, bool bye) {
  Frame f;
  f.source = static_cast<std::uint16_t>(options_.robot_id);
  f.kind = kClockKind;
  f.enqueued_s = f.delivered_s = now_s;
  std::uint64_t heard = 0;
  for (const auto& [id, t] : teammates_) {
    if (t.known && id < 64) heard |= 1ULL << id;
  }
  PutU64(&f.payload, options_.incarnation, 4);
  std::uint64_t bits = 0;
  std::memcpy(&bits, &now_s, sizeof bits);
  PutU64(&f.payload, bits, 8);
  f.payload.push_back(bye ? 1 : 0);
  PutU64(&f.payload, heard, 8);
  transport_->Send(f);
}

std::string LinkEndpoint::Who() const {
  return "fleet link: robot " + std::to_string(options_.robot_id) + ": ";
}

void LinkEndpoint::ReceiveAll(double now_s) {
  for (auto& f : transport_->Receive()) {
    TeammateLinkState* t = Teammate(f.source);
    if (t == nullptr) {
      ++counters_.unknown_robot;
      log::Warn(Who() + "ignored a frame from robot " + std::to_string(f.source) +
                " (not in the team)");
      continue;
    }
    if (f.destination != middleware::kBroadcast && f.destination != options_.robot_id) {
      ++counters_.not_for_us;
      continue;
    }
    if (f.kind == kClockKind) {
      if (f.payload.size() != kClockBytes) {
        ++counters_.rejected;
        continue;
      }
      const auto inc = static_cast<std::uint32_t>(GetU64(f.payload, 0, 4));
      const std::uint64_t bits = GetU64(f.payload, 4, 8);
      double clock = 0.0;
      std::memcpy(&clock, &bits, sizeof clock);
      if (!std::isfinite(clock) || inc == 0) {
        ++counters_.rejected;
        continue;
      }
      if (!NoteIncarnation(t, inc)) continue;
      t->clock_s = std::max(t->clock_s, clock);  // a late repeat never turns it back
      t->left = f.payload[12] != 0;
      t->hears_us = ((GetU64(f.payload, 13, 8) >> options_.robot_id) & 1ULL) != 0;
      t->last_heard_s = now_s;
      if (t->silent) send_full_poses_ = true;  // back from silence: it missed pose updates
      t->silent = false;
      continue;
    }
    // Each teammate gets its share of the inbox: one that floods it (or stamps frames far in
    // the future) cannot crowd out the others.
    const std::size_t share = std::max<std::size_t>(
        1, options_.max_held_frames / std::max<std::size_t>(1, teammates_.size()));
    if (t->held_frames >= share) {
      ++counters_.inbox_overflow;
      continue;
    }
    if (inbox_.Add(std::move(f))) ++t->held_frames;
  }
}

bool LinkEndpoint::NoteIncarnation(TeammateLinkState* t, std::uint32_t incarnation) {
  if (t->known && incarnation == t->incarnation) return true;
  // Frames of an incarnation that was replaced (still in flight, or held in the inbox) are
  // stale: they must not switch the teammate back.
  if (std::find(t->retired.begin(), t->retired.end(), incarnation) != t->retired.end()) {
    ++counters_.stale_incarnation;
    return false;
  }
  if (t->known) {
    t->retired.push_back(t->incarnation);
    if (t->retired.size() > 8) t->retired.erase(t->retired.begin());
  }
  const bool restarted = t->known;
  pending_events_.push_back(
      {t->robot_id, incarnation,
       restarted ? msgs::TeammateEventKind::kRestarted : msgs::TeammateEventKind::kJoined});
  if (restarted) ++t->restarts;
  log::Info(Who() + "teammate " + std::to_string(t->robot_id) +
            (restarted ? " restarted" : " joined") + " (incarnation " +
            std::to_string(incarnation) + ")");
  t->incarnation = incarnation;
  t->known = true;
  t->left = false;
  t->left_reported = false;
  t->held_map = {};
  t->held_map_version = 0;
  t->acked_own_version = 0;
  t->timeout_clock_s = -1e300;
  t->clock_s = -1e300;
  t->frames_since_restart = 0;
  t->last_seq = {};
  t->last_map_sent_s = -1e300;
  send_full_poses_ = true;
  return true;
}

bool LinkEndpoint::InStep(const TeammateLinkState& t, double now_s) const {
  return t.known && !t.left && t.clock_s >= now_s - options_.max_lag_s &&
         t.clock_s > t.timeout_clock_s;
}

double ClockRepeatCapS(const LinkOptions& options, std::size_t clock_frame_bytes) {
  const double robots = static_cast<double>(std::max<std::size_t>(options.team.size(), 2));
  const double bits_per_round =
      robots * (robots - 1.0) * 8.0 *
      static_cast<double>(clock_frame_bytes + kClockDatagramOverheadBytes);
  const double rate_bps = options.channel.team_rate_bps;
  if (!(rate_bps > 0.0) || !std::isfinite(rate_bps)) return 1.0;
  return std::max(1.0, bits_per_round / (0.25 * rate_bps));
}

double HeartbeatPeriodS(const LinkOptions& options, std::size_t heartbeat_bits) {
  const double robots = static_cast<double>(std::max<std::size_t>(options.team.size(), 2));
  const double rate_bps = options.channel.team_rate_bps;
  const double share = options.heartbeat_max_share;
  if (!(rate_bps > 0.0) || !std::isfinite(rate_bps) || !(share > 0.0)) {
    return options.heartbeat_period_s;
  }
  return std::max(options.heartbeat_period_s,
                  robots * static_cast<double>(heartbeat_bits) / (share * rate_bps));
}

double LinkEndpoint::silence_s() const {
  return std::max(options_.silence_s, kSilencePeriods * heartbeat_period_s_);
}

double LinkEndpoint::resend_map_s() const {
  return std::max(options_.resend_map_s, kResendPeriods * heartbeat_period_s_);
}

void LinkEndpoint::WaitForTeammates(double now_s, const std::function<bool()>& cancelled) {
  const auto start = std::chrono::steady_clock::now();
  auto last_clock = start;
  // Repeats of the clock frame: while discovering, from 50 ms; once running, from 1 s (the
  // frame sent after the tick usually arrives); doubling up to a cap that keeps the team's
  // repeats within a quarter of the link's rate.
  const double cap_s = ClockRepeatCapS(options_, middleware::kFrameHeaderBits / 8 + kClockBytes);
  double clock_interval_s = started_ ? std::min(1.0, cap_s) : 0.05;
  const double need = now_s - 1.5 * options_.tick_s;
  while (true) {
    bool ready = true;
    for (const auto& [id, t] : teammates_) {
      if (!started_) {
        // First tick: every teammate must be there and hear us (DDS discovery is not
        // instantaneous; frames sent before it completes would be lost).
        if (!t.known || !t.hears_us) ready = false;
      } else if (InStep(t, now_s) && t.clock_s <= need) {
        ready = false;
      }
    }
    if (ready || (cancelled && cancelled())) break;
    const auto now = std::chrono::steady_clock::now();
    const double waited = std::chrono::duration<double>(now - start).count();
    const double limit = started_ ? options_.lockstep_timeout_s : options_.startup_timeout_s;
    if (waited > limit) {
      for (auto& [id, t] : teammates_) {
        if (started_ ? (InStep(t, now_s) && t.clock_s <= need) : (!t.known || !t.hears_us)) {
          t.timeout_clock_s = t.clock_s;
          ++counters_.lockstep_timeouts;
        }
      }
      break;
    }
    if (std::chrono::duration<double>(now - last_clock).count() > clock_interval_s) {
      // Discovery: a teammate's reader may have matched since. Running: the clock frame or
      // the teammate's may have been lost (best-effort DDS); with reliable DDS a repeat is
      // one small sample a second at most. Backing off, so that on a slow link the repeats
      // (and their reliable resends) do not fill it.
      SendClock(now_s, false);
      last_clock = now;
      clock_interval_s = std::min(cap_s, 2.0 * clock_interval_s);
    }
    std::this_thread::sleep_for(std::chrono::microseconds(500));
    ReceiveAll(now_s);
  }
  counters_.lockstep_wait_s +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  started_ = true;
}

void LinkEndpoint::Deliver(const Frame& f, double now_s, msgs::FleetIncoming* in) {
  TeammateLinkState* t = Teammate(f.source);
  if (t == nullptr) return;
  const auto kind = static_cast<FleetKind>(f.kind);
  const std::size_t bits = middleware::LinkBits(f);
  auto reject = [&]() {
    log::Warn(Who() + "rejected a " + std::string(msgs::FleetKindName(kind)) +
              " frame from robot " + std::to_string(f.source) +
              " (does not decode, breaks a bound or names another sender)");
    ++counters_.rejected;
    ++t->frames_rejected;
    channel_.CountRejected(f.kind);
  };
  auto check_header = [&](const msgs::FleetHeader& h) {
    if (h.robot_id != f.source) {
      ++counters_.header_mismatch;
      reject();
      return false;
    }
    if (!NoteIncarnation(t, h.incarnation)) return false;
    // Per kind, a teammate's messages carry increasing seqs and the channel keeps their order:
    // one not above the last delivered is a replay or a stale copy.
    std::uint32_t& last_seq = t->last_seq[static_cast<std::size_t>(kind)];
    if (h.seq <= last_seq) {
      ++counters_.replayed;
      ++t->frames_rejected;
      channel_.CountRejected(f.kind);
      return false;
    }
    last_seq = h.seq;
    t->last_heard_s = now_s;
    if (t->silent) send_full_poses_ = true;  // back from silence: it missed pose updates
    t->silent = false;
    ++t->frames_received;
    ++t->frames_since_restart;
    channel_.CountReceived(f.kind, bits);
    return true;
  };
  switch (kind) {
    case FleetKind::kHeartbeat: {
      msgs::Heartbeat m;
      if (!Decode(f.payload, &m, options_.codec, options_.bounds)) return reject();
      if (!check_header(m.header)) return;
      for (const auto& a : m.acks) {
        if (a.robot_id == options_.robot_id && a.incarnation == options_.incarnation) {
          t->acked_own_version = a.object_map_version;
        }
      }
      if (!m.transforms.empty()) in->transforms.push_back({m.header, std::move(m.transforms)});
      return;
    }
    case FleetKind::kObjectMap: {
      msgs::ObjectMapUpdate m;
      if (!Decode(f.payload, &m, options_.codec, options_.bounds)) return reject();
      if (!check_header(m.header)) return;
      msgs::ObjectMap merged = t->held_map;
      std::uint32_t version = t->held_map_version;
      if (!ApplyObjectMapUpdate(m, &merged, &version)) {
        ++t->base_mismatches;
        return;
      }
      if (merged.objects.size() > static_cast<std::size_t>(options_.bounds.max_objects)) {
        return reject();  // deltas that grow the held map past the bound: never trusted
      }
      t->held_map = std::move(merged);
      t->held_map_version = version;
      t->held_map.robot_id = t->robot_id;
      t->held_map.time_s = m.header.time_s;
      in->object_maps.push_back({m.header, t->held_map_version, t->held_map});
      return;
    }
    case FleetKind::kKeyframePoses: {
      msgs::KeyframePoses m;
      if (!Decode(f.payload, &m, options_.codec, options_.bounds)) return reject();
      if (!check_header(m.header)) return;
      in->poses.push_back(std::move(m));
      return;
    }
    case FleetKind::kScanRequest: {
      msgs::ScanRequest m;
      if (!Decode(f.payload, &m, options_.codec, options_.bounds)) return reject();
      if (!check_header(m.header)) return;
      if (m.target_robot == options_.robot_id) in->requests.push_back(std::move(m));
      return;
    }
    case FleetKind::kScanReply: {
      msgs::ScanReply m;
      if (!Decode(f.payload, &m, options_.codec, options_.bounds)) return reject();
      if (!check_header(m.header)) return;
      if (m.requester_robot == options_.robot_id) in->replies.push_back(std::move(m));
      return;
    }
    case FleetKind::kLoopClosures: {
      msgs::LoopClosureMessage m;
      if (!Decode(f.payload, &m, options_.codec, options_.bounds)) return reject();
      if (!check_header(m.header)) return;
      if (m.target_robot == options_.robot_id) in->loops.push_back(std::move(m));
      return;
    }
  }
  reject();  // unknown kind
}

msgs::FleetIncoming LinkEndpoint::Tick(double now_s, const msgs::FleetOutgoing* outgoing,
                                       const std::function<bool()>& cancelled) {
  // Every tick, also without news: a teammate that joined or restarted may need the last map
  // and poses again.
  static const msgs::FleetOutgoing kNothing;
  QueueOutgoing(outgoing != nullptr ? *outgoing : kNothing, now_s);
  if (now_s >= next_heartbeat_s_) {
    next_heartbeat_s_ = now_s + heartbeat_period_s_;
    msgs::Heartbeat hb;
    hb.header = Header(FleetKind::kHeartbeat, now_s);
    hb.num_keyframes = own_keyframes_;
    for (const auto& [id, t] : teammates_) {
      if (t.known && !t.left) hb.acks.push_back({id, t.incarnation, t.held_map_version});
    }
    hb.transforms = transforms_;
    try {
      std::vector<std::uint8_t> payload = Encode(hb, options_.codec);
      heartbeat_period_s_ =
          HeartbeatPeriodS(options_, middleware::kFrameHeaderBits + 8 * payload.size());
      next_heartbeat_s_ = now_s + heartbeat_period_s_;
      Queue(FleetKind::kHeartbeat, -1, std::move(payload), now_s);
    } catch (const std::exception& e) {
      ++counters_.encode_errors;
      counters_.last_encode_error = std::string("heartbeat: ") + e.what();
    }
  }
  // The modem works between ticks: what finishes by the next tick is handed over now, marked
  // with its true delivery time (the receivers hold it until then). Never delivered in the
  // tick it was sent in (see the header): the same behaviour whatever order the robots' ticks
  // run in.
  for (auto& f : channel_.Transmit(now_s + options_.tick_s)) {
    f.delivered_s = std::max(f.delivered_s, now_s + 0.5 * options_.tick_s);
    transport_->Send(f);
  }
  if (options_.lockstep) SendClock(now_s, false);
  ReceiveAll(now_s);
  if (options_.lockstep) WaitForTeammates(now_s, cancelled);

  msgs::FleetIncoming in;
  in.time_s = now_s;
  for (const auto& f : inbox_.Due(now_s)) {
    if (TeammateLinkState* t = Teammate(f.source); t != nullptr && t->held_frames > 0) {
      --t->held_frames;
    }
    Deliver(f, now_s, &in);
  }
  for (auto& [id, t] : teammates_) {
    if (t.known && !t.silent && !t.left && t.last_heard_s >= 0.0 &&
        now_s - t.last_heard_s > silence_s()) {
      t.silent = true;
      pending_events_.push_back({id, t.incarnation, msgs::TeammateEventKind::kSilent});
      log::Warn(Who() + "teammate " + std::to_string(id) + " silent for " +
                std::to_string(now_s - t.last_heard_s) + " s of mission time");
    }
    if (t.left && !t.left_reported) {
      t.left_reported = true;
      pending_events_.push_back({id, t.incarnation, msgs::TeammateEventKind::kLeft});
      log::Info(Who() + "teammate " + std::to_string(id) + " left");
    }
  }
  in.events = std::move(pending_events_);
  pending_events_.clear();
  return in;
}

void LinkEndpoint::Close(double now_s) { SendClock(now_s, true); }

std::string LinkEndpoint::StatsJson() const {
  using nlohmann::json;
  const auto& s = channel_.stats();
  json kinds = json::object();
  for (int k = 1; k < msgs::kNumFleetKinds; ++k) {
    const auto& ks = s.by_kind[k];
    kinds[msgs::FleetKindName(static_cast<FleetKind>(k))] = {
        {"frames_sent", ks.frames_sent},
        {"bits_sent", ks.bits_sent},
        {"mean_bits", ks.frames_sent ? static_cast<double>(ks.bits_sent) / ks.frames_sent : 0.0},
        {"max_bits", ks.max_bits},
        {"dropped_queue", ks.dropped_queue},
        {"dropped_expired", ks.dropped_expired},
        {"superseded", ks.superseded},
        {"lost", ks.lost},
        {"frames_received", ks.frames_received},
        {"bits_received", ks.bits_received},
        {"rejected", ks.rejected}};
  }
  const auto tc = transport_->counters();
  json teammates = json::array();
  for (const auto& [id, t] : teammates_) {
    teammates.push_back({{"robot_id", id},
                         {"known", t.known},
                         {"incarnation", t.incarnation},
                         {"frames_received", t.frames_received},
                         {"frames_rejected", t.frames_rejected},
                         {"base_mismatches", t.base_mismatches},
                         {"restarts", t.restarts},
                         {"frames_since_restart", t.frames_since_restart},
                         {"held_map_version", t.held_map_version},
                         {"acked_own_version", t.acked_own_version}});
  }
  const json out = {{"robot_id", options_.robot_id},
                    {"incarnation", options_.incarnation},
                    {"transport", transport_->Describe()},
                    {"team_rate_bps", options_.channel.team_rate_bps},
                    {"heartbeat_period_s", heartbeat_period_s_},
                    {"busy_s", s.busy_s},
                    {"kinds", kinds},
                    {"counters",
                     {{"unknown_robot", counters_.unknown_robot},
                      {"not_for_us", counters_.not_for_us},
                      {"rejected", counters_.rejected},
                      {"header_mismatch", counters_.header_mismatch},
                      {"stale_incarnation", counters_.stale_incarnation},
                      {"replayed", counters_.replayed},
                      {"objects_left_out", counters_.objects_left_out},
                      {"inbox_overflow", counters_.inbox_overflow},
                      {"encode_errors", counters_.encode_errors},
                      {"last_encode_error", counters_.last_encode_error},
                      {"lockstep_timeouts", counters_.lockstep_timeouts},
                      {"lockstep_wait_s", counters_.lockstep_wait_s},
                      {"transport_frames_sent", tc.frames_sent},
                      {"transport_frames_received", tc.frames_received},
                      {"transport_frames_malformed", tc.frames_malformed},
                      {"transport_frames_own", tc.frames_own},
                      {"transport_peers_lost", tc.peers_lost},
                      {"transport_send_failed", tc.send_failed}}},
                    {"teammates", teammates}};
  return out.dump(2) + "\n";
}

}  // namespace draco::fleet
