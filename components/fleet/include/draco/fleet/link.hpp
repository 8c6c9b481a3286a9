// One robot's end of the fleet link: turns what its team agent wants sent into compact frames
// (object-map deltas against what the teammates acknowledged, pose updates only for keyframes
// that moved, scans, requests, loops, heartbeats), queues them in the acoustic channel model,
// hands transmitted frames to the transport, and turns received frames back into checked
// messages. It tracks teammates: incarnations (a restart resets what is held of a teammate),
// silence, and, for replays over DDS, lock-step with the teammates' mission clocks.
//
// Delivery rule (the same over DDS and in-process): in its tick at time t a robot hands the
// transport the frames the modem finishes by t + tick_s, each marked with its delivery time
// max(last bit + latency, t + tick_s / 2); a receiver hands a frame out in its first tick at or
// after that time. So no robot sees a frame in the tick it was sent in, whatever order the
// robots' ticks run in, and a short message queued at t arrives at t + tick_s.
//
// Lock-step (replay over DDS only): after its tick at time t a robot sends a clock frame (not
// link traffic: it models the common clock real vehicles have) and waits, at most
// lockstep_timeout_s of wall time, until every teammate in step has finished its tick at
// t - tick_s. A teammate is in step while its clock is within max_lag_s behind; one that times
// out, says goodbye or falls behind is not waited for until it catches up again. A restarted
// daemon replays from the start at full speed and rejoins when it catches up. While it waits
// a robot repeats its clock frame (backing off to ClockRepeatCapS), so a lost clock frame
// (best-effort DDS on a lossy link) costs a repeat, not a lock-step timeout.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "draco/fleet/codec.hpp"
#include "draco/middleware/channel.hpp"
#include "draco/middleware/transport.hpp"
#include "draco/msgs/fleet.hpp"

namespace draco::fleet {

struct LinkOptions {
  int robot_id = 0;
  std::vector<int> team;          // every robot id of the team (own included); others are ignored
  std::uint32_t incarnation = 0;  // 0: drawn from the wall clock and pid at construction
  middleware::ChannelOptions channel;
  CodecOptions codec;
  Bounds bounds;
  ObjectDeltaOptions object_delta;
  PoseDeltaOptions pose_delta;
  double tick_s = 0.5;
  double heartbeat_period_s = 5.0;  // the shortest period (see heartbeat_max_share)
  // The team's heartbeats take at most this share of channel.team_rate_bps: on a slow link the
  // period grows (1 kbit/s, three robots: about 17 s), and silence_s and resend_map_s grow
  // with it (HeartbeatPeriodS). 0: heartbeats every heartbeat_period_s whatever the rate.
  double heartbeat_max_share = 0.05;
  double silence_s = 30.0;  // mission time without a frame: the teammate is silent
  bool lockstep = false;
  double lockstep_timeout_s = 10.0;  // wall seconds
  double startup_timeout_s = 30.0;   // wall seconds to discover every teammate (first tick)
  double max_lag_s = 2.0;      // a teammate further behind (restarted, stalled) is not waited for
  double resend_map_s = 10.0;  // own map sent again this often to a teammate that holds none
  // A new object-map update takes an older one still waiting in the channel's queue out of it
  // (it carries all the older one carries); false: every update is sent.
  bool supersede_maps = true;
  std::size_t max_held_frames = 4096;  // receiver inbox bound, shared equally by the teammates
};

// Lock-step clock repeats while waiting for teammates (their longest interval, seconds): the
// team's repeats together take at most a quarter of team_rate_bps, each repeat going to every
// teammate as its own datagram of clock_frame_bytes plus kClockDatagramOverheadBytes (UDP/IP
// and RTPS headers); never under 1 s. For three robots: 1 s at the paper's 62.5 kbit/s, 5.0 s
// at 5 kbit/s, 25 s at 1 kbit/s.
inline constexpr std::size_t kClockDatagramOverheadBytes = 100;
double ClockRepeatCapS(const LinkOptions& options, std::size_t clock_frame_bytes);

// The heartbeat period for a heartbeat frame of heartbeat_bits (header included): every robot
// of the team sending one per period takes at most heartbeat_max_share of the team's rate;
// never under heartbeat_period_s. A teammate is silent after max(silence_s, 6 periods), and
// the own map is sent again after max(resend_map_s, 2 periods): an acknowledgement rides on
// the teammate's next heartbeat.
double HeartbeatPeriodS(const LinkOptions& options, std::size_t heartbeat_bits);
inline constexpr double kSilencePeriods = 6.0;
inline constexpr double kResendPeriods = 2.0;

struct TeammateLinkState {
  int robot_id = 0;
  std::uint32_t incarnation = 0;
  bool known = false;
  bool silent = false;
  bool left = false;
  double last_heard_s = -1.0;       // own mission time of the last frame from it
  double clock_s = -1e300;          // its mission clock (lock-step)
  double timeout_clock_s = -1e300;  // its clock when a lock-step wait for it timed out
  bool hears_us = false;            // its clock frames say it hears us
  bool left_reported = false;
  std::uint32_t held_map_version = 0;   // of its object map
  std::uint32_t acked_own_version = 0;  // of our object map, from its heartbeats
  msgs::ObjectMap held_map;
  std::uint64_t frames_received = 0;
  std::uint64_t frames_rejected = 0;
  std::uint64_t base_mismatches = 0;
  std::size_t held_frames = 0;             // its frames in the inbox, not yet due
  std::vector<std::uint32_t> retired;      // its replaced incarnations (their frames: stale)
  double last_map_sent_s = -1e300;         // own object map last queued (for resends)
  int restarts = 0;                        // new incarnations seen after the first
  std::uint64_t frames_since_restart = 0;  // messages from the current incarnation
  // Header seq of the last message delivered, per kind, of the current incarnation: a message
  // whose seq is not above it is a replay (or older than one delivered) and is rejected.
  std::array<std::uint32_t, msgs::kNumFleetKinds> last_seq{};
};

struct LinkCounters {
  std::uint64_t unknown_robot = 0;  // frames from a robot id not in the team
  std::uint64_t not_for_us = 0;
  std::uint64_t rejected = 0;           // failed to decode or broke a bound
  std::uint64_t header_mismatch = 0;    // message header robot differs from the frame source
  std::uint64_t stale_incarnation = 0;  // frames of a teammate's replaced incarnation
  std::uint64_t replayed = 0;  // messages heard again, or older than one of their kind delivered
  std::uint64_t objects_left_out = 0;  // own objects the encoding's bounds cannot carry
  std::uint64_t inbox_overflow = 0;
  std::uint64_t encode_errors = 0;  // own messages that broke a bound (not sent)
  std::string last_encode_error;    // what the last such message broke
  std::uint64_t lockstep_timeouts = 0;
  double lockstep_wait_s = 0.0;  // wall seconds spent waiting
};

class LinkEndpoint {
 public:
  LinkEndpoint(const LinkOptions& options, std::unique_ptr<middleware::Transport> transport);
  ~LinkEndpoint();

  // One tick at mission time now_s: queue `outgoing` (may be null), transmit, receive,
  // deliver what is due. Never throws on what teammates sent.
  // `cancelled` (may be empty) is polled while lock-step waits: true ends the wait (SIGTERM).
  msgs::FleetIncoming Tick(double now_s, const msgs::FleetOutgoing* outgoing,
                           const std::function<bool()>& cancelled = {});
  // Last words: a goodbye clock frame (teammates stop waiting for this robot).
  void Close(double now_s);

  const middleware::LinkStats& stats() const { return channel_.stats(); }
  const LinkCounters& counters() const { return counters_; }
  const std::map<int, TeammateLinkState>& teammates() const { return teammates_; }
  // The heartbeat period in use (HeartbeatPeriodS), and the silence and resend times it sets.
  double heartbeat_period_s() const { return heartbeat_period_s_; }
  double silence_s() const;
  double resend_map_s() const;
  middleware::TransportCounters transport_counters() const;
  std::uint32_t incarnation() const { return options_.incarnation; }
  // Statistics as JSON: per kind (sent, received, bits, max), counters, teammates.
  std::string StatsJson() const;

 private:
  void Queue(msgs::FleetKind kind, int destination, std::vector<std::uint8_t> payload,
             double now_s);
  void QueueOutgoing(const msgs::FleetOutgoing& out, double now_s);
  void SendClock(double now_s, bool bye);
  void ReceiveAll(double now_s);
  std::string Who() const;  // "fleet link: robot 2: ", the start of its log lines
  void WaitForTeammates(double now_s, const std::function<bool()>& cancelled);
  bool InStep(const TeammateLinkState& t, double now_s) const;
  // False: a replaced incarnation (the frame is stale and dropped).
  bool NoteIncarnation(TeammateLinkState* t, std::uint32_t incarnation);
  void Deliver(const middleware::Frame& frame, double now_s, msgs::FleetIncoming* in);
  msgs::FleetHeader Header(msgs::FleetKind kind, double now_s);
  TeammateLinkState* Teammate(int robot_id);

  LinkOptions options_;
  std::unique_ptr<middleware::Transport> transport_;
  middleware::AcousticChannel channel_;
  middleware::Inbox inbox_;
  ObjectMapDeltaEncoder object_encoder_;
  KeyframePoseDeltaEncoder pose_encoder_;
  std::map<int, TeammateLinkState> teammates_;
  std::vector<msgs::TeammateEvent> pending_events_;
  std::uint32_t seq_[msgs::kNumFleetKinds] = {};
  double next_heartbeat_s_ = 0.0;
  double heartbeat_period_s_ = 0.0;  // HeartbeatPeriodS of the last heartbeat sent
  bool send_full_poses_ = false;
  msgs::ObjectMap last_map_;  // the newest own map and poses the agent gave
  bool has_last_map_ = false;
  std::vector<msgs::KeyframePoseEntry> last_poses_;
  bool has_last_poses_ = false;
  bool started_ = false;
  int own_keyframes_ = 0;
  std::vector<msgs::Heartbeat::Transform> transforms_;  // own, sent with each heartbeat
  LinkCounters counters_;
};

}  // namespace draco::fleet
