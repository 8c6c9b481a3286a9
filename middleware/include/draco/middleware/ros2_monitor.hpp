// Publishing to ROS 2 tools (RViz, Foxglove, ros2 topic echo) with no ROS installed: ROS 2's
// own wire types and topic naming on a DDS domain of the vehicle's or ship's local network,
// never the team link's (middleware/idl/ros2.idl; docs/install.md, "Watching from ROS 2").
//
// A ROS 2 topic "/draco/alpha/path" is the DDS topic "rt/draco/alpha/path" of type
// "nav_msgs::msg::dds_::Path_", as ROS 2's DDS middlewares name them. Writers are reliable,
// transient-local, keep-last 1: a subscriber with ROS 2's default QoS (reliable or best effort,
// volatile or transient local) matches, and one that joins late gets the newest sample.
// Cyclone DDS stays private to middleware/: nothing here includes a DDS header.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace draco::middleware {

struct Ros2MonitorOptions {
  int domain_id = 0;        // ROS_DOMAIN_ID of the local network: 0 to 232, not the link's
  std::string config_file;  // Cyclone DDS XML; "": $CYCLONEDDS_URI or Cyclone's defaults
};

// A pose in the plane, stamped (mission time, seconds).
struct StampedPose2 {
  double stamp_s = 0.0;
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

struct PointXyz {
  float x_m = 0.0f;
  float y_m = 0.0f;
  float z_m = 0.0f;
};

struct Ros2MonitorCounters {
  std::uint64_t samples_written = 0;
  std::uint64_t write_failed = 0;
  std::uint64_t bytes_written = 0;  // payload (poses, point data), not DDS overhead
};

// The DDS topic of a ROS 2 topic name ("/a/b" or "a/b" -> "rt/a/b"). Throws
// std::invalid_argument naming the name unless it is a valid fully qualified ROS 2 name:
// tokens of letters, digits and '_', separated by single '/', no token starting with a digit,
// no trailing '/', no "__".
std::string Ros2DdsTopicName(std::string_view ros_topic);

// The ROS 2 message time of a stamp in seconds (sec rounded down, nanosec 0 to 999999999).
// Throws std::invalid_argument when the stamp is not finite or out of int32 seconds.
void Ros2Time(double stamp_s, std::int32_t* sec, std::uint32_t* nanosec);

class Ros2Monitor {
 public:
  virtual ~Ros2Monitor() = default;
  // Each writes one sample on the ROS 2 topic (its writer made on first use); false when DDS
  // refused (counted). Throws std::invalid_argument on a bad topic name, frame id or stamp.
  // geometry_msgs/msg/PoseStamped; yaw about z as a unit quaternion, z = 0.
  virtual bool PublishPose(std::string_view topic, std::string_view frame_id,
                           const StampedPose2& pose) = 0;
  // nav_msgs/msg/Path: header stamp stamp_s; each pose with its own stamp and the frame id.
  virtual bool PublishPath(std::string_view topic, std::string_view frame_id, double stamp_s,
                           const std::vector<StampedPose2>& poses) = 0;
  // sensor_msgs/msg/PointCloud2: one row, fields x y z (FLOAT32, offsets 0 4 8), point step
  // 12, the host's byte order, dense.
  virtual bool PublishPointCloud(std::string_view topic, std::string_view frame_id, double stamp_s,
                                 const std::vector<PointXyz>& points) = 0;
  virtual Ros2MonitorCounters counters() const = 0;
};

// Throws std::invalid_argument for a bad option, std::runtime_error when DDS cannot start or
// the domain is the team link's in this process (the message names the domain and file).
std::unique_ptr<Ros2Monitor> MakeRos2Monitor(const Ros2MonitorOptions& options);

}  // namespace draco::middleware
