// Scan-point block codings of the fleet codec (private; apps/fleet_sizes measures them).
// Points are integer grid coordinates (metres / point_step_m). Every coding sends the points as
// a set: the decoded order is the coding's own (documented in docs/fleet.md).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "draco/fleet/codec.hpp"

namespace draco::fleet::points {

struct GridPoint {
  std::int64_t x = 0;
  std::int64_t y = 0;
  bool operator==(const GridPoint&) const = default;
};

enum class PointCoding : std::uint8_t {
  kFixed = 0,        // offset (min x, min y), then x and y in the fewest fixed bits
  kChain = 1,        // greedy nearest-neighbour chain, zigzag deltas, exp-Golomb (per-axis k)
  kSortedBytes = 2,  // sorted by (x, y), byte LEB128 deltas (byte-aligned: for deflate)
  kSorted = 3,       // sorted by (x, y), x deltas and zigzag y deltas, exp-Golomb (per-axis k)
};
inline constexpr int kNumPointCodings = 4;
const char* PointCodingName(PointCoding coding);

// The block (bytes, zero-padded) of `points` in `coding`.
std::vector<std::uint8_t> EncodeBlock(const std::vector<GridPoint>& points, PointCoding coding);
// Decodes exactly `count` points (the block must hold nothing else); each |coordinate| must be
// at most max_abs. Returns an empty string or the reason.
std::string DecodeBlock(const std::vector<std::uint8_t>& block, PointCoding coding, int count,
                        std::int64_t max_abs, std::vector<GridPoint>* points);

// Raw deflate (zlib, no header). Inflate fails (false) on a bad stream or when the output
// would exceed max_out bytes.
std::vector<std::uint8_t> Deflate(const std::vector<std::uint8_t>& bytes);
bool Inflate(const std::vector<std::uint8_t>& bytes, std::size_t max_out,
             std::vector<std::uint8_t>* out);

// A scan-reply payload with the given coding (deflated or not, even when larger), for
// measurements (Encode picks the smallest).
std::vector<std::uint8_t> EncodeScanReplyWith(const msgs::ScanReply& m, const CodecOptions& o,
                                              PointCoding coding, bool deflate);

}  // namespace draco::fleet::points
