// Runtime adapter fleet.Ros2Monitor: a robot's team estimate and sonar map on ROS 2 topics of
// the vehicle's (or ship's) local DDS domain, for RViz, Foxglove or `ros2 topic echo`
// (middleware/ros2_monitor.hpp; docs/install.md, "Watching from ROS 2"). Off unless enabled:
// it never touches the team link, and a disabled monitor opens no DDS participant.
//
// Topics (prefix /draco, robot alpha, frame "alpha/map" = alpha's map frame):
//   /draco/alpha/path                nav_msgs/msg/Path         own keyframes (team estimate)
//   /draco/alpha/pose                geometry_msgs/msg/PoseStamped  own newest keyframe
//   /draco/alpha/team/bravo/path     nav_msgs/msg/Path         a placed teammate, own frame
//   /draco/alpha/map                 sensor_msgs/msg/PointCloud2    own sonar points
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "draco/graph/component.hpp"
#include "draco/middleware/ros2_monitor.hpp"
#include "draco/msgs/map.hpp"
#include "draco/msgs/slam.hpp"
#include "draco/msgs/team.hpp"

namespace draco::fleet {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;

class Ros2MonitorComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Publishes the robot's team estimate (paths, newest pose) and its sonar map as ROS 2 "
        "messages (nav_msgs/Path, geometry_msgs/PoseStamped, sensor_msgs/PointCloud2) on a DDS "
        "domain of the local network, never the team link's. Off unless enabled.");
    const auto in = [](const char* doc, graph::Delivery d) {
      return graph::InputOptions{
          .trigger = true, .delivery = d, .depth = 4096, .required = false, .doc = doc};
    };
    estimate_ = spec.Input<msgs::TeamTrajectories>(
        "team_estimate", in("team estimate from team.TwoStepOptimizer", graph::Delivery::kLatest));
    trajectory_ = spec.Input<msgs::KeyframeTrajectory>(
        "trajectory",
        in("own local-SLAM keyframes (before any team estimate)", graph::Delivery::kLatest));
    keyframe_ = spec.Input<msgs::Keyframe>(
        "keyframe", in("own keyframes (their sonar points make the map)", graph::Delivery::kQueue));
    spec.Param("enabled", &enabled_, {.doc = "publish (false: no DDS participant at all)"});
    spec.Param("robot", &robot_, {.doc = "own robot name: topic names and frame ids"});
    spec.Param("team_names", &team_names_, {.doc = "robot names by id: alpha, bravo, ..."});
    spec.Param("domain_id", &options_.domain_id,
               {.doc = "DDS domain of the local network (ROS_DOMAIN_ID); never the link's",
                .min = 0,
                .max = 232});
    spec.Param("dds_config", &options_.config_file,
               {.doc = "Cyclone DDS XML for that domain; empty: $CYCLONEDDS_URI or defaults"});
    spec.Param("topic_prefix", &prefix_,
               {.doc = "ROS 2 namespace of the topics: <prefix>/<robot>/path, ..."});
    spec.Param(
        "path_period_s", &path_period_s_,
        {.doc = "paths and pose at most this often (mission time)", .unit = "s", .min = 0.0});
    spec.Param("map_period_s", &map_period_s_,
               {.doc = "the map cloud at most this often (mission time)", .unit = "s", .min = 0.0});
    spec.Param(
        "map_cell_m", &map_cell_m_,
        {.doc = "the map cloud keeps one point per cell of this size", .unit = "m", .min = 0.01});
  }

  Status Start(Context&) override {
    if (!enabled_) return Status::Ok();
    if (robot_.empty()) return Status::Fatal("robot: the own robot's name (topics, frame ids)");
    try {
      (void)middleware::Ros2DdsTopicName(prefix_ + "/" + robot_ + "/path");
      monitor_ = middleware::MakeRos2Monitor(options_);
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    return Status::Ok();
  }

  Status Process(Context& ctx) override {
    for (const auto& k : keyframe_.TakeAll()) points_[k->index] = k->points_body;
    if (auto t = trajectory_.Take()) own_ = t->value;
    if (auto e = estimate_.Take()) team_ = e->value;
    if (!monitor_) return Status::Ok();
    const double now_s = ctx.Now().Seconds();
    try {
      if (now_s - last_path_s_ >= path_period_s_) {
        last_path_s_ = now_s;
        PublishPaths(now_s);
      }
      if (now_s - last_map_s_ >= map_period_s_) {
        last_map_s_ = now_s;
        PublishMap(now_s);
      }
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    return Status::Ok();
  }

 private:
  // The own keyframes: the team estimate's when it is newer than local SLAM's, else local SLAM's.
  const std::vector<msgs::KeyframePose>* OwnKeyframes() const {
    if (team_) {
      const auto it = team_->trajectories.find(team_->own_robot);
      if (it != team_->trajectories.end() && (!own_ || team_->time_s >= own_->time_s)) {
        return &it->second;
      }
    }
    return own_ ? &own_->keyframes : nullptr;
  }

  static std::vector<middleware::StampedPose2> Poses(const std::vector<msgs::KeyframePose>& kfs) {
    std::vector<middleware::StampedPose2> out;
    out.reserve(kfs.size());
    for (const auto& k : kfs) {
      out.push_back({k.time_s, k.T_map_kf.x_m, k.T_map_kf.y_m, k.T_map_kf.yaw_rad});
    }
    return out;
  }

  std::string Name(int id) const {
    if (id >= 0 && id < static_cast<int>(team_names_.size())) return team_names_[id];
    return "robot" + std::to_string(id);
  }

  void PublishPaths(double now_s) {
    const std::string frame = robot_ + "/map";
    const std::string base = prefix_ + "/" + robot_;
    if (const auto* own = OwnKeyframes(); own != nullptr && !own->empty()) {
      const auto poses = Poses(*own);
      monitor_->PublishPath(base + "/path", frame, now_s, poses);
      monitor_->PublishPose(base + "/pose", frame, poses.back());
    }
    if (!team_) return;
    for (const auto& [id, kfs] : team_->trajectories) {
      if (id == team_->own_robot || kfs.empty()) continue;
      monitor_->PublishPath(base + "/team/" + Name(id) + "/path", frame, now_s, Poses(kfs));
    }
  }

  void PublishMap(double now_s) {
    const auto* own = OwnKeyframes();
    if (own == nullptr) return;
    // One point per cell (the first in keyframe order).
    std::vector<std::pair<std::pair<long long, long long>, middleware::PointXyz>> cells;
    for (const auto& k : *own) {
      const auto it = points_.find(k.index);
      if (it == points_.end()) continue;
      const double c = std::cos(k.T_map_kf.yaw_rad), s = std::sin(k.T_map_kf.yaw_rad);
      for (const auto& p : it->second) {
        const double x = k.T_map_kf.x_m + c * p.x_m - s * p.y_m;
        const double y = k.T_map_kf.y_m + s * p.x_m + c * p.y_m;
        cells.push_back(
            {{std::llround(std::floor(x / map_cell_m_)), std::llround(std::floor(y / map_cell_m_))},
             {static_cast<float>(x), static_cast<float>(y), 0.0f}});
      }
    }
    std::stable_sort(cells.begin(), cells.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<middleware::PointXyz> cloud;
    cloud.reserve(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i) {
      if (i == 0 || cells[i].first != cells[i - 1].first) cloud.push_back(cells[i].second);
    }
    monitor_->PublishPointCloud(prefix_ + "/" + robot_ + "/map", robot_ + "/map", now_s, cloud);
  }

  bool enabled_ = false;
  std::string robot_;
  std::vector<std::string> team_names_{"alpha", "bravo", "charlie"};
  std::string prefix_ = "/draco";
  double path_period_s_ = 1.0;
  double map_period_s_ = 10.0;
  double map_cell_m_ = 0.2;
  middleware::Ros2MonitorOptions options_;
  std::unique_ptr<middleware::Ros2Monitor> monitor_;
  graph::In<msgs::TeamTrajectories> estimate_;
  graph::In<msgs::KeyframeTrajectory> trajectory_;
  graph::In<msgs::Keyframe> keyframe_;
  std::shared_ptr<const msgs::TeamTrajectories> team_;
  std::shared_ptr<const msgs::KeyframeTrajectory> own_;
  std::map<int, std::vector<msgs::Point2>> points_;
  double last_path_s_ = -1e300;
  double last_map_s_ = -1e300;
};

}  // namespace

DRACO_REGISTER_COMPONENT(Ros2MonitorComponent, "fleet.Ros2Monitor")

}  // namespace draco::fleet
