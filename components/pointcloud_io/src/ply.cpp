// PLY files through pcl::io (pointcloud_io.hpp).
#include <pcl/io/ply_io.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cloud.hpp"
#include "detail.hpp"
#include "draco/pointcloud_io/pointcloud_io.hpp"

namespace draco::pointcloud_io {

void WritePly(const std::string& path, const std::vector<msgs::Point2>& points) {
  detail::QuietPcl();
  const auto cloud = detail::ToPcl(points);
  detail::WriteThroughTemporary(path, "PLY", [&](const std::string& tmp) {
    if (!cloud.empty()) return pcl::io::savePLYFileBinary(tmp, cloud);
    // PCL 1.13 writes no file for an empty cloud; this is the header it writes otherwise,
    // with no vertices (its own reader and CloudCompare read it).
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f << "ply\nformat binary_little_endian 1.0\ncomment PCL generated\nelement vertex 0\n"
         "property float x\nproperty float y\nproperty float z\nend_header\n";
    f.flush();
    return f ? 0 : -1;
  });
}

namespace {

[[noreturn]] void Fail(const std::string& path, const std::string& why) {
  throw std::runtime_error(path + ": not a readable PLY file: " + why);
}

// Bytes of a PLY scalar type, 0 when unknown.
std::size_t TypeBytes(const std::string& type) {
  static const std::map<std::string, std::size_t> kBytes{
      {"char", 1},   {"int8", 1},    {"uchar", 1},  {"uint8", 1},  {"short", 2}, {"int16", 2},
      {"ushort", 2}, {"uint16", 2},  {"int", 4},    {"int32", 4},  {"uint", 4},  {"uint32", 4},
      {"float", 4},  {"float32", 4}, {"double", 8}, {"float64", 8}};
  const auto it = kBytes.find(type);
  return it == kBytes.end() ? 0 : it->second;
}

// PCL's reader sizes its buffers from the header's element counts before reading the data (a
// 100-byte file announcing 2e9 vertices took 23 GB): every element must fit in what follows
// the header, at its smallest (binary: its scalars' bytes and each list's count; ascii: two
// characters a value).
void CheckPly(const std::string& path, std::size_t file_size) {
  std::ifstream f(path, std::ios::binary);
  if (!f) Fail(path, "cannot open");
  std::string line;
  if (!std::getline(f, line) || line.rfind("ply", 0) != 0) Fail(path, "no 'ply' first line");
  std::size_t header = line.size() + 1;
  bool ascii = false, ended = false;
  unsigned long long needed = 0, element_bytes = 0, count = 0;
  int line_no = 1;
  while (!ended && std::getline(f, line)) {
    ++line_no;
    header += line.size() + 1;
    if (header > 64 * 1024) Fail(path, "no end_header in the first 64 KiB");
    std::istringstream is(line);
    std::string key;
    is >> key;
    const std::string at = "line " + std::to_string(line_no) + ": ";
    if (key == "format") {
      std::string kind;
      is >> kind;
      ascii = kind == "ascii";
    } else if (key == "element" || key == "end_header") {
      needed += count * element_bytes;
      element_bytes = 0;
      count = 0;
      if (key == "end_header") {
        ended = true;
      } else {
        std::string name, digits;
        is >> name >> digits;
        if (digits.empty() || digits.size() > 10 ||
            digits.find_first_not_of("0123456789") != std::string::npos) {
          Fail(path, at + "element " + name + " has no count");
        }
        count = std::stoull(digits);
      }
    } else if (key == "property") {
      std::string type;
      is >> type;
      if (type == "list") is >> type;  // the count's type: at least one per element
      const std::size_t bytes = TypeBytes(type);
      if (bytes == 0) Fail(path, at + "property type '" + type + "'");
      element_bytes += ascii ? 2 : bytes;
    }
  }
  if (!ended) Fail(path, "no end_header");
  const std::size_t body = file_size - std::min(file_size, header);
  if (needed > body) {
    Fail(path, "truncated: the header announces at least " + std::to_string(needed) +
                   " bytes of elements, " + std::to_string(body) + " follow");
  }
}

}  // namespace

std::vector<msgs::Point2> ReadMapPly(const std::string& path) {
  CheckPly(path, detail::FileSize(path, "PLY"));
  detail::QuietPcl();
  pcl::PCLPointCloud2 blob;
  int status = -1;
  try {
    status = pcl::io::loadPLYFile(path, blob);
  } catch (const std::exception& e) {  // pcl::PCLException, std::bad_alloc
    Fail(path, e.what());
  }
  if (status < 0) Fail(path, "PCL's reader refused it (truncated or corrupt)");
  return detail::FromBlob(blob, path, "PLY");
}

}  // namespace draco::pointcloud_io
