// libFuzzer target: any UDP datagram reaching a robot's plain-UDP link (transport udp).
//
// middleware::DecodeUdpDatagram on the input, then on the input with its last 4 bytes made the
// right CRC-32 of the rest (else mutations would rarely get past the CRC, and the checks behind
// it would go unfuzzed). A datagram that decodes must encode back to the very same bytes (the
// layout has one encoding per frame), and what it holds must be a frame the transport accepts:
// kind 1-255, payload <= kMaxPayloadBytes, finite times. Memory: at most 4 x the input + 4 kB.
// Seeds: tests/fuzz/corpus/fuzz_udp_datagram/ (datagrams of real link frames:
// gen_fleet_corpus writes them beside the fleet codec's seeds).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "allocation_bound.hpp"
#include "draco/middleware/transport.hpp"

namespace {

std::uint32_t Crc32(const std::uint8_t* data, std::size_t size) {  // as zlib's crc32
  std::uint32_t c = 0xFFFFFFFFU;
  for (std::size_t i = 0; i < size; ++i) {
    c ^= data[i];
    for (int k = 0; k < 8; ++k) c = (c & 1U) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
  }
  return c ^ 0xFFFFFFFFU;
}

void Check(const std::uint8_t* data, std::size_t size) {
  using namespace draco::middleware;
  const auto frame = DecodeUdpDatagram(data, size);
  if (!frame) return;
  if (frame->kind == 0 || frame->payload.size() > kMaxPayloadBytes ||
      !std::isfinite(frame->enqueued_s) || !std::isfinite(frame->delivered_s)) {
    std::fprintf(stderr, "fuzz_udp_datagram: decoded a frame the transport must refuse\n");
    std::abort();
  }
  const std::vector<std::uint8_t> again = EncodeUdpDatagram(*frame);
  if (again.size() != size || !std::equal(again.begin(), again.end(), data)) {
    std::fprintf(stderr, "fuzz_udp_datagram: re-encoding differs from the datagram\n");
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // The copy below, a frame's payload and its re-encoding: about 3 x the input.
  const draco::fuzz::AllocationBound bound(size, 4, 4096, "fuzz_udp_datagram");
  Check(data, size);
  if (size >= 4) {
    std::vector<std::uint8_t> fixed(data, data + size);
    const std::uint32_t crc = Crc32(fixed.data(), size - 4);
    for (int i = 0; i < 4; ++i) fixed[size - 4 + i] = static_cast<std::uint8_t>(crc >> (8 * i));
    Check(fixed.data(), fixed.size());
  }
  return 0;
}
