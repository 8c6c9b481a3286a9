// libFuzzer target: what a teammate (or anything on the link) may send a robot.
//
// The first input byte picks the path (modulo 7); the rest is its input:
//   1-6  fleet::Decode of the message kind with that msgs::FleetKind value (heartbeat, object
//        map, keyframe poses, scan request, scan reply, loop closures) on the payload bytes. A
//        message that decodes is encoded again, and that encoding must decode (the encoder's output
//        is always valid). A decoded object-map update is applied to an empty held map.
//   0    the link's receive path: a LinkEndpoint (robot 0 of team {0, 1, 2}, in-process
//        settings) ticks over frames cut from the input (LinkFrames below) handed to it by a
//        transport: frame envelope checks, clock frames (the only byte layout parsed outside
//        the codec), incarnations, the inbox and its shares, delivery and decoding.
// Seeds: tests/fuzz/corpus/fuzz_fleet_codec/ (real encoded messages, gen_fleet_corpus.cpp).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "allocation_bound.hpp"
#include "draco/fleet/codec.hpp"
#include "draco/fleet/link.hpp"
#include "draco/log/log.hpp"
#include "draco/middleware/transport.hpp"

namespace {

using namespace draco;

[[noreturn]] void Die(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_fleet_codec: %s: %s\n", what, detail.c_str());
  std::abort();
}

// Decode; on success re-encode and decode again (must succeed).
template <typename Message>
void DecodeAndRoundTrip(const std::vector<std::uint8_t>& payload) {
  Message m;
  if (!fleet::Decode(payload, &m)) return;
  std::vector<std::uint8_t> again;
  try {
    again = fleet::Encode(m);
  } catch (const std::invalid_argument&) {
    return;  // the decoder's bounds allow half a quantisation step more than the encoder's
  }
  Message back;
  if (const auto r = fleet::Decode(again, &back); !r)
    Die("re-encoded message does not decode", r.error);
}

void ObjectMap(const std::vector<std::uint8_t>& payload) {
  DecodeAndRoundTrip<msgs::ObjectMapUpdate>(payload);
  msgs::ObjectMapUpdate update;
  if (!fleet::Decode(payload, &update)) return;
  msgs::ObjectMap held;
  std::uint32_t version = 0;
  fleet::ApplyObjectMapUpdate(update, &held, &version);
  fleet::ApplyObjectMapUpdate(update, &held, &version);  // the same update twice (a replay)
}

// Frames from the input: [source u8][destination u8][kind u8][delivered tick u8][seq u8]
// [length u16 little-endian][payload]; the last frame takes what is left when short.
class FuzzTransport final : public middleware::Transport {
 public:
  explicit FuzzTransport(std::vector<middleware::Frame> frames) : frames_(std::move(frames)) {}
  bool Send(const middleware::Frame&) override { return true; }
  std::vector<middleware::Frame> Receive() override {
    // Half the frames on the first tick, the rest on the second: ticks see held frames too.
    std::vector<middleware::Frame> out;
    const std::size_t n = calls_ == 0 ? frames_.size() / 2 : frames_.size();
    for (; next_ < n; ++next_) out.push_back(frames_[next_]);
    ++calls_;
    return out;
  }
  std::string Describe() const override { return "fuzz"; }
  middleware::TransportCounters counters() const override { return {}; }

 private:
  std::vector<middleware::Frame> frames_;
  std::size_t next_ = 0;
  int calls_ = 0;
};

std::vector<middleware::Frame> LinkFrames(const std::uint8_t* data, std::size_t size) {
  std::vector<middleware::Frame> frames;
  std::size_t at = 0;
  while (size - at >= 7 && frames.size() < 64) {
    middleware::Frame f;
    f.source = data[at] == 0xff ? middleware::kBroadcast : data[at] % 8;  // team {0, 1, 2}
    f.destination = data[at + 1] >= 0x80 ? middleware::kBroadcast : data[at + 1] % 8;
    f.kind = data[at + 2];
    f.priority = 0;
    f.delivered_s = 0.25 * data[at + 3];  // ticks every 0.5 s from 0
    if (data[at + 3] == 0xff) f.delivered_s = std::numeric_limits<double>::quiet_NaN();
    f.enqueued_s = f.delivered_s;
    f.seq = data[at + 4];
    const std::size_t length = data[at + 5] | (std::size_t{data[at + 6]} << 8);
    at += 7;
    const std::size_t take = std::min(length, size - at);
    f.payload.assign(data + at, data + at + take);
    at += take;
    frames.push_back(std::move(f));
  }
  return frames;
}

void Link(const std::uint8_t* data, std::size_t size) {
  fleet::LinkOptions options;
  options.robot_id = 0;
  options.team = {0, 1, 2};
  options.incarnation = 7;
  options.max_held_frames = 16;  // small: the share bound is reached
  fleet::LinkEndpoint link(options, std::make_unique<FuzzTransport>(LinkFrames(data, size)));
  for (int tick = 0; tick < 4; ++tick) link.Tick(0.5 * tick, nullptr);
  (void)link.StatsJson();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  draco::log::SetLevel(draco::log::Level::kOff);  // rejected frames are logged as warnings
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Memory bound: every count in a message is capped by fleet::Bounds (and sizes a buffer only
  // as far as the payload's bits go), so a reader's heap is a few MiB whatever the input.
  const draco::fuzz::AllocationBound bound(size, 64, 4 << 20, "fuzz_fleet_codec");
  if (size == 0) return 0;
  const int path = data[0] % 7;
  const std::vector<std::uint8_t> payload(data + 1, data + size);
  switch (static_cast<msgs::FleetKind>(path)) {
    case msgs::FleetKind::kHeartbeat:
      DecodeAndRoundTrip<msgs::Heartbeat>(payload);
      break;
    case msgs::FleetKind::kObjectMap:
      ObjectMap(payload);
      break;
    case msgs::FleetKind::kKeyframePoses:
      DecodeAndRoundTrip<msgs::KeyframePoses>(payload);
      break;
    case msgs::FleetKind::kScanRequest:
      DecodeAndRoundTrip<msgs::ScanRequest>(payload);
      break;
    case msgs::FleetKind::kScanReply:
      DecodeAndRoundTrip<msgs::ScanReply>(payload);
      break;
    case msgs::FleetKind::kLoopClosures:
      DecodeAndRoundTrip<msgs::LoopClosureMessage>(payload);
      break;
    default:
      Link(data + 1, size - 1);
      break;
  }
  return 0;
}
