#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <thread>
#include <vector>

#include "draco/middleware/transport.hpp"

namespace draco::middleware {
namespace {

Frame MakeFrame(std::uint16_t destination, std::uint8_t kind, std::uint32_t seq,
                std::size_t payload_bytes = 4) {
  Frame f;
  f.destination = destination;
  f.kind = kind;
  f.priority = 2;
  f.seq = seq;
  f.enqueued_s = 12.5;
  f.delivered_s = 13.25;
  for (std::size_t i = 0; i < payload_bytes; ++i) {
    f.payload.push_back(static_cast<std::uint8_t>(i * 7 + seq));
  }
  return f;
}

// A socket that counts the datagrams reaching it (a peer address nobody runs a robot on).
class Spy {
 public:
  Spy() : fd_(socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK, 0)) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    socklen_t len = sizeof a;
    getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
  }
  ~Spy() { close(fd_); }
  Spy(const Spy&) = delete;
  Spy& operator=(const Spy&) = delete;
  int port() const { return port_; }
  int Count() {  // datagrams since the last call (waits 100 ms for stragglers)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::uint8_t buf[65536];
    int n = 0;
    while (recv(fd_, buf, sizeof buf, 0) >= 0) ++n;
    return n;
  }

 private:
  int fd_;
  int port_ = 0;
};

// A UDP port free on 127.0.0.1 now (the kernel's pick for a socket bound to port 0).
int FreePort() { return Spy().port(); }

UdpOptions Options(std::uint16_t id, int port, const std::vector<int>& peer_ports) {
  UdpOptions o;
  o.robot_id = id;
  o.bind_address = "127.0.0.1";
  o.port = port;
  for (int p : peer_ports) o.peers.push_back("127.0.0.1:" + std::to_string(p));
  return o;
}

// Loopback delivers at once, but give the kernel a moment: receive until `count` frames
// arrived or a second went by.
std::vector<Frame> ReceiveAtLeast(Transport& t, std::size_t count) {
  std::vector<Frame> got;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (got.size() < count && std::chrono::steady_clock::now() < until) {
    for (auto& f : t.Receive()) got.push_back(std::move(f));
    if (got.size() < count) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return got;
}

void SendRaw(int port, const std::vector<std::uint8_t>& bytes) {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
  close(fd);
}

TEST(UdpDatagram, RoundTripsEveryFieldAndCostsTheStatedOverhead) {
  Frame f = MakeFrame(3, 6, 0xA1B2C3D4u, 300);
  f.source = 2;
  const auto bytes = EncodeUdpDatagram(f);
  ASSERT_EQ(bytes.size(), kUdpDatagramOverheadBytes + 300);
  EXPECT_EQ(bytes[0], 'D');
  EXPECT_EQ(bytes[3], 1);  // version
  const auto back = DecodeUdpDatagram(bytes.data(), bytes.size());
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->source, 2);
  EXPECT_EQ(back->destination, 3);
  EXPECT_EQ(back->kind, 6);
  EXPECT_EQ(back->priority, 2);
  EXPECT_EQ(back->seq, 0xA1B2C3D4u);
  EXPECT_EQ(back->enqueued_s, 12.5);
  EXPECT_EQ(back->delivered_s, 13.25);
  EXPECT_EQ(back->payload, f.payload);
  // Little-endian on the wire whatever the host: seq's low byte first at offset 10.
  EXPECT_EQ(bytes[10], 0xD4);
  EXPECT_EQ(bytes[13], 0xA1);
}

TEST(UdpDatagram, RejectsWhatIsNotAFrame) {
  const auto good = EncodeUdpDatagram(MakeFrame(kBroadcast, 1, 7, 20));
  ASSERT_TRUE(DecodeUdpDatagram(good.data(), good.size()).has_value());
  EXPECT_FALSE(DecodeUdpDatagram(nullptr, 0).has_value());
  EXPECT_FALSE(DecodeUdpDatagram(good.data(), good.size() - 1).has_value());  // truncated
  auto longer = good;
  longer.push_back(0);
  EXPECT_FALSE(DecodeUdpDatagram(longer.data(), longer.size()).has_value());
  // Any single flipped bit is caught (magic, version, length or the CRC).
  for (std::size_t i = 0; i < good.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      auto bad = good;
      bad[i] ^= static_cast<std::uint8_t>(1U << bit);
      EXPECT_FALSE(DecodeUdpDatagram(bad.data(), bad.size()).has_value()) << i << " " << bit;
    }
  }
  // Kind 0 and a time that is not finite are refused even with a right CRC.
  EXPECT_FALSE([] {
    auto b = EncodeUdpDatagram(MakeFrame(kBroadcast, 0, 1));
    return DecodeUdpDatagram(b.data(), b.size()).has_value();
  }());
  Frame nan = MakeFrame(kBroadcast, 1, 1);
  nan.delivered_s = std::numeric_limits<double>::quiet_NaN();
  const auto b = EncodeUdpDatagram(nan);
  EXPECT_FALSE(DecodeUdpDatagram(b.data(), b.size()).has_value());
  Frame huge = MakeFrame(kBroadcast, 1, 1, kMaxPayloadBytes + 1);
  EXPECT_THROW(EncodeUdpDatagram(huge), std::invalid_argument);
}

TEST(UdpTransport, BroadcastReachesEveryPeerAndDirectedFramesOnlyTheirRobot) {
  const int pa = FreePort(), pb = FreePort(), pc = FreePort();
  // Every robot lists the whole team, itself included (one list for the team).
  auto a = MakeUdpTransport(Options(1, pa, {pa, pb, pc}));
  auto b = MakeUdpTransport(Options(2, pb, {pa, pb, pc}));
  auto c = MakeUdpTransport(Options(3, pc, {pa, pb, pc}));
  EXPECT_NE(a->Describe().find("udp:127.0.0.1:" + std::to_string(pa)), std::string::npos);
  ASSERT_TRUE(a->Send(MakeFrame(kBroadcast, 1, 0)));
  ASSERT_TRUE(a->Send(MakeFrame(3, 4, 1)));  // for c only
  const auto at_b = ReceiveAtLeast(*b, 1);
  const auto at_c = ReceiveAtLeast(*c, 2);
  ASSERT_EQ(at_b.size(), 1u);
  EXPECT_EQ(at_b[0].source, 1);
  EXPECT_EQ(at_b[0].kind, 1);
  ASSERT_EQ(at_c.size(), 2u);
  EXPECT_EQ(at_c[1].kind, 4);
  EXPECT_EQ(at_c[1].destination, 3);
  EXPECT_EQ(at_c[1].payload, MakeFrame(3, 4, 1).payload);
  // a's own frames came back to it (a had not heard c, so the frame for c went to every
  // peer, a included) and are counted, not returned.
  EXPECT_TRUE(ReceiveAtLeast(*a, 1).empty());
  EXPECT_EQ(a->counters().frames_own, 2u);
  EXPECT_EQ(a->counters().frames_sent, 2u);
  EXPECT_EQ(b->counters().frames_received, 1u);
  EXPECT_EQ(c->counters().frames_received, 2u);
}

TEST(UdpTransport, ADirectedFrameGoesWhereItsRobotWasHeardFromOnceItWas) {
  Spy spy;
  const int pa = FreePort(), pb = FreePort();
  auto a = MakeUdpTransport(Options(1, pa, {pb}));
  auto b = MakeUdpTransport(Options(2, pb, {pa, spy.port()}));
  // b has not heard robot 1 yet: its frame for 1 goes to every peer.
  ASSERT_TRUE(b->Send(MakeFrame(1, 5, 0)));
  EXPECT_EQ(ReceiveAtLeast(*a, 1).size(), 1u);
  EXPECT_EQ(spy.Count(), 1);
  // Once b heard a, a frame for robot 1 goes to a's address only.
  ASSERT_TRUE(a->Send(MakeFrame(kBroadcast, 1, 0)));
  ASSERT_EQ(ReceiveAtLeast(*b, 1).size(), 1u);
  ASSERT_TRUE(b->Send(MakeFrame(1, 5, 1)));
  const auto at_a = ReceiveAtLeast(*a, 1);
  ASSERT_EQ(at_a.size(), 1u);
  EXPECT_EQ(at_a[0].seq, 1u);
  EXPECT_EQ(spy.Count(), 0);
  // Broadcasts still go to every peer.
  ASSERT_TRUE(b->Send(MakeFrame(kBroadcast, 2, 2)));
  EXPECT_EQ(spy.Count(), 1);
}

TEST(UdpTransport, GarbageIsCountedAndTheLinkGoesOn) {
  const int pa = FreePort(), pb = FreePort();
  auto a = MakeUdpTransport(Options(1, pa, {pb}));
  auto b = MakeUdpTransport(Options(2, pb, {pa}));
  SendRaw(pb, {});                           // empty datagram
  SendRaw(pb, {'D', 'R', 'L', 1, 0, 0, 0});  // short
  SendRaw(pb, std::vector<std::uint8_t>(1400, 0xAB));
  auto corrupt = EncodeUdpDatagram(MakeFrame(kBroadcast, 1, 0, 50));
  corrupt[40] ^= 0x10;  // a payload byte: the CRC catches it
  SendRaw(pb, corrupt);
  ASSERT_TRUE(a->Send(MakeFrame(kBroadcast, 2, 9)));
  const auto got = ReceiveAtLeast(*b, 1);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].seq, 9u);
  EXPECT_EQ(b->counters().frames_malformed, 4u);
  EXPECT_EQ(b->counters().frames_received, 1u);
}

TEST(UdpTransport, RefusesBadFramesAndBadOptionsWithClearErrors) {
  const int pa = FreePort(), pb = FreePort();
  auto a = MakeUdpTransport(Options(1, pa, {pb}));
  EXPECT_FALSE(a->Send(MakeFrame(kBroadcast, 0, 0)));
  EXPECT_FALSE(a->Send(MakeFrame(kBroadcast, 1, 0, kMaxPayloadBytes + 1)));
  EXPECT_EQ(a->counters().send_failed, 2u);
  EXPECT_EQ(a->counters().frames_sent, 0u);

  const auto message = [](const UdpOptions& o) {
    try {
      MakeUdpTransport(o);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  UdpOptions o = Options(1, FreePort(), {pb});
  o.peers = {};
  EXPECT_NE(message(o).find("udp peers: empty"), std::string::npos);
  o.peers = {"127.0.0.1:70000"};
  EXPECT_NE(message(o).find("port '70000': expected 1 to 65535"), std::string::npos);
  o.peers = {"no-such-host.invalid:7470"};
  EXPECT_NE(message(o).find("cannot resolve 'no-such-host.invalid'"), std::string::npos);
  o.peers = {"127.0.0.1"};
  o.bind_address = "everywhere";
  EXPECT_NE(message(o).find("udp bind_address 'everywhere'"), std::string::npos);
  o.bind_address = "127.0.0.1";
  o.port = 0;
  EXPECT_NE(message(o).find("udp port 0"), std::string::npos);
  // A port already taken: the error names the address and port.
  o.port = pa;
  EXPECT_NE(message(o).find("cannot bind 127.0.0.1:" + std::to_string(pa)), std::string::npos);
}

}  // namespace
}  // namespace draco::middleware
