// Object map of one robot (DRACo-SLAM2 section III-A): DBSCAN over the point-cloud map in
// the local frame, one rotated minimum-area rectangle per cluster, filters n_min and d_min.
//
// Points are stored per keyframe in the keyframe frame. AddKeyframe places them with the
// keyframe's current pose and updates the clustering incrementally. When loop closures
// move keyframes, UpdatePoses re-places every point and re-clusters from scratch (the
// result is the same as clustering the re-placed map; ids are carried over by overlap).
#pragma once

#include <cstdint>
#include <vector>

#include "draco/msgs/objects.hpp"
#include "draco/msgs/slam.hpp"
#include "draco/objects/dbscan.hpp"

namespace draco::objects {

using msgs::Pose2;

struct ObjectMapperOptions {
  DbscanOptions dbscan;  // eps 1.5 m, min points 20
  int min_points = 20;   // n_min: clusters with fewer points are dropped
  // d_min: clusters whose long side is under this are dropped (the paper and the code: 3 m,
  // which drops single piles and boats; 1 m measures better, docs/front-end.md).
  double min_length_m = 1.0;
  bool rectangle_center = false;  // centre = rectangle centre (false: mean of the points,
                                  // as the reference)
  // UpdatePoses re-clusters when a keyframe moved more than this.
  double move_translation_m = 0.05;
  double move_rotation_rad = 0.002;
};

struct KeyframePose {
  int index = 0;
  Pose2 T_local_kf;
};

class ObjectMapper {
 public:
  explicit ObjectMapper(const ObjectMapperOptions& options = {});

  // A new keyframe (index unseen so far), its pose in the local frame and its points in the
  // keyframe frame.
  void AddKeyframe(int index, const Pose2& T_local_kf, const std::vector<msgs::Point2>& points_kf);

  // New poses for some or all keyframes (unknown indices are ignored). Returns true when a
  // keyframe moved beyond the thresholds and the map was re-clustered.
  bool UpdatePoses(const std::vector<KeyframePose>& poses);

  // The object map (objects sorted by id).
  msgs::ObjectMap Objects(int robot_id = 0, double time_s = 0.0) const;

  const IncrementalDbscan& clusters() const { return dbscan_; }
  int num_reclusters() const { return num_reclusters_; }
  std::size_t num_keyframes() const { return keyframes_.size(); }

 private:
  struct Keyframe {
    int index = 0;
    Pose2 T_local_kf;
    std::vector<msgs::Point2> points_kf;
  };
  std::vector<msgs::Point2> Place(const Keyframe& kf) const;

  ObjectMapperOptions options_;
  IncrementalDbscan dbscan_;
  std::vector<Keyframe> keyframes_;  // in insertion order
  std::vector<int> point_keyframe_;  // keyframe index of every point
  int num_reclusters_ = 0;
};

// One object from a cluster's points (rectangle, centre, count; id and keyframes unset).
msgs::Object DescribeCluster(const std::vector<msgs::Point2>& points, bool rectangle_center);

}  // namespace draco::objects
