#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "draco/middleware/channel.hpp"

namespace draco::middleware {
namespace {

Frame MakeFrame(std::uint8_t kind, std::size_t payload_bytes, std::uint8_t priority = 0) {
  Frame f;
  f.kind = kind;
  f.priority = priority;
  f.payload.assign(payload_bytes, static_cast<std::uint8_t>(kind));
  return f;
}

TEST(AcousticChannel, SharedRateGivesHandComputedArrivalTimes) {
  // 62.5 kbps shared by 3 robots: 20833.33 bit/s each. Frames of 1000, 500 and 2000 payload
  // bytes are 8064, 4064 and 16064 bits on the link (64-bit header): 0.387072 s, 0.195072 s,
  // 0.771072 s of airtime, back to back from t = 1 s, then 0.1 s latency.
  ChannelOptions options{.team_rate_bps = 62500.0, .team_size = 3, .latency_s = 0.1};
  AcousticChannel channel(1, options);
  ASSERT_TRUE(channel.Enqueue(MakeFrame(1, 1000), 1.0));
  ASSERT_TRUE(channel.Enqueue(MakeFrame(2, 500), 1.0));
  ASSERT_TRUE(channel.Enqueue(MakeFrame(3, 2000), 1.0));
  EXPECT_EQ(channel.queued_bits(), 8064u + 4064u + 16064u);

  EXPECT_TRUE(channel.Transmit(1.3).empty());  // first frame's last bit leaves at 1.387072
  std::vector<Frame> out = channel.Transmit(1.6);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(out[0].delivered_s, 1.0 + 0.387072 + 0.1, 1e-9);
  EXPECT_NEAR(out[1].delivered_s, 1.0 + 0.387072 + 0.195072 + 0.1, 1e-9);
  EXPECT_EQ(out[0].source, 1);
  EXPECT_EQ(out[0].seq, 0u);
  EXPECT_EQ(out[1].seq, 1u);
  EXPECT_EQ(out[0].enqueued_s, 1.0);
  out = channel.Transmit(10.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].delivered_s, 1.0 + 0.387072 + 0.195072 + 0.771072 + 0.1, 1e-9);
  EXPECT_EQ(channel.queued_frames(), 0u);
  EXPECT_EQ(channel.queued_bits(), 0u);

  const LinkStats& stats = channel.stats();
  EXPECT_EQ(stats.by_kind[1].frames_sent, 1u);
  EXPECT_EQ(stats.by_kind[3].bits_sent, 16064u);
  EXPECT_EQ(stats.by_kind[3].max_bits, 16064u);
  EXPECT_NEAR(stats.busy_s, 0.387072 + 0.195072 + 0.771072, 1e-9);
  ASSERT_EQ(stats.traffic.size(), 3u);
  EXPECT_NEAR(stats.traffic[1].start_s, 1.387072, 1e-9);
  EXPECT_NEAR(stats.traffic[1].end_s, 1.582144, 1e-9);
  EXPECT_EQ(stats.traffic[2].bits, 16064u);
}

TEST(AcousticChannel, DropWaitingTakesOnlyWaitingFramesOfThatKindAndDestination) {
  // 1000 bit/s: a 117-byte frame takes 1 s. Three broadcast maps (kind 2), one map for robot
  // 4, one reply (kind 5); the first map is on the air when the newer map comes.
  AcousticChannel channel(
      0, ChannelOptions{.team_rate_bps = 1000.0, .team_size = 1, .latency_s = 0.0});
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(channel.Enqueue(MakeFrame(2, 117, 2), 0.0));
  Frame directed = MakeFrame(2, 117, 2);
  directed.destination = 4;
  ASSERT_TRUE(channel.Enqueue(directed, 0.0));
  ASSERT_TRUE(channel.Enqueue(MakeFrame(5, 117, 2), 0.0));
  EXPECT_TRUE(channel.Transmit(0.5).empty());  // the first map is being sent
  EXPECT_EQ(channel.DropWaiting(2, kBroadcast), 2u);
  EXPECT_EQ(channel.queued_frames(), 3u);  // the one on the air, the directed map, the reply
  EXPECT_EQ(channel.queued_bits(), 3000u);
  EXPECT_EQ(channel.stats().by_kind[2].superseded, 2u);
  const auto out = channel.Transmit(10.0);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0].kind, 2);
  EXPECT_EQ(out[0].seq, 0u);  // the map on the air went out whole
  EXPECT_EQ(out[1].destination, 4);
  EXPECT_EQ(out[2].kind, 5);
  EXPECT_EQ(channel.stats().by_kind[2].frames_sent, 2u);
}

TEST(AcousticChannel, IdleTransmitterStartsAtEnqueueTime) {
  AcousticChannel channel(
      0, ChannelOptions{.team_rate_bps = 1000.0, .team_size = 1, .latency_s = 0.5});
  ASSERT_TRUE(channel.Enqueue(MakeFrame(1, 12), 5.0));  // 160 bits: 0.16 s
  const std::vector<Frame> out = channel.Transmit(100.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].delivered_s, 5.0 + 0.16 + 0.5, 1e-12);
}

TEST(AcousticChannel, PriorityThenFifo) {
  AcousticChannel channel(2, ChannelOptions{.team_rate_bps = 1000.0, .team_size = 1});
  // All queued at t = 0; the transmitter picks by priority, FIFO within a priority.
  ASSERT_TRUE(channel.Enqueue(MakeFrame(1, 10, 2), 0.0));  // seq 0
  ASSERT_TRUE(channel.Enqueue(MakeFrame(2, 10, 0), 0.0));  // seq 1
  ASSERT_TRUE(channel.Enqueue(MakeFrame(3, 10, 1), 0.0));  // seq 2
  ASSERT_TRUE(channel.Enqueue(MakeFrame(4, 10, 0), 0.0));  // seq 3
  ASSERT_TRUE(channel.Enqueue(MakeFrame(5, 10, 2), 0.0));  // seq 4
  const std::vector<Frame> out = channel.Transmit(100.0);
  std::vector<std::uint32_t> seqs;
  for (const Frame& f : out) seqs.push_back(f.seq);
  EXPECT_EQ(seqs, (std::vector<std::uint32_t>{1, 3, 2, 0, 4}));
}

TEST(AcousticChannel, TransmissionInProgressIsNotPreempted) {
  // 1000 bit/s; a 1064-bit low-priority frame starts at 0 and ends at 1.064; an urgent frame
  // queued at 0.5 goes next, even though Transmit was not called in between.
  AcousticChannel channel(
      0, ChannelOptions{.team_rate_bps = 1000.0, .team_size = 1, .latency_s = 0.0});
  ASSERT_TRUE(channel.Enqueue(MakeFrame(1, 125, 5), 0.0));
  EXPECT_TRUE(channel.Transmit(0.5).empty());
  ASSERT_TRUE(channel.Enqueue(MakeFrame(2, 125, 0), 0.5));
  const std::vector<Frame> out = channel.Transmit(10.0);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].kind, 1);
  EXPECT_NEAR(out[0].delivered_s, 1.064, 1e-12);
  EXPECT_EQ(out[1].kind, 2);
  EXPECT_NEAR(out[1].delivered_s, 2.128, 1e-12);
}

TEST(AcousticChannel, FramesWaitingTooLongExpire) {
  // 100 bit/s: a 1064-bit frame takes 10.64 s; with max_wait_s = 5 the second and third
  // frames (queued at 0) would start at 10.64: expired.
  AcousticChannel channel(
      0,
      ChannelOptions{.team_rate_bps = 100.0, .team_size = 1, .latency_s = 0.0, .max_wait_s = 5.0});
  ASSERT_TRUE(channel.Enqueue(MakeFrame(1, 125), 0.0));
  ASSERT_TRUE(channel.Enqueue(MakeFrame(2, 125), 0.0));
  ASSERT_TRUE(channel.Enqueue(MakeFrame(2, 125), 0.0));
  std::vector<Frame> out = channel.Transmit(20.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].kind, 1);
  EXPECT_EQ(channel.stats().by_kind[2].dropped_expired, 2u);
  EXPECT_EQ(channel.queued_frames(), 0u);
  // Behind a transmission in progress, a frame waiting past max_wait_s is dropped at now_s.
  ASSERT_TRUE(channel.Enqueue(MakeFrame(3, 125), 20.0));  // starts at 20, ends at 30.64
  ASSERT_TRUE(channel.Enqueue(MakeFrame(4, 1), 21.0));
  EXPECT_TRUE(channel.Transmit(25.5).empty());
  EXPECT_EQ(channel.queued_frames(), 2u);
  EXPECT_TRUE(channel.Transmit(27.0).empty());  // kind 4 waited 6 s
  EXPECT_EQ(channel.queued_frames(), 1u);
  EXPECT_EQ(channel.stats().by_kind[4].dropped_expired, 1u);
  out = channel.Transmit(31.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].kind, 3);
}

TEST(AcousticChannel, QueueOverflowAndOversizedFramesAreDropped) {
  AcousticChannel channel(
      0, ChannelOptions{.team_rate_bps = 1000.0, .team_size = 1, .max_queue_bits = 3000});
  EXPECT_TRUE(channel.Enqueue(MakeFrame(1, 117), 0.0));   // 1000 bits
  EXPECT_TRUE(channel.Enqueue(MakeFrame(1, 117), 0.0));   // 2000
  EXPECT_FALSE(channel.Enqueue(MakeFrame(2, 200), 0.0));  // 1664 more: does not fit
  EXPECT_TRUE(channel.Enqueue(MakeFrame(1, 117), 0.0));   // exactly 3000
  EXPECT_FALSE(channel.Enqueue(MakeFrame(1, 0), 0.0));    // 64 more
  EXPECT_EQ(channel.queued_frames(), 3u);
  EXPECT_EQ(channel.queued_bits(), 3000u);
  EXPECT_EQ(channel.stats().by_kind[1].dropped_queue, 1u);
  EXPECT_EQ(channel.stats().by_kind[2].dropped_queue, 1u);

  AcousticChannel big(0, ChannelOptions{});
  EXPECT_FALSE(big.Enqueue(MakeFrame(4, kMaxPayloadBytes + 1), 0.0));
  EXPECT_TRUE(big.Enqueue(MakeFrame(4, kMaxPayloadBytes), 0.0));
  EXPECT_FALSE(big.Enqueue(MakeFrame(0, 10), 0.0));  // kind 0 is never valid
  EXPECT_EQ(big.stats().by_kind[4].dropped_queue, 1u);
  EXPECT_EQ(big.stats().by_kind[0].dropped_queue, 1u);
}

TEST(AcousticChannel, LossIsDeterministicAndNearTheProbability) {
  const ChannelOptions options{.team_rate_bps = 1e9,
                               .team_size = 1,
                               .latency_s = 0.0,
                               .loss_probability = 0.2,
                               .loss_seed = 42};
  auto run = [&](std::uint64_t seed) {
    ChannelOptions o = options;
    o.loss_seed = seed;
    AcousticChannel channel(3, o);
    std::vector<std::uint32_t> delivered;
    for (int i = 0; i < 5000; ++i) {
      EXPECT_TRUE(channel.Enqueue(MakeFrame(1, 8), i * 1.0));
      for (const Frame& f : channel.Transmit(i * 1.0 + 0.5)) delivered.push_back(f.seq);
    }
    EXPECT_EQ(channel.stats().by_kind[1].frames_sent, 5000u);
    EXPECT_EQ(channel.stats().by_kind[1].lost + delivered.size(), 5000u);
    return delivered;
  };
  const std::vector<std::uint32_t> a = run(42);
  const std::vector<std::uint32_t> b = run(42);
  const std::vector<std::uint32_t> c = run(43);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  const double loss_rate = 1.0 - a.size() / 5000.0;
  EXPECT_NEAR(loss_rate, 0.2, 0.02);  // ~5 standard deviations

  // Transmit-call pattern does not change which frames are lost.
  ChannelOptions o = options;
  AcousticChannel batch(3, o);
  for (int i = 0; i < 5000; ++i) ASSERT_TRUE(batch.Enqueue(MakeFrame(1, 8), i * 1.0));
  std::vector<std::uint32_t> d;
  for (const Frame& f : batch.Transmit(1e6)) d.push_back(f.seq);
  EXPECT_EQ(a, d);
  EXPECT_EQ(batch.stats().traffic.size(), 5000u);
  EXPECT_EQ(std::count_if(batch.stats().traffic.begin(), batch.stats().traffic.end(),
                          [](const TrafficRecord& r) { return r.lost; }),
            static_cast<long>(5000 - d.size()));
}

TEST(AcousticChannel, TdmaSendsOnlyInOwnSlot) {
  // 3 robots, 2 s slots: robot 1 owns [2, 4) + 6k. Full team rate, 10000 bit/s: a frame of
  // 30000 bits needs 3 s of airtime: 2 s in [2, 4), 1 s in [8, 9).
  ChannelOptions options{
      .team_rate_bps = 10000.0, .team_size = 3, .tdma = true, .slot_s = 2.0, .latency_s = 0.1};
  AcousticChannel channel(1, options);
  ASSERT_TRUE(channel.Enqueue(MakeFrame(1, 3742), 0.0));  // 64 + 29936 = 30000 bits
  EXPECT_TRUE(channel.Transmit(8.5).empty());
  std::vector<Frame> out = channel.Transmit(9.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].delivered_s, 9.1, 1e-9);
  ASSERT_EQ(channel.stats().traffic.size(), 1u);
  EXPECT_NEAR(channel.stats().traffic[0].start_s, 2.0, 1e-12);
  EXPECT_NEAR(channel.stats().busy_s, 3.0, 1e-9);

  // Enqueued during someone else's slot: waits for the own slot; small frames fill the slot.
  ASSERT_TRUE(channel.Enqueue(MakeFrame(2, 117), 10.0));  // 1000 bits: 0.1 s
  ASSERT_TRUE(channel.Enqueue(MakeFrame(2, 117), 10.0));
  out = channel.Transmit(20.0);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(out[0].delivered_s, 14.1 + 0.1, 1e-9);
  EXPECT_NEAR(out[1].delivered_s, 14.2 + 0.1, 1e-9);

  // Many frames from every robot: no transmission time outside the robot's own slot.
  for (std::uint16_t robot = 0; robot < 3; ++robot) {
    AcousticChannel c(robot, options);
    for (int i = 0; i < 200; ++i) {
      ASSERT_TRUE(c.Enqueue(MakeFrame(1, 200 + 37 * (i % 11)), i * 1.5));
    }
    std::size_t delivered = 0;
    for (double t = 0.0; t < 400.0; t += 0.7) delivered += c.Transmit(t).size();
    EXPECT_EQ(delivered, 200u);
    const double offset = 2.0 * robot;
    double airtime = 0.0;
    for (const TrafficRecord& r : c.stats().traffic) {
      const double phase = std::fmod(r.start_s - offset + 600.0, 6.0);
      EXPECT_LT(phase, 2.0) << "robot " << robot << " starts at " << r.start_s;
      airtime += r.bits / 10000.0;
      // It ends inside an own slot (possibly a later one) and took at least its airtime.
      const double end_phase = std::fmod(r.end_s - offset + 600.0, 6.0);
      EXPECT_LE(end_phase, 2.0 + 1e-9);
      EXPECT_GE(r.end_s - r.start_s, r.bits / 10000.0 - 1e-9);
    }
    EXPECT_NEAR(c.stats().busy_s, airtime, 1e-6);
  }
}

TEST(Inbox, OrderIndependentOfArrivalOrder) {
  std::vector<Frame> frames;
  auto add = [&](std::uint16_t source, std::uint32_t seq, double delivered) {
    Frame f;
    f.source = source;
    f.seq = seq;
    f.kind = 1;
    f.delivered_s = delivered;
    frames.push_back(f);
  };
  add(2, 0, 1.5);
  add(1, 0, 1.5);
  add(1, 1, 1.0);
  add(3, 7, 2.0);
  add(2, 1, 3.0);
  std::vector<std::vector<std::pair<std::uint16_t, std::uint32_t>>> results;
  std::vector<int> order{0, 1, 2, 3, 4};
  do {  // every arrival order
    Inbox inbox;
    for (const int i : order) inbox.Add(frames[i]);
    std::vector<std::pair<std::uint16_t, std::uint32_t>> got;
    for (const Frame& f : inbox.Due(0.9)) got.emplace_back(f.source, f.seq);
    EXPECT_TRUE(got.empty());
    for (const Frame& f : inbox.Due(2.0)) got.emplace_back(f.source, f.seq);
    EXPECT_EQ(inbox.size(), 1u);
    for (const Frame& f : inbox.Due(5.0)) got.emplace_back(f.source, f.seq);
    results.push_back(got);
  } while (std::next_permutation(order.begin(), order.end()));
  EXPECT_EQ(results.size(), 120u);
  ASSERT_FALSE(results.empty());
  const std::vector<std::pair<std::uint16_t, std::uint32_t>> expected{
      {1, 1}, {1, 0}, {2, 0}, {3, 7}, {2, 1}};
  for (const auto& r : results) EXPECT_EQ(r, expected);
}

TEST(LinkStats, CountsAndCsv) {
  // 1024 bit/s: times exact in binary.
  AcousticChannel channel(0, ChannelOptions{.team_rate_bps = 1024.0, .team_size = 1});
  ASSERT_TRUE(channel.Enqueue(MakeFrame(1, 12), 0.0));  // 160 bits: 0.15625 s
  ASSERT_TRUE(channel.Enqueue(MakeFrame(2, 2), 0.0));   // 80 bits: 0.078125 s
  channel.Transmit(10.0);
  channel.CountReceived(2, 80);
  channel.CountRejected(2);
  const auto& st = channel.stats();
  EXPECT_EQ(st.by_kind[1].frames_sent, 1u);
  EXPECT_EQ(st.by_kind[1].bits_sent, 160u);
  EXPECT_EQ(st.by_kind[1].max_bits, 160u);
  EXPECT_EQ(st.by_kind[2].frames_received, 1u);
  EXPECT_EQ(st.by_kind[2].bits_received, 80u);
  EXPECT_EQ(st.by_kind[2].rejected, 1u);
  EXPECT_DOUBLE_EQ(st.busy_s, 0.234375);
  const std::vector<std::string> names{"", "object_map", "scan \"reply\""};
  const std::string csv = TrafficCsv(channel.stats(), names);
  EXPECT_EQ(csv,
            "start_s,end_s,kind,bits,lost\n"
            "0,0.15625,object_map,160,0\n"
            "0.15625,0.234375,scan \"reply\",80,0\n");
}

}  // namespace
}  // namespace draco::middleware
