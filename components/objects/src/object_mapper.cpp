// Object map from the incremental clustering (see object_mapper.hpp).
#include "draco/objects/object_mapper.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <unordered_map>

#include "draco/objects/geometry.hpp"

namespace draco::objects {

ObjectMapper::ObjectMapper(const ObjectMapperOptions& options)
    : options_(options), dbscan_(options.dbscan) {}

std::vector<msgs::Point2> ObjectMapper::Place(const Keyframe& kf) const {
  std::vector<msgs::Point2> out;
  out.reserve(kf.points_kf.size());
  for (const auto& p : kf.points_kf) out.push_back(Transform(kf.T_local_kf, p));
  return out;
}

void ObjectMapper::AddKeyframe(int index, const Pose2& T_local_kf,
                               const std::vector<msgs::Point2>& points_kf) {
  for (const auto& kf : keyframes_) {
    if (kf.index == index) throw std::invalid_argument("ObjectMapper: keyframe added twice");
  }
  keyframes_.push_back({index, T_local_kf, points_kf});
  dbscan_.Add(Place(keyframes_.back()));
  point_keyframe_.insert(point_keyframe_.end(), points_kf.size(), index);
}

bool ObjectMapper::UpdatePoses(const std::vector<KeyframePose>& poses) {
  std::unordered_map<int, std::size_t> slot;
  for (std::size_t i = 0; i < keyframes_.size(); ++i) slot[keyframes_[i].index] = i;
  bool moved = false;
  for (const auto& pose : poses) {
    const auto it = slot.find(pose.index);
    if (it == slot.end()) continue;
    Pose2& old = keyframes_[it->second].T_local_kf;
    const double dt = std::hypot(pose.T_local_kf.x_m - old.x_m, pose.T_local_kf.y_m - old.y_m);
    const double dr = std::abs(NormalizeAngle(pose.T_local_kf.yaw_rad - old.yaw_rad));
    if (dt > options_.move_translation_m || dr > options_.move_rotation_rad) moved = true;
    old = pose.T_local_kf;
  }
  if (!moved) return false;
  const std::vector<int> previous = dbscan_.Labels();
  dbscan_.Clear();
  for (const auto& kf : keyframes_) dbscan_.Add(Place(kf));
  dbscan_.RemapIds(previous);
  ++num_reclusters_;
  return true;
}

msgs::Object DescribeCluster(const std::vector<msgs::Point2>& points, bool rectangle_center) {
  msgs::Object object;
  const Rectangle rect = MinAreaRectangle(points);
  double sx = 0.0, sy = 0.0;
  for (const auto& p : points) sx += p.x_m, sy += p.y_m;
  const double n = std::max<double>(1.0, double(points.size()));
  object.rect_center = rect.center;
  object.center = rectangle_center ? rect.center : msgs::Point2{sx / n, sy / n};
  object.length_m = rect.length_m;
  object.breadth_m = rect.breadth_m;
  object.yaw_rad = rect.yaw_rad;
  object.num_points = static_cast<int>(points.size());
  return object;
}

msgs::ObjectMap ObjectMapper::Objects(int robot_id, double time_s) const {
  std::map<int, std::vector<std::size_t>> members;  // by id: sorted output
  for (std::size_t i = 0; i < dbscan_.size(); ++i) {
    const int label = dbscan_.Label(i);
    if (label != kNoise) members[label].push_back(i);
  }
  msgs::ObjectMap map;
  map.robot_id = robot_id;
  map.time_s = time_s;
  std::vector<msgs::Point2> points;
  for (const auto& [id, idx] : members) {
    if (static_cast<int>(idx.size()) < options_.min_points) continue;
    points.clear();
    std::vector<int> keyframes;
    for (const std::size_t i : idx) {
      points.push_back(dbscan_.points()[i]);
      if (keyframes.empty() || keyframes.back() != point_keyframe_[i]) {
        keyframes.push_back(point_keyframe_[i]);
      }
    }
    msgs::Object object = DescribeCluster(points, options_.rectangle_center);
    if (object.length_m < options_.min_length_m) continue;
    std::sort(keyframes.begin(), keyframes.end());
    keyframes.erase(std::unique(keyframes.begin(), keyframes.end()), keyframes.end());
    object.id = static_cast<std::uint32_t>(id);
    object.keyframes = std::move(keyframes);
    map.objects.push_back(std::move(object));
  }
  return map;
}

}  // namespace draco::objects
