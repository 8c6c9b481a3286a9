// Read (and write) throughput of recorded missions.
//   recording_read_bench                  synthetic 512 x 512 speckle pings, PNG and raw
//   recording_read_bench MISSION ROBOT    reads one robot of an existing mission
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "draco/recording/recording.hpp"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using draco::recording::Record;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

void ReadRobot(const fs::path& dir, const std::string& robot) {
  const auto start = Clock::now();
  auto reader = draco::recording::RobotReader::Open(dir, robot);
  std::size_t pings = 0, records = 0;
  while (auto record = reader.Next()) {
    ++records;
    pings += std::holds_alternative<draco::msgs::SonarPing>(*record);
  }
  const double s = Seconds(start);
  std::printf("read %s/%s: %zu records, %zu pings in %.2f s: %.0f pings/s, %.0f records/s\n",
              dir.c_str(), robot.c_str(), records, pings, s, pings / s, records / s);
}

// A fan of Rayleigh speckle with a few bright arcs, like a simulated frame.
draco::msgs::SonarPing SpeckleFrame(int id, std::mt19937& rng) {
  draco::msgs::SonarPing ping;
  ping.time_s = 0.2 * id;
  ping.ping_id = static_cast<std::uint32_t>(id);
  ping.num_ranges = 512;
  ping.num_beams = 512;
  ping.range_resolution_m = 30.0 / 512;
  ping.vertical_aperture_rad = 0.349;
  for (int b = 0; b < 512; ++b) ping.bearings_rad.push_back(-1.134f + 2.268f * b / 511);
  ping.intensity.resize(512 * 512);
  std::exponential_distribution<double> speckle(1.0);
  for (int r = 0; r < 512; ++r) {
    for (int b = 0; b < 512; ++b) {
      const double structure = (r + 7 * id) % 97 < 3 && b % 64 < 20 ? 0.6 : 0.0;
      const double energy = (0.01 + structure) * speckle(rng);
      ping.intensity[r * 512 + b] =
          static_cast<std::uint8_t>(std::min(255.0, 255.0 * std::sqrt(std::min(1.0, 4 * energy))));
    }
  }
  return ping;
}

void Synthetic(draco::recording::ImageCompression compression, const char* label) {
  const fs::path dir = fs::temp_directory_path() / "draco-recording-bench";
  fs::remove_all(dir);
  draco::recording::MissionInfo info;
  info.name = "bench";
  info.world = "none";
  info.robots = {{"alpha", 0, false}};
  draco::recording::WriterOptions options;
  options.compression = compression;
  const int kPings = 300;
  std::mt19937 rng(1);
  std::vector<draco::msgs::SonarPing> frames;
  for (int i = 0; i < 20; ++i) frames.push_back(SpeckleFrame(i, rng));

  auto mission = draco::recording::MissionWriter::Create(dir, info, options);
  auto writer = mission.OpenRobot("alpha");
  const auto start = Clock::now();
  for (int i = 0; i < kPings; ++i) {
    draco::msgs::SonarPing ping = frames[i % frames.size()];
    ping.time_s = 0.2 * i;
    writer.WritePing(ping);
  }
  writer.Close();
  mission.Close();
  const double s = Seconds(start);
  const double bytes = static_cast<double>(fs::file_size(dir / "alpha" / "sonar.drs"));
  std::printf("%s: wrote %d pings of 512 x 512 in %.2f s: %.0f pings/s, %.1f KiB per ping\n", label,
              kPings, s, kPings / s, bytes / kPings / 1024);
  ReadRobot(dir, "alpha");
  fs::remove_all(dir);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 3) {
      ReadRobot(argv[1], argv[2]);
      return 0;
    }
    if (argc != 1) {
      std::fprintf(stderr, "usage: %s [MISSION_DIR ROBOT]\n", argv[0]);
      return 2;
    }
    Synthetic(draco::recording::ImageCompression::kZlib, "zlib level 1 (default)");
    Synthetic(draco::recording::ImageCompression::kPng, "PNG level 1");
    Synthetic(draco::recording::ImageCompression::kRaw, "raw");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
