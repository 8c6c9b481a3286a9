// A plain Cyclone DDS subscriber of the ROS 2 monitor's topics, built from the same IDL
// (middleware/idl/ros2.idl) and with a ROS 2 subscription's default QoS (reliable, volatile,
// keep last 10): what RViz or `ros2 topic echo` would get. For tests/fleet_app/ros2_test.sh.
//   ros2_listener DOMAIN CONFIG_XML SECONDS ROBOT...
// Listens for SECONDS (or until a file named stop appears in the working folder) to
// /draco/<robot>/path, /draco/<robot>/pose and /draco/<robot>/map of each ROBOT, then prints
// one JSON object per topic: samples, the last sample's size, frame id and stamp, and the last
// path's final pose.
#include <dds/dds.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ros2.h"

namespace {

struct Topic {
  std::string name;
  const dds_topic_descriptor_t* type;
  dds_entity_t reader = 0;
  int samples = 0;
  unsigned size = 0;  // poses of a path, points of a cloud, 1 for a pose
  std::string frame_id;
  double stamp_s = 0.0;
  double last_x = 0.0, last_y = 0.0;
};

double Stamp(const builtin_interfaces_msg_dds__Time_& t) { return t.sec + 1e-9 * t.nanosec; }

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: ros2_listener DOMAIN CONFIG_XML SECONDS ROBOT...\n");
    return 2;
  }
  const int domain = std::atoi(argv[1]);
  std::ifstream in(argv[2]);
  std::stringstream xml;
  xml << in.rdbuf();
  const dds_entity_t d = dds_create_domain(static_cast<dds_domainid_t>(domain), xml.str().c_str());
  if (d < 0) {
    std::fprintf(stderr, "dds_create_domain: %s\n", dds_strretcode(d));
    return 1;
  }
  const dds_entity_t participant = dds_create_participant(domain, nullptr, nullptr);
  if (participant < 0) return 1;
  std::vector<Topic> topics;
  for (int k = 4; k < argc; ++k) {
    const std::string base = std::string("rt/draco/") + argv[k];
    topics.push_back({base + "/path", &nav_msgs_msg_dds__Path__desc});
    topics.push_back({base + "/pose", &geometry_msgs_msg_dds__PoseStamped__desc});
    topics.push_back({base + "/map", &sensor_msgs_msg_dds__PointCloud2__desc});
  }
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
  for (auto& t : topics) {
    const dds_entity_t topic = dds_create_topic(participant, t.type, t.name.c_str(), qos, nullptr);
    t.reader = topic < 0 ? topic : dds_create_reader(participant, topic, qos, nullptr);
    if (t.reader < 0) {
      std::fprintf(stderr, "reader for %s: %s\n", t.name.c_str(), dds_strretcode(t.reader));
      return 1;
    }
  }
  dds_delete_qos(qos);
  std::printf("listening\n");
  std::fflush(stdout);
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(std::atof(argv[3]));
  while (std::chrono::steady_clock::now() < end && !std::filesystem::exists("stop")) {
    for (auto& t : topics) {
      void* samples[1] = {nullptr};
      dds_sample_info_t info;
      while (dds_take(t.reader, samples, &info, 1, 1) > 0) {
        if (info.valid_data) {
          ++t.samples;
          if (t.type == &nav_msgs_msg_dds__Path__desc) {
            const auto* p = static_cast<const nav_msgs_msg_dds__Path_*>(samples[0]);
            t.size = p->poses._length;
            t.frame_id = p->header.frame_id;
            t.stamp_s = Stamp(p->header.stamp);
            if (p->poses._length > 0) {
              t.last_x = p->poses._buffer[p->poses._length - 1].pose.position.x;
              t.last_y = p->poses._buffer[p->poses._length - 1].pose.position.y;
            }
          } else if (t.type == &geometry_msgs_msg_dds__PoseStamped__desc) {
            const auto* p = static_cast<const geometry_msgs_msg_dds__PoseStamped_*>(samples[0]);
            t.size = 1;
            t.frame_id = p->header.frame_id;
            t.stamp_s = Stamp(p->header.stamp);
            t.last_x = p->pose.position.x;
            t.last_y = p->pose.position.y;
          } else {
            const auto* c = static_cast<const sensor_msgs_msg_dds__PointCloud2_*>(samples[0]);
            const bool consistent = c->width * c->point_step == c->data._length &&
                                    c->fields._length == 3 && c->point_step == 12;
            t.size = consistent ? c->width : 0;
            t.frame_id = c->header.frame_id;
            t.stamp_s = Stamp(c->header.stamp);
          }
        }
        dds_return_loan(t.reader, samples, 1);
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  for (const auto& t : topics) {
    std::printf(
        "{\"topic\": \"%s\", \"samples\": %d, \"size\": %u, \"frame_id\": \"%s\", \"stamp_s\": "
        "%.6f, \"last_x\": %.4f, \"last_y\": %.4f}\n",
        t.name.c_str(), t.samples, t.size, t.frame_id.c_str(), t.stamp_s, t.last_x, t.last_y);
  }
  dds_delete(participant);
  dds_delete(d);
  return 0;
}
