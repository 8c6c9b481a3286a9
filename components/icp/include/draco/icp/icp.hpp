// 2D ICP scan matching (point-to-point as the reference's libpointmatcher setup, or
// point-to-line), the overlap ratio, and a covariance estimated from the match itself.
// Transforms are named by frames: T_target_source maps source points into the target
// frame. No runtime dependency.
#pragma once

#include <vector>

#include "draco/icp/kdtree2.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::icp {

enum class Metric { kPointToPoint, kPointToLine };

struct IcpOptions {
  Metric metric = Metric::kPointToPoint;
  // Correspondences: the nearest target point, dropped beyond this (the reference searches
  // within 10 m, then its max-distance outlier filter drops pairs beyond 3 m)...
  double max_correspondence_distance_m = 3.0;
  // ...then only the closest trim_fraction of the remaining pairs are kept (reference 0.8).
  double trim_fraction = 0.8;
  int max_iterations = 40;
  // Converged when the mean change over the last convergence_window iterations is below
  // both thresholds. The reference's 0.1 m / 0.01 rad (ReferenceIcpOptions) stops ICP
  // while it still moves several centimetres per iteration: on the synthetic marina scans
  // of tests/icp it ends 0.05 rad and 0.25 m off; these defaults end within 5 mm.
  int convergence_window = 4;
  double convergence_translation_m = 0.001;
  double convergence_rotation_rad = 0.0001;
  int min_correspondences = 6;
  // Overlap ratio: fraction of source points with a target point within this distance.
  double overlap_distance_m = 0.5;
  // Covariance: target normals from this many neighbours; residual sigma floor; and a
  // Tikhonov term that keeps the information matrix invertible in degenerate scenes.
  int normal_neighbors = 6;
  double min_residual_sigma_m = 0.01;
  double information_regularization = 1e-6;
};

// The reference's settings (libpointmatcher in Bruce-SLAM), for comparison.
inline IcpOptions ReferenceIcpOptions() {
  IcpOptions o;
  o.convergence_translation_m = 0.1;
  o.convergence_rotation_rad = 0.01;
  return o;
}

struct IcpResult {
  msgs::Pose2 T_target_source;
  // Covariance of a right perturbation of T_target_source (x, y, yaw in the source frame):
  // sigma^2 (J^T J + eps I)^-1 with point-to-line Jacobians on the final correspondences
  // and sigma^2 their residual variance.
  msgs::Covariance3 covariance{};
  bool converged = false;  // the convergence test passed within max_iterations
  bool valid = false;      // enough correspondences in every iteration
  int iterations = 0;
  int correspondences = 0;  // after trimming, last iteration
  double rmse_m = 0.0;      // point-to-point, over the kept correspondences
  double overlap_ratio = 0.0;
};

// A target cloud prepared once (kd-tree, normals on demand) for many alignments.
class IcpTarget {
 public:
  explicit IcpTarget(Cloud2 points);
  IcpTarget(const IcpTarget&) = delete;
  IcpTarget& operator=(const IcpTarget&) = delete;
  const Cloud2& points() const { return points_; }
  const KdTree2& tree() const { return tree_; }
  // Unit normal of target point i (principal axis of its neighbourhood), computed on first use.
  const Eigen::Vector2d& Normal(int i, int neighbors);

 private:
  Cloud2 points_;
  KdTree2 tree_;
  std::vector<Eigen::Vector2d> normals_;
  std::vector<char> has_normal_;
  std::vector<int> scratch_;
};

IcpResult AlignIcp(const Cloud2& source, IcpTarget& target,
                   const msgs::Pose2& initial_T_target_source, const IcpOptions& options = {});
IcpResult AlignIcp(const Cloud2& source, const Cloud2& target,
                   const msgs::Pose2& initial_T_target_source, const IcpOptions& options = {});

// Fraction of source points (moved by T_target_source) with a target point within
// max_distance_m.
double OverlapRatio(const Cloud2& source, const KdTree2& target, const msgs::Pose2& T_target_source,
                    double max_distance_m);

Cloud2 ToCloud(const std::vector<msgs::Point2>& points);

}  // namespace draco::icp
