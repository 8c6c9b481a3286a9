// The ROS 2 monitor read back by a plain Cyclone DDS reader built from the same IDL
// (middleware/idl/ros2.idl): ROS 2 topic and type names, field values, QoS a ROS 2 subscriber
// uses, and the serialized bytes of a PoseStamped against a hand-computed XCDR1 (plain CDR,
// little endian) encoding, which is what a ROS 2 reader decodes.
#include "draco/middleware/ros2_monitor.hpp"

#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "draco/middleware/transport.hpp"
#include "ros2.h"

namespace draco::middleware {
namespace {

using Clock = std::chrono::steady_clock;

// Away from dds_test.cpp's offsets (0 to 9) for the same process id.
int TestDomain(int offset) { return 1 + (static_cast<int>(getpid()) % 190) + 20 + offset; }

Ros2MonitorOptions Options(int domain) {
  return {.domain_id = domain, .config_file = DRACO_SOURCE_DIR "/config/dds/loopback.xml"};
}

bool PollFor(double seconds, const std::function<bool()>& step) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  while (Clock::now() < deadline) {
    if (step()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return step();
}

// A reader as a ROS 2 subscription with default QoS makes it (reliable, volatile, keep last
// 10), or transient local to get what was written before it joined.
class PlainReader {
 public:
  PlainReader(int domain, const dds_topic_descriptor_t* type, const std::string& topic,
              bool transient_local = false) {
    participant_ = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    if (participant_ < 0) throw std::runtime_error("participant");
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_durability(qos,
                        transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
    const dds_entity_t t = dds_create_topic(participant_, type, topic.c_str(), qos, nullptr);
    if (t < 0) throw std::runtime_error("topic");
    reader_ = dds_create_reader(participant_, t, qos, nullptr);
    dds_delete_qos(qos);
    if (reader_ < 0) throw std::runtime_error("reader");
  }
  ~PlainReader() { dds_delete(participant_); }

  // Waits for the writer to match this reader (volatile readers must match before a write).
  bool Matched(double seconds) {
    return PollFor(seconds, [&] {
      dds_subscription_matched_status_t s{};
      return dds_get_subscription_matched_status(reader_, &s) == DDS_RETCODE_OK &&
             s.current_count > 0;
    });
  }

  // Takes one sample (decoded with the generated type) and hands it to `check`.
  template <class T>
  bool TakeOne(double seconds, const std::function<void(const T&)>& check) {
    return PollFor(seconds, [&] {
      void* samples[1] = {nullptr};
      dds_sample_info_t info;
      const dds_return_t n = dds_take(reader_, samples, &info, 1, 1);
      if (n <= 0) return false;
      const bool valid = info.valid_data;
      if (valid) check(*static_cast<const T*>(samples[0]));
      dds_return_loan(reader_, samples, n);
      return valid;
    });
  }

  // Takes one sample as its serialized bytes (what travels on the wire).
  std::vector<std::uint8_t> TakeBytes(double seconds) {
    std::vector<std::uint8_t> bytes;
    PollFor(seconds, [&] {
      struct ddsi_serdata* data[1] = {nullptr};
      dds_sample_info_t info;
      const dds_return_t n = dds_takecdr(reader_, data, 1, &info, DDS_ANY_STATE);
      if (n <= 0) return false;
      bytes.resize(ddsi_serdata_size(data[0]));
      ddsi_serdata_to_ser(data[0], 0, bytes.size(), bytes.data());
      ddsi_serdata_unref(data[0]);
      return info.valid_data;
    });
    return bytes;
  }

  dds_entity_t reader() const { return reader_; }

 private:
  dds_entity_t participant_ = 0;
  dds_entity_t reader_ = 0;
};

TEST(Ros2Names, TopicsAndStamps) {
  EXPECT_EQ(Ros2DdsTopicName("/draco/alpha/path"), "rt/draco/alpha/path");
  EXPECT_EQ(Ros2DdsTopicName("draco/alpha/team/bravo/path"), "rt/draco/alpha/team/bravo/path");
  for (const char* bad : {"", "/", "a//b", "a/", "1a", "a/2b", "a b", "a__b", "a-b", "/a/b/"}) {
    EXPECT_THROW(Ros2DdsTopicName(bad), std::invalid_argument) << bad;
  }
  std::int32_t sec = 0;
  std::uint32_t nsec = 0;
  Ros2Time(12.25, &sec, &nsec);
  EXPECT_EQ(sec, 12);
  EXPECT_EQ(nsec, 250000000u);
  Ros2Time(-0.5, &sec, &nsec);  // ROS 2 time: sec rounded down, nanosec positive
  EXPECT_EQ(sec, -1);
  EXPECT_EQ(nsec, 500000000u);
  Ros2Time(0.9999999999, &sec, &nsec);
  EXPECT_EQ(sec, 1);
  EXPECT_EQ(nsec, 0u);
  EXPECT_THROW(Ros2Time(std::nan(""), &sec, &nsec), std::invalid_argument);
  EXPECT_THROW(Ros2Time(3e9, &sec, &nsec), std::invalid_argument);
}

TEST(Ros2Monitor, PathPoseAndCloudReachAPlainReader) {
  const int domain = TestDomain(0);
  auto monitor = MakeRos2Monitor(Options(domain));
  PlainReader paths(domain, &nav_msgs_msg_dds__Path__desc, "rt/draco/alpha/path");
  PlainReader clouds(domain, &sensor_msgs_msg_dds__PointCloud2__desc, "rt/draco/alpha/map");
  // No writer yet: the first publish makes it; publish until the volatile reader matched.
  const std::vector<StampedPose2> poses = {{10.0, 1.0, 2.0, 0.0},
                                           {11.5, 3.0, -4.0, std::numbers::pi / 2}};
  ASSERT_TRUE(monitor->PublishPath("/draco/alpha/path", "alpha/map", 12.25, poses));
  ASSERT_TRUE(paths.Matched(5.0));
  ASSERT_TRUE(monitor->PublishPath("/draco/alpha/path", "alpha/map", 12.25, poses));
  bool got = false;
  ASSERT_TRUE(paths.TakeOne<nav_msgs_msg_dds__Path_>(5.0, [&](const auto& p) {
    got = true;
    EXPECT_STREQ(p.header.frame_id, "alpha/map");
    EXPECT_EQ(p.header.stamp.sec, 12);
    EXPECT_EQ(p.header.stamp.nanosec, 250000000u);
    ASSERT_EQ(p.poses._length, 2u);
    const auto& b = p.poses._buffer[1];
    EXPECT_EQ(b.header.stamp.sec, 11);
    EXPECT_EQ(b.header.stamp.nanosec, 500000000u);
    EXPECT_DOUBLE_EQ(b.pose.position.x, 3.0);
    EXPECT_DOUBLE_EQ(b.pose.position.y, -4.0);
    EXPECT_DOUBLE_EQ(b.pose.position.z, 0.0);
    EXPECT_NEAR(b.pose.orientation.z, std::sqrt(0.5), 1e-12);  // yaw 90 deg about z
    EXPECT_NEAR(b.pose.orientation.w, std::sqrt(0.5), 1e-12);
    EXPECT_DOUBLE_EQ(p.poses._buffer[0].pose.orientation.w, 1.0);
  }));
  EXPECT_TRUE(got);

  const std::vector<PointXyz> points = {{1.5f, -2.0f, 0.0f}, {7.25f, 3.0f, 0.5f}};
  ASSERT_TRUE(monitor->PublishPointCloud("/draco/alpha/map", "alpha/map", 20.0, points));
  ASSERT_TRUE(clouds.Matched(5.0));
  ASSERT_TRUE(monitor->PublishPointCloud("/draco/alpha/map", "alpha/map", 20.0, points));
  ASSERT_TRUE(clouds.TakeOne<sensor_msgs_msg_dds__PointCloud2_>(5.0, [&](const auto& c) {
    EXPECT_EQ(c.height, 1u);
    EXPECT_EQ(c.width, 2u);
    EXPECT_EQ(c.point_step, 12u);
    EXPECT_EQ(c.row_step, 24u);
    EXPECT_TRUE(c.is_dense);
    EXPECT_EQ(c.is_bigendian, std::endian::native == std::endian::big);
    ASSERT_EQ(c.fields._length, 3u);
    const char* names[3] = {"x", "y", "z"};
    for (std::uint32_t i = 0; i < 3; ++i) {
      EXPECT_STREQ(c.fields._buffer[i].name, names[i]);
      EXPECT_EQ(c.fields._buffer[i].offset, 4 * i);
      EXPECT_EQ(c.fields._buffer[i].datatype, 7);  // FLOAT32
      EXPECT_EQ(c.fields._buffer[i].count, 1u);
    }
    ASSERT_EQ(c.data._length, 24u);
    float xyz[6];
    std::memcpy(xyz, c.data._buffer, sizeof xyz);
    EXPECT_EQ(xyz[0], 1.5f);
    EXPECT_EQ(xyz[1], -2.0f);
    EXPECT_EQ(xyz[3], 7.25f);
    EXPECT_EQ(xyz[5], 0.5f);
  }));
  const auto counters = monitor->counters();
  EXPECT_EQ(counters.samples_written, 4u);
  EXPECT_EQ(counters.write_failed, 0u);
}

// Type names as ROS 2 registers them, and the bytes of a PoseStamped against the XCDR1
// encoding computed by hand.
TEST(Ros2Monitor, PoseStampedBytesAreRos2sEncoding) {
  EXPECT_STREQ(nav_msgs_msg_dds__Path__desc.m_typename, "nav_msgs::msg::dds_::Path_");
  EXPECT_STREQ(sensor_msgs_msg_dds__PointCloud2__desc.m_typename,
               "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_STREQ(geometry_msgs_msg_dds__PoseStamped__desc.m_typename,
               "geometry_msgs::msg::dds_::PoseStamped_");
  const int domain = TestDomain(1);
  auto monitor = MakeRos2Monitor(Options(domain));
  const StampedPose2 pose{3.5, -1.25, 8.0, 0.0};
  ASSERT_TRUE(monitor->PublishPose("/draco/alpha/pose", "alpha/map", pose));
  // Joins after the write: transient local hands it the newest sample.
  PlainReader late(domain, &geometry_msgs_msg_dds__PoseStamped__desc, "rt/draco/alpha/pose",
                   /*transient_local=*/true);
  const auto bytes = late.TakeBytes(5.0);
  if (std::endian::native != std::endian::little) GTEST_SKIP() << "expected bytes are LE";
  std::vector<std::uint8_t> expected = {0x00, 0x01, 0x00, 0x00};  // CDR_LE, options 0
  const auto put = [&](const void* p, std::size_t n) {
    const auto* b = static_cast<const std::uint8_t*>(p);
    expected.insert(expected.end(), b, b + n);
  };
  const std::int32_t sec = 3;
  const std::uint32_t nanosec = 500000000u, length = 10;  // "alpha/map" + NUL
  put(&sec, 4);
  put(&nanosec, 4);
  put(&length, 4);
  put("alpha/map", 10);  // offsets 12 to 21; doubles align to 8 (from the encapsulation's end)
  expected.insert(expected.end(), 2, 0);
  for (const double d : {-1.25, 8.0, 0.0, 0.0, 0.0, 0.0, 1.0}) put(&d, 8);
  ASSERT_EQ(bytes.size(), expected.size());
  EXPECT_EQ(bytes, expected);
}

TEST(Ros2Monitor, NeverSharesTheTeamLinksDomain) {
  const int domain = TestDomain(2);
  auto link =
      MakeDdsTransport(DdsOptions{.domain_id = domain,
                                  .robot_id = 1,
                                  .config_file = DRACO_SOURCE_DIR "/config/dds/loopback.xml"});
  try {
    auto monitor = MakeRos2Monitor(Options(domain));
    ADD_FAILURE() << "the monitor opened the link's domain";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("needs a domain of its own"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(MakeRos2Monitor({.domain_id = 233}), std::invalid_argument);
  EXPECT_THROW(MakeRos2Monitor({.domain_id = TestDomain(3), .config_file = "/nonexistent.xml"}),
               std::runtime_error);
}

TEST(Ros2Monitor, BadNamesAndMixedTypesAreClearErrors) {
  auto monitor = MakeRos2Monitor(Options(TestDomain(4)));
  const StampedPose2 pose{1.0, 0.0, 0.0, 0.0};
  EXPECT_THROW(monitor->PublishPose("/draco/9/pose", "alpha/map", pose), std::invalid_argument);
  EXPECT_THROW(monitor->PublishPose("/draco/alpha/pose", "/alpha/map", pose),
               std::invalid_argument);
  EXPECT_THROW(monitor->PublishPose("/draco/alpha/pose", "", pose), std::invalid_argument);
  EXPECT_THROW(monitor->PublishPose("/draco/alpha/pose", "alpha/map", {std::nan(""), 0, 0, 0}),
               std::invalid_argument);
  ASSERT_TRUE(monitor->PublishPose("/draco/alpha/pose", "alpha/map", pose));
  try {
    monitor->PublishPath("/draco/alpha/pose", "alpha/map", 1.0, {pose});
    ADD_FAILURE() << "a Path on a PoseStamped topic";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("geometry_msgs::msg::dds_::PoseStamped_"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(monitor->counters().samples_written, 1u);
}

}  // namespace
}  // namespace draco::middleware
