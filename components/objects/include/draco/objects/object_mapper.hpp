// Object map of one robot (DRACo-SLAM2 section III-A): DBSCAN over the point-cloud map in
// the local frame, one rotated minimum-area rectangle per cluster, filters n_min and d_min.
//
// Points are stored per keyframe in the keyframe frame. AddKeyframe places them with the
// keyframe's current pose and updates the clustering incrementally. When loop closures
// move keyframes, UpdatePoses re-places every point and re-clusters from scratch (the
// result is the same as clustering the re-placed map; ids are carried over by overlap).
// A caller that bounds how often that happens (its cost is every point of the map) sets the
// poses with SetPoses and re-clusters with Recluster when it chooses: until then the
// clusters keep the points where they were placed, and new keyframes join at their poses.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include "draco/msgs/map.hpp"
#include "draco/msgs/objects.hpp"
#include "draco/msgs/slam.hpp"
#include "draco/objects/dbscan.hpp"

namespace draco::objects {

using msgs::Pose2;

// Straight segments in a set of points, strongest first: the line with the most points within
// inlier_m (a Hough vote over angle_step_rad x inlier_m bins, refined by a least-squares fit
// of its inliers), cut at gaps longer than max_gap_m, the longest run kept when it is at least
// min_length_m long with min_points points; its points are removed and the search repeats
// (at most max_segments). Each result lists the indices of its points.
struct SegmentOptions {
  double inlier_m = 0.6;
  double angle_step_rad = 0.0349;  // 2 deg
  double max_gap_m = 3.0;
  double min_length_m = 6.0;
  int min_points = 20;
  int max_segments = 8;
};

struct ObjectMapperOptions {
  DbscanOptions dbscan;  // eps 1.5 m, min points 20
  int min_points = 20;   // n_min: clusters with fewer points are dropped
  // d_min: clusters whose long side is under this are dropped (the paper and the code: 3 m,
  // which drops single piles and boats; 1 m measures better, docs/front-end.md).
  double min_length_m = 1.0;
  bool rectangle_center = false;  // centre = rectangle centre (false: mean of the points,
                                  // as the reference)
  // Structures as lines (off when split_min_length_m is 0): a cluster at least this long whose
  // rectangle is not slender (length < split_max_aspect * breadth: an L-shaped pier, a pier
  // with its boats) is described by the straight segments found in its points instead (each
  // an object of id (k + 1) << 16 | cluster id); a cluster with no segment stays whole. See
  // SplitIntoSegments.
  double split_min_length_m = 0.0;
  double split_max_aspect = 3.0;
  SegmentOptions segments;
  // UpdatePoses re-clusters when a keyframe moved more than this.
  double move_translation_m = 0.05;
  double move_rotation_rad = 0.002;
  // The local SLAM's point landmarks seen at least this often join the object map as objects
  // flagged `landmark` (callers that hold them: frontend::BuildObjectMap); 0: not at all.
  int landmark_min_sightings = 2;
};

// Appends the landmarks seen at least min_sightings times among keyframes <= last_keyframe to
// map as objects flagged `landmark` (id kLandmarkIdBit + landmark id, centre = its estimate,
// length = breadth = its diameter, keyframes = those sightings), most-seen first. Nothing when
// min_sightings <= 0.
void AppendLandmarks(const std::vector<msgs::LandmarkEstimate>& landmarks, int last_keyframe,
                     int min_sightings, msgs::ObjectMap* map);

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

  // UpdatePoses in two halves. SetPoses stores the poses; a keyframe that moved beyond the
  // thresholds since its points were placed leaves a re-clustering pending (returned).
  // Recluster re-places every point at its keyframe's current pose and re-clusters when one
  // is pending (returns whether it did).
  bool SetPoses(const std::vector<KeyframePose>& poses);
  bool Recluster();
  bool recluster_pending() const { return pending_; }

  // The object map (objects sorted by id). Clusters whose members did not change since the
  // last call (and no Recluster in between) are not described again.
  msgs::ObjectMap Objects(int robot_id = 0, double time_s = 0.0);

  const IncrementalDbscan& clusters() const { return dbscan_; }
  int num_reclusters() const { return num_reclusters_; }
  std::size_t num_keyframes() const { return keyframes_.size(); }

 private:
  struct Keyframe {
    int index = 0;
    Pose2 T_local_kf;         // current pose
    Pose2 T_local_kf_placed;  // the pose its points were placed with
    std::vector<msgs::Point2> points_kf;
  };
  std::vector<msgs::Point2> Place(const Keyframe& kf) const;
  // The objects of cluster id (members idx, sorted): none, one, or its segments.
  void DescribeObjects(int id, const std::vector<std::size_t>& idx,
                       std::vector<msgs::Object>* out) const;
  struct Described {
    std::size_t members = 0;
    std::uint64_t hash = 0;  // of the member indices
    std::vector<msgs::Object> objects;
  };

  ObjectMapperOptions options_;
  IncrementalDbscan dbscan_;
  std::vector<Keyframe> keyframes_;  // in insertion order
  std::vector<int> point_keyframe_;  // keyframe index of every point
  int num_reclusters_ = 0;
  bool pending_ = false;
  std::map<int, Described> described_;  // by cluster id, at the last Objects()
};

std::vector<std::vector<std::size_t>> SplitIntoSegments(const std::vector<msgs::Point2>& points,
                                                        const SegmentOptions& options = {});

// One object from a cluster's points (rectangle, centre, count; id and keyframes unset).
msgs::Object DescribeCluster(const std::vector<msgs::Point2>& points, bool rectangle_center);

}  // namespace draco::objects
