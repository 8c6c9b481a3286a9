// Streams the sonar and navigation messages of a ROS 1 bag recorded on a vehicle, in bag
// (receipt) time order, converted to draco's sensor messages. Each connection is decoded
// by the message definition stored in the bag, so older layouts work. The bag file itself
// (format 2.0) is read by draco's own reader (src/bag_file.hpp), which checks every length,
// count and offset against the file.
//
//   draco::rosbag::BagReader reader = draco::rosbag::BagReader::Open("mission.bag", {});
//   while (auto record = reader.Next()) { ... std::get_if<msgs::SonarPing>(&record->message) }
//
// Errors (missing, truncated or corrupt file; malformed message) throw BagError naming the
// file and, for a message, its topic, index on that topic and the field.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "draco/msgs/sensors.hpp"
#include "draco/rosbag/convert.hpp"

namespace draco::rosbag {

class BagError : public std::runtime_error {
 public:
  // bad_message: one message could not be decoded or converted; the reader is positioned
  // after it and can go on. Otherwise the file itself is unusable.
  explicit BagError(const std::string& what, bool bad_message = false)
      : std::runtime_error(what), bad_message_(bad_message) {}
  bool bad_message() const { return bad_message_; }

 private:
  bool bad_message_ = false;
};

struct Options {
  // Sonar: the first of these topics present in the bag is read (OculusPing or
  // OculusPingUncompressed, told apart by the connection's type).
  std::vector<std::string> sonar_topics = {"/sonar_oculus_node/M750d/ping",
                                           "/sonar_oculus_node/ping"};
  std::string dvl_topic = "/rti/body_velocity/raw";  // rti_dvl/DVL
  std::string imu_topic = "/vn100/imu/raw";          // sensor_msgs/Imu
  std::string depth_topic = "/bar30/depth/raw";      // bar30_depth/Depth
  std::string ground_truth_topic = "/pose_true";     // geometry_msgs/PoseStamped
  // Message times from header.stamp (the sensor's time); false, or a zero stamp, uses the
  // time the recorder received the message. Mission time = that time - bag start time.
  bool use_header_stamp = true;
  ConvertOptions convert;
};

using Message = std::variant<msgs::SonarPing, msgs::DvlVelocity, msgs::Ahrs, msgs::Depth,
                             msgs::GroundTruthPose>;

struct Record {
  std::string topic;
  std::size_t index = 0;        // index of this message on its topic, from 0
  double receipt_time_s = 0.0;  // absolute (Unix) time the recorder received it
  double stamp_time_s = 0.0;    // absolute time the message's time_s was derived from
  Message message;              // time_s in mission seconds (relative to bag start)
};

// Topics of a bag, as listed in its connections.
struct TopicInfo {
  std::string topic;
  std::string datatype;
  std::string md5sum;
  std::size_t message_count = 0;
};

class BagReader {
 public:
  // Opens the bag and selects the topics. Throws BagError (file missing, not a bag,
  // truncated index, a selected connection with an unusable message definition or type).
  static BagReader Open(const std::string& path, Options options = {});

  BagReader(BagReader&&) noexcept;
  BagReader& operator=(BagReader&&) noexcept;
  ~BagReader();

  // The next message in receipt-time order; nullopt at the end. Throws BagError on a
  // malformed message (the reader is positioned after it: Next() may be called again).
  std::optional<Record> Next();

  const std::string& path() const;
  double start_time_s() const;  // absolute bag start (earliest receipt time), Unix seconds
  double end_time_s() const;
  const std::string& sonar_topic() const;  // the sonar topic chosen ("" when none)
  std::vector<TopicInfo> Topics() const;   // every topic in the bag
  std::size_t selected_message_count() const;

 private:
  struct Impl;
  explicit BagReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace draco::rosbag
