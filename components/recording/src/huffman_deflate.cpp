#include "huffman_deflate.hpp"

#include <algorithm>
#include <array>
#include <utility>

#include <zlib.h>

namespace draco::recording::internal {
namespace {

constexpr int kLitCodes = 257;  // 256 literals and end-of-block
constexpr int kMaxBits = 15;    // literal/length code limit (RFC 1951)
constexpr int kMaxClBits = 7;   // code-length code limit

// Huffman code lengths for freq[0, n), none longer than limit. Zero-frequency symbols get
// length 0. If the optimal tree is too deep, frequencies are halved (kept nonzero) and the
// tree rebuilt; all-equal frequencies give a balanced tree, so this ends.
void BuildLengths(const std::uint32_t* freq, int n, int limit, std::uint8_t* len) {
  std::vector<std::uint64_t> f(freq, freq + n);
  std::vector<std::pair<std::uint64_t, int>> leaves;
  std::vector<std::uint64_t> w;
  std::vector<int> parent;
  std::vector<int> depth;
  for (;;) {
    std::fill(len, len + n, 0);
    leaves.clear();
    for (int i = 0; i < n; ++i) {
      if (f[i] != 0) leaves.push_back({f[i], i});
    }
    const int m = static_cast<int>(leaves.size());
    if (m == 0) return;
    if (m == 1) {
      len[leaves[0].second] = 1;
      return;
    }
    std::sort(leaves.begin(), leaves.end());
    // Two-queue construction: leaves in weight order, internal nodes are made in weight order.
    const int nodes = 2 * m - 1;
    w.assign(nodes, 0);
    parent.assign(nodes, 0);
    depth.assign(nodes, 0);
    for (int i = 0; i < m; ++i) w[i] = leaves[i].first;
    int li = 0;
    int ii = m;
    auto pick = [&](int next) {
      if (li < m && (ii >= next || w[li] <= w[ii])) return li++;
      return ii++;
    };
    for (int next = m; next < nodes; ++next) {
      const int a = pick(next);
      const int b = pick(next);
      w[next] = w[a] + w[b];
      parent[a] = next;
      parent[b] = next;
    }
    int max_depth = 0;
    for (int k = nodes - 2; k >= 0; --k) depth[k] = depth[parent[k]] + 1;
    for (int i = 0; i < m; ++i) {
      len[leaves[i].second] = static_cast<std::uint8_t>(depth[i]);
      max_depth = std::max(max_depth, depth[i]);
    }
    if (max_depth <= limit) return;
    for (auto& x : f) x = (x + 1) / 2;
  }
}

// Canonical codes (RFC 1951 3.2.2), bit-reversed: deflate sends Huffman codes MSB first
// into an LSB-first bit stream.
void CanonicalCodes(const std::uint8_t* len, int n, std::uint16_t* code) {
  std::array<int, kMaxBits + 2> count{};
  for (int i = 0; i < n; ++i) ++count[len[i]];
  count[0] = 0;
  std::array<int, kMaxBits + 2> next{};
  int c = 0;
  for (int bits = 1; bits <= kMaxBits; ++bits) {
    c = (c + count[bits - 1]) << 1;
    next[bits] = c;
  }
  for (int i = 0; i < n; ++i) {
    const int l = len[i];
    code[i] = 0;
    if (l == 0) continue;
    int v = next[l]++;
    int r = 0;
    for (int b = 0; b < l; ++b) {
      r = (r << 1) | (v & 1);
      v >>= 1;
    }
    code[i] = static_cast<std::uint16_t>(r);
  }
}

class BitWriter {
 public:
  explicit BitWriter(std::uint8_t* p) : p_(p) {}
  void Put(std::uint32_t bits, int n) {
    acc_ |= static_cast<std::uint64_t>(bits) << count_;
    count_ += n;
    if (count_ >= 32) {
      for (int i = 0; i < 4; ++i) p_[i] = static_cast<std::uint8_t>(acc_ >> (8 * i));
      p_ += 4;
      acc_ >>= 32;
      count_ -= 32;
    }
  }
  // Pads to a byte boundary and returns the end of the written bytes.
  std::uint8_t* Finish() {
    while (count_ > 0) {
      *p_++ = static_cast<std::uint8_t>(acc_);
      acc_ >>= 8;
      count_ = std::max(0, count_ - 8);
    }
    return p_;
  }

 private:
  std::uint8_t* p_;
  std::uint64_t acc_ = 0;
  int count_ = 0;
};

void WriteBlock(const std::uint8_t* data, std::size_t size, bool final_block, BitWriter& bw) {
  std::array<std::uint32_t, kLitCodes> freq{};
  std::array<std::array<std::uint32_t, 256>, 4> part{};  // 4 histograms: fewer store stalls
  std::size_t k = 0;
  for (; k + 3 < size; k += 4) {
    ++part[0][data[k]];
    ++part[1][data[k + 1]];
    ++part[2][data[k + 2]];
    ++part[3][data[k + 3]];
  }
  for (; k < size; ++k) ++part[0][data[k]];
  for (int v = 0; v < 256; ++v) freq[v] = part[0][v] + part[1][v] + part[2][v] + part[3][v];
  freq[256] = 1;  // end of block
  std::array<std::uint8_t, kLitCodes> len{};
  BuildLengths(freq.data(), kLitCodes, kMaxBits, len.data());
  if (size == 0) len[0] = 1;  // an end-of-block-only code still needs two codes: 0 and 256
  std::array<std::uint16_t, kLitCodes> code{};
  CanonicalCodes(len.data(), kLitCodes, code.data());

  // Code lengths: 257 literal/length codes, then 2 distance codes of length 1 (unused, but a
  // complete distance code keeps every inflater happy). Sent literally (symbols 0-15).
  constexpr int kDistCodes = 2;
  std::array<std::uint32_t, 19> cl_freq{};
  for (int i = 0; i < kLitCodes; ++i) ++cl_freq[len[i]];
  cl_freq[1] += kDistCodes;
  std::array<std::uint8_t, 19> cl_len{};
  BuildLengths(cl_freq.data(), 19, kMaxClBits, cl_len.data());
  std::array<std::uint16_t, 19> cl_code{};
  CanonicalCodes(cl_len.data(), 19, cl_code.data());
  static constexpr int kClOrder[19] = {16, 17, 18, 0, 8,  7, 9,  6, 10, 5,
                                       11, 4,  12, 3, 13, 2, 14, 1, 15};
  int hclen = 19;
  while (hclen > 4 && cl_len[kClOrder[hclen - 1]] == 0) --hclen;

  bw.Put(final_block ? 1 : 0, 1);
  bw.Put(2, 2);                // dynamic Huffman
  bw.Put(kLitCodes - 257, 5);  // HLIT
  bw.Put(kDistCodes - 1, 5);   // HDIST
  bw.Put(hclen - 4, 4);        // HCLEN
  for (int i = 0; i < hclen; ++i) bw.Put(cl_len[kClOrder[i]], 3);
  for (int i = 0; i < kLitCodes; ++i) bw.Put(cl_code[len[i]], cl_len[len[i]]);
  for (int i = 0; i < kDistCodes; ++i) bw.Put(cl_code[1], cl_len[1]);

  // Literals: code and length packed per symbol for one lookup.
  std::array<std::uint32_t, 256> packed{};
  for (int i = 0; i < 256; ++i) packed[i] = (static_cast<std::uint32_t>(code[i]) << 8) | len[i];
  std::size_t i = 0;
  for (; i + 1 < size; i += 2) {  // two literals per write: at most 30 bits
    const std::uint32_t p0 = packed[data[i]];
    const std::uint32_t p1 = packed[data[i + 1]];
    const int n0 = static_cast<int>(p0 & 0xff);
    bw.Put((p0 >> 8) | ((p1 >> 8) << n0), n0 + static_cast<int>(p1 & 0xff));
  }
  for (; i < size; ++i) {
    const std::uint32_t p = packed[data[i]];
    bw.Put(p >> 8, static_cast<int>(p & 0xff));
  }
  bw.Put(code[256], len[256]);
}

}  // namespace

void HuffmanDeflateAppend(const std::uint8_t* data, std::size_t size,
                          std::vector<std::uint8_t>& out, std::size_t block_bytes) {
  block_bytes = std::max<std::size_t>(1, block_bytes);
  const std::size_t blocks = std::max<std::size_t>(1, (size + block_bytes - 1) / block_bytes);
  // Worst case: 15 bits per literal plus a header of at most ~200 bytes per block.
  const std::size_t start = out.size();
  out.resize(start + 2 + size * 2 + blocks * 256 + 8);
  std::uint8_t* p = out.data() + start;
  *p++ = 0x78;  // CMF: deflate, 32 KiB window
  *p++ = 0x01;  // FLG: fastest, (0x78 * 256 + 0x01) % 31 == 0
  BitWriter bw(p);
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t begin = b * block_bytes;
    const std::size_t n = std::min(block_bytes, size - std::min(size, begin));
    WriteBlock(data + begin, n, b + 1 == blocks, bw);
  }
  p = bw.Finish();
  const auto adler = static_cast<std::uint32_t>(
      adler32(adler32(0L, Z_NULL, 0), size == 0 ? Z_NULL : data, static_cast<uInt>(size)));
  for (int i = 3; i >= 0; --i) *p++ = static_cast<std::uint8_t>(adler >> (8 * i));
  out.resize(static_cast<std::size_t>(p - out.data()));
}

}  // namespace draco::recording::internal
