// Object map from the incremental clustering (see object_mapper.hpp).
#include "draco/objects/object_mapper.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <stdexcept>
#include <unordered_map>
#include <utility>

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
  keyframes_.push_back({index, T_local_kf, T_local_kf, points_kf});
  dbscan_.Add(Place(keyframes_.back()));
  point_keyframe_.insert(point_keyframe_.end(), points_kf.size(), index);
}

bool ObjectMapper::UpdatePoses(const std::vector<KeyframePose>& poses) {
  SetPoses(poses);
  return Recluster();
}

bool ObjectMapper::SetPoses(const std::vector<KeyframePose>& poses) {
  std::unordered_map<int, std::size_t> slot;
  for (std::size_t i = 0; i < keyframes_.size(); ++i) slot[keyframes_[i].index] = i;
  for (const auto& pose : poses) {
    const auto it = slot.find(pose.index);
    if (it == slot.end()) continue;
    Keyframe& kf = keyframes_[it->second];
    kf.T_local_kf = pose.T_local_kf;
    const Pose2& placed = kf.T_local_kf_placed;
    const double dt =
        std::hypot(pose.T_local_kf.x_m - placed.x_m, pose.T_local_kf.y_m - placed.y_m);
    const double dr = std::abs(NormalizeAngle(pose.T_local_kf.yaw_rad - placed.yaw_rad));
    if (dt > options_.move_translation_m || dr > options_.move_rotation_rad) pending_ = true;
  }
  return pending_;
}

bool ObjectMapper::Recluster() {
  if (!pending_) return false;
  const std::vector<int> previous = dbscan_.Labels();
  std::vector<msgs::Point2> points;
  points.reserve(previous.size());
  for (auto& kf : keyframes_) {
    kf.T_local_kf_placed = kf.T_local_kf;
    const auto placed = Place(kf);
    points.insert(points.end(), placed.begin(), placed.end());
  }
  dbscan_.Rebuild(std::move(points));
  dbscan_.RemapIds(previous);
  described_.clear();  // every point moved
  ++num_reclusters_;
  pending_ = false;
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

std::vector<std::vector<std::size_t>> SplitIntoSegments(const std::vector<msgs::Point2>& points,
                                                        const SegmentOptions& o) {
  std::vector<std::vector<std::size_t>> segments;
  if (points.empty() || !(o.inlier_m > 0.0) || !(o.angle_step_rad > 0.0)) return segments;
  std::vector<std::size_t> left(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) left[i] = i;
  double cx = 0.0, cy = 0.0;  // a local origin keeps the offsets small
  for (const auto& p : points) cx += p.x_m, cy += p.y_m;
  cx /= double(points.size());
  cy /= double(points.size());
  const int n_angles =
      std::max(1, static_cast<int>(std::ceil(std::numbers::pi / o.angle_step_rad)));
  std::vector<int> votes;
  while (static_cast<int>(segments.size()) < o.max_segments &&
         static_cast<int>(left.size()) >= o.min_points) {
    // 1. Hough vote: line normal angle t, offset r = (p - c) . n(t) in inlier_m bins.
    double r_max = 0.0;
    for (const std::size_t i : left) {
      r_max = std::max(r_max, std::hypot(points[i].x_m - cx, points[i].y_m - cy));
    }
    const int n_r = static_cast<int>(std::ceil(2.0 * r_max / o.inlier_m)) + 2;
    int best = -1, best_t = 0, best_r = 0;
    votes.assign(std::size_t(n_r), 0);
    for (int t = 0; t < n_angles; ++t) {
      const double th = t * o.angle_step_rad, nx = std::cos(th), ny = std::sin(th);
      std::fill(votes.begin(), votes.end(), 0);
      for (const std::size_t i : left) {
        const double r = (points[i].x_m - cx) * nx + (points[i].y_m - cy) * ny;
        const int bin = static_cast<int>(std::floor((r + r_max) / o.inlier_m)) + 1;
        ++votes[std::size_t(bin)];
      }
      for (int b = 0; b + 1 < n_r; ++b) {  // two adjacent bins: a line on a bin edge
        const int v = votes[std::size_t(b)] + votes[std::size_t(b + 1)];
        if (v > best) best = v, best_t = t, best_r = b;
      }
    }
    if (best < o.min_points) break;
    // 2. Inliers of the peak, then a least-squares line through them (principal axis).
    const double th = best_t * o.angle_step_rad;
    double nx = std::cos(th), ny = std::sin(th);
    double r0 = (best_r + 0.0) * o.inlier_m - r_max;  // the two bins span [r0, r0 + 2 inlier_m)
    double mx = 0.0, my = 0.0;
    std::vector<std::size_t> in;
    for (const std::size_t i : left) {
      const double r = (points[i].x_m - cx) * nx + (points[i].y_m - cy) * ny;
      if (r >= r0 - 1e-9 && r < r0 + 2.0 * o.inlier_m) in.push_back(i);
    }
    for (int refit = 0; refit < 2 && in.size() >= 2; ++refit) {
      mx = my = 0.0;
      for (const std::size_t i : in) mx += points[i].x_m, my += points[i].y_m;
      mx /= double(in.size());
      my /= double(in.size());
      double sxx = 0.0, syy = 0.0, sxy = 0.0;
      for (const std::size_t i : in) {
        const double dx = points[i].x_m - mx, dy = points[i].y_m - my;
        sxx += dx * dx, syy += dy * dy, sxy += dx * dy;
      }
      const double dir = 0.5 * std::atan2(2.0 * sxy, sxx - syy);  // principal direction
      nx = -std::sin(dir);
      ny = std::cos(dir);
      in.clear();
      for (const std::size_t i : left) {
        const double r = (points[i].x_m - mx) * nx + (points[i].y_m - my) * ny;
        if (std::abs(r) <= o.inlier_m) in.push_back(i);
      }
    }
    // 3. Longest run along the line without a gap over max_gap_m.
    const double dx = ny, dy = -nx;  // direction along the line
    std::sort(in.begin(), in.end(), [&](std::size_t u, std::size_t v) {
      const double su = points[u].x_m * dx + points[u].y_m * dy;
      const double sv = points[v].x_m * dx + points[v].y_m * dy;
      return su < sv || (su == sv && u < v);
    });
    std::size_t run_begin = 0, best_begin = 0, best_end = 0;
    double best_len = -1.0;
    for (std::size_t k = 0; k <= in.size(); ++k) {
      const bool cut =
          k == in.size() || (k > 0 && (points[in[k]].x_m - points[in[k - 1]].x_m) * dx +
                                              (points[in[k]].y_m - points[in[k - 1]].y_m) * dy >
                                          o.max_gap_m);
      if (!cut) continue;
      if (k > run_begin) {
        const double len = (points[in[k - 1]].x_m - points[in[run_begin]].x_m) * dx +
                           (points[in[k - 1]].y_m - points[in[run_begin]].y_m) * dy;
        if (len > best_len) best_len = len, best_begin = run_begin, best_end = k;
      }
      run_begin = k;
    }
    if (best_len < o.min_length_m || static_cast<int>(best_end - best_begin) < o.min_points) {
      // The strongest line is too short or broken up: remove its points and look further.
      if (in.empty()) break;
      std::vector<char> drop(points.size(), 0);
      for (const std::size_t i : in) drop[i] = 1;
      std::erase_if(left, [&](std::size_t i) { return drop[i] != 0; });
      continue;
    }
    std::vector<std::size_t> segment(in.begin() + std::ptrdiff_t(best_begin),
                                     in.begin() + std::ptrdiff_t(best_end));
    std::vector<char> drop(points.size(), 0);
    for (const std::size_t i : segment) drop[i] = 1;
    std::erase_if(left, [&](std::size_t i) { return drop[i] != 0; });
    std::sort(segment.begin(), segment.end());
    segments.push_back(std::move(segment));
  }
  return segments;
}

void ObjectMapper::DescribeObjects(int id, const std::vector<std::size_t>& idx,
                                   std::vector<msgs::Object>* out) const {
  if (static_cast<int>(idx.size()) < options_.min_points) return;
  std::vector<msgs::Point2> points;
  points.reserve(idx.size());
  std::vector<int> keyframes;
  for (const std::size_t i : idx) {
    points.push_back(dbscan_.points()[i]);
    if (keyframes.empty() || keyframes.back() != point_keyframe_[i]) {
      keyframes.push_back(point_keyframe_[i]);
    }
  }
  msgs::Object object = DescribeCluster(points, options_.rectangle_center);
  if (object.length_m < options_.min_length_m) return;
  if (options_.split_min_length_m > 0.0 && object.length_m >= options_.split_min_length_m &&
      object.length_m < options_.split_max_aspect * object.breadth_m && id < (1 << 16)) {
    const auto segments = SplitIntoSegments(points, options_.segments);
    if (!segments.empty()) {
      std::vector<msgs::Point2> seg_points;
      for (std::size_t k = 0; k < segments.size(); ++k) {
        seg_points.clear();
        std::vector<int> seg_keyframes;
        for (const std::size_t j : segments[k]) {
          seg_points.push_back(points[j]);
          seg_keyframes.push_back(point_keyframe_[idx[j]]);
        }
        msgs::Object seg = DescribeCluster(seg_points, options_.rectangle_center);
        std::sort(seg_keyframes.begin(), seg_keyframes.end());
        seg_keyframes.erase(std::unique(seg_keyframes.begin(), seg_keyframes.end()),
                            seg_keyframes.end());
        seg.id = static_cast<std::uint32_t>(((k + 1) << 16) | std::size_t(id));
        seg.keyframes = std::move(seg_keyframes);
        out->push_back(std::move(seg));
      }
      return;
    }
  }
  std::sort(keyframes.begin(), keyframes.end());
  keyframes.erase(std::unique(keyframes.begin(), keyframes.end()), keyframes.end());
  object.id = static_cast<std::uint32_t>(id);
  object.keyframes = std::move(keyframes);
  out->push_back(std::move(object));
}

msgs::ObjectMap ObjectMapper::Objects(int robot_id, double time_s) {
  std::map<int, std::vector<std::size_t>> members;  // by id: sorted output
  for (std::size_t i = 0; i < dbscan_.size(); ++i) {
    const int label = dbscan_.Label(i);
    if (label != kNoise) members[label].push_back(i);
  }
  msgs::ObjectMap map;
  map.robot_id = robot_id;
  map.time_s = time_s;
  // A cluster whose members are those it had at the last call, with no re-clustering in
  // between (its points have not moved), is described as then.
  std::map<int, Described> described;
  for (const auto& [id, idx] : members) {
    std::uint64_t hash = 1469598103934665603ull;  // FNV-1a over the member indices
    for (const std::size_t i : idx) hash = (hash ^ std::uint64_t(i)) * 1099511628211ull;
    Described d{idx.size(), hash, {}};
    const auto it = described_.find(id);
    if (it != described_.end() && it->second.members == d.members && it->second.hash == hash) {
      d.objects = std::move(it->second.objects);
    } else {
      DescribeObjects(id, idx, &d.objects);
    }
    map.objects.insert(map.objects.end(), d.objects.begin(), d.objects.end());
    described.emplace(id, std::move(d));
  }
  described_ = std::move(described);
  std::sort(map.objects.begin(), map.objects.end(),
            [](const msgs::Object& x, const msgs::Object& y) { return x.id < y.id; });
  return map;
}

void AppendLandmarks(const std::vector<msgs::LandmarkEstimate>& landmarks, int last_keyframe,
                     int min_sightings, msgs::ObjectMap* map) {
  if (min_sightings <= 0) return;
  std::vector<msgs::Object> out;
  for (const auto& l : landmarks) {
    if (l.id < 0 || !std::isfinite(l.p_map.x_m) || !std::isfinite(l.p_map.y_m)) continue;
    msgs::Object o;
    for (const int k : l.keyframes) {
      if (k <= last_keyframe) o.keyframes.push_back(k);
    }
    if (static_cast<int>(o.keyframes.size()) < min_sightings) continue;
    o.id = msgs::kLandmarkIdBit + static_cast<std::uint32_t>(l.id);
    o.center = o.rect_center = l.p_map;
    o.length_m = o.breadth_m = 2.0 * std::max(0.0, l.radius_m);
    o.num_points = static_cast<int>(o.keyframes.size());
    o.landmark = true;
    out.push_back(std::move(o));
  }
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.keyframes.size() > b.keyframes.size();
  });
  for (auto& o : out) map->objects.push_back(std::move(o));
}

}  // namespace draco::objects
