// The writer's literal-only deflate: every stream must inflate (zlib) to the input exactly,
// for sizes around the block boundary, constant data, random data and speckle-like data.
#include "huffman_deflate.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <random>
#include <vector>

namespace draco::recording::internal {
namespace {

std::vector<std::uint8_t> Inflate(const std::vector<std::uint8_t>& stream, std::size_t size) {
  std::vector<std::uint8_t> out(size + 16);
  uLongf out_size = static_cast<uLongf>(out.size());
  const int rc =
      uncompress(out.data(), &out_size, stream.data(), static_cast<uLong>(stream.size()));
  EXPECT_EQ(rc, Z_OK);
  out.resize(out_size);
  return out;
}

void ExpectRoundTrip(const std::vector<std::uint8_t>& data) {
  std::vector<std::uint8_t> stream = {0xAB};  // appends: what was there stays
  HuffmanDeflateAppend(data.data(), data.size(), stream);
  ASSERT_EQ(stream[0], 0xAB);
  const std::vector<std::uint8_t> body(stream.begin() + 1, stream.end());
  EXPECT_EQ(Inflate(body, data.size()), data) << "size " << data.size();
}

TEST(HuffmanDeflate, InflatesToTheInputAtEverySize) {
  std::mt19937 rng(1);
  for (std::size_t size : {0u, 1u, 2u, 255u, 16383u, 16384u, 16385u, 40000u, 262144u}) {
    std::vector<std::uint8_t> data(size);
    for (auto& b : data) b = static_cast<std::uint8_t>(rng());
    ExpectRoundTrip(data);
  }
}

TEST(HuffmanDeflate, ConstantAndSkewedData) {
  ExpectRoundTrip(std::vector<std::uint8_t>(100000, 7));
  // Speckle-like: exponential intensities, mostly dark.
  std::mt19937 rng(2);
  std::exponential_distribution<double> e(1.0 / 20.0);
  std::vector<std::uint8_t> speckle(512 * 512);
  for (auto& b : speckle) b = static_cast<std::uint8_t>(std::min(255.0, e(rng)));
  std::vector<std::uint8_t> stream;
  HuffmanDeflateAppend(speckle.data(), speckle.size(), stream);
  EXPECT_EQ(Inflate(stream, speckle.size()), speckle);
  // Entropy of this source is about 6.2 bits per byte: the stream is well below raw.
  EXPECT_LT(stream.size(), speckle.size() * 85 / 100);
}

TEST(HuffmanDeflate, IsDeterministic) {
  std::vector<std::uint8_t> data(50000);
  std::mt19937 rng(3);
  for (auto& b : data) b = static_cast<std::uint8_t>(rng() % 40);
  std::vector<std::uint8_t> a, b;
  HuffmanDeflateAppend(data.data(), data.size(), a);
  HuffmanDeflateAppend(data.data(), data.size(), b);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace draco::recording::internal
