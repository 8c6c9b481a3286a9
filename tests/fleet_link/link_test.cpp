// fleet::LinkEndpoint over the in-process bus: what one robot queues reaches its teammates
// (object maps as deltas, poses, requests, replies, loops) at the delivery rule's times;
// restarts, unknown robots and garbage are handled; lock-step waits for a lagging teammate.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <map>
#include <thread>

#include "draco/fleet/link.hpp"
#include "draco/graph/graph.hpp"
#include "draco/middleware/transport.hpp"

namespace draco::fleet {
namespace {

std::string Bus() {
  static int n = 0;
  return "link_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
         std::to_string(n++);
}

LinkOptions Options(int id, std::uint32_t incarnation) {
  LinkOptions o;
  o.robot_id = id;
  o.team = {0, 1, 2};
  o.incarnation = incarnation;
  o.channel.team_size = 3;
  o.channel.latency_s = 0.1;
  o.tick_s = 0.5;
  o.heartbeat_period_s = 2.0;
  return o;
}

msgs::ObjectMap Map(int n, double shift_m) {
  msgs::ObjectMap m;
  for (int i = 0; i < n; ++i) {
    msgs::Object o;
    o.id = static_cast<std::uint32_t>(10 + i);
    o.center = {3.0 * i + shift_m, -2.0 * i};
    o.rect_center = o.center;
    o.length_m = 2.0 + 0.1 * i;
    o.breadth_m = 1.0;
    o.yaw_rad = 0.3;
    o.num_points = 50 + i;
    m.objects.push_back(o);
  }
  return m;
}

struct Team {
  explicit Team(const std::string& bus) {
    for (int i = 0; i < 3; ++i) {
      links.push_back(std::make_unique<LinkEndpoint>(Options(i, 100 + i),
                                                     middleware::MakeInProcessTransport(bus, i)));
    }
  }
  // Ticks every robot at t (robot 0 first); returns what each received.
  std::vector<msgs::FleetIncoming> Tick(double t,
                                        std::vector<const msgs::FleetOutgoing*> out = {}) {
    out.resize(3, nullptr);
    std::vector<msgs::FleetIncoming> in;
    for (int i = 0; i < 3; ++i) in.push_back(links[i]->Tick(t, out[i]));
    return in;
  }
  std::vector<std::unique_ptr<LinkEndpoint>> links;
};

TEST(LinkEndpoint, TeammatesJoinThroughHeartbeatsAndObjectMapsArriveAsDeltas) {
  Team team(Bus());
  // Heartbeats at t = 0 make everybody known.
  auto in = team.Tick(0.0);
  for (const auto& i : in) EXPECT_TRUE(i.events.empty());  // nothing delivered in the same tick
  in = team.Tick(0.5);
  for (int r = 0; r < 3; ++r) {
    ASSERT_EQ(in[r].events.size(), 2u) << "robot " << r;
    for (const auto& e : in[r].events) EXPECT_EQ(e.kind, msgs::TeammateEventKind::kJoined);
  }
  // Robot 0 sends its map: full the first time.
  msgs::FleetOutgoing out;
  out.has_object_map = true;
  out.object_map = Map(30, 0.0);
  in = team.Tick(1.0, {&out});
  EXPECT_TRUE(in[1].object_maps.empty());
  in = team.Tick(1.5);
  ASSERT_EQ(in[1].object_maps.size(), 1u);
  ASSERT_EQ(in[2].object_maps.size(), 1u);
  const auto& held = in[1].object_maps[0];
  EXPECT_EQ(held.header.robot_id, 0);
  ASSERT_EQ(held.map.objects.size(), 30u);
  EXPECT_NEAR(held.map.objects[7].center.x_m, 21.0, 0.05);
  const auto full_bits = team.links[0]->stats().by_kind[2].max_bits;
  // Heartbeats acknowledge version 1; a change of two objects then travels as a small delta.
  for (double t = 2.0; t <= 4.5; t += 0.5) team.Tick(t);
  out.object_map.objects[3].center.x_m += 1.0;
  out.object_map.objects[4].length_m += 1.0;
  team.Tick(5.0, {&out});
  in = team.Tick(5.5);
  ASSERT_EQ(in[2].object_maps.size(), 1u);
  EXPECT_NEAR(in[2].object_maps[0].map.objects[3].center.x_m, 10.0, 0.05);
  EXPECT_NEAR(in[2].object_maps[0].map.objects[4].length_m, 3.4, 0.06);
  const auto& k = team.links[0]->stats().by_kind[2];
  EXPECT_EQ(k.frames_sent, 2u);
  EXPECT_LT(k.bits_sent - full_bits, full_bits / 3) << "the delta is not small";
}

TEST(LinkEndpoint, RequestsRepliesAndLoopsReachOnlyTheirTarget) {
  Team team(Bus());
  team.Tick(0.0);
  team.Tick(0.5);
  msgs::FleetOutgoing out;
  msgs::ScanRequest req;
  req.target_robot = 2;
  req.object_ids = {10, 11};
  out.requests.push_back(req);
  msgs::ScanReply rep;
  rep.requester_robot = 1;
  rep.keyframe = 42;
  rep.points_kf = {{1.0, 2.0}, {3.0, -1.0}};
  out.replies.push_back(rep);
  team.Tick(1.0, {&out});
  const auto in = team.Tick(1.5);
  EXPECT_TRUE(in[1].requests.empty());
  ASSERT_EQ(in[2].requests.size(), 1u);
  EXPECT_EQ(in[2].requests[0].object_ids, (std::vector<std::uint32_t>{10, 11}));
  ASSERT_EQ(in[1].replies.size(), 1u);
  EXPECT_TRUE(in[2].replies.empty());
  EXPECT_EQ(in[1].replies[0].keyframe, 42);
  EXPECT_NEAR(in[1].replies[0].points_kf[1].x_m, 3.0, 0.05);
}

TEST(LinkEndpoint, ARestartIsNoticedAndTheMapIsSentAgainInFull) {
  const std::string bus = Bus();
  Team team(bus);
  msgs::FleetOutgoing out;
  out.has_object_map = true;
  out.object_map = Map(10, 0.0);
  team.Tick(0.0);
  team.Tick(0.5);
  team.Tick(1.0, {nullptr, &out});
  auto in = team.Tick(1.5);
  ASSERT_EQ(in[0].object_maps.size(), 1u);
  // Robot 1 restarts: new incarnation on the same bus.
  team.links[1].reset();
  team.links[1] =
      std::make_unique<LinkEndpoint>(Options(1, 999), middleware::MakeInProcessTransport(bus, 1));
  team.Tick(2.0);  // heartbeat of the new incarnation
  in = team.Tick(2.5);
  bool restarted = false;
  for (const auto& e : in[0].events) {
    restarted |=
        e.robot_id == 1 && e.kind == msgs::TeammateEventKind::kRestarted && e.incarnation == 999;
  }
  EXPECT_TRUE(restarted);
  EXPECT_EQ(team.links[0]->teammates().at(1).restarts, 1);
  EXPECT_EQ(team.links[0]->teammates().at(1).held_map_version, 0u);
  // The restarted robot sends its map again: full (its encoder starts over), accepted.
  team.Tick(3.0, {nullptr, &out});
  in = team.Tick(3.5);
  ASSERT_EQ(in[0].object_maps.size(), 1u);
  EXPECT_EQ(in[0].object_maps[0].map.objects.size(), 10u);
}

TEST(LinkEndpoint, GarbageAndStrangersAreCountedNeverDelivered) {
  const std::string bus = Bus();
  Team team(bus);
  auto stranger = middleware::MakeInProcessTransport(bus, 17);
  auto impostor = middleware::MakeInProcessTransport(bus, 2);  // robot 2's id, bad payloads
  team.Tick(0.0);
  middleware::Frame f;
  f.source = 17;
  f.kind = 1;
  f.delivered_s = 0.3;
  f.payload = {1, 2, 3};
  stranger->Send(f);
  f.source = 2;
  for (std::uint8_t kind = 1; kind <= 7; ++kind) {
    f.kind = kind;
    f.seq = kind;
    f.payload.assign(37, kind);
    impostor->Send(f);
  }
  const auto in = team.Tick(0.5);
  EXPECT_TRUE(in[0].object_maps.empty());
  EXPECT_TRUE(in[0].requests.empty());
  EXPECT_GE(team.links[0]->counters().unknown_robot, 1u);
  EXPECT_GE(team.links[0]->counters().rejected, 6u);
}

// Bad input (docs/hardening.md): a frame heard again (a replay, or a copy that took a longer
// path) and a message older than one already delivered are rejected and counted, never
// delivered twice or after their successor. Before, the same loop message was delivered twice.
TEST(LinkEndpoint, ReplayedAndOutOfOrderMessagesAreCountedNotDelivered) {
  const std::string bus = Bus();
  Team team(bus);
  auto impostor = middleware::MakeInProcessTransport(bus, 2);  // robot 2's id
  team.Tick(0.0);
  team.Tick(0.5);
  const auto frame = [](std::uint32_t seq, double delivered_s) {
    msgs::LoopClosureMessage m;
    m.header = {.robot_id = 2, .incarnation = 102, .seq = seq, .time_s = 0.5};
    m.target_robot = 0;
    msgs::InterRobotLoop l;
    l.id = seq;
    l.own_robot = 2;
    l.teammate_robot = 0;
    l.covariance = {0.01, 0, 0, 0, 0.01, 0, 0, 0, 0.001};
    m.loops.push_back(l);
    middleware::Frame f;
    f.kind = static_cast<std::uint8_t>(msgs::FleetKind::kLoopClosures);
    f.destination = 0;
    f.seq = 1000 + seq;
    f.delivered_s = delivered_s;
    f.payload = Encode(m);
    return f;
  };
  impostor->Send(frame(5, 0.8));
  auto in = team.Tick(1.0);
  ASSERT_EQ(in[0].loops.size(), 1u);
  impostor->Send(frame(5, 1.3));  // the same message again
  impostor->Send(frame(4, 1.3));  // an older one, late
  impostor->Send(frame(6, 1.3));  // the next one
  in = team.Tick(1.5);
  ASSERT_EQ(in[0].loops.size(), 1u);
  EXPECT_EQ(in[0].loops[0].header.seq, 6u);
  EXPECT_EQ(team.links[0]->counters().replayed, 2u);
  EXPECT_EQ(team.links[0]->teammates().at(2).frames_rejected, 2u);
}

TEST(LinkEndpoint, LockstepWaitsForALaggingTeammateAndStopsWaitingWhenItLeaves) {
  const std::string bus = Bus();
  LinkOptions a = Options(0, 1), b = Options(1, 2);
  a.team = b.team = {0, 1};
  a.channel.team_size = b.channel.team_size = 2;
  a.lockstep = b.lockstep = true;
  a.lockstep_timeout_s = b.lockstep_timeout_s = 10.0;
  LinkEndpoint la(a, middleware::MakeInProcessTransport(bus, 0));
  std::atomic<double> b_clock{-1.0};
  std::thread tb([&] {
    LinkEndpoint lb(b, middleware::MakeInProcessTransport(bus, 1));
    for (int k = 0; k <= 10; ++k) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));  // b is slow
      b_clock = 0.5 * k;
      lb.Tick(0.5 * k, nullptr);
    }
    lb.Close(5.0);
  });
  for (int k = 0; k <= 10; ++k) {
    la.Tick(0.5 * k, nullptr);
    // After its tick at t, a has waited for b's tick at t - 0.5.
    EXPECT_GE(b_clock.load(), 0.5 * k - 0.5 - 1e-9) << "a ran ahead at tick " << k;
  }
  tb.join();
  // b said goodbye: a goes on alone without waiting.
  const auto start = std::chrono::steady_clock::now();
  for (int k = 11; k <= 20; ++k) la.Tick(0.5 * k, nullptr);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  EXPECT_EQ(la.counters().lockstep_timeouts, 0u);
}

// Drops every clock frame (kind 15) a robot sends at the given mission times, as best-effort
// DDS on a lossy link would; everything else passes.
class DropClockFrames : public middleware::Transport {
 public:
  DropClockFrames(std::unique_ptr<middleware::Transport> inner, std::vector<double> times_s)
      : inner_(std::move(inner)), times_s_(std::move(times_s)) {}
  bool Send(const middleware::Frame& frame) override {
    if (frame.kind == 15 && frame.payload.size() >= 12) {
      double clock = 0.0;
      std::uint64_t bits = 0;
      for (int i = 0; i < 8; ++i) bits |= std::uint64_t{frame.payload[4 + i]} << (8 * i);
      std::memcpy(&clock, &bits, sizeof clock);
      for (double t : times_s_) {
        if (std::abs(t - clock) < 1e-9 && dropped_first_[t]++ == 0) return true;  // lost once
      }
    }
    return inner_->Send(frame);
  }
  std::vector<middleware::Frame> Receive() override { return inner_->Receive(); }
  std::string Describe() const override { return inner_->Describe(); }
  middleware::TransportCounters counters() const override { return inner_->counters(); }

 private:
  std::unique_ptr<middleware::Transport> inner_;
  std::vector<double> times_s_;
  std::map<double, int> dropped_first_;
};

TEST(LinkEndpoint, LockstepRepeatsALostClockFrameInsteadOfTimingOut) {
  // Both robots' clock frames of the ticks at 1.0 and 1.5 s are lost the first time they are
  // sent. After its tick at 1.5 s each waits for the other's tick at 1.0 s (clock >= 0.75 s)
  // and has heard only 0.5 s: only a repeat ends the wait before the timeout.
  const std::string bus = Bus();
  LinkOptions a = Options(0, 1), b = Options(1, 2);
  a.team = b.team = {0, 1};
  a.channel.team_size = b.channel.team_size = 2;
  a.lockstep = b.lockstep = true;
  a.lockstep_timeout_s = b.lockstep_timeout_s = 20.0;
  const std::vector<double> lost = {1.0, 1.5};
  LinkEndpoint la(
      a, std::make_unique<DropClockFrames>(middleware::MakeInProcessTransport(bus, 0), lost));
  std::thread tb([&] {
    LinkEndpoint lb(
        b, std::make_unique<DropClockFrames>(middleware::MakeInProcessTransport(bus, 1), lost));
    for (int k = 0; k <= 6; ++k) lb.Tick(0.5 * k, nullptr);
    lb.Close(3.0);
    EXPECT_EQ(lb.counters().lockstep_timeouts, 0u);
  });
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k <= 6; ++k) la.Tick(0.5 * k, nullptr);
  tb.join();
  EXPECT_EQ(la.counters().lockstep_timeouts, 0u);
  // One wait of a repeat (1 s), far from the 20 s timeout.
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10.0);
}

TEST(LinkEndpoint, ClockRepeatsKeepToAQuarterOfTheTeamRate) {
  LinkOptions o = Options(0, 1);
  const std::size_t frame_bytes = 29;  // 8-byte modem header + 21-byte clock payload
  // Three robots, six datagrams a round of (29 + 100) bytes: 6192 bits.
  o.channel.team_rate_bps = 5000.0;
  EXPECT_NEAR(ClockRepeatCapS(o, frame_bytes), 6192.0 / 1250.0, 1e-9);
  o.channel.team_rate_bps = 1000.0;
  EXPECT_NEAR(ClockRepeatCapS(o, frame_bytes), 6192.0 / 250.0, 1e-9);
  o.channel.team_rate_bps = 62500.0;  // the paper's modem: the 1 s floor
  EXPECT_DOUBLE_EQ(ClockRepeatCapS(o, frame_bytes), 1.0);
  o.team = {0, 1, 2, 3, 4};  // five robots at 5 kbit/s: 20 datagrams a round
  o.channel.team_rate_bps = 5000.0;
  EXPECT_NEAR(ClockRepeatCapS(o, frame_bytes), 20.0 * 129.0 * 8.0 / 1250.0, 1e-9);
}

TEST(LinkEndpoint, HeartbeatPeriodGrowsOnASlowLink) {
  LinkOptions o = Options(0, 1);  // three robots, 2 s period
  o.heartbeat_max_share = 0.05;
  o.channel.team_rate_bps = 1000.0;  // 3 x 280 bits per period within 50 bit/s: 16.8 s
  EXPECT_NEAR(HeartbeatPeriodS(o, 280), 3.0 * 280.0 / 50.0, 1e-9);
  o.channel.team_rate_bps = 62500.0;  // the paper's modem: the configured period
  EXPECT_DOUBLE_EQ(HeartbeatPeriodS(o, 280), 2.0);
  o.heartbeat_max_share = 0.0;  // off
  o.channel.team_rate_bps = 1000.0;
  EXPECT_DOUBLE_EQ(HeartbeatPeriodS(o, 280), 2.0);
}

TEST(LinkEndpoint, HeartbeatsKeepToTheirShareOfASlowLinkWithoutFalseSilence) {
  const double duration_s = 600.0;
  for (const double share : {0.05, 0.0}) {
    const std::string bus = Bus();
    std::vector<std::unique_ptr<LinkEndpoint>> links;
    for (int i = 0; i < 3; ++i) {
      LinkOptions o = Options(i, 100 + i);
      o.channel.team_rate_bps = 1000.0;
      o.heartbeat_max_share = share;
      links.push_back(
          std::make_unique<LinkEndpoint>(o, middleware::MakeInProcessTransport(bus, i)));
    }
    int silent = 0;
    for (double t = 0.0; t < duration_s; t += 0.5) {
      for (auto& link : links) {
        for (const auto& e : link->Tick(t, nullptr).events) {
          silent += e.kind == msgs::TeammateEventKind::kSilent;
        }
      }
    }
    EXPECT_EQ(silent, 0) << "share " << share;  // only heartbeats on the link, none lost
    double team_bits = 0.0;
    for (const auto& link : links) {
      team_bits += static_cast<double>(
          link->stats().by_kind[static_cast<int>(msgs::FleetKind::kHeartbeat)].bits_sent);
    }
    const double used = team_bits / (1000.0 * duration_s);
    if (share > 0.0) {
      // A window of duration_s holds at most duration_s / period + 1 heartbeats per robot.
      const double period_s = links[0]->heartbeat_period_s();
      EXPECT_LE(used, share * (duration_s + period_s) / duration_s);
      EXPECT_GT(used, 0.8 * share);
      EXPECT_GT(links[0]->heartbeat_period_s(), 5.0);
      EXPECT_DOUBLE_EQ(links[0]->silence_s(), kSilencePeriods * links[0]->heartbeat_period_s());
      EXPECT_DOUBLE_EQ(links[0]->resend_map_s(), kResendPeriods * links[0]->heartbeat_period_s());
    } else {
      EXPECT_DOUBLE_EQ(links[0]->heartbeat_period_s(), 2.0);
      EXPECT_DOUBLE_EQ(links[0]->silence_s(), 30.0);
      EXPECT_GT(used, 4.0 * 0.05);  // every 2 s: more than four times the share
    }
  }
}

TEST(LinkEndpoint, AFloodingTeammateCannotCrowdOutTheOthers) {
  const std::string bus = Bus();
  LinkOptions o = Options(0, 1);
  o.max_held_frames = 40;  // 20 per teammate
  LinkEndpoint a(o, middleware::MakeInProcessTransport(bus, 0));
  LinkEndpoint c(Options(2, 3), middleware::MakeInProcessTransport(bus, 2));
  auto flooder = middleware::MakeInProcessTransport(bus, 1);
  a.Tick(0.0, nullptr);
  c.Tick(0.0, nullptr);
  middleware::Frame f;
  f.kind = 1;
  f.delivered_s = 1e9;  // far in the future: held, never due
  f.payload = {1, 2, 3};
  for (std::uint32_t i = 0; i < 500; ++i) {
    f.seq = i;
    flooder->Send(f);
  }
  a.Tick(0.5, nullptr);
  EXPECT_EQ(a.counters().inbox_overflow, 480u);
  EXPECT_EQ(a.teammates().at(1).held_frames, 20u);
  // Robot 2's heartbeats still get through.
  c.Tick(0.5, nullptr);
  c.Tick(1.0, nullptr);
  a.Tick(1.0, nullptr);
  const auto in = a.Tick(1.5, nullptr);
  EXPECT_TRUE(a.teammates().at(2).known);
  EXPECT_GT(a.teammates().at(2).frames_received, 0u);
  (void)in;
}

TEST(LinkEndpoint, FramesOfAReplacedIncarnationAreStale) {
  const std::string bus = Bus();
  LinkOptions o0 = Options(0, 1), o1 = Options(1, 101), n1 = Options(1, 999);
  o0.team = o1.team = n1.team = {0, 1};
  o0.channel.team_size = o1.channel.team_size = n1.channel.team_size = 2;
  LinkEndpoint a(o0, middleware::MakeInProcessTransport(bus, 0));
  LinkEndpoint old1(o1, middleware::MakeInProcessTransport(bus, 1));
  for (double t = 0.0; t <= 1.0; t += 0.5) {
    a.Tick(t, nullptr);
    old1.Tick(t, nullptr);
  }
  LinkEndpoint new1(n1, middleware::MakeInProcessTransport(bus, 1));  // the restart
  new1.Tick(1.5, nullptr);
  a.Tick(1.5, nullptr);
  old1.Tick(2.0, nullptr);  // the old daemon's last heartbeat, still on its way
  new1.Tick(2.0, nullptr);
  a.Tick(2.0, nullptr);
  a.Tick(2.5, nullptr);
  a.Tick(3.0, nullptr);
  EXPECT_EQ(a.teammates().at(1).incarnation, 999u);
  EXPECT_EQ(a.teammates().at(1).restarts, 1);
  EXPECT_GE(a.counters().stale_incarnation, 1u);
}

TEST(LinkEndpoint, ARestartedTeammateGetsTheLastMapWithoutNews) {
  const std::string bus = Bus();
  LinkOptions o0 = Options(0, 1), o1 = Options(1, 2);
  o0.team = o1.team = {0, 1};
  o0.channel.team_size = o1.channel.team_size = 2;
  o1.resend_map_s = 5.0;
  auto a = std::make_unique<LinkEndpoint>(o0, middleware::MakeInProcessTransport(bus, 0));
  LinkEndpoint b(o1, middleware::MakeInProcessTransport(bus, 1));
  msgs::FleetOutgoing out;
  out.has_object_map = true;
  out.object_map = Map(6, 0.0);
  int maps = 0;
  for (double t = 0.0; t <= 30.0; t += 0.5) {
    if (t == 15.0) {  // a restarts: a new incarnation that holds nothing of b's map
      a.reset();
      o0.incarnation = 77;
      a = std::make_unique<LinkEndpoint>(o0, middleware::MakeInProcessTransport(bus, 0));
    }
    const auto in = a->Tick(t, nullptr);
    for (const auto& m : in.object_maps) maps += m.map.objects.size() == 6u ? 1 : 0;
    b.Tick(t, t == 1.0 ? &out : nullptr);  // b's map never changes after t = 1
  }
  EXPECT_EQ(maps, 2) << "once before the restart, once after";
  EXPECT_EQ(b.stats().by_kind[2].frames_sent, 2u);
}

// A transport whose link can be cut (a bridge port down): while cut, nothing it sends leaves
// and nothing sent to it arrives.
class CuttableTransport : public middleware::Transport {
 public:
  CuttableTransport(std::unique_ptr<middleware::Transport> inner, const bool* cut)
      : inner_(std::move(inner)), cut_(cut) {}
  bool Send(const middleware::Frame& frame) override { return *cut_ || inner_->Send(frame); }
  std::vector<middleware::Frame> Receive() override {
    auto frames = inner_->Receive();
    if (*cut_) frames.clear();
    return frames;
  }
  std::string Describe() const override { return inner_->Describe(); }
  middleware::TransportCounters counters() const override { return inner_->counters(); }

 private:
  std::unique_ptr<middleware::Transport> inner_;
  const bool* cut_;
};

// Robot a's link is down from 15 s to 75 s (longer than silence_s: each marks the other
// silent). Meanwhile b's map grows from 6 to 8 objects and b adds keyframes 5-9, and then b's
// map and poses never change again (its recording ended). Once the link is back, a must hold
// b's newest map and every keyframe pose: b sends its map again to a teammate whose
// acknowledged version is behind its newest, and its full pose list to one heard again after
// silence. Before, a kept the 6-object map and 5 poses to the end.
TEST(LinkEndpoint, ATeammateCutOffGetsWhatItMissedWhenTheLinkIsBack) {
  const std::string bus = Bus();
  LinkOptions o0 = Options(0, 1), o1 = Options(1, 2);
  o0.team = o1.team = {0, 1};
  o0.channel.team_size = o1.channel.team_size = 2;
  bool cut = false;
  LinkEndpoint a(
      o0, std::make_unique<CuttableTransport>(middleware::MakeInProcessTransport(bus, 0), &cut));
  LinkEndpoint b(o1, middleware::MakeInProcessTransport(bus, 1));
  const auto poses = [](int n) {
    std::vector<msgs::KeyframePoseEntry> p;
    for (int k = 0; k < n; ++k) p.push_back({k, 2.0 * k, {1.0 * k, 0.5 * k, 0.1 * k}, 20});
    return p;
  };
  std::map<int, msgs::KeyframePoseEntry> held_poses;
  std::size_t held_objects = 0;
  int silent_events = 0;
  for (double t = 0.0; t <= 120.0; t += 0.5) {
    cut = t >= 15.0 && t < 75.0;
    const auto in = a.Tick(t, nullptr);
    for (const auto& m : in.object_maps) held_objects = m.map.objects.size();
    for (const auto& m : in.poses) {
      for (const auto& e : m.poses) held_poses[e.index] = e;
    }
    for (const auto& e : in.events)
      silent_events += e.kind == msgs::TeammateEventKind::kSilent ? 1 : 0;
    msgs::FleetOutgoing out;
    if (t == 1.0 || t == 20.0) {
      out.has_object_map = true;
      out.object_map = Map(t == 1.0 ? 6 : 8, 0.0);
      out.has_poses = true;
      out.poses = poses(t == 1.0 ? 5 : 10);
    }
    b.Tick(t, out.has_object_map ? &out : nullptr);
    if (t == 14.0) {
      ASSERT_EQ(held_objects, 6u);  // before the cut: the first map and poses arrived
      ASSERT_EQ(held_poses.size(), 5u);
    }
  }
  EXPECT_EQ(silent_events, 1);
  EXPECT_EQ(held_objects, 8u);
  EXPECT_EQ(a.teammates().at(1).held_map.objects.size(), 8u);
  ASSERT_EQ(held_poses.size(), 10u);
  EXPECT_DOUBLE_EQ(held_poses.at(9).T_map_kf.x_m, 9.0);
  EXPECT_EQ(b.teammates().at(0).acked_own_version, a.teammates().at(1).held_map_version);
}

TEST(LinkEndpoint, DeltasThatGrowTheHeldMapPastTheBoundAreRejected) {
  const std::string bus = Bus();
  LinkOptions o0 = Options(0, 1), o1 = Options(1, 2);
  o0.team = o1.team = {0, 1};
  o0.channel.team_size = o1.channel.team_size = 2;
  o0.bounds.max_objects = 10;
  LinkEndpoint a(o0, middleware::MakeInProcessTransport(bus, 0));
  LinkEndpoint b(o1, middleware::MakeInProcessTransport(bus, 1));
  msgs::FleetOutgoing first, second;
  first.has_object_map = second.has_object_map = true;
  first.object_map = Map(8, 0.0);
  second.object_map = Map(8, 0.0);
  for (auto o : Map(8, 100.0).objects) {  // 8 more objects elsewhere: 16 held > 10
    o.id += 100;
    second.object_map.objects.push_back(o);
  }
  std::size_t held = 0;
  for (double t = 0.0; t <= 12.0; t += 0.5) {
    for (const auto& m : a.Tick(t, nullptr).object_maps) held = m.map.objects.size();
    b.Tick(t, t == 1.0 ? &first : (t == 8.0 ? &second : nullptr));
  }
  EXPECT_EQ(held, 8u);
  EXPECT_EQ(a.teammates().at(1).held_map.objects.size(), 8u);
  EXPECT_GE(a.counters().rejected, 1u);
}

TEST(LinkEndpoint, AnObjectBeyondTheBoundsIsLeftOutNotTheMap) {
  Team team(Bus());
  team.Tick(0.0);
  team.Tick(0.5);
  msgs::FleetOutgoing out;
  out.has_object_map = true;
  out.object_map = Map(5, 0.0);
  out.object_map.objects[2].length_m = 900.0;  // past the 500 m side bound
  team.Tick(1.0, {&out});
  const auto in = team.Tick(1.5);
  ASSERT_EQ(in[1].object_maps.size(), 1u);
  EXPECT_EQ(in[1].object_maps[0].map.objects.size(), 4u);
  EXPECT_EQ(team.links[0]->counters().objects_left_out, 1u);
  EXPECT_EQ(team.links[0]->counters().encode_errors, 0u);
}

// fleet.Link's DDS settings are graph parameters, checked when the graph loads: a wrong
// reliability names the parameter, the component and the accepted values.
TEST(FleetLinkParams, DdsSettingsAreValidatedWhenTheGraphLoads) {
  const std::string good = R"(schema: 1
components:
  - id: link
    type: fleet.Link
    params:
      transport: dds
      domain_id: 7
      dds_topic_prefix: teamA_
      dds_reliability: best_effort
      dds_history_depth: 64
      dds_liveliness_lease_s: 2.5
)";
  EXPECT_NO_THROW(graph::LoadGraphString(good, "robot.yaml"));
  const std::string bad = R"(schema: 1
components:
  - id: link
    type: fleet.Link
    params: { transport: dds, dds_reliability: fast }
)";
  try {
    graph::LoadGraphString(bad, "robot.yaml");
    FAIL() << "no error";
  } catch (const graph::GraphError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("robot.yaml:5:"), std::string::npos) << m;
    EXPECT_NE(m.find("parameter 'dds_reliability' of 'link': 'fast' is not allowed"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("reliable, best_effort"), std::string::npos) << m;
  }
  graph::LoadOptions depth;
  depth.overrides = {"link.dds_history_depth=0"};
  EXPECT_THROW(graph::LoadGraphString(good, "robot.yaml", depth), graph::GraphError);
}

}  // namespace
}  // namespace draco::fleet
