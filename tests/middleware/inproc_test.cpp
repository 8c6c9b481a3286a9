#include <gtest/gtest.h>

#include <vector>

#include "draco/middleware/transport.hpp"

namespace draco::middleware {
namespace {

Frame MakeFrame(std::uint16_t destination, std::uint8_t kind, std::uint32_t seq) {
  Frame f;
  f.destination = destination;
  f.kind = kind;
  f.seq = seq;
  f.payload = {1, 2, 3, static_cast<std::uint8_t>(seq)};
  return f;
}

TEST(InProcessTransport, BroadcastReachesEveryOtherEndpointInSendOrder) {
  auto a = MakeInProcessTransport("bus-broadcast", 1);
  auto b = MakeInProcessTransport("bus-broadcast", 2);
  auto c = MakeInProcessTransport("bus-broadcast", 3);
  auto other_bus = MakeInProcessTransport("bus-elsewhere", 2);
  EXPECT_EQ(a->Describe(), "inproc:bus-broadcast");
  ASSERT_TRUE(a->Send(MakeFrame(kBroadcast, 1, 0)));
  ASSERT_TRUE(b->Send(MakeFrame(kBroadcast, 2, 0)));
  ASSERT_TRUE(a->Send(MakeFrame(kBroadcast, 3, 1)));
  // Delivered before Send returned: no waiting.
  const std::vector<Frame> at_c = c->Receive();
  ASSERT_EQ(at_c.size(), 3u);
  EXPECT_EQ(at_c[0].source, 1);
  EXPECT_EQ(at_c[0].kind, 1);
  EXPECT_EQ(at_c[1].source, 2);
  EXPECT_EQ(at_c[2].kind, 3);
  EXPECT_EQ(at_c[2].payload, (std::vector<std::uint8_t>{1, 2, 3, 1}));
  const std::vector<Frame> at_a = a->Receive();  // never its own frames
  ASSERT_EQ(at_a.size(), 1u);
  EXPECT_EQ(at_a[0].source, 2);
  EXPECT_EQ(b->Receive().size(), 2u);
  EXPECT_TRUE(other_bus->Receive().empty());
  EXPECT_TRUE(c->Receive().empty());  // taken
  EXPECT_EQ(a->counters().frames_sent, 2u);
  EXPECT_EQ(c->counters().frames_received, 3u);
}

TEST(InProcessTransport, UnicastReachesOnlyTheDestination) {
  auto a = MakeInProcessTransport("bus-unicast", 1);
  auto b = MakeInProcessTransport("bus-unicast", 2);
  auto c = MakeInProcessTransport("bus-unicast", 3);
  ASSERT_TRUE(a->Send(MakeFrame(3, 4, 0)));
  ASSERT_TRUE(a->Send(MakeFrame(9, 4, 1)));  // nobody
  EXPECT_TRUE(b->Receive().empty());
  const std::vector<Frame> at_c = c->Receive();
  ASSERT_EQ(at_c.size(), 1u);
  EXPECT_EQ(at_c[0].destination, 3);
  EXPECT_EQ(at_c[0].source, 1);
}

TEST(InProcessTransport, RefusesInvalidFramesAndUnregistersOnDestruction) {
  auto a = MakeInProcessTransport("bus-life", 1);
  {
    auto b = MakeInProcessTransport("bus-life", 2);
    Frame big = MakeFrame(kBroadcast, 1, 0);
    big.payload.resize(kMaxPayloadBytes + 1);
    EXPECT_FALSE(a->Send(big));
    EXPECT_FALSE(a->Send(MakeFrame(kBroadcast, 0, 1)));  // kind 0
    EXPECT_EQ(a->counters().send_failed, 2u);
    EXPECT_TRUE(b->Receive().empty());
  }
  EXPECT_TRUE(a->Send(MakeFrame(kBroadcast, 1, 2)));  // b is gone: nobody to deliver to
  // An endpoint that reuses our robot id (a restarted daemon): its frames are "own".
  auto twin = MakeInProcessTransport("bus-life", 1);
  ASSERT_TRUE(twin->Send(MakeFrame(kBroadcast, 1, 3)));
  EXPECT_TRUE(a->Receive().empty());
  EXPECT_EQ(a->counters().frames_own, 1u);
}

}  // namespace
}  // namespace draco::middleware
