// Bit writer and reader of the fleet codec (private). Bits are written most significant first
// into bytes filled from their high bit; the last byte is padded with zero bits.
//
// Variable-length integers:
//   varint        LEB128 in the bit stream: 7-bit groups, low group first, a continuation bit
//                 after each group (at most 10 groups).
//   exp-Golomb k  v + 2^k = w written as (bit_width(w) - 1 - k) zero bits then w (its leading
//                 one included): small values in k + 1 bits, any value in at most ~2x its width.
//   zigzag        signed to unsigned: 0, -1, 1, -2, ... -> 0, 1, 2, 3, ...
// Every read is bounds-checked: on truncation (or an over-long code) the reader fails, stays
// failed, and returns zeros; callers check ok() (or the bool) before using a value.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace draco::fleet::bits {

inline std::uint64_t ZigZag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
inline std::int64_t UnZigZag(std::uint64_t u) {
  return static_cast<std::int64_t>(u >> 1) ^ -static_cast<std::int64_t>(u & 1);
}

// Bits exp-Golomb order k takes for v.
int ExpGolombBits(std::uint64_t v, int k);
// The order k in [0, max_k] that codes `values` in the fewest bits (and that total).
int BestExpGolombOrder(const std::vector<std::uint64_t>& values, int max_k = 24,
                       std::uint64_t* total_bits = nullptr);

class BitWriter {
 public:
  void Put(std::uint64_t value, int num_bits);  // low num_bits of value, num_bits in [0, 64]
  void PutBit(bool bit) { Put(bit ? 1 : 0, 1); }
  void PutVarint(std::uint64_t value);
  void PutExpGolomb(std::uint64_t value, int k);
  void PutSignedExpGolomb(std::int64_t value, int k) { PutExpGolomb(ZigZag(value), k); }
  void AlignToByte();                                     // zero bits up to a byte boundary
  void PutBytes(const std::vector<std::uint8_t>& bytes);  // aligns first
  std::size_t bit_size() const { return num_bits_; }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }  // last byte zero-padded

 private:
  std::vector<std::uint8_t> bytes_;
  std::size_t num_bits_ = 0;
};

class BitReader {
 public:
  BitReader(const std::uint8_t* data, std::size_t size_bytes)
      : data_(data), size_bits_(size_bytes * 8) {}
  explicit BitReader(const std::vector<std::uint8_t>& bytes)
      : BitReader(bytes.data(), bytes.size()) {}

  bool Get(int num_bits, std::uint64_t* value);  // num_bits in [0, 64]
  bool GetBit(bool* bit);
  bool GetVarint(std::uint64_t* value);
  bool GetExpGolomb(int k, std::uint64_t* value);
  bool GetSignedExpGolomb(int k, std::int64_t* value);
  bool AlignToByte();  // skips to the next byte boundary; the skipped bits must be zero

  bool ok() const { return ok_; }
  std::size_t position_bits() const { return pos_; }
  std::size_t remaining_bits() const { return size_bits_ - pos_; }
  // True when what is left is only the zero padding of the last byte.
  bool AtPaddedEnd() const;

 private:
  bool Fail() {
    ok_ = false;
    pos_ = size_bits_;
    return false;
  }
  const std::uint8_t* data_;
  std::size_t size_bits_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

}  // namespace draco::fleet::bits
