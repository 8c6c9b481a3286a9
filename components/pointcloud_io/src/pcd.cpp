// PCD files through pcl::io (pointcloud_io.hpp).
//
// Reading checks the header and the size of the data section before PCL sees the file:
// PCL 1.13's reader dereferences past its field list when the FIELDS line is damaged
// (a segmentation fault, measured with byte flips in tests/pointcloud_io), and it allocates
// what the header announces before reading: a header may announce no more points than the
// data section can hold (binary: their bytes; ascii: two characters a value; compressed: 88
// bytes a compressed byte, LZF's limit), so the memory read is bounded by a multiple of the
// file's size.
#include <pcl/io/pcd_io.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "cloud.hpp"
#include "detail.hpp"
#include "draco/pointcloud_io/pointcloud_io.hpp"

namespace draco::pointcloud_io {
namespace {

constexpr std::size_t kMaxHeaderBytes = 64 * 1024;

[[noreturn]] void Fail(const std::string& path, const std::string& why) {
  throw std::runtime_error(path + ": not a readable PCD file: " + why);
}

std::vector<std::string> Tokens(const std::string& line) {
  std::istringstream is(line);
  std::vector<std::string> out;
  for (std::string t; is >> t;) out.push_back(t);
  return out;
}

// A non-negative decimal integer that fits in 32 bits, else nullopt-like -1.
long long Count(const std::string& s) {
  if (s.empty() || s.size() > 10) return -1;
  long long v = 0;
  for (const char c : s) {
    if (c < '0' || c > '9') return -1;
    v = v * 10 + (c - '0');
  }
  return v <= std::numeric_limits<std::uint32_t>::max() ? v : -1;
}

// The text points of an ascii PCD: exactly `points` non-empty lines of `values` numbers each
// (PCL 1.13's text reader misreads other text: a fuzzed file made it request a 100 TB string).
void CheckAsciiPoints(const std::string& path, std::istream& f, long long points, long long values,
                      int line_no) {
  long long lines = 0;
  std::string line;
  while (std::getline(f, line)) {
    ++line_no;
    const auto t = Tokens(line);
    if (t.empty()) continue;
    const std::string at = "line " + std::to_string(line_no) + ": ";
    if (++lines > points)
      Fail(path, at + "more points than the header's " + std::to_string(points));
    if (static_cast<long long>(t.size()) != values) {
      Fail(path, at + std::to_string(t.size()) + " values, the header announces " +
                     std::to_string(values));
    }
    for (const auto& token : t) {
      char* end = nullptr;
      std::strtod(token.c_str(), &end);
      if (end != token.c_str() + token.size()) Fail(path, at + "'" + token + "' is not a number");
    }
  }
  if (lines != points) {
    Fail(path, "truncated: " + std::to_string(lines) + " point lines, the header announces " +
                   std::to_string(points));
  }
}

// Checks what PCL's reader relies on. Returns nothing; throws naming the file and the line.
void CheckPcd(const std::string& path) {
  const std::size_t file_size = detail::FileSize(path, "PCD");
  std::ifstream f(path, std::ios::binary);
  if (!f) Fail(path, "cannot open");
  std::vector<std::string> fields;
  std::vector<long long> sizes, counts;
  std::vector<char> types;
  long long width = -1, height = 1, points = -1;
  std::string data;
  std::size_t header_bytes = 0;
  int line_no = 0;
  std::string line;
  while (data.empty()) {
    if (!std::getline(f, line)) Fail(path, "the header ends before its DATA line");
    ++line_no;
    header_bytes += line.size() + 1;
    if (header_bytes > kMaxHeaderBytes) Fail(path, "no DATA line in the first 64 KiB");
    const auto t = Tokens(line);
    const std::string at = "line " + std::to_string(line_no) + ": ";
    if (t.empty() || t[0][0] == '#') continue;
    const std::string& key = t[0];
    const std::size_t n = t.size() - 1;
    if (key == "VERSION" || key == "VIEWPOINT") {
      continue;
    } else if (key == "FIELDS") {
      if (!fields.empty()) Fail(path, at + "a second FIELDS line");
      if (n == 0) Fail(path, at + "FIELDS names no field");
      fields.assign(t.begin() + 1, t.end());
    } else if (key == "SIZE" || key == "TYPE" || key == "COUNT") {
      if (fields.empty()) Fail(path, at + key + " before FIELDS");
      if (n != fields.size()) {
        Fail(path, at + key + " has " + std::to_string(n) + " entries for " +
                       std::to_string(fields.size()) + " fields");
      }
      for (std::size_t i = 1; i <= n; ++i) {
        if (key == "TYPE") {
          if (t[i] != "F" && t[i] != "I" && t[i] != "U") Fail(path, at + "TYPE '" + t[i] + "'");
          types.push_back(t[i][0]);
        } else {
          const long long v = Count(t[i]);
          if (key == "SIZE" && v != 1 && v != 2 && v != 4 && v != 8) {
            Fail(path, at + "SIZE '" + t[i] + "'");
          }
          if (key == "COUNT" && (v < 1 || v > 1 << 20)) Fail(path, at + "COUNT '" + t[i] + "'");
          (key == "SIZE" ? sizes : counts).push_back(v);
        }
      }
    } else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
      const long long v = n == 1 ? Count(t[1]) : -1;
      if (v < 0) Fail(path, at + key + " is not a count");
      (key == "WIDTH" ? width : key == "HEIGHT" ? height : points) = v;
    } else if (key == "DATA") {
      if (n != 1 || (t[1] != "ascii" && t[1] != "binary" && t[1] != "binary_compressed")) {
        Fail(path, at + "DATA must be ascii, binary or binary_compressed");
      }
      data = t[1];
    } else {
      Fail(path, at + "unknown header entry '" + key + "'");
    }
  }
  if (fields.empty() || sizes.size() != fields.size() || types.size() != fields.size()) {
    Fail(path, "the header lacks FIELDS, SIZE or TYPE");
  }
  if (counts.empty()) counts.assign(fields.size(), 1);
  if (width < 0) Fail(path, "the header has no WIDTH");
  if (points < 0) points = width * height;
  if (points != width * height) {
    Fail(path, "POINTS " + std::to_string(points) + " is not WIDTH x HEIGHT");
  }
  long long point_bytes = 0;
  bool x = false, y = false;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    point_bytes += sizes[i] * counts[i];
    if (fields[i] == "x" || fields[i] == "y") {
      if (types[i] != 'F' || (sizes[i] != 4 && sizes[i] != 8) || counts[i] != 1) {
        Fail(path, "field " + fields[i] + " is not one float");
      }
      (fields[i] == "x" ? x : y) = true;
    }
  }
  if (!x || !y) Fail(path, "no x and y fields");
  const std::size_t body = file_size - std::min(file_size, header_bytes);
  const auto needed = static_cast<unsigned long long>(points) * point_bytes;
  if (data == "binary" && body < needed) {
    Fail(path, "truncated: " + std::to_string(body) + " bytes of points, the header announces " +
                   std::to_string(needed));
  }
  if (data == "binary_compressed") {
    std::uint32_t sizes_lzf[2] = {0, 0};  // compressed, uncompressed
    // PCL reads the block's sizes, and allocates twice the uncompressed one, whenever the data
    // holds them, even when the header announces no points.
    const bool block = points > 0 || body >= sizeof(sizes_lzf);
    if (block && !f.read(reinterpret_cast<char*>(sizes_lzf), sizeof(sizes_lzf))) {
      Fail(path, "truncated before the compressed block");
    }
    if (block && sizes_lzf[1] != needed) {
      Fail(path, "the compressed block holds " + std::to_string(sizes_lzf[1]) +
                     " bytes of points, the header announces " + std::to_string(needed));
    }
    // LZF writes at most 264 bytes (a back reference) for 3 bytes of input.
    if (points > 0 && sizes_lzf[1] > 88ull * sizes_lzf[0]) {
      Fail(path, "a compressed block of " + std::to_string(sizes_lzf[0]) +
                     " bytes cannot hold the " + std::to_string(sizes_lzf[1]) + " it announces");
    }
    if (points > 0 && body < sizeof(sizes_lzf) + sizes_lzf[0]) {
      Fail(path, "truncated: " + std::to_string(body - sizeof(sizes_lzf)) +
                     " compressed bytes, the file announces " + std::to_string(sizes_lzf[0]));
    }
  }
  // Every value takes at least two characters (a digit and a separator).
  long long values = 0;
  for (const long long c : counts) values += c;
  if (data == "ascii" && static_cast<unsigned long long>(points) * 2 * values > body) {
    Fail(path, "truncated: " + std::to_string(points) + " points of " + std::to_string(values) +
                   " values announced in " + std::to_string(body) + " bytes of text");
  }
  if (data == "ascii") CheckAsciiPoints(path, f, points, values, line_no);
}

}  // namespace

void WritePcd(const std::string& path, const std::vector<msgs::Point2>& points,
              PcdEncoding encoding) {
  detail::QuietPcl();
  const auto cloud = detail::ToPcl(points);
  detail::WriteThroughTemporary(path, "PCD", [&](const std::string& tmp) {
    pcl::PCDWriter writer;
    switch (encoding) {
      case PcdEncoding::kBinaryCompressed:
        return writer.writeBinaryCompressed(tmp, cloud);
      case PcdEncoding::kAscii:
        return writer.writeASCII(tmp, cloud, 9);
      case PcdEncoding::kBinary:
        break;
    }
    return writer.writeBinary(tmp, cloud);
  });
}

std::vector<msgs::Point2> ReadMapPcd(const std::string& path) {
  CheckPcd(path);
  detail::QuietPcl();
  pcl::PCLPointCloud2 blob;
  int status = -1;
  try {
    status = pcl::io::loadPCDFile(path, blob);
  } catch (const std::exception& e) {  // pcl::PCLException, std::bad_alloc
    Fail(path, e.what());
  }
  if (status < 0) Fail(path, "PCL's reader refused it");
  return detail::FromBlob(blob, path, "PCD");
}

}  // namespace draco::pointcloud_io
