// Read and write throughput of recorded missions, per image encoding.
//   recording_read_bench                          synthetic 512 x 512 speckle pings, every
//                                                 encoding: file write and read, then the
//                                                 codecs alone in memory
//   recording_read_bench MISSION ROBOT            reads one robot of an existing mission
//   recording_read_bench MISSION ROBOT --recode [PINGS]
//                                                 the robot's first PINGS pings (default all):
//                                                 rewritten once per encoding into a scratch
//                                                 mission under the temp folder, read back
//                                                 (pings only), removed; then the codecs alone
//                                                 on its first 200 pings
//   recording_read_bench MISSION ROBOT --copy OUT [LEVEL]
//                                                 copies the robot (every stream) into the
//                                                 one-robot mission OUT with zstd images at
//                                                 LEVEL (default 1), to time reading it
// Sizes are per ping; "x zlib" columns are ratios against zlib level 1 measured in the same
// run (the machine is shared: compare within a run).
#include <lz4.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "draco/recording/recording.hpp"
#include "huffman_deflate.hpp"

namespace {

namespace fs = std::filesystem;
namespace rec = draco::recording;
using Clock = std::chrono::steady_clock;
using draco::msgs::SonarPing;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

void ReadRobot(const fs::path& dir, const std::string& robot) {
  const auto start = Clock::now();
  auto reader = rec::RobotReader::Open(dir, robot);
  std::size_t pings = 0, records = 0;
  while (auto record = reader.Next()) {
    ++records;
    pings += std::holds_alternative<SonarPing>(*record);
  }
  const double s = Seconds(start);
  std::printf("read %s/%s: %zu records, %zu pings in %.2f s: %.0f pings/s, %.0f records/s\n",
              dir.c_str(), robot.c_str(), records, pings, s, pings / s, records / s);
}

// A fan of Rayleigh speckle with a few bright arcs, like a simulated frame.
SonarPing SpeckleFrame(int id, std::mt19937& rng) {
  SonarPing ping;
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

struct Encoding {
  const char* label;
  rec::ImageCompression compression;
  int level;
};

// zlib level 1 first: the other rows are compared against it.
const Encoding kEncodings[] = {
    {"zlib 1", rec::ImageCompression::kZlib, 1}, {"zstd -1", rec::ImageCompression::kZstd, -1},
    {"zstd 1", rec::ImageCompression::kZstd, 1}, {"zstd 3", rec::ImageCompression::kZstd, 3},
    {"zstd 7", rec::ImageCompression::kZstd, 7}, {"PNG 1", rec::ImageCompression::kPng, 1},
    {"raw", rec::ImageCompression::kRaw, 0},
};

struct Figures {
  double bytes_per_ping = 0;
  double write_pings_per_s = 0;
  double read_pings_per_s = 0;
};

void PrintHeader(const char* what) {
  std::printf("\n%s\n%-8s %14s %8s %14s %8s %14s %8s\n", what, "encoding", "KiB per ping", "x zlib",
              "write pings/s", "x zlib", "read pings/s", "x zlib");
}

void PrintRow(const char* label, const Figures& f, const Figures& zlib) {
  std::printf("%-8s %14.1f %8.3f %14.0f %8.2f %14.0f %8.2f\n", label, f.bytes_per_ping / 1024,
              f.bytes_per_ping / zlib.bytes_per_ping, f.write_pings_per_s,
              f.write_pings_per_s / zlib.write_pings_per_s, f.read_pings_per_s,
              f.read_pings_per_s / zlib.read_pings_per_s);
}

// Writes the pings that next_ping hands out (nullptr at the end) into a one-robot scratch
// mission with the encoding, times WritePing alone, then times reading the file back.
Figures WriteAndRead(const Encoding& encoding, const rec::MissionInfo& like,
                     const std::function<const SonarPing*()>& next_ping) {
  const fs::path dir = fs::temp_directory_path() / "draco-recording-bench";
  fs::remove_all(dir);
  rec::MissionInfo info = like;
  info.robots = {{"alpha", 0, false}};
  rec::WriterOptions options;
  options.compression = encoding.compression;
  options.compression_level = encoding.level;
  auto mission = rec::MissionWriter::Create(dir, info, options);
  auto writer = mission.OpenRobot("alpha");
  double write_s = 0;
  std::size_t pings = 0;
  while (const SonarPing* ping = next_ping()) {
    const auto start = Clock::now();
    writer.WritePing(*ping);
    write_s += Seconds(start);
    ++pings;
  }
  writer.Close();
  mission.Close();
  Figures f;
  f.bytes_per_ping = static_cast<double>(fs::file_size(dir / "alpha" / "sonar.drs")) / pings;
  f.write_pings_per_s = pings / write_s;
  const auto start = Clock::now();
  auto reader = rec::RobotReader::Open(dir, "alpha");
  std::size_t read = 0;
  while (auto record = reader.Next()) read += std::holds_alternative<SonarPing>(*record);
  f.read_pings_per_s = read / Seconds(start);
  fs::remove_all(dir);
  if (read != pings) throw std::runtime_error("read back fewer pings than written");
  return f;
}

void Synthetic() {
  const int kPings = 300;
  std::mt19937 rng(1);
  std::vector<SonarPing> frames;
  for (int i = 0; i < 20; ++i) frames.push_back(SpeckleFrame(i, rng));
  rec::MissionInfo info;
  info.name = "bench";
  info.world = "none";
  PrintHeader("synthetic: 300 pings of 512 x 512 (20 distinct frames), file write and read");
  Figures zlib;
  for (const Encoding& encoding : kEncodings) {
    int i = 0;
    SonarPing ping;
    const Figures f = WriteAndRead(encoding, info, [&]() -> const SonarPing* {
      if (i == kPings) return nullptr;
      ping = frames[i % frames.size()];
      ping.time_s = 0.2 * i++;
      return &ping;
    });
    if (&encoding == &kEncodings[0]) zlib = f;
    PrintRow(encoding.label, f, zlib);
  }
}

// ---- the codecs alone, in memory ---------------------------------------------------------

struct Codec {
  std::string label;
  std::function<void(const std::vector<std::uint8_t>&, std::vector<std::uint8_t>&)> compress;
  // Decompresses into out, which has the image's size.
  std::function<void(const std::vector<std::uint8_t>&, std::vector<std::uint8_t>&)> decompress;
};

void Check(bool ok, const std::string& what) {
  if (!ok) throw std::runtime_error(what + " failed");
}

std::vector<Codec> Codecs() {
  std::vector<Codec> codecs;
  // zlib as the recording writes it at level 1 (the writer's literal-only deflate), read by
  // zlib's inflate as the reader does.
  codecs.push_back({"zlib 1",
                    [](const std::vector<std::uint8_t>& in, std::vector<std::uint8_t>& out) {
                      out.clear();
                      draco::recording::internal::HuffmanDeflateAppend(in.data(), in.size(), out);
                    },
                    [](const std::vector<std::uint8_t>& in, std::vector<std::uint8_t>& out) {
                      uLongf n = static_cast<uLongf>(out.size());
                      Check(uncompress(out.data(), &n, in.data(), static_cast<uLong>(in.size())) ==
                                    Z_OK &&
                                n == out.size(),
                            "uncompress");
                    }});
  static ZSTD_CCtx* const cctx = ZSTD_createCCtx();
  static ZSTD_DCtx* const dctx = ZSTD_createDCtx();
  auto zstd_decompress = [](const std::vector<std::uint8_t>& in, std::vector<std::uint8_t>& out) {
    const std::size_t n = ZSTD_decompressDCtx(dctx, out.data(), out.size(), in.data(), in.size());
    Check(!ZSTD_isError(n) && n == out.size(), "ZSTD_decompressDCtx");
  };
  for (int level : {-1, 1, 3, 7}) {
    codecs.push_back({"zstd " + std::to_string(level),
                      [level](const std::vector<std::uint8_t>& in, std::vector<std::uint8_t>& out) {
                        out.resize(ZSTD_compressBound(in.size()));
                        const std::size_t n = ZSTD_compressCCtx(cctx, out.data(), out.size(),
                                                                in.data(), in.size(), level);
                        Check(!ZSTD_isError(n), "ZSTD_compressCCtx");
                        out.resize(n);
                      },
                      zstd_decompress});
  }
  // zstd with a block ended every block_bytes (each block may bring its own Huffman table, as
  // the writer's zlib level 1 does every 16 KiB; the writer's zstd does the same): still one
  // frame, stating its content size.
  for (const auto& [level, block_bytes] :
       {std::pair{1, 4096}, std::pair{1, 8192}, std::pair{1, 16384}, std::pair{1, 32768},
        std::pair{3, 16384}}) {
    codecs.push_back(
        {"zstd " + std::to_string(level) + " " + std::to_string(block_bytes / 1024) + "K",
         [level = level, block_bytes = block_bytes](const std::vector<std::uint8_t>& in,
                                                    std::vector<std::uint8_t>& out) {
           ZSTD_CCtx_reset(cctx, ZSTD_reset_session_and_parameters);
           ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, level);
           ZSTD_CCtx_setPledgedSrcSize(cctx, in.size());
           out.resize(ZSTD_compressBound(in.size()) + 1024);
           ZSTD_outBuffer o{out.data(), out.size(), 0};
           const auto block = static_cast<std::size_t>(block_bytes);
           for (std::size_t at = 0; at < in.size(); at += block) {
             const std::size_t n = std::min(block, in.size() - at);
             ZSTD_inBuffer i{in.data() + at, n, 0};
             const bool last = at + n == in.size();
             const std::size_t left =
                 ZSTD_compressStream2(cctx, &o, &i, last ? ZSTD_e_end : ZSTD_e_flush);
             Check(!ZSTD_isError(left) && left == 0, "ZSTD_compressStream2");
           }
           out.resize(o.pos);
           ZSTD_CCtx_reset(cctx, ZSTD_reset_session_and_parameters);
         },
         zstd_decompress});
  }
  codecs.push_back(
      {"lz4",
       [](const std::vector<std::uint8_t>& in, std::vector<std::uint8_t>& out) {
         out.resize(static_cast<std::size_t>(LZ4_compressBound(static_cast<int>(in.size()))));
         const int n = LZ4_compress_default(
             reinterpret_cast<const char*>(in.data()), reinterpret_cast<char*>(out.data()),
             static_cast<int>(in.size()), static_cast<int>(out.size()));
         Check(n > 0, "LZ4_compress_default");
         out.resize(static_cast<std::size_t>(n));
       },
       [](const std::vector<std::uint8_t>& in, std::vector<std::uint8_t>& out) {
         const int n = LZ4_decompress_safe(
             reinterpret_cast<const char*>(in.data()), reinterpret_cast<char*>(out.data()),
             static_cast<int>(in.size()), static_cast<int>(out.size()));
         Check(n == static_cast<int>(out.size()), "LZ4_decompress_safe");
       }});
  return codecs;
}

// Each codec compresses and decompresses every image (decoded bytes checked); figures are
// per image, compression ratio against the raw bytes.
void CodecsAlone(const std::vector<std::vector<std::uint8_t>>& images, const char* what) {
  std::printf("\n%s: the codecs alone, in memory, %zu images of %zu bytes\n", what, images.size(),
              images.front().size());
  std::printf("%-12s %10s %8s %14s %8s %14s %8s\n", "codec", "of raw", "x zlib", "compress ms",
              "x zlib", "decompress ms", "x zlib");
  double zlib_ratio = 0, zlib_compress = 0, zlib_decompress = 0;
  std::vector<std::uint8_t> packed, unpacked;
  for (const Codec& codec : Codecs()) {
    double bytes = 0, compress_s = 0, decompress_s = 0;
    for (const auto& image : images) {
      auto start = Clock::now();
      codec.compress(image, packed);
      compress_s += Seconds(start);
      bytes += static_cast<double>(packed.size());
      unpacked.assign(image.size(), 0);
      start = Clock::now();
      codec.decompress(packed, unpacked);
      decompress_s += Seconds(start);
      Check(unpacked == image, codec.label + " round trip");
    }
    const double n = static_cast<double>(images.size());
    const double ratio = bytes / (n * static_cast<double>(images.front().size()));
    const double compress_ms = 1e3 * compress_s / n, decompress_ms = 1e3 * decompress_s / n;
    if (codec.label == "zlib 1") {
      zlib_ratio = ratio;
      zlib_compress = compress_ms;
      zlib_decompress = decompress_ms;
    }
    std::printf("%-12s %10.3f %8.3f %14.3f %8.2f %14.3f %8.2f\n", codec.label.c_str(), ratio,
                ratio / zlib_ratio, compress_ms, compress_ms / zlib_compress, decompress_ms,
                decompress_ms / zlib_decompress);
  }
}

// ---- an existing mission -------------------------------------------------------------------

void Recode(const fs::path& dir, const std::string& robot, std::size_t max_pings) {
  rec::ReadOptions sonar_only;
  sonar_only.dvl = sonar_only.ahrs = sonar_only.depth = sonar_only.ground_truth = false;
  const rec::MissionInfo info = rec::LoadMissionInfo(dir);
  const std::string what =
      dir.string() + "/" + robot + ": " +
      (max_pings == SIZE_MAX ? std::string("every ping")
                             : "the first " + std::to_string(max_pings) + " pings") +
      " rewritten per encoding, file write and read (pings only)";
  PrintHeader(what.c_str());
  Figures zlib;
  for (const Encoding& encoding : kEncodings) {
    auto source = rec::RobotReader::Open(dir, robot, sonar_only);
    std::size_t pings = 0;
    SonarPing ping;
    const Figures f = WriteAndRead(encoding, info, [&]() -> const SonarPing* {
      if (pings == max_pings) return nullptr;
      auto record = source.Next();
      if (!record) return nullptr;
      ping = std::get<SonarPing>(std::move(*record));
      ++pings;
      return &ping;
    });
    if (&encoding == &kEncodings[0]) zlib = f;
    PrintRow(encoding.label, f, zlib);
  }
  std::vector<std::vector<std::uint8_t>> images;
  auto source = rec::RobotReader::Open(dir, robot, sonar_only);
  while (images.size() < 200) {
    auto record = source.Next();
    if (!record) break;
    images.push_back(std::get<SonarPing>(*record).intensity);
  }
  CodecsAlone(images, (dir.string() + "/" + robot).c_str());
}

void Copy(const fs::path& dir, const std::string& robot, const fs::path& out, int level) {
  auto source = rec::RobotReader::Open(dir, robot);
  rec::MissionInfo info = source.Mission();
  info.robots = {source.Robot()};
  rec::WriterOptions options;
  options.compression = rec::ImageCompression::kZstd;
  options.compression_level = level;
  auto mission = rec::MissionWriter::Create(out, info, options);
  auto writer = mission.OpenRobot(robot);
  const auto start = Clock::now();
  std::size_t records = 0;
  while (auto record = source.Next()) {
    ++records;
    std::visit(
        [&](const auto& m) {
          using T = std::decay_t<decltype(m)>;
          if constexpr (std::is_same_v<T, SonarPing>) writer.WritePing(m);
          if constexpr (std::is_same_v<T, draco::msgs::DvlVelocity>) writer.WriteDvl(m);
          if constexpr (std::is_same_v<T, draco::msgs::Ahrs>) writer.WriteAhrs(m);
          if constexpr (std::is_same_v<T, draco::msgs::Depth>) writer.WriteDepth(m);
          if constexpr (std::is_same_v<T, draco::msgs::GroundTruthPose>) writer.WriteGroundTruth(m);
        },
        *record);
  }
  const std::uint64_t pings = writer.PingCount();
  writer.Close();
  mission.Close();
  std::printf("copied %s/%s to %s (zstd level %d): %zu records, %llu pings in %.1f s\n",
              dir.c_str(), robot.c_str(), out.c_str(), level, records,
              static_cast<unsigned long long>(pings), Seconds(start));
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc >= 4 ? argv[3] : "";
    if (argc == 3) {
      ReadRobot(argv[1], argv[2]);
    } else if ((argc == 4 || argc == 5) && mode == "--recode") {
      const std::size_t pings = argc == 5 ? std::stoul(argv[4]) : SIZE_MAX;
      Recode(argv[1], argv[2], pings);
    } else if ((argc == 5 || argc == 6) && mode == "--copy") {
      Copy(argv[1], argv[2], argv[4], argc == 6 ? std::stoi(argv[5]) : 1);
    } else if (argc == 1) {
      Synthetic();
      std::mt19937 rng(1);
      std::vector<std::vector<std::uint8_t>> images;
      for (int i = 0; i < 100; ++i) images.push_back(SpeckleFrame(i, rng).intensity);
      CodecsAlone(images, "synthetic");
    } else {
      std::fprintf(stderr,
                   "usage: %s [MISSION_DIR ROBOT [--recode [PINGS] | --copy OUT_DIR [LEVEL]]]\n",
                   argv[0]);
      return 2;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
