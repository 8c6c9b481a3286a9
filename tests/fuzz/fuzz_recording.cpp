// libFuzzer target: recorded missions and the simulator's YAML files.
//
// The first input byte picks the reader (modulo 4; the seeds use the digits '0' to '3'):
//   0  the recorded-mission reader. The rest of the input is cut into files at lines
//      "%%<name>" (mission.yaml before the first such line): mission.yaml, sonar.drs,
//      dvl.csv, ahrs.csv, depth.csv, groundtruth.tum. They are written into a scratch
//      mission folder (robot "alpha"; a file not in the input is absent) and read:
//      LoadMissionInfo, RobotReader::Open("alpha") and every record, RobotReplayLengthS.
//      Every sonar record's CRC is made right before writing (a mutation would otherwise only
//      ever test the CRC check) unless the selector byte has its high bit set.
//   1  sim::ParseWorld (config/worlds/*.yaml)
//   2  sim::ParseMission (config/missions/*.yaml)
//   3  sim::ParseGeneratorOptions (config/generator/*.yaml)
// Errors must be RecordingError or sim::ConfigError; anything else escaping is a crash.
// Seeds: tests/fuzz/corpus/fuzz_recording/ (a mission cut from draco-sim's marina mission by
// gen_recording_corpus, and the repository's worlds, missions and generator style).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <string_view>

#include <zlib.h>

#include "allocation_bound.hpp"
#include "draco/recording/recording.hpp"
#include "draco/sim/generator.hpp"
#include "draco/sim/mission.hpp"
#include "draco/sim/world.hpp"

namespace {

namespace fs = std::filesystem;

fs::path g_root;     // scratch folder
fs::path g_mission;  // g_root / "mission"

constexpr const char* kFiles[] = {"mission.yaml", "sonar.drs", "dvl.csv",
                                  "ahrs.csv",     "depth.csv", "groundtruth.tum"};

// name -> bytes; a "%%name" line starts a file, the text before the first one is mission.yaml.
std::map<std::string, std::string> Files(std::string_view text) {
  std::map<std::string, std::string> files;
  std::string current = "mission.yaml";
  std::size_t start = 0;  // of the current file's bytes
  std::size_t line = 0;   // start of the line being looked at
  while (true) {
    const bool marker = text.compare(line, 2, "%%") == 0;
    std::size_t end = text.find('\n', line);
    if (marker && end != std::string_view::npos) {
      files[current] += text.substr(start, line - start);
      current = std::string(text.substr(line + 2, end - line - 2));
      start = end + 1;
    }
    if (end == std::string_view::npos) break;
    line = end + 1;
  }
  files[current] += text.substr(start);
  return files;
}

std::uint32_t U32(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(s[at + i]);
  return v;
}

// Recomputes the CRC of every record of a sonar.drs (layout: docs/recording-format.md) as far
// as the record headers chain.
void FixCrcs(std::string& drs) {
  std::size_t at = 16;  // file header
  while (at + 12 <= drs.size() && drs.compare(at, 4, "DREC") == 0) {
    const std::size_t length = U32(drs, at + 8);
    if (length > drs.size() || at + 16 + length > drs.size()) break;
    const auto* body = reinterpret_cast<const Bytef*>(drs.data() + at + 4);
    const auto crc = static_cast<std::uint32_t>(crc32(0, body, static_cast<uInt>(8 + length)));
    for (int i = 0; i < 4; ++i) drs[at + 12 + length + i] = static_cast<char>(crc >> (8 * i));
    at += 16 + length;
  }
}

void ReadMission(std::string_view text, bool fix_crcs) {
  auto files = Files(text);
  if (auto it = files.find("sonar.drs"); fix_crcs && it != files.end()) FixCrcs(it->second);
  for (const char* name : kFiles) {
    const fs::path path =
        std::string(name) == "mission.yaml" ? g_mission / name : g_mission / "alpha" / name;
    if (auto it = files.find(name); it != files.end()) {
      std::ofstream(path, std::ios::binary) << it->second;
    } else {
      std::error_code ignored;
      fs::remove(path, ignored);
    }
  }
  try {
    (void)draco::recording::LoadMissionInfo(g_mission);
    auto reader = draco::recording::RobotReader::Open(g_mission, "alpha");
    while (reader.Next()) {
    }
  } catch (const draco::recording::RecordingError&) {
  }
  (void)draco::recording::RobotReplayLengthS(g_mission, "alpha");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  char pattern[] = "/tmp/draco-fuzz-recording-XXXXXX";
  if (::mkdtemp(pattern) == nullptr) {
    std::perror("mkdtemp");
    std::abort();
  }
  g_root = pattern;
  g_mission = g_root / "mission";
  fs::create_directories(g_mission / "alpha");
  std::atexit([] {
    std::error_code ignored;
    fs::remove_all(g_root, ignored);
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Memory bound: a sonar record is at most what the file holds, a compressed image at most
  // 1032 pixels a byte (deflate), decoded once more by OpenCV for PNG: 2 x 1032 a byte; YAML
  // about 200 a byte; a world at most 100000 primitives (the fixed part).
  const draco::fuzz::AllocationBound bound(size, 2100, 16 << 20, "fuzz_recording");
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 4) {
      case 0:
        ReadMission(text, (data[0] & 0x80) == 0);
        break;
      case 1:
        (void)draco::sim::ParseWorld(text, "world.yaml");
        break;
      case 2:
        (void)draco::sim::ParseMission(text, "mission.yaml",
                                       fs::path(DRACO_SOURCE_DIR) / "config/missions");
        break;
      default:
        (void)draco::sim::ParseGeneratorOptions(text, "style.yaml");
        break;
    }
  } catch (const draco::sim::ConfigError&) {
  }
  return 0;
}
