// Stage 1, the object map (stages.hpp): ObjectMapper on the own keyframes, published when it
// changed enough.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "draco/agent/stages.hpp"
#include "stage_util.hpp"

namespace draco::agent {

using namespace stage_util;  // NOLINT(google-build-using-namespace): private helpers

ObjectMapperStage::ObjectMapperStage(const ObjectMapperStageOptions& options)
    : options_(options),
      mapper_(std::make_unique<objects::ObjectMapper>(options.mapper)),
      last_publish_s_(kNever) {
  objects_.robot_id = options.robot_id;
}
ObjectMapperStage::~ObjectMapperStage() = default;

ObjectMapperStage::Output ObjectMapperStage::Step(double now_s, msgs::TeamStepStats* st) {
  WallTimer wall(st);
  if (st != nullptr) st->time_s = now_s;
  Output out;
  if (own_.version() != seen_version_) {
    bool changed = false;
    std::vector<objects::KeyframePose> poses;
    for (const auto& [index, kf] : own_.entries()) {
      if (mapped_.count(index) && kf.has_pose) poses.push_back({index, kf.T_map_kf});
    }
    changed = mapper_->UpdatePoses(poses) || changed;
    for (const auto& [index, kf] : own_.entries()) {
      if (!mapped_.count(index) && kf.has_pose && kf.has_points) {
        mapper_->AddKeyframe(index, kf.T_map_kf, kf.points_kf);
        mapped_.insert(index);
        changed = true;
      }
    }
    // Clusters are re-described only when the mapper changed; landmarks (which move with
    // every solve of the local SLAM) are appended to them.
    if (changed) clusters_ = mapper_->Objects(options_.robot_id, now_s);
    if (changed || own_.landmarks_version() != seen_landmarks_version_) {
      objects_ = clusters_;
      const int last = mapped_.empty() ? -1 : *mapped_.rbegin();
      objects::AppendLandmarks(own_.landmarks(), last, options_.mapper.landmark_min_sightings,
                               &objects_);
      seen_landmarks_version_ = own_.landmarks_version();
      ++version_;
    }
    seen_version_ = own_.version();
  }
  objects_.robot_id = options_.robot_id;
  objects_.map_heading_rad = odom_heading_rad_;
  if (options_.map_heading_from_keyframes && std::isfinite(odom_heading_rad_)) {
    double sum_sin = 0.0, sum_cos = 0.0;
    for (const auto& [index, kf] : own_.entries()) {
      const auto ahrs = ahrs_heading_rad_.find(index);
      if (!kf.has_pose || ahrs == ahrs_heading_rad_.end()) continue;
      const double h = ahrs->second - kf.T_map_kf.yaw_rad;
      sum_sin += std::sin(h);
      sum_cos += std::cos(h);
    }
    if (sum_sin != 0.0 || sum_cos != 0.0) objects_.map_heading_rad = std::atan2(sum_sin, sum_cos);
  }
  if (now_s - last_publish_s_ >= options_.object_map_period_s && !objects_.objects.empty()) {
    bool same = published_once_ && last_published_.objects.size() == objects_.objects.size();
    for (std::size_t i = 0; same && i < objects_.objects.size(); ++i) {
      const auto& a = objects_.objects[i];
      const auto& b = last_published_.objects[i];
      same = a.id == b.id && a.num_points == b.num_points && a.center.x_m == b.center.x_m &&
             a.center.y_m == b.center.y_m && a.length_m == b.length_m &&
             a.breadth_m == b.breadth_m && a.yaw_rad == b.yaw_rad && a.keyframes == b.keyframes;
    }
    if (!same) {
      out.has_object_map = true;
      out.object_map = objects_;
      out.object_map.time_s = now_s;
      last_published_ = objects_;
      published_once_ = true;
      last_publish_s_ = now_s;
    }
  }
  if (own_.poses_version() != seen_poses_version_) {
    for (const auto& [index, kf] : own_.entries()) {
      if (!kf.has_pose) continue;
      out.poses.push_back({index, kf.time_s, kf.T_map_kf, static_cast<int>(kf.points_kf.size())});
    }
    out.has_poses = !out.poses.empty();
    seen_poses_version_ = own_.poses_version();
  }
  return out;
}

}  // namespace draco::agent
