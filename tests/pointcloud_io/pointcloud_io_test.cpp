// Point-cloud files (pointcloud_io.hpp): what draco writes PCL reads back unchanged (exact
// floats) in every encoding, PLY likewise; draco reads PCL's files; truncated and corrupt
// files give an error naming the file, never a crash; writes are atomic.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "draco/pointcloud_io/pointcloud_io.hpp"
#include "largest_allocation.hpp"

namespace draco::pointcloud_io {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("draco_pcio_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::vector<std::string> Listing(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

std::string Slurp(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

void Spit(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// Values that do not survive a short decimal form, and a few plain ones.
std::vector<msgs::Point2> AwkwardPoints() {
  std::vector<msgs::Point2> pts{{0.1, -0.2},
                                {-123.456789012, 98.7654321},
                                {1e-7, -3.3e-9},
                                {12345.678901, -54321.123456},
                                {1.0 / 3.0, 2.0 / 3.0},
                                {0.0, -0.0}};
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-300.0, 300.0);
  for (int i = 0; i < 2000; ++i) pts.push_back({u(rng), u(rng)});
  return pts;
}

void ExpectSameAsWritten(const std::vector<msgs::Point2>& written,
                         const pcl::PointCloud<pcl::PointXYZ>& read) {
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < written.size(); ++i) {
    ASSERT_EQ(read[i].x, static_cast<float>(written[i].x_m)) << i;
    ASSERT_EQ(read[i].y, static_cast<float>(written[i].y_m)) << i;
    ASSERT_EQ(read[i].z, 0.0f) << i;
  }
}

void ExpectSameAsWritten(const std::vector<msgs::Point2>& written,
                         const std::vector<msgs::Point2>& read) {
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < written.size(); ++i) {
    ASSERT_EQ(read[i].x_m, static_cast<double>(static_cast<float>(written[i].x_m))) << i;
    ASSERT_EQ(read[i].y_m, static_cast<double>(static_cast<float>(written[i].y_m))) << i;
  }
}

class PcdEncodings : public ::testing::TestWithParam<PcdEncoding> {};

TEST_P(PcdEncodings, ReadBackByPclUnchanged) {
  const fs::path dir = TempDir(PcdEncodingName(GetParam()));
  const auto pts = AwkwardPoints();
  const std::string path = (dir / "m.pcd").string();
  WritePcd(path, pts, GetParam());
  pcl::PointCloud<pcl::PointXYZ> cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(path, cloud), 0);
  ExpectSameAsWritten(pts, cloud);
  ExpectSameAsWritten(pts, ReadMapPcd(path));
  ExpectSameAsWritten(pts, ReadMap(path));
  // The header says what it holds: x y z float32, unorganised, the encoding asked for.
  const std::string bytes = Slurp(path);
  EXPECT_NE(bytes.find("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"), std::string::npos);
  EXPECT_NE(bytes.find("\nPOINTS " + std::to_string(pts.size()) + "\n"), std::string::npos);
  const std::string data = std::string("\nDATA ") + PcdEncodingName(GetParam()) + "\n";
  const auto at = bytes.find(data);
  ASSERT_NE(at, std::string::npos);
  if (GetParam() == PcdEncoding::kBinary) {
    EXPECT_EQ(bytes.size(), at + data.size() + 12 * pts.size());
  }
  EXPECT_EQ(Listing(dir), std::vector<std::string>{"m.pcd"});
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(All, PcdEncodings,
                         ::testing::Values(PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed,
                                           PcdEncoding::kAscii),
                         [](const auto& i) { return std::string(PcdEncodingName(i.param)); });

TEST(Ply, ReadBackByPclUnchanged) {
  const fs::path dir = TempDir("ply");
  const auto pts = AwkwardPoints();
  const std::string path = (dir / "m.ply").string();
  WritePly(path, pts);
  pcl::PointCloud<pcl::PointXYZ> cloud;
  ASSERT_EQ(pcl::io::loadPLYFile(path, cloud), 0);
  ExpectSameAsWritten(pts, cloud);
  ExpectSameAsWritten(pts, ReadMapPly(path));
  EXPECT_EQ(Slurp(path).rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  fs::remove_all(dir);
}

TEST(PointcloudIo, ReadsWhatPclWrites) {
  const fs::path dir = TempDir("pclwrites");
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (int i = 0; i < 50; ++i) cloud.push_back(pcl::PointXYZ(0.25f * i, -1.5f * i, 2.0f));
  pcl::io::savePCDFileBinaryCompressed((dir / "c.pcd").string(), cloud);
  pcl::io::savePLYFileASCII((dir / "a.ply").string(), cloud);
  for (const char* name : {"c.pcd", "a.ply"}) {
    const auto read = ReadMap((dir / name).string());
    ASSERT_EQ(read.size(), 50u) << name;
    EXPECT_EQ(read[7].x_m, 1.75) << name;
    EXPECT_EQ(read[7].y_m, -10.5) << name;  // z is dropped
  }
  // A cloud with only x y (another tool's 2D map).
  Spit(dir / "xy.pcd",
       "# other tool\nVERSION .7\nFIELDS x y\nSIZE 4 4\nTYPE F F\nCOUNT 1 1\nWIDTH 2\nHEIGHT 1\n"
       "POINTS 2\nDATA ascii\n1 2\n3.5 -4\n");
  const auto xy = ReadMapPcd((dir / "xy.pcd").string());
  ASSERT_EQ(xy.size(), 2u);
  EXPECT_EQ(xy[1].x_m, 3.5);
  EXPECT_EQ(xy[1].y_m, -4.0);
  fs::remove_all(dir);
}

TEST(PointcloudIo, EmptyMaps) {
  const fs::path dir = TempDir("empty");
  for (const auto e : {PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed, PcdEncoding::kAscii}) {
    const std::string path = (dir / (std::string(PcdEncodingName(e)) + ".pcd")).string();
    // Writing and reading an empty map is not worth a console line (PCL 1.13 prints "Input
    // point cloud has no data!" unless told to be quiet).
    ::testing::internal::CaptureStderr();
    WritePcd(path, {}, e);
    EXPECT_TRUE(ReadMapPcd(path).empty()) << path;
    EXPECT_EQ(::testing::internal::GetCapturedStderr(), "") << path;
    // PCL reads the empty file. Into a blob, not a PointCloud<PointXYZ>: PCL 1.13's
    // fromPCLPointCloud2 takes &cloud[0] of the empty point vector, which UBSan reports
    // (reference binding to null pointer) in the sanitizer build.
    pcl::PCLPointCloud2 blob;
    EXPECT_EQ(pcl::io::loadPCDFile(path, blob), 0) << path;
    EXPECT_EQ(blob.width * blob.height, 0u) << path;
  }
  const std::string ply = (dir / "e.ply").string();
  WritePly(ply, {});
  EXPECT_TRUE(ReadMapPly(ply).empty());
  fs::remove_all(dir);
}

// The error names the file.
template <typename F>
void ExpectErrorNaming(const std::string& path, F read, const std::string& also = "") {
  try {
    read(path);
    ADD_FAILURE() << path << ": no error";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(path + ": ", 0), 0u) << what;
    if (!also.empty()) {
      EXPECT_NE(what.find(also), std::string::npos) << what;
    }
  }
}

TEST(PointcloudIo, TruncatedFilesAreRefusedByName) {
  const fs::path dir = TempDir("truncated");
  const auto pts = AwkwardPoints();
  const fs::path whole = dir / "whole.pcd";
  WritePcd(whole.string(), pts);
  const std::string bytes = Slurp(whole);
  const std::string cut = (dir / "cut.pcd").string();
  Spit(cut, bytes.substr(0, bytes.size() - 5));
  ExpectErrorNaming(cut, ReadMapPcd, "truncated");
  for (std::size_t n : {std::size_t{0}, std::size_t{20}, bytes.find("DATA"), bytes.size() / 2}) {
    Spit(cut, bytes.substr(0, n));
    ExpectErrorNaming(cut, ReadMapPcd);
  }
  WritePcd(whole.string(), pts, PcdEncoding::kBinaryCompressed);
  const std::string packed = Slurp(whole);
  Spit(cut, packed.substr(0, packed.size() - 100));
  ExpectErrorNaming(cut, ReadMapPcd, "truncated");
  WritePly((dir / "whole.ply").string(), pts);
  const std::string ply = Slurp(dir / "whole.ply");
  Spit(dir / "cut.ply", ply.substr(0, ply.size() / 2));
  ExpectErrorNaming((dir / "cut.ply").string(), ReadMapPly);
  ExpectErrorNaming((dir / "missing.pcd").string(), ReadMapPcd, "no such file");
  ExpectErrorNaming((dir / "missing.ply").string(), ReadMapPly, "no such file");
  ExpectErrorNaming((dir / "map.txt").string(), ReadMap, ".pcd or .ply");
  fs::remove_all(dir);
}

TEST(PointcloudIo, DamagedHeadersAreRefusedByName) {
  const fs::path dir = TempDir("header");
  const std::string path = (dir / "h.pcd").string();
  const std::string body = "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 0\n";
  // A damaged FIELDS line: PCL 1.13's reader itself crashes on this one.
  Spit(path, "VERSION 0.7\n}IELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n" + body);
  ExpectErrorNaming(path, ReadMapPcd, "unknown header entry");
  Spit(path, "VERSION 0.7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\n" + body);
  ExpectErrorNaming(path, ReadMapPcd, "SIZE has 2 entries for 3 fields");
  Spit(path, "VERSION 0.7\nFIELDS a b c\nSIZE 4 4 4\nTYPE F F F\n" + body);
  ExpectErrorNaming(path, ReadMapPcd, "no x and y");
  Spit(path, "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 3\nPOINTS 1\nDATA ascii\n");
  ExpectErrorNaming(path, ReadMapPcd, "WIDTH x HEIGHT");
  Spit(path, "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA lzma\n");
  ExpectErrorNaming(path, ReadMapPcd, "DATA must be");
  // The text points themselves: as many as announced, each with as many numbers.
  const std::string xyz = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  Spit(path, xyz + "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1.5 2.5 0\n3.5 4.5\n");
  ExpectErrorNaming(path, ReadMapPcd, "line 11: 2 values, the header announces 3");
  Spit(path, xyz + "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 0\nCOLUMNS x y\n");
  ExpectErrorNaming(path, ReadMapPcd, "'COLUMNS' is not a number");
  Spit(path, xyz + "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 0\n3 4 0\n5 6 0\n");
  ExpectErrorNaming(path, ReadMapPcd, "more points than the header's 2");
  Spit(path, "not a point cloud at all");
  ExpectErrorNaming(path, ReadMapPcd);
  Spit(dir / "h.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float a\nend_header\n1\n");
  ExpectErrorNaming((dir / "h.ply").string(), ReadMapPly);
  fs::remove_all(dir);
}

// PCL sizes its buffers from the header before reading: a small file announcing a huge cloud
// is refused before PCL allocates (docs/hardening.md, "Memory bounds").
TEST(PointcloudIo, HeadersCannotMakeTheReaderAllocateWhatTheFileCannotHold) {
  const fs::path dir = TempDir("bounds");
  const std::string pcd = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  std::string lzf("\x10\x00\x00\x00\x00\x00\x00\x0c", 8);  // 16 bytes packed, 192 MiB
  lzf += std::string(16, 'a');
  const std::vector<std::tuple<std::string, std::string, std::string>> cases{
      {"binary.pcd",
       pcd + "WIDTH 100000000\nHEIGHT 1\nPOINTS 100000000\nDATA binary\n" + std::string(64, '\0'),
       "truncated"},
      {"packed.pcd",
       pcd + "WIDTH 16777216\nHEIGHT 1\nPOINTS 16777216\nDATA binary_compressed\n" + lzf,
       "cannot hold"},
      {"wide.pcd",
       "VERSION 0.7\nFIELDS x y w\nSIZE 4 4 8\nTYPE F F F\nCOUNT 1 1 1000000\nWIDTH 100\n"
       "HEIGHT 1\nPOINTS 100\nDATA ascii\n" +
           std::string(1200, '1'),
       "truncated"},
      {"binary.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty float x\n"
       "property float y\nproperty float z\nend_header\nabcdefghijkl",
       "truncated"},
      {"ascii.ply",
       "ply\nformat ascii 1.0\nelement vertex 300000000\nproperty float x\nproperty float y\n"
       "end_header\n1 2\n",
       "truncated"}};
  for (const auto& [name, bytes, why] : cases) {
    const std::string path = (dir / name).string();
    Spit(path, bytes);
    const test_support::LargestAllocation largest;
    ExpectErrorNaming(path, ReadMap, why);
    if (test_support::LargestAllocation::Supported()) {
      EXPECT_LT(largest.bytes(), 1u << 20) << name;
    }
  }
  fs::remove_all(dir);
}

// Found by fuzz_pointcloud (tests/fuzz): a compressed PCD announcing no points (WIDTH 0) whose
// data starts with an LZF block announcing 822084064 bytes: PCL 1.13 read the block's sizes
// anyway and allocated the uncompressed size twice (1.6 GB from a 502-byte file). The block must
// announce what the header does.
TEST(PointcloudIo, FuzzFoundCompressedBlockOfNoPointsIsChecked) {
  const std::string path =
      DRACO_SOURCE_DIR "/tests/data/fuzz/pcd-compressed-block-of-no-points.pcd";
  const test_support::LargestAllocation largest;
  ExpectErrorNaming(path, ReadMap,
                    "the compressed block holds 822084064 bytes of points, the header announces 0");
  if (test_support::LargestAllocation::Supported()) {
    EXPECT_LT(largest.bytes(), 1u << 20);
  }
}

// Random byte damage (fixed seeds) in every format: each file reads or is refused with an
// error naming it; none crashes the process.
TEST(PointcloudIo, CorruptFilesNeverCrash) {
  const fs::path dir = TempDir("fuzz");
  std::vector<msgs::Point2> pts;
  for (int i = 0; i < 300; ++i) pts.push_back({0.37 * i, -0.11 * i});
  std::vector<std::pair<std::string, std::string>> originals;
  for (const auto e : {PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed, PcdEncoding::kAscii}) {
    const fs::path p = dir / (std::string(PcdEncodingName(e)) + ".pcd");
    WritePcd(p.string(), pts, e);
    originals.emplace_back(".pcd", Slurp(p));
  }
  WritePly((dir / "b.ply").string(), pts);
  originals.emplace_back(".ply", Slurp(dir / "b.ply"));
  std::mt19937 rng(2024);
  int read = 0, refused = 0;
  for (const auto& [ext, original] : originals) {
    for (int trial = 0; trial < 150; ++trial) {
      std::string bytes = original;
      const int flips = 1 + trial % 8;
      // Half the trials damage the header, where the parsers are.
      const std::size_t span = trial % 2 ? bytes.size() : std::min<std::size_t>(bytes.size(), 200);
      for (int k = 0; k < flips; ++k) bytes[rng() % span] = static_cast<char>(rng());
      const std::string path = (dir / ("damaged" + ext)).string();
      Spit(path, bytes);
      try {
        ReadMap(path);
        ++read;
      } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
        ++refused;
      }
    }
  }
  EXPECT_EQ(read + refused, 600);
  EXPECT_GT(refused, 0);
  fs::remove_all(dir);
}

TEST(PointcloudIo, WritesAreAtomicAndFailuresNamed) {
  const fs::path dir = TempDir("atomic");
  const std::string path = (dir / "missing" / "m.pcd").string();
  try {
    WritePcd(path, AwkwardPoints());
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ": cannot write PCD", 0), 0u) << e.what();
  }
  EXPECT_THROW(WritePly((dir / "missing" / "m.ply").string(), AwkwardPoints()), std::runtime_error);
  WritePcd((dir / "m.pcd").string(), AwkwardPoints());
  WritePcd((dir / "m.pcd").string(), {{1, 2}});  // replaced whole
  EXPECT_EQ(ReadMapPcd((dir / "m.pcd").string()).size(), 1u);
  EXPECT_EQ(Listing(dir), std::vector<std::string>{"m.pcd"});
  fs::remove_all(dir);
}

TEST(PointcloudIo, EncodingNames) {
  EXPECT_EQ(ParsePcdEncoding("binary_compressed"), PcdEncoding::kBinaryCompressed);
  try {
    ParsePcdEncoding("lzf");
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("binary, binary_compressed, ascii"), std::string::npos);
  }
}

}  // namespace
}  // namespace draco::pointcloud_io
