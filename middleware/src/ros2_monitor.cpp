// ROS 2 wire types over Cyclone DDS (middleware/idl/ros2.idl): one participant on the
// monitor's domain, one writer per topic made on first use.
#include "draco/middleware/ros2_monitor.hpp"

#include <dds/dds.h>

#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <stdexcept>

#include "dds_domains.hpp"
#include "ros2.h"

namespace draco::middleware {
namespace {

constexpr std::uint8_t kFloat32 = 7;  // sensor_msgs/msg/PointField FLOAT32

std::string Where(const Ros2MonitorOptions& o) {
  return "ROS 2 monitor, domain " + std::to_string(o.domain_id) + ", config " +
         (o.config_file.empty() ? std::string("default ($CYCLONEDDS_URI or built-in)")
                                : "'" + o.config_file + "'");
}

// Frame ids as tf2 takes them: not empty, printable, no spaces, no leading '/'.
void CheckFrameId(std::string_view frame_id) {
  bool ok = !frame_id.empty() && frame_id.front() != '/';
  for (const char c : frame_id) ok = ok && std::isgraph(static_cast<unsigned char>(c));
  if (!ok) {
    throw std::invalid_argument("ROS 2 frame id '" + std::string(frame_id) +
                                "': expected printable characters, no spaces, no leading '/'");
  }
}

struct QosDeleter {
  void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};

void SetHeader(std_msgs_msg_dds__Header_* h, double stamp_s, const std::string& frame_id) {
  Ros2Time(stamp_s, &h->stamp.sec, &h->stamp.nanosec);
  h->frame_id = const_cast<char*>(frame_id.c_str());  // only read by dds_write
}

void SetPose(geometry_msgs_msg_dds__Pose_* p, const StampedPose2& pose) {
  if (!std::isfinite(pose.x_m) || !std::isfinite(pose.y_m) || !std::isfinite(pose.yaw_rad)) {
    throw std::invalid_argument("ROS 2 pose: x, y and yaw must be finite");
  }
  p->position = {pose.x_m, pose.y_m, 0.0};
  p->orientation = {0.0, 0.0, std::sin(0.5 * pose.yaw_rad), std::cos(0.5 * pose.yaw_rad)};
}

class CycloneRos2Monitor final : public Ros2Monitor {
 public:
  explicit CycloneRos2Monitor(const Ros2MonitorOptions& options) : options_(options) {
    if (options.domain_id < 0 || options.domain_id > 232) {
      throw std::invalid_argument("ROS 2 monitor domain_id " + std::to_string(options.domain_id) +
                                  ": expected 0 to 232");
    }
    Domains::Get().Acquire(options_.domain_id, options_.config_file, DomainUse::kRos2Monitor,
                           Where(options_));
    participant_ =
        dds_create_participant(static_cast<dds_domainid_t>(options_.domain_id), nullptr, nullptr);
    if (participant_ < 0) {
      const dds_return_t rc = participant_;
      participant_ = 0;
      Domains::Get().Release(options_.domain_id);
      throw std::runtime_error(std::string("dds: dds_create_participant failed: ") +
                               dds_strretcode(rc) + " (" + Where(options_) + ")");
    }
  }

  ~CycloneRos2Monitor() override {
    dds_delete(participant_);  // its topics and writers too
    Domains::Get().Release(options_.domain_id);
  }

  bool PublishPose(std::string_view topic, std::string_view frame_id,
                   const StampedPose2& pose) override {
    CheckFrameId(frame_id);
    const std::string frame(frame_id);
    geometry_msgs_msg_dds__PoseStamped_ sample{};
    SetHeader(&sample.header, pose.stamp_s, frame);
    SetPose(&sample.pose, pose);
    return Write(topic, &geometry_msgs_msg_dds__PoseStamped__desc, &sample, 7 * sizeof(double));
  }

  bool PublishPath(std::string_view topic, std::string_view frame_id, double stamp_s,
                   const std::vector<StampedPose2>& poses) override {
    CheckFrameId(frame_id);
    const std::string frame(frame_id);
    std::vector<geometry_msgs_msg_dds__PoseStamped_> items(poses.size());
    for (std::size_t i = 0; i < poses.size(); ++i) {
      SetHeader(&items[i].header, poses[i].stamp_s, frame);
      SetPose(&items[i].pose, poses[i]);
    }
    nav_msgs_msg_dds__Path_ sample{};
    SetHeader(&sample.header, stamp_s, frame);
    sample.poses._maximum = static_cast<std::uint32_t>(items.size());
    sample.poses._length = static_cast<std::uint32_t>(items.size());
    sample.poses._buffer = items.data();
    sample.poses._release = false;
    return Write(topic, &nav_msgs_msg_dds__Path__desc, &sample, items.size() * 7 * sizeof(double));
  }

  bool PublishPointCloud(std::string_view topic, std::string_view frame_id, double stamp_s,
                         const std::vector<PointXyz>& points) override {
    CheckFrameId(frame_id);
    const std::string frame(frame_id);
    constexpr std::uint32_t kStep = 12;
    if (points.size() > std::numeric_limits<std::uint32_t>::max() / kStep) {
      throw std::invalid_argument("ROS 2 point cloud: too many points");
    }
    std::vector<std::uint8_t> data(points.size() * kStep);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const float xyz[3] = {points[i].x_m, points[i].y_m, points[i].z_m};
      std::memcpy(data.data() + i * kStep, xyz, kStep);
    }
    char x[] = "x", y[] = "y", z[] = "z";
    sensor_msgs_msg_dds__PointField_ fields[3] = {
        {x, 0, kFloat32, 1}, {y, 4, kFloat32, 1}, {z, 8, kFloat32, 1}};
    sensor_msgs_msg_dds__PointCloud2_ sample{};
    SetHeader(&sample.header, stamp_s, frame);
    sample.height = 1;
    sample.width = static_cast<std::uint32_t>(points.size());
    sample.fields._maximum = 3;
    sample.fields._length = 3;
    sample.fields._buffer = fields;
    sample.fields._release = false;
    sample.is_bigendian = std::endian::native == std::endian::big;
    sample.point_step = kStep;
    sample.row_step = static_cast<std::uint32_t>(data.size());
    sample.data._maximum = static_cast<std::uint32_t>(data.size());
    sample.data._length = static_cast<std::uint32_t>(data.size());
    sample.data._buffer = data.data();
    sample.data._release = false;
    sample.is_dense = true;
    return Write(topic, &sensor_msgs_msg_dds__PointCloud2__desc, &sample, data.size());
  }

  Ros2MonitorCounters counters() const override {
    std::lock_guard lock(mutex_);
    return counters_;
  }

 private:
  bool Write(std::string_view topic, const dds_topic_descriptor_t* type, const void* sample,
             std::size_t payload_bytes) {
    const std::string name = Ros2DdsTopicName(topic);
    std::lock_guard lock(mutex_);
    auto it = writers_.find(name);
    if (it == writers_.end()) {
      it = writers_.emplace(name, Writer{type, MakeWriter(name, type)}).first;
    } else if (it->second.type != type) {
      throw std::invalid_argument("ROS 2 topic '" + std::string(topic) + "' carries " +
                                  it->second.type->m_typename + ", not " + type->m_typename);
    }
    if (dds_write(it->second.writer, sample) != DDS_RETCODE_OK) {
      ++counters_.write_failed;
      return false;
    }
    ++counters_.samples_written;
    counters_.bytes_written += payload_bytes;
    return true;
  }

  dds_entity_t MakeWriter(const std::string& name, const dds_topic_descriptor_t* type) {
    std::unique_ptr<dds_qos_t, QosDeleter> qos(dds_create_qos());
    dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
    const dds_entity_t topic =
        dds_create_topic(participant_, type, name.c_str(), qos.get(), nullptr);
    if (topic < 0) {
      throw std::runtime_error("dds: dds_create_topic '" + name +
                               "' failed: " + dds_strretcode(topic) + " (" + Where(options_) + ")");
    }
    const dds_entity_t writer = dds_create_writer(participant_, topic, qos.get(), nullptr);
    if (writer < 0) {
      throw std::runtime_error("dds: dds_create_writer '" + name + "' failed: " +
                               dds_strretcode(writer) + " (" + Where(options_) + ")");
    }
    return writer;
  }

  struct Writer {
    const dds_topic_descriptor_t* type;
    dds_entity_t writer;
  };
  Ros2MonitorOptions options_;
  dds_entity_t participant_ = 0;
  mutable std::mutex mutex_;
  std::map<std::string, Writer> writers_;
  Ros2MonitorCounters counters_;
};

}  // namespace

std::string Ros2DdsTopicName(std::string_view ros_topic) {
  std::string_view name = ros_topic;
  if (!name.empty() && name.front() == '/') name.remove_prefix(1);
  bool ok = !name.empty() && name.back() != '/' && name.find("//") == std::string_view::npos &&
            name.find("__") == std::string_view::npos;
  bool token_start = true;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '/') {
      token_start = true;
      continue;
    }
    ok = ok && (std::isalnum(u) || c == '_') && u < 128 && !(token_start && std::isdigit(u));
    token_start = false;
  }
  if (!ok) {
    throw std::invalid_argument("ROS 2 topic '" + std::string(ros_topic) +
                                "': expected tokens of letters, digits and '_' separated by '/' "
                                "(no token starting with a digit, no '__', no trailing '/')");
  }
  return "rt/" + std::string(name);
}

void Ros2Time(double stamp_s, std::int32_t* sec, std::uint32_t* nanosec) {
  if (!std::isfinite(stamp_s) || stamp_s < std::numeric_limits<std::int32_t>::min() ||
      stamp_s >= 2147483647.0) {
    throw std::invalid_argument("ROS 2 stamp " + std::to_string(stamp_s) +
                                " s: expected a finite time within int32 seconds");
  }
  const double whole = std::floor(stamp_s);
  auto ns = static_cast<std::int64_t>(std::llround((stamp_s - whole) * 1e9));
  auto s = static_cast<std::int64_t>(whole);
  if (ns >= 1000000000) {
    ns -= 1000000000;
    ++s;
  }
  *sec = static_cast<std::int32_t>(s);
  *nanosec = static_cast<std::uint32_t>(ns);
}

std::unique_ptr<Ros2Monitor> MakeRos2Monitor(const Ros2MonitorOptions& options) {
  return std::make_unique<CycloneRos2Monitor>(options);
}

}  // namespace draco::middleware
