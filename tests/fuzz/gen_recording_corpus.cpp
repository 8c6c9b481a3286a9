// Writes the recorded-mission seeds of fuzz_recording from a real draco-sim mission.
//
// Reads robot alpha of MISSION_DIR (e.g. `draco-sim config/missions/marina.yaml --duration-s 5
// --robots 1 --no-pictures --out MISSION_DIR`), keeps its first 0.5 s of navigation and its
// first three pings, thinned to every 16th beam and every 8th range bin (32 x 64: small seeds,
// real speckle), and writes that mission with the recording writer once per image encoding
// (zstd, zlib, PNG, raw). Each seed is "0" + mission.yaml + "%%<file>" sections
// (fuzz_recording.cpp).
//
//   gen_recording_corpus MISSION_DIR OUT_DIR
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "draco/recording/recording.hpp"

namespace {

namespace fs = std::filesystem;
using namespace draco;

std::string Slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

msgs::SonarPing Thin(const msgs::SonarPing& ping, int beam_step, int range_step) {
  msgs::SonarPing out = ping;
  out.num_beams = ping.num_beams / beam_step;
  out.num_ranges = ping.num_ranges / range_step;
  out.range_resolution_m = ping.range_resolution_m * range_step;
  out.bearings_rad.clear();
  out.intensity.clear();
  for (int b = 0; b < out.num_beams; ++b)
    out.bearings_rad.push_back(ping.bearings_rad[b * beam_step]);
  for (int r = 0; r < out.num_ranges; ++r) {
    for (int b = 0; b < out.num_beams; ++b)
      out.intensity.push_back(ping.At(r * range_step, b * beam_step));
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: gen_recording_corpus MISSION_DIR OUT_DIR\n");
    return 2;
  }
  const fs::path mission = argv[1];
  const fs::path out_dir = argv[2];
  fs::create_directories(out_dir);
  constexpr double kKeepS = 0.5;
  constexpr int kBeamStep = 16;
  constexpr int kRangeStep = 8;

  auto reader = recording::RobotReader::Open(mission, "alpha");
  recording::MissionInfo info = reader.Mission();
  info.robots = {reader.Robot()};
  info.sonar.num_beams /= kBeamStep;
  info.sonar.num_ranges /= kRangeStep;
  info.sonar.range_resolution_m *= kRangeStep;
  std::vector<recording::Record> records;
  int pings = 0;
  while (auto record = reader.Next()) {
    if (recording::RecordTime(*record) > kKeepS) break;
    if (const auto* ping = std::get_if<msgs::SonarPing>(&*record)) {
      if (pings++ >= 3) continue;
      records.emplace_back(Thin(*ping, kBeamStep, kRangeStep));
    } else {
      records.push_back(*record);
    }
  }

  const struct {
    const char* name;
    recording::ImageCompression compression;
  } kEncodings[] = {{"zstd", recording::ImageCompression::kZstd},
                    {"zlib", recording::ImageCompression::kZlib},
                    {"png", recording::ImageCompression::kPng},
                    {"raw", recording::ImageCompression::kRaw}};
  const fs::path scratch = out_dir / ".scratch";
  for (const auto& encoding : kEncodings) {
    fs::remove_all(scratch);
    auto writer = recording::MissionWriter::Create(scratch, info, {encoding.compression, 1});
    auto robot = writer.OpenRobot("alpha");
    for (const auto& record : records) {
      std::visit(
          [&](const auto& m) {
            using T = std::decay_t<decltype(m)>;
            if constexpr (std::is_same_v<T, msgs::SonarPing>) robot.WritePing(m);
            if constexpr (std::is_same_v<T, msgs::DvlVelocity>) robot.WriteDvl(m);
            if constexpr (std::is_same_v<T, msgs::Ahrs>) robot.WriteAhrs(m);
            if constexpr (std::is_same_v<T, msgs::Depth>) robot.WriteDepth(m);
            if constexpr (std::is_same_v<T, msgs::GroundTruthPose>) robot.WriteGroundTruth(m);
          },
          record);
    }
    robot.Close();
    writer.Close();
    std::string seed = "0" + Slurp(scratch / "mission.yaml");
    for (const char* file : {"dvl.csv", "ahrs.csv", "depth.csv", "groundtruth.tum", "sonar.drs"}) {
      seed += std::string("%%") + file + "\n" + Slurp(scratch / "alpha" / file);
    }
    std::ofstream(out_dir / (std::string("marina-cut-") + encoding.name), std::ios::binary) << seed;
    std::printf("%s: %zu bytes\n", encoding.name, seed.size());
  }
  fs::remove_all(scratch);
  return 0;
}
