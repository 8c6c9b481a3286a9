#include "bits.hpp"

#include <bit>
#include <limits>

namespace draco::fleet::bits {

namespace {
constexpr int kMaxExpGolombOrder = 40;
}

int ExpGolombBits(std::uint64_t v, int k) {
  // w = v + 2^k may overflow 64 bits for huge v; the writer handles it by the same formula in
  // 128-bit-free form: values here come from quantised fields far below 2^62.
  const std::uint64_t w = v + (std::uint64_t{1} << k);
  const int n = std::bit_width(w) - 1;
  return (n - k) + n + 1;
}

int BestExpGolombOrder(const std::vector<std::uint64_t>& values, int max_k,
                       std::uint64_t* total_bits) {
  int best_k = 0;
  std::uint64_t best = std::numeric_limits<std::uint64_t>::max();
  for (int k = 0; k <= max_k && k <= kMaxExpGolombOrder; ++k) {
    std::uint64_t total = 0;
    for (const std::uint64_t v : values) total += static_cast<std::uint64_t>(ExpGolombBits(v, k));
    if (total < best) {
      best = total;
      best_k = k;
    }
  }
  if (total_bits) *total_bits = values.empty() ? 0 : best;
  return best_k;
}

void BitWriter::Put(std::uint64_t value, int num_bits) {
  for (int i = num_bits - 1; i >= 0; --i) {
    if (num_bits_ % 8 == 0) bytes_.push_back(0);
    if ((value >> i) & 1) bytes_.back() |= static_cast<std::uint8_t>(0x80u >> (num_bits_ % 8));
    ++num_bits_;
  }
}

void BitWriter::PutVarint(std::uint64_t value) {
  do {
    Put(value & 0x7f, 7);
    value >>= 7;
    PutBit(value != 0);
  } while (value != 0);
}

void BitWriter::PutExpGolomb(std::uint64_t value, int k) {
  const std::uint64_t w = value + (std::uint64_t{1} << k);
  const int n = std::bit_width(w) - 1;
  Put(0, n - k);
  Put(w, n + 1);
}

void BitWriter::AlignToByte() {
  if (num_bits_ % 8 != 0) Put(0, 8 - static_cast<int>(num_bits_ % 8));
}

void BitWriter::PutBytes(const std::vector<std::uint8_t>& bytes) {
  AlignToByte();
  bytes_.insert(bytes_.end(), bytes.begin(), bytes.end());
  num_bits_ += bytes.size() * 8;
}

bool BitReader::Get(int num_bits, std::uint64_t* value) {
  *value = 0;
  if (!ok_) return false;
  if (num_bits < 0 || num_bits > 64 || static_cast<std::size_t>(num_bits) > remaining_bits())
    return Fail();
  std::uint64_t v = 0;
  for (int i = 0; i < num_bits; ++i) {
    v = (v << 1) | ((data_[pos_ / 8] >> (7 - pos_ % 8)) & 1u);
    ++pos_;
  }
  *value = v;
  return true;
}

bool BitReader::GetBit(bool* bit) {
  std::uint64_t v = 0;
  const bool got = Get(1, &v);
  *bit = v != 0;
  return got;
}

bool BitReader::GetVarint(std::uint64_t* value) {
  *value = 0;
  std::uint64_t v = 0;
  for (int group = 0; group < 10; ++group) {
    std::uint64_t bits7 = 0;
    bool more = false;
    if (!Get(7, &bits7) || !GetBit(&more)) return false;
    if (group == 9 && (bits7 > 1 || more)) return Fail();  // beyond 64 bits
    v |= bits7 << (7 * group);
    if (!more) {
      *value = v;
      return true;
    }
  }
  return Fail();
}

bool BitReader::GetExpGolomb(int k, std::uint64_t* value) {
  *value = 0;
  if (!ok_) return false;
  if (k < 0 || k > kMaxExpGolombOrder) return Fail();
  int zeros = 0;
  for (;;) {
    bool bit = false;
    if (!GetBit(&bit)) return false;
    if (bit) break;
    if (++zeros + k > 62) return Fail();  // longer than any value the writer produces
  }
  const int n = zeros + k;  // bits after the leading one
  std::uint64_t rest = 0;
  if (!Get(n, &rest)) return false;
  const std::uint64_t w = (std::uint64_t{1} << n) | rest;
  *value = w - (std::uint64_t{1} << k);
  return true;
}

bool BitReader::GetSignedExpGolomb(int k, std::int64_t* value) {
  std::uint64_t u = 0;
  const bool got = GetExpGolomb(k, &u);
  *value = UnZigZag(u);
  return got;
}

bool BitReader::AlignToByte() {
  const std::size_t skip = (8 - pos_ % 8) % 8;
  std::uint64_t pad = 0;
  if (!Get(static_cast<int>(skip), &pad)) return false;
  if (pad != 0) return Fail();
  return true;
}

bool BitReader::AtPaddedEnd() const {
  if (!ok_) return false;
  if (remaining_bits() >= 8) return false;
  for (std::size_t p = pos_; p < size_bits_; ++p)
    if ((data_[p / 8] >> (7 - p % 8)) & 1u) return false;
  return true;
}

}  // namespace draco::fleet::bits
