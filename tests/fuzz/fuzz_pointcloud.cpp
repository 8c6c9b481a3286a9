// libFuzzer target: point-cloud files (pointcloud_io::ReadMapPcd / ReadMapPly: draco's header
// and size checks, then PCL's readers and conversion).
//
// The first input byte picks the format (modulo 2; the seeds use '0' and '1'): 0 PCD, 1 PLY.
// The rest is written as a file of that extension and read with pointcloud_io::ReadMap. Errors
// must be std::runtime_error; anything else escaping, a crash, a hang or a memory bound broken
// is a finding. Seeds: tests/fuzz/corpus/fuzz_pointcloud/ (maps written by pointcloud_io: PCD
// binary, binary_compressed and ascii, PLY binary; an ascii PLY as PCL writes it).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "allocation_bound.hpp"
#include "draco/pointcloud_io/pointcloud_io.hpp"

namespace {
std::string g_dir;
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  char pattern[] = "/tmp/draco-fuzz-pointcloud-XXXXXX";
  if (::mkdtemp(pattern) == nullptr) {
    std::perror("mkdtemp");
    std::abort();
  }
  g_dir = pattern;
  std::atexit([] {
    std::error_code ignored;
    std::filesystem::remove_all(g_dir, ignored);
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // Memory bound: a header announces no more than its data section holds (binary: the bytes;
  // ascii: two characters a value; LZF: 88 bytes a compressed byte), PCL's cloud and the
  // PointXYZ copy at most a few times that.
  const draco::fuzz::AllocationBound bound(size, 512, 16 << 20, "fuzz_pointcloud");
  const std::string path = g_dir + (data[0] % 2 == 0 ? "/input.pcd" : "/input.ply");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  try {
    (void)draco::pointcloud_io::ReadMap(path);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
