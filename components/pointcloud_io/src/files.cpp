// Encoding names, the extension dispatch and the atomic write (pointcloud_io.hpp). No PCL.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <system_error>

#include "detail.hpp"
#include "draco/pointcloud_io/pointcloud_io.hpp"

namespace draco::pointcloud_io {

const char* PcdEncodingName(PcdEncoding encoding) {
  switch (encoding) {
    case PcdEncoding::kBinary:
      return "binary";
    case PcdEncoding::kBinaryCompressed:
      return "binary_compressed";
    case PcdEncoding::kAscii:
      return "ascii";
  }
  return "binary";
}

PcdEncoding ParsePcdEncoding(std::string_view name) {
  for (const auto e : {PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed, PcdEncoding::kAscii}) {
    if (name == PcdEncodingName(e)) return e;
  }
  throw std::invalid_argument("PCD encoding '" + std::string(name) +
                              "' is not one of: binary, binary_compressed, ascii");
}

std::vector<msgs::Point2> ReadMap(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".pcd") return ReadMapPcd(path);
  if (ext == ".ply") return ReadMapPly(path);
  throw std::runtime_error(path + ": not a point-cloud file name (expected .pcd or .ply)");
}

namespace detail {

void WriteThroughTemporary(const std::string& path, const std::string& what,
                           const std::function<int(const std::string& tmp)>& write) {
  const std::string tmp = path + ".partial." + std::to_string(::getpid());
  std::string failure;
  try {
    if (write(tmp) < 0) failure = "the PCL writer failed";
  } catch (const std::exception& e) {
    failure = e.what();
  }
  std::error_code ec;
  if (failure.empty()) {
    std::filesystem::rename(tmp, path, ec);
    if (!ec) return;
    failure = "cannot rename into place: " + ec.message();
  }
  std::filesystem::remove(tmp, ec);
  throw std::runtime_error(path + ": cannot write " + what + " (" + failure + ")");
}

std::size_t FileSize(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw std::runtime_error(path + ": cannot open " + what + " (no such file)");
  }
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw std::runtime_error(path + ": cannot open " + what + " (" + ec.message() + ")");
  return static_cast<std::size_t>(size);
}

}  // namespace detail
}  // namespace draco::pointcloud_io
