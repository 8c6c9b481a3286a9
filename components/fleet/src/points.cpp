#include "points.hpp"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <limits>

#include "bits.hpp"

namespace draco::fleet::points {

namespace {

using bits::BitReader;
using bits::BitWriter;

constexpr int kOrderBits = 5;  // exp-Golomb orders 0..31
constexpr int kWidthBits = 6;  // fixed widths 0..63
constexpr int kOffsetOrder = 8;

std::int64_t Abs(std::int64_t v) { return v < 0 ? -v : v; }

std::vector<GridPoint> Sorted(std::vector<GridPoint> p) {
  std::sort(p.begin(), p.end(), [](const GridPoint& a, const GridPoint& b) {
    return a.x != b.x ? a.x < b.x : a.y < b.y;
  });
  return p;
}

// Greedy nearest-neighbour chain from the lowest (x, y).
std::vector<GridPoint> Chain(const std::vector<GridPoint>& in) {
  std::vector<GridPoint> rest = Sorted(in);
  std::vector<GridPoint> out;
  out.reserve(rest.size());
  if (rest.empty()) return out;
  out.push_back(rest.front());
  rest.erase(rest.begin());
  while (!rest.empty()) {
    const GridPoint& c = out.back();
    std::size_t best = 0;
    std::int64_t best_d = std::numeric_limits<std::int64_t>::max();
    for (std::size_t i = 0; i < rest.size(); ++i) {
      const std::int64_t dx = rest[i].x - c.x, dy = rest[i].y - c.y;
      const std::int64_t d = dx * dx + dy * dy;
      if (d < best_d) {
        best_d = d;
        best = i;
      }
    }
    out.push_back(rest[best]);
    rest[best] = rest.back();
    rest.pop_back();
  }
  return out;
}

// Deltas of consecutive points (the first against the origin).
void Deltas(const std::vector<GridPoint>& p, std::vector<std::int64_t>* dx,
            std::vector<std::int64_t>* dy) {
  GridPoint prev;
  for (const auto& q : p) {
    dx->push_back(q.x - prev.x);
    dy->push_back(q.y - prev.y);
    prev = q;
  }
}

std::vector<std::uint64_t> ZigZags(const std::vector<std::int64_t>& v) {
  std::vector<std::uint64_t> out;
  out.reserve(v.size());
  for (const auto x : v) out.push_back(bits::ZigZag(x));
  return out;
}

void EncodeFixed(const std::vector<GridPoint>& p, BitWriter* w) {
  if (p.empty()) return;
  std::int64_t min_x = p[0].x, max_x = p[0].x, min_y = p[0].y, max_y = p[0].y;
  for (const auto& q : p) {
    min_x = std::min(min_x, q.x);
    max_x = std::max(max_x, q.x);
    min_y = std::min(min_y, q.y);
    max_y = std::max(max_y, q.y);
  }
  const int wx = std::bit_width(static_cast<std::uint64_t>(max_x - min_x));
  const int wy = std::bit_width(static_cast<std::uint64_t>(max_y - min_y));
  w->PutSignedExpGolomb(min_x, kOffsetOrder);
  w->PutSignedExpGolomb(min_y, kOffsetOrder);
  w->Put(static_cast<std::uint64_t>(wx), kWidthBits);
  w->Put(static_cast<std::uint64_t>(wy), kWidthBits);
  for (const auto& q : p) {
    w->Put(static_cast<std::uint64_t>(q.x - min_x), wx);
    w->Put(static_cast<std::uint64_t>(q.y - min_y), wy);
  }
}

// Chain: both deltas zigzag. Sorted: x deltas unsigned after the first point.
void EncodeDeltas(const std::vector<GridPoint>& p, bool sorted, BitWriter* w) {
  if (p.empty()) return;
  std::vector<std::int64_t> dx, dy;
  Deltas(p, &dx, &dy);
  std::vector<std::uint64_t> ux = ZigZags(dx);
  if (sorted)
    for (std::size_t i = 1; i < dx.size(); ++i) ux[i] = static_cast<std::uint64_t>(dx[i]);
  const std::vector<std::uint64_t> uy = ZigZags(dy);
  const int kx = bits::BestExpGolombOrder(ux, (1 << kOrderBits) - 1);
  const int ky = bits::BestExpGolombOrder(uy, (1 << kOrderBits) - 1);
  w->Put(static_cast<std::uint64_t>(kx), kOrderBits);
  w->Put(static_cast<std::uint64_t>(ky), kOrderBits);
  for (std::size_t i = 0; i < p.size(); ++i) {
    w->PutExpGolomb(ux[i], kx);
    w->PutExpGolomb(uy[i], ky);
  }
}

void EncodeSortedBytes(const std::vector<GridPoint>& p, BitWriter* w) {
  GridPoint prev;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::int64_t dx = p[i].x - prev.x;
    w->PutVarint(i == 0 ? bits::ZigZag(dx) : static_cast<std::uint64_t>(dx));
    w->PutVarint(bits::ZigZag(p[i].y - prev.y));
    prev = p[i];
  }
}

}  // namespace

const char* PointCodingName(PointCoding coding) {
  switch (coding) {
    case PointCoding::kFixed:
      return "fixed";
    case PointCoding::kChain:
      return "chain";
    case PointCoding::kSortedBytes:
      return "sorted-bytes";
    case PointCoding::kSorted:
      return "sorted";
  }
  return "unknown";
}

std::vector<std::uint8_t> EncodeBlock(const std::vector<GridPoint>& points, PointCoding coding) {
  BitWriter w;
  switch (coding) {
    case PointCoding::kFixed:
      EncodeFixed(points, &w);
      break;
    case PointCoding::kChain:
      EncodeDeltas(Chain(points), false, &w);
      break;
    case PointCoding::kSortedBytes:
      EncodeSortedBytes(Sorted(points), &w);
      break;
    case PointCoding::kSorted:
      EncodeDeltas(Sorted(points), true, &w);
      break;
  }
  return w.bytes();
}

std::string DecodeBlock(const std::vector<std::uint8_t>& block, PointCoding coding, int count,
                        std::int64_t max_abs, std::vector<GridPoint>* points) {
  points->clear();
  if (count < 0) return "negative point count";
  BitReader r(block);
  const auto check = [&](const GridPoint& q) { return Abs(q.x) <= max_abs && Abs(q.y) <= max_abs; };
  // A delta larger than this cannot lead to a coordinate within the bound (and adding it could
  // overflow).
  const std::uint64_t max_delta = 2 * static_cast<std::uint64_t>(max_abs);
  const auto add = [&](std::int64_t base, std::uint64_t magnitude, bool negative,
                       std::int64_t* out) {
    if (magnitude > max_delta) return false;
    *out = negative ? base - static_cast<std::int64_t>(magnitude)
                    : base + static_cast<std::int64_t>(magnitude);
    return true;
  };
  // Delta-coded points: each (ux, uy) is the move from the previous point, zigzag-signed, x
  // unsigned after the first point when the points are sorted by x.
  const auto deltas = [&](bool sorted, const auto& read_pair) -> const char* {
    GridPoint prev;
    for (int i = 0; i < count; ++i) {
      std::uint64_t ux = 0, uy = 0;
      if (const char* error = read_pair(&ux, &uy)) return error;
      GridPoint q;
      const bool signed_x = !sorted || i == 0;
      const std::uint64_t mx = signed_x ? (ux >> 1) + (ux & 1) : ux;
      const std::uint64_t my = (uy >> 1) + (uy & 1);
      if (!add(prev.x, mx, signed_x && (ux & 1), &q.x) || !add(prev.y, my, uy & 1, &q.y) ||
          !check(q))
        return "coordinate out of bounds";
      points->push_back(q);
      prev = q;
    }
    return nullptr;
  };
  points->reserve(static_cast<std::size_t>(count));  // the caller checked count against Bounds
  if (count > 0) {
    switch (coding) {
      case PointCoding::kFixed: {
        std::int64_t min_x = 0, min_y = 0;
        std::uint64_t wx = 0, wy = 0;
        r.GetSignedExpGolomb(kOffsetOrder, &min_x);
        r.GetSignedExpGolomb(kOffsetOrder, &min_y);
        r.Get(kWidthBits, &wx);
        r.Get(kWidthBits, &wy);
        if (!r.ok()) return "truncated";
        if (wx > 62 || wy > 62) return "field width over 62 bits";
        if (Abs(min_x) > max_abs || Abs(min_y) > max_abs) return "coordinate out of bounds";
        for (int i = 0; i < count; ++i) {
          std::uint64_t ox = 0, oy = 0;
          if (!r.Get(static_cast<int>(wx), &ox) || !r.Get(static_cast<int>(wy), &oy))
            return "truncated";
          GridPoint q;
          if (!add(min_x, ox, false, &q.x) || !add(min_y, oy, false, &q.y) || !check(q))
            return "coordinate out of bounds";
          points->push_back(q);
        }
        break;
      }
      case PointCoding::kChain:
      case PointCoding::kSorted: {
        const bool sorted = coding == PointCoding::kSorted;
        std::uint64_t kx = 0, ky = 0;
        r.Get(kOrderBits, &kx);
        r.Get(kOrderBits, &ky);
        if (!r.ok()) return "truncated";
        const char* error =
            deltas(sorted, [&](std::uint64_t* ux, std::uint64_t* uy) -> const char* {
              return r.GetExpGolomb(static_cast<int>(kx), ux) &&
                             r.GetExpGolomb(static_cast<int>(ky), uy)
                         ? nullptr
                         : "truncated or bad code";
            });
        if (error) return error;
        break;
      }
      case PointCoding::kSortedBytes: {
        const char* error = deltas(true, [&](std::uint64_t* ux, std::uint64_t* uy) -> const char* {
          return r.GetVarint(ux) && r.GetVarint(uy) ? nullptr : "truncated or bad varint";
        });
        if (error) return error;
        break;
      }
      default:
        return "unknown point coding";
    }
  }
  if (!r.AtPaddedEnd()) return "bytes left over after the points";
  return {};
}

std::vector<std::uint8_t> Deflate(const std::vector<std::uint8_t>& bytes) {
  z_stream s{};
  if (deflateInit2(&s, Z_BEST_COMPRESSION, Z_DEFLATED, -15, 9, Z_DEFAULT_STRATEGY) != Z_OK)
    return {};
  std::vector<std::uint8_t> out(deflateBound(&s, static_cast<uLong>(bytes.size())) + 16);
  s.next_in = const_cast<Bytef*>(bytes.data());
  s.avail_in = static_cast<uInt>(bytes.size());
  s.next_out = out.data();
  s.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&s, Z_FINISH);
  out.resize(s.total_out);
  deflateEnd(&s);
  if (rc != Z_STREAM_END) return {};
  return out;
}

bool Inflate(const std::vector<std::uint8_t>& bytes, std::size_t max_out,
             std::vector<std::uint8_t>* out) {
  out->clear();
  z_stream s{};
  if (inflateInit2(&s, -15) != Z_OK) return false;
  std::vector<std::uint8_t> buf(max_out + 1);  // one more: output beyond max_out is an error
  s.next_in = const_cast<Bytef*>(bytes.data());
  s.avail_in = static_cast<uInt>(bytes.size());
  s.next_out = buf.data();
  s.avail_out = static_cast<uInt>(buf.size());
  const int rc = inflate(&s, Z_FINISH);
  const std::size_t produced = s.total_out;
  const bool all_input = s.avail_in == 0;
  inflateEnd(&s);
  if (rc != Z_STREAM_END || !all_input || produced > max_out) return false;
  buf.resize(produced);
  *out = std::move(buf);
  return true;
}

}  // namespace draco::fleet::points
