// libFuzzer target: ROS 1 bags from vehicles (rosbag::BagReader on bag bytes).
//
// The input is written as a bag file and read as draco-local-slam reads one: Open with the
// default topics, Topics(), then Next() to the end (a BagError for one malformed message is
// skipped, as the reader allows; any other BagError ends the file). Errors must be BagError;
// anything else escaping, a crash, a hang or a memory bound broken is a finding.
// Seeds: tests/fuzz/corpus/fuzz_rosbag/ (the bags tests/rosbag/write_test_bags.py writes with
// the official ROS 1 writer: uncompressed, bz2, lz4, old layouts, truncated and damaged).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "allocation_bound.hpp"
#include "draco/rosbag/bag_reader.hpp"

namespace {
std::string g_path;
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  char pattern[] = "/tmp/draco-fuzz-rosbag-XXXXXX";
  if (::mkdtemp(pattern) == nullptr) {
    std::perror("mkdtemp");
    std::abort();
  }
  g_path = std::string(pattern) + "/input.bag";
  static const std::string dir = pattern;
  std::atexit([] {
    std::error_code ignored;
    std::filesystem::remove_all(dir, ignored);
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Memory bound: the index and headers are at most the file; one chunk at most 16384 times
  // its bytes (bz2 of zeros); one decoded message at most 2^20 values; one image at most 64
  // Mi pixels (the fixed part).
  const draco::fuzz::AllocationBound bound(size, 16384, 128 << 20, "fuzz_rosbag");
  {
    std::ofstream out(g_path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    auto reader = draco::rosbag::BagReader::Open(g_path);
    (void)reader.Topics();
    for (std::size_t i = 0; i <= size; ++i) {  // a message takes at least a byte
      try {
        if (!reader.Next()) break;
      } catch (const draco::rosbag::BagError& e) {
        if (!e.bad_message()) break;
      }
    }
  } catch (const draco::rosbag::BagError&) {
  }
  return 0;
}
