// A link frame: what one robot hands the acoustic modem, as bytes. The middleware knows
// nothing of sonar or SLAM: the payload is the compact encoding of a fleet message
// (components/fleet), the kind a small integer the middleware only counts by.
#pragma once

#include <cstdint>
#include <vector>

namespace draco::middleware {

inline constexpr std::uint16_t kBroadcast = 0xFFFF;
inline constexpr std::size_t kMaxPayloadBytes = 16384;  // larger frames are refused

struct Frame {
  std::uint16_t source = 0;                // sending robot id
  std::uint16_t destination = kBroadcast;  // a robot id or kBroadcast
  std::uint8_t kind = 0;                   // message kind (counted per kind)
  std::uint8_t priority = 0;               // 0 most urgent
  std::uint32_t seq = 0;                   // sender's running frame count (all kinds)
  double enqueued_s = 0.0;                 // mission time the sender queued it
  double delivered_s = 0.0;                // mission time it reaches the receivers
  std::vector<std::uint8_t> payload;
};

// Bits a frame occupies on the acoustic link: the modem frame header plus the payload.
// The header (source, destination, kind, seq, length: 8 bytes) is what an acoustic modem
// packet would carry; DDS's own envelope on loopback is not counted.
inline constexpr std::size_t kFrameHeaderBits = 64;
inline std::size_t LinkBits(const Frame& frame) {
  return kFrameHeaderBits + 8 * frame.payload.size();
}

}  // namespace draco::middleware
