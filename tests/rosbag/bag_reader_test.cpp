// BagReader on bags written by the official ROS 1 writer (test_bags.hpp).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "draco/rosbag/bag_reader.hpp"
#include "largest_allocation.hpp"
#include "test_bags.hpp"

namespace draco::rosbag {
namespace {

using namespace testbags;  // NOLINT: the known values

std::string Bag(const std::string& name) { return Path(name); }

std::vector<Record> ReadAll(const std::string& path, Options options = {}) {
  BagReader reader = BagReader::Open(path, std::move(options));
  std::vector<Record> out;
  while (auto r = reader.Next()) out.push_back(std::move(*r));
  return out;
}

template <class T>
std::vector<T> Only(const std::vector<Record>& records) {
  std::vector<T> out;
  for (const auto& r : records) {
    if (const T* m = std::get_if<T>(&r.message)) out.push_back(*m);
  }
  return out;
}

// Expects BagError whose message contains every one of `parts`.
template <class Fn>
void ExpectBagError(Fn fn, const std::vector<std::string>& parts) {
  try {
    fn();
    ADD_FAILURE() << "no BagError";
  } catch (const BagError& e) {
    for (const auto& part : parts) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos)
          << "'" << part << "' not in: " << e.what();
    }
  }
}

void CheckFullBag(const std::vector<Record>& records) {
  ASSERT_EQ(records.size(), 3u + 3u + 10u + 5u + 5u);  // the unrelated topic is not read
  for (std::size_t i = 1; i < records.size(); ++i) {
    EXPECT_LE(records[i - 1].receipt_time_s, records[i].receipt_time_s);
  }
  auto pings = Only<msgs::SonarPing>(records);
  auto dvl = Only<msgs::DvlVelocity>(records);
  auto ahrs = Only<msgs::Ahrs>(records);
  auto depth = Only<msgs::Depth>(records);
  auto poses = Only<msgs::GroundTruthPose>(records);
  ASSERT_EQ(pings.size(), 3u);
  ASSERT_EQ(dvl.size(), 3u);
  ASSERT_EQ(ahrs.size(), 10u);
  ASSERT_EQ(depth.size(), 5u);
  ASSERT_EQ(poses.size(), 5u);

  // Mission time = header stamp - bag start (the first receipt time).
  for (int k = 0; k < 3; ++k) {
    const auto& p = pings[static_cast<std::size_t>(k)];
    EXPECT_NEAR(p.time_s, 0.2 * k - kReceiptDelay, 1e-6);
    EXPECT_EQ(p.ping_id, 100u + static_cast<unsigned>(k));
    EXPECT_EQ(p.num_ranges, kNumRanges);
    EXPECT_EQ(p.num_beams, kNumBeams);
    EXPECT_DOUBLE_EQ(p.range_resolution_m, kRangeResolution);
    ASSERT_EQ(p.bearings_rad.size(), static_cast<std::size_t>(kNumBeams));
    ASSERT_EQ(p.intensity.size(), static_cast<std::size_t>(kNumRanges * kNumBeams));
    for (int c = 0; c < kNumBeams; ++c) {
      // Starboard-positive bearings become counter-clockwise: negated, columns reversed.
      double expected = -BearingHundredths(kNumBeams - 1 - c) * 0.01 * M_PI / 180.0;
      EXPECT_NEAR(p.bearings_rad[static_cast<std::size_t>(c)], expected, 1e-6);
    }
    int worst = 0;
    for (int r = 0; r < kNumRanges; ++r) {
      for (int c = 0; c < kNumBeams; ++c) {
        double raw = Pattern(k, r, kNumBeams - 1 - c);
        int expected = static_cast<int>(std::lround(std::pow(raw / 255.0, 255.0 / kGamma) * 255));
        worst = std::max(worst, std::abs(p.At(r, c) - expected));
      }
    }
    EXPECT_LE(worst, 3) << "ping " << k;  // JPEG of uniform 8x8 blocks is near-exact
  }
  for (int k = 0; k < 3; ++k) {
    const auto& d = dvl[static_cast<std::size_t>(k)];
    EXPECT_NEAR(d.time_s, 0.2 * k + 0.001 - kReceiptDelay, 1e-6);
    EXPECT_EQ(d.velocity_body_mps, (std::array<double, 3>{0.5, 0.1, -0.02}));
    EXPECT_NEAR(d.altitude_m, 3.0 + 0.1 * k, 1e-12);
    EXPECT_TRUE(d.valid);
  }
  for (int k = 0; k < 10; ++k) {
    const auto& a = ahrs[static_cast<std::size_t>(k)];
    EXPECT_NEAR(a.time_s, 0.05 * k + 0.002 - kReceiptDelay, 1e-6);
    EXPECT_NEAR(a.roll_rad, 0.1, 1e-9);
    EXPECT_NEAR(a.pitch_rad, 0.2, 1e-9);
    EXPECT_NEAR(a.yaw_rad, -(1.0 + 0.1 * k), 1e-9);
    EXPECT_NEAR(a.yaw_rate_radps, -0.05, 1e-12);
  }
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(depth[static_cast<std::size_t>(k)].depth_m, 2.0 + 0.25 * k);
    const auto& g = poses[static_cast<std::size_t>(k)];
    EXPECT_NEAR(g.time_s, 0.1 * k + 0.004 - kReceiptDelay, 1e-6);
    EXPECT_EQ(g.position_m, (std::array<double, 3>{1.0 * k, -2.0 * k, 3.0}));
    EXPECT_NEAR(g.yaw_rad, -0.3, 1e-9);
  }
}

TEST(BagReader, ReadsEveryStreamWithKnownValues) {
  BagReader reader = BagReader::Open(Bag("full.bag"));
  EXPECT_EQ(reader.sonar_topic(), "/sonar_oculus_node/M750d/ping");
  EXPECT_NEAR(reader.start_time_s(), kBagStart + kReceiptDelay, 1e-6);
  EXPECT_EQ(reader.selected_message_count(), 26u);
  CheckFullBag(ReadAll(Bag("full.bag")));
}

TEST(BagReader, Lz4AndBz2ChunksGiveTheSameMessages) {
  CheckFullBag(ReadAll(Bag("lz4.bag")));
  CheckFullBag(ReadAll(Bag("bz2.bag")));
}

TEST(BagReader, ListsTopicsWithTheWritersMd5) {
  auto topics = BagReader::Open(Bag("full.bag")).Topics();
  std::map<std::string, TopicInfo> by_topic;
  for (const auto& t : topics) by_topic[t.topic] = t;
  ASSERT_EQ(by_topic.count("/sonar_oculus_node/M750d/ping"), 1u);
  EXPECT_EQ(by_topic["/sonar_oculus_node/M750d/ping"].datatype, "sonar_oculus/OculusPing");
  EXPECT_EQ(by_topic["/sonar_oculus_node/M750d/ping"].md5sum, "9f6ad8a7bb36e92c4f0225b11da7ca2e");
  EXPECT_EQ(by_topic["/vn100/imu/raw"].message_count, 10u);
  EXPECT_EQ(by_topic["/rosout_like"].datatype, "std_msgs/String");
}

TEST(BagReader, OptionsChangeTimesFramesAndGamma) {
  Options options;
  options.use_header_stamp = false;
  options.convert.frd_to_flu = false;
  options.convert.linearize_gamma = false;
  auto records = ReadAll(Bag("full.bag"), options);
  auto pings = Only<msgs::SonarPing>(records);
  ASSERT_EQ(pings.size(), 3u);
  EXPECT_NEAR(pings[1].time_s, 0.2, 1e-6);  // receipt time - bag start
  EXPECT_NEAR(pings[1].bearings_rad[0], -65.0 * M_PI / 180.0, 1e-6);
  int worst = 0;
  for (int r = 0; r < kNumRanges; ++r) {
    for (int c = 0; c < kNumBeams; ++c) {
      worst = std::max(worst, std::abs(pings[1].At(r, c) - Pattern(1, r, c)));
    }
  }
  EXPECT_LE(worst, 2);
  auto ahrs = Only<msgs::Ahrs>(records);
  EXPECT_NEAR(ahrs[3].yaw_rad, 1.3, 1e-9);
  EXPECT_NEAR(ahrs[3].pitch_rad, -0.2, 1e-9);
  auto poses = Only<msgs::GroundTruthPose>(records);
  EXPECT_EQ(poses[2].position_m, (std::array<double, 3>{2.0, 4.0, -3.0}));
}

TEST(BagReader, TopicNamesAreConfigurable) {
  Options options;
  options.sonar_topics = {"/no/such/topic"};
  options.imu_topic = "";
  options.ground_truth_topic = "/elsewhere";
  auto records = ReadAll(Bag("full.bag"), options);
  EXPECT_TRUE(Only<msgs::SonarPing>(records).empty());
  EXPECT_TRUE(Only<msgs::Ahrs>(records).empty());
  EXPECT_TRUE(Only<msgs::GroundTruthPose>(records).empty());
  EXPECT_EQ(Only<msgs::DvlVelocity>(records).size(), 3u);
}

TEST(BagReader, UncompressedPingsOnTheFallbackTopic) {
  BagReader reader = BagReader::Open(Bag("uncompressed_ping.bag"));
  EXPECT_EQ(reader.sonar_topic(), "/sonar_oculus_node/ping");
  Options options;
  options.convert.frd_to_flu = false;
  options.convert.linearize_gamma = false;
  auto pings = Only<msgs::SonarPing>(ReadAll(Bag("uncompressed_ping.bag"), options));
  ASSERT_EQ(pings.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    for (int r = 0; r < kNumRanges; ++r) {
      for (int c = 0; c < kNumBeams; ++c) {
        ASSERT_EQ(pings[static_cast<std::size_t>(k)].At(r, c), Pattern(k, r, c));
      }
    }
  }
}

TEST(BagReader, OlderPingLayoutWithoutPartNumber) {
  auto pings = Only<msgs::SonarPing>(ReadAll(Bag("old_layout.bag")));
  ASSERT_EQ(pings.size(), 2u);
  EXPECT_EQ(pings[1].ping_id, 101u);
  EXPECT_EQ(pings[1].num_beams, kNumBeams);
  EXPECT_DOUBLE_EQ(pings[1].range_resolution_m, kRangeResolution);
  EXPECT_NEAR(pings[1].time_s, 0.2 - kReceiptDelay, 1e-6);
}

TEST(BagReader, TruncatedMessageNamesFileTopicIndexAndField) {
  const std::string path = Bag("truncated_message.bag");
  BagReader reader = BagReader::Open(path);
  ASSERT_TRUE(reader.Next().has_value());
  ExpectBagError([&] { reader.Next(); }, {path, "/sonar_oculus_node/M750d/ping", "message 1",
                                          "field 'bearings'", "32 elements"});
  EXPECT_FALSE(reader.Next().has_value());  // positioned after the bad message
}

TEST(BagReader, UndecodableJpegNamesTheField) {
  const std::string path = Bag("bad_jpeg.bag");
  BagReader reader = BagReader::Open(path);
  ExpectBagError([&] { reader.Next(); }, {path, "message 0", "ping.data"});
}

TEST(BagReader, BearingTableNotMatchingTheImage) {
  const std::string path = Bag("bad_geometry.bag");
  BagReader reader = BagReader::Open(path);
  ExpectBagError([&] { reader.Next(); }, {path, "bearings", "10 entries", "32 beams"});
}

TEST(BagReader, MissingTruncatedAndCorruptFiles) {
  ExpectBagError([] { BagReader::Open(Bag("nope.bag")); }, {"nope.bag", "cannot open"});
  ExpectBagError([] { BagReader::Open(Bag("not_a_bag.bag")); }, {"not_a_bag.bag"});
  ExpectBagError([] { ReadAll(Bag("truncated_file.bag")); }, {"truncated_file.bag"});
}

// Every cut of a valid bag is either read or refused with a BagError; nothing crashes.
TEST(BagReader, EveryTruncationIsAnErrorNeverACrash) {
  for (const std::string name : {"full.bag", "lz4.bag"}) {
    std::ifstream in(Bag(name), std::ios::binary);
    std::string whole((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string cut_path = Bag("cut.bag");
    for (std::size_t n = 0; n < whole.size(); n += 97) {
      {
        std::ofstream out(cut_path, std::ios::binary | std::ios::trunc);
        out.write(whole.data(), static_cast<std::streamsize>(n));
      }
      try {
        ReadAll(cut_path);
      } catch (const BagError& e) {
        EXPECT_NE(std::string(e.what()).find("cut.bag"), std::string::npos) << e.what();
      }
    }
  }
}

// ---- bad bags: every size in the file is checked before it is used (docs/hardening.md) ----

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::uint32_t U32At(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(s[at + i]);
  return v;
}

void SetU32At(std::string& s, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s[at + i] = static_cast<char>(v >> (8 * i));
}

// The top-level records of a bag (format 2.0): where each starts, its op, its data, and where
// each header field's value is.
struct RawRecord {
  std::size_t pos = 0;
  int op = -1;
  std::size_t data_pos = 0;
  std::size_t data_len = 0;
  std::map<std::string, std::size_t> value_at;
};

std::vector<RawRecord> Records(const std::string& bag) {
  std::vector<RawRecord> out;
  std::size_t at = 13;  // "#ROSBAG V2.0\n"
  while (at + 4 <= bag.size()) {
    RawRecord r;
    r.pos = at;
    const std::size_t header_len = U32At(bag, at);
    std::size_t f = at + 4;
    while (f < at + 4 + header_len) {
      const std::size_t len = U32At(bag, f);
      const std::size_t eq = bag.find('=', f + 4);
      const std::string name = bag.substr(f + 4, eq - f - 4);
      r.value_at[name] = eq + 1;
      if (name == "op") r.op = static_cast<std::uint8_t>(bag[eq + 1]);
      f += 4 + len;
    }
    r.data_len = U32At(bag, f);
    r.data_pos = f + 4;
    out.push_back(r);
    at = r.data_pos + r.data_len;
  }
  return out;
}

RawRecord First(const std::vector<RawRecord>& records, int op) {
  for (const auto& r : records) {
    if (r.op == op) return r;
  }
  ADD_FAILURE() << "no record with op " << op;
  return {};
}

// The first index record of the connection on `topic`.
RawRecord FirstIndexOf(const std::string& bag, const std::string& topic) {
  const auto records = Records(bag);
  for (const auto& c : records) {
    if (c.op != 7) continue;
    const std::size_t topic_at = c.value_at.at("topic");
    if (bag.compare(topic_at, topic.size(), topic) != 0) continue;
    const std::uint32_t conn = U32At(bag, c.value_at.at("conn"));
    for (const auto& r : records) {
      if (r.op == 4 && U32At(bag, r.value_at.at("conn")) == conn) return r;
    }
  }
  ADD_FAILURE() << "no index record of " << topic;
  return {};
}

std::string WriteBag(const std::string& name, const std::string& bytes) {
  const std::string path = Bag(name);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  return path;
}

// Found by fuzz_rosbag (tests/fuzz): with Debian's rosbag_storage this input (full.bag with one
// index offset changed) made the reader read outside the chunk (SEGV in
// rosbag::Bag::readHeaderFromBuffer). The index offset must point into its chunk.
TEST(BagReader, FuzzFoundIndexOffsetOutsideTheChunkIsAnError) {
  const std::string path =
      DRACO_SOURCE_DIR "/tests/data/fuzz/rosbag-index-offset-outside-chunk.bag";
  ExpectBagError([&] { ReadAll(path); }, {path, "index record at byte", "of a", "-byte chunk"});
}

TEST(BagReader, IndexOffsetsMustPointAtAMessageRecordOfTheirChunk) {
  const std::string whole = ReadBytes(Bag("full.bag"));
  const RawRecord index = FirstIndexOf(whole, "/sonar_oculus_node/M750d/ping");
  RawRecord chunk;  // the chunk the index record follows
  for (const auto& r : Records(whole)) {
    if (r.op == 5 && r.pos < index.pos) chunk = r;
  }
  const std::uint32_t chunk_size = U32At(whole, chunk.value_at.at("size"));
  // Past the chunk: refused when the bag is opened.
  std::string bytes = whole;
  SetU32At(bytes, index.data_pos + 8, chunk_size + 100);
  ExpectBagError([&] { BagReader::Open(WriteBag("offset_past.bag", bytes)); },
                 {"offset_past.bag", "message 0 at offset " + std::to_string(chunk_size + 100),
                  "of a " + std::to_string(chunk_size) + "-byte chunk"});
  // Inside the chunk but not at a record: the message read fails, naming the offset.
  bytes = whole;
  SetU32At(bytes, index.data_pos + 8, 7);
  ExpectBagError([&] { ReadAll(WriteBag("offset_inside.bag", bytes)); },
                 {"offset_inside.bag", "read error", "message at offset 7 of chunk at byte"});
}

TEST(BagReader, LengthsAndSizesInTheFileAreCheckedBeforeAllocating) {
  // not_a_bag.bag: the format line, then noise whose first word, read as a header length,
  // made rosbag_storage allocate 2 GB.
  {
    const test_support::LargestAllocation largest;
    ExpectBagError([] { BagReader::Open(Bag("not_a_bag.bag")); },
                   {"not_a_bag.bag", "bag header at byte 13", "does not fit"});
    if (test_support::LargestAllocation::Supported()) {
      EXPECT_LT(largest.bytes(), 1u << 20);
    }
  }
  // An lz4 chunk claiming 2 GiB uncompressed.
  std::string bytes = ReadBytes(Bag("lz4.bag"));
  const RawRecord chunk = First(Records(bytes), 5);
  SetU32At(bytes, chunk.value_at.at("size"), 0x7fffffff);
  {
    const std::string path = WriteBag("huge_chunk.bag", bytes);
    const test_support::LargestAllocation largest;
    ExpectBagError([&] { ReadAll(path); }, {"huge_chunk.bag", "lz4 chunk of",
                                            "claims 2147483647 bytes uncompressed", "implausible"});
    if (test_support::LargestAllocation::Supported()) {
      EXPECT_LT(largest.bytes(), 1u << 20);
    }
  }
  // A connection record whose data length runs past the end of the file.
  bytes = ReadBytes(Bag("full.bag"));
  const RawRecord connection = First(Records(bytes), 7);  // the index's first connection
  SetU32At(bytes, connection.data_pos - 4, 0x40000000);
  ExpectBagError([&] { BagReader::Open(WriteBag("long_connection.bag", bytes)); },
                 {"long_connection.bag", "data of 1073741824 bytes", "left in the file"});
}

TEST(BagReader, ChunksMustNotOverlapOrRepeat) {
  // Two chunk-info records naming the same chunk would read its index twice (memory
  // quadratic in the file).
  std::string bytes = ReadBytes(Bag("full.bag"));
  std::vector<RawRecord> infos;
  for (const auto& r : Records(bytes)) {
    if (r.op == 6) infos.push_back(r);
  }
  ASSERT_GE(infos.size(), 2u);
  const std::size_t first_pos = infos[0].value_at.at("chunk_pos");
  bytes.replace(infos[1].value_at.at("chunk_pos"), 8, bytes.substr(first_pos, 8));
  ExpectBagError([&] { BagReader::Open(WriteBag("repeated_chunk.bag", bytes)); },
                 {"repeated_chunk.bag", "chunk info record", "is not after the previous chunk"});
}

}  // namespace
}  // namespace draco::rosbag
