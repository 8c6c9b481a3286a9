// Cyclone DDS transport on loopback with the shipped config/dds/loopback.xml (and lan.xml,
// unicast.xml). Each test picks a
// domain id from the process id, so concurrent test processes do not hear each other.
#include <dds/dds.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "draco/middleware/transport.hpp"
#include "link.h"

extern char** environ;

namespace draco::middleware {
namespace {

using Clock = std::chrono::steady_clock;

int TestDomain(int offset) { return 1 + (static_cast<int>(getpid()) % 190) + offset; }

DdsOptions Options(int domain, std::uint16_t robot) {
  return DdsOptions{.domain_id = domain,
                    .robot_id = robot,
                    .config_file = DRACO_SOURCE_DIR "/config/dds/loopback.xml"};
}

Frame MakeFrame(std::uint16_t destination, std::uint8_t kind, std::uint32_t seq,
                std::size_t payload_bytes = 8) {
  Frame f;
  f.destination = destination;
  f.kind = kind;
  f.seq = seq;
  f.enqueued_s = 1.5;
  f.delivered_s = 2.25;
  f.payload.resize(payload_bytes);
  for (std::size_t i = 0; i < payload_bytes; ++i) f.payload[i] = static_cast<std::uint8_t>(i * 7);
  return f;
}

// Polls `step` every 10 ms until it returns true or `seconds` pass.
bool PollFor(double seconds, const std::function<bool()>& step) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  while (Clock::now() < deadline) {
    if (step()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return step();
}

TEST(DdsTransport, TwoRobotsExchangeFramesBothWays) {
  const int domain = TestDomain(0);
  auto a = MakeDdsTransport(Options(domain, 1));
  auto b = MakeDdsTransport(Options(domain, 2));
  EXPECT_EQ(a->Describe(), "dds:domain " + std::to_string(domain));

  // Discovery: repeat a hello until the other side hears it.
  const auto start = Clock::now();
  std::uint32_t hello = 0;
  ASSERT_TRUE(PollFor(5.0, [&] {
    EXPECT_TRUE(a->Send(MakeFrame(kBroadcast, 1, hello++)));
    return !b->Receive().empty();
  })) << "robot 2 never heard robot 1";
  std::cout << "[ info ] in-process discovery: "
            << std::chrono::duration<double>(Clock::now() - start).count() << " s\n";
  a->Receive();

  ASSERT_TRUE(a->Send(MakeFrame(2, 4, 100, kMaxPayloadBytes)));  // unicast, largest frame
  ASSERT_TRUE(a->Send(MakeFrame(3, 4, 101)));                    // for robot 3: not for b
  ASSERT_TRUE(b->Send(MakeFrame(kBroadcast, 5, 7, 100)));
  std::vector<Frame> at_a, at_b;
  auto take = [&] {  // late hellos (kind 1) left out
    for (Frame& f : a->Receive()) at_a.push_back(std::move(f));
    for (Frame& f : b->Receive()) {
      if (f.kind != 1) at_b.push_back(std::move(f));
    }
  };
  ASSERT_TRUE(PollFor(5.0, [&] {
    take();
    return !at_a.empty() && !at_b.empty();
  }));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // anything else in flight
  take();
  ASSERT_EQ(at_b.size(), 1u);
  EXPECT_EQ(at_b[0].source, 1);
  EXPECT_EQ(at_b[0].destination, 2);
  EXPECT_EQ(at_b[0].kind, 4);
  EXPECT_EQ(at_b[0].seq, 100u);
  EXPECT_EQ(at_b[0].enqueued_s, 1.5);
  EXPECT_EQ(at_b[0].delivered_s, 2.25);
  EXPECT_EQ(at_b[0].payload, MakeFrame(2, 4, 100, kMaxPayloadBytes).payload);
  ASSERT_EQ(at_a.size(), 1u);
  EXPECT_EQ(at_a[0].source, 2);
  EXPECT_EQ(at_a[0].kind, 5);
  EXPECT_EQ(at_a[0].payload.size(), 100u);

  // Own frames come back through the shared topic: counted, never returned.
  EXPECT_GT(a->counters().frames_own, 0u);
  EXPECT_GT(b->counters().frames_own, 0u);
  EXPECT_EQ(a->counters().frames_malformed, 0u);

  Frame big = MakeFrame(2, 4, 102, kMaxPayloadBytes + 1);
  EXPECT_FALSE(a->Send(big));
  EXPECT_EQ(a->counters().send_failed, 1u);
}

TEST(DdsTransport, MalformedSamplesAreCountedNotReturned) {
  const int domain = TestDomain(1);
  auto b = MakeDdsTransport(Options(domain, 2));
  // A raw peer on the same topic that writes garbage.
  const dds_entity_t participant = dds_create_participant(domain, nullptr, nullptr);
  ASSERT_GT(participant, 0);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 64);
  const dds_entity_t topic =
      dds_create_topic(participant, &draco_link_LinkFrame_desc, "draco_link", qos, nullptr);
  ASSERT_GT(topic, 0);
  const dds_entity_t writer = dds_create_writer(participant, topic, qos, nullptr);
  dds_delete_qos(qos);
  ASSERT_GT(writer, 0);
  ASSERT_TRUE(PollFor(5.0, [&] {
    dds_publication_matched_status_t status{};
    dds_get_publication_matched_status(writer, &status);
    return status.current_count >= 1;
  }));

  std::uint8_t bytes[4] = {1, 2, 3, 4};
  auto write = [&](std::uint16_t source, std::uint8_t kind, double delivered_s) {
    draco_link_LinkFrame s{};
    s.source = source;
    s.destination = kBroadcast;
    s.kind = kind;
    s.delivered_s = delivered_s;
    s.payload._length = s.payload._maximum = 4;
    s.payload._buffer = bytes;
    ASSERT_EQ(dds_write(writer, &s), DDS_RETCODE_OK);
  };
  write(9, 0, 1.0);                                       // kind 0
  write(9, 3, std::numeric_limits<double>::quiet_NaN());  // not a time
  write(9, 3, std::numeric_limits<double>::infinity());   // not a time
  write(2, 3, 1.0);                                       // claims to be robot 2 itself
  write(9, 3, 1.0);                                       // fine
  std::vector<Frame> got;
  ASSERT_TRUE(PollFor(5.0, [&] {
    for (Frame& f : b->Receive()) got.push_back(std::move(f));
    return !got.empty();
  }));
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].source, 9);
  EXPECT_EQ(got[0].payload, (std::vector<std::uint8_t>{1, 2, 3, 4}));
  EXPECT_EQ(b->counters().frames_malformed, 3u);
  EXPECT_EQ(b->counters().frames_own, 1u);
  EXPECT_EQ(b->counters().frames_received, 1u);
  dds_delete(participant);
}

TEST(DdsTransport, UnreadableConfigNamesTheFile) {
  DdsOptions options = Options(TestDomain(2), 1);
  options.config_file = "/nonexistent/cyclonedds.xml";
  try {
    MakeDdsTransport(options);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/cyclonedds.xml"), std::string::npos)
        << e.what();
  }
}

// The other shipped profiles start Cyclone and carry frames: lan.xml (multicast discovery)
// and unicast.xml with its peers from $DRACO_DDS_PEERS, which it cannot do without.
void ExchangeOneFrame(const std::string& profile, int domain) {
  DdsOptions options = Options(domain, 1);
  options.config_file = DRACO_SOURCE_DIR "/config/dds/" + profile;
  auto a = MakeDdsTransport(options);
  options.robot_id = 2;
  auto b = MakeDdsTransport(options);
  std::uint32_t seq = 0;
  EXPECT_TRUE(PollFor(5.0,
                      [&] {
                        EXPECT_TRUE(a->Send(MakeFrame(2, 4, seq++)));
                        return !b->Receive().empty();
                      }))
      << profile << ": robot 2 never heard robot 1";
}

TEST(DdsTransport, LanProfileWorks) { ExchangeOneFrame("lan.xml", TestDomain(4)); }

TEST(DdsTransport, UnicastProfileTakesItsPeersFromTheEnvironment) {
  const char* old = std::getenv("DRACO_DDS_PEERS");
  const std::string saved = old ? old : "";
  ::unsetenv("DRACO_DDS_PEERS");
  DdsOptions options = Options(TestDomain(5), 1);
  options.config_file = DRACO_SOURCE_DIR "/config/dds/unicast.xml";
  EXPECT_THROW(MakeDdsTransport(options), std::runtime_error) << "started without peers";
  ::setenv("DRACO_DDS_PEERS", "127.0.0.1,localhost", 1);
  ExchangeOneFrame("unicast.xml", TestDomain(6));
  if (old) {
    ::setenv("DRACO_DDS_PEERS", saved.c_str(), 1);
  } else {
    ::unsetenv("DRACO_DDS_PEERS");
  }
}

// Two processes on loopback: this test starts itself again as robot 2 (DdsPeer.Echo), which
// answers every hello; measures the time from spawn to the first answer.
TEST(DdsTransport, TwoProcessesDiscoverEachOtherOnLoopback) {
  const int domain = TestDomain(3);
  auto a = MakeDdsTransport(Options(domain, 1));
  std::vector<std::string> env_strings;
  for (char** e = environ; *e; ++e) env_strings.emplace_back(*e);
  env_strings.push_back("DRACO_MW_PEER_DOMAIN=" + std::to_string(domain));
  std::vector<char*> envp;
  for (std::string& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::string exe = "/proc/self/exe";
  std::string filter = "--gtest_filter=DdsPeer.Echo";
  char* argv[] = {exe.data(), filter.data(), nullptr};
  pid_t child = 0;
  const auto start = Clock::now();
  ASSERT_EQ(posix_spawn(&child, exe.c_str(), nullptr, nullptr, argv, envp.data()), 0);

  std::uint32_t hello = 0;
  bool answered = false;
  bool sent_ok = true;
  PollFor(8.0, [&] {
    if (hello % 5 == 0) sent_ok = a->Send(MakeFrame(kBroadcast, 1, hello)) && sent_ok;
    ++hello;
    for (const Frame& f : a->Receive()) {
      if (f.source == 2 && f.kind == 2 && f.destination == 1) answered = true;
    }
    return answered;
  });
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  EXPECT_TRUE(sent_ok);
  EXPECT_TRUE(answered) << "no answer from the peer process";
  std::cout << "[ info ] two processes: spawn to first answer " << seconds << " s\n";
  a->Send(MakeFrame(2, 3, hello));  // stop
  int status = 0;
  bool exited = false;
  PollFor(10.0, [&] {
    if (!exited && waitpid(child, &status, WNOHANG) == child) exited = true;
    if (!exited && hello++ % 20 == 0) a->Send(MakeFrame(2, 3, hello));  // repeat the stop
    return exited;
  });
  if (!exited) {
    kill(child, SIGKILL);
    waitpid(child, &status, 0);
  }
  EXPECT_TRUE(exited);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

// Teams on one domain with different topic prefixes: each robot hears its teammates (so
// discovery works for both teams) and never a robot of the other team.
TEST(DdsTransport, TopicPrefixSeparatesTeamsOnOneDomain) {
  const int domain = TestDomain(7);
  auto with_prefix = [&](std::uint16_t robot, const std::string& prefix) {
    DdsOptions o = Options(domain, robot);
    o.topic_prefix = prefix;
    return MakeDdsTransport(o);
  };
  auto a1 = with_prefix(1, "teamA_");
  auto a2 = with_prefix(2, "teamA_");
  auto b3 = with_prefix(3, "teamB_");
  auto b4 = with_prefix(4, "teamB_");
  std::vector<Frame> at_a2, at_b3, at_b4;
  std::uint32_t seq = 0;
  auto exchange = [&] {
    EXPECT_TRUE(a1->Send(MakeFrame(kBroadcast, 4, seq)));
    EXPECT_TRUE(b3->Send(MakeFrame(kBroadcast, 5, seq)));
    ++seq;
    for (Frame& f : a2->Receive()) at_a2.push_back(std::move(f));
    for (Frame& f : b3->Receive()) at_b3.push_back(std::move(f));
    for (Frame& f : b4->Receive()) at_b4.push_back(std::move(f));
    a1->Receive();
  };
  ASSERT_TRUE(PollFor(5.0, [&] {
    exchange();
    return !at_a2.empty() && !at_b4.empty();
  })) << "a team did not hear itself";
  // More frames, and time for any cross-team sample to arrive: at least 0.5 s and more than
  // 10 frames each (an exchange can take longer than 50 ms on a slow or sanitized build).
  const auto settle = Clock::now() + std::chrono::milliseconds(500);
  PollFor(20.0, [&] {
    exchange();
    return Clock::now() >= settle && at_a2.size() > 10u && at_b4.size() > 10u;
  });
  for (const Frame& f : at_a2)
    EXPECT_EQ(f.source, 1) << "robot 2 (team A) heard robot " << f.source;
  for (const Frame& f : at_b4)
    EXPECT_EQ(f.source, 3) << "robot 4 (team B) heard robot " << f.source;
  EXPECT_TRUE(at_b3.empty()) << "robot 3 (team B) heard team A";
  EXPECT_GT(at_a2.size(), 10u);
  EXPECT_GT(at_b4.size(), 10u);
}

// Bad settings are refused before DDS starts, naming the setting and what it expects.
TEST(DdsTransport, BadOptionsAreClearErrors) {
  EXPECT_EQ(ParseDdsReliability("reliable"), DdsReliability::kReliable);
  EXPECT_EQ(ParseDdsReliability("best_effort"), DdsReliability::kBestEffort);
  auto message = [](const std::function<void()>& f) -> std::string {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no std::invalid_argument";
  };
  EXPECT_EQ(message([] { ParseDdsReliability("fast"); }),
            "dds reliability 'fast': expected reliable or best_effort");
  DdsOptions o = Options(TestDomain(2), 1);
  o.topic_prefix = "team A";
  EXPECT_EQ(message([&] { MakeDdsTransport(o); }),
            "dds topic_prefix 'team A': expected letters, digits and '_' only");
  o = Options(TestDomain(2), 1);
  o.history_depth = 0;
  EXPECT_EQ(message([&] { MakeDdsTransport(o); }), "dds history_depth 0: expected 1 to 100000");
  o = Options(TestDomain(2), 1);
  o.liveliness_lease_s = -1.0;
  EXPECT_NE(message([&] { MakeDdsTransport(o); }).find("dds liveliness_lease_s"),
            std::string::npos);
  o = Options(300, 1);
  EXPECT_EQ(message([&] { MakeDdsTransport(o); }), "dds domain_id 300: expected 0 to 232");
}

// Best effort carries frames too (same QoS on both sides), with a shallow history.
TEST(DdsTransport, BestEffortWithShallowHistoryCarriesFrames) {
  DdsOptions o = Options(TestDomain(9), 1);
  o.reliability = DdsReliability::kBestEffort;
  o.history_depth = 4;
  auto a = MakeDdsTransport(o);
  o.robot_id = 2;
  auto b = MakeDdsTransport(o);
  std::uint32_t seq = 0;
  EXPECT_TRUE(PollFor(5.0, [&] {
    EXPECT_TRUE(a->Send(MakeFrame(2, 4, seq++)));
    return !b->Receive().empty();
  }));
}

// A teammate whose process dies is noticed through its liveliness lease: this test starts a
// peer process with a 0.5 s lease, hears it, kills it with SIGKILL (no goodbye), and the
// transport counts the lost writer within a few seconds.
TEST(DdsTransport, LivelinessLeaseNoticesAKilledTeammate) {
  const int domain = TestDomain(8);
  auto a = MakeDdsTransport(Options(domain, 1));
  std::vector<std::string> env_strings;
  for (char** e = environ; *e; ++e) env_strings.emplace_back(*e);
  env_strings.push_back("DRACO_MW_PEER_DOMAIN=" + std::to_string(domain));
  env_strings.push_back("DRACO_MW_PEER_LEASE_S=0.5");
  std::vector<char*> envp;
  for (std::string& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::string exe = "/proc/self/exe";
  std::string filter = "--gtest_filter=DdsPeer.Echo";
  char* argv[] = {exe.data(), filter.data(), nullptr};
  pid_t child = 0;
  ASSERT_EQ(posix_spawn(&child, exe.c_str(), nullptr, nullptr, argv, envp.data()), 0);
  std::uint32_t hello = 0;
  const bool answered = PollFor(8.0, [&] {
    if (hello++ % 5 == 0) a->Send(MakeFrame(kBroadcast, 1, hello));
    for (const Frame& f : a->Receive()) {
      if (f.source == 2 && f.kind == 2) return true;
    }
    return false;
  });
  EXPECT_TRUE(answered) << "no answer from the peer process";
  EXPECT_EQ(a->counters().peers_lost, 0u);
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  const auto killed = Clock::now();
  EXPECT_TRUE(PollFor(5.0, [&] {
    a->Receive();
    return a->counters().peers_lost >= 1;
  })) << "the killed peer's writer was never reported lost";
  std::cout << "[ info ] killed peer noticed after "
            << std::chrono::duration<double>(Clock::now() - killed).count() << " s (lease 0.5 s)\n";
}

// Robot 2 of TwoProcessesDiscoverEachOtherOnLoopback and LivelinessLeaseNoticesAKilledTeammate
// (skipped unless started by one of them).
TEST(DdsPeer, Echo) {
  const char* domain = std::getenv("DRACO_MW_PEER_DOMAIN");
  if (domain == nullptr) GTEST_SKIP() << "started by TwoProcessesDiscoverEachOtherOnLoopback";
  DdsOptions options = Options(std::atoi(domain), 2);
  if (const char* lease = std::getenv("DRACO_MW_PEER_LEASE_S")) {
    options.liveliness_lease_s = std::atof(lease);
  }
  auto b = MakeDdsTransport(options);
  bool stop = false;
  PollFor(15.0, [&] {
    for (const Frame& f : b->Receive()) {
      if (f.kind == 3) stop = true;
      if (f.kind == 1) {
        EXPECT_TRUE(b->Send(MakeFrame(1, 2, f.seq)));
      }
    }
    return stop;
  });
  EXPECT_TRUE(stop);
}

}  // namespace
}  // namespace draco::middleware
