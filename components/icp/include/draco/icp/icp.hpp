// 2D ICP scan matching (point-to-point as the reference's libpointmatcher setup, or
// point-to-line), the overlap ratio, and a covariance estimated from the match itself.
// Transforms are named by frames: T_target_source maps source points into the target
// frame. No runtime dependency.
//
// Registration back ends (IcpOptions::backend): draco's own 2D ICP (the default), PCL's
// ICP, GICP or NDT, or MRPT's 2D ICP. PCL is used in src/pcl_*.cpp only, MRPT in
// src/mrpt_icp.cpp only (one translation unit per back end); this header stays plain C++.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "draco/icp/kdtree2.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::icp {

enum class Metric { kPointToPoint, kPointToLine };

// Who computes the alignment. Whatever the back end, the result's covariance, rmse, overlap
// and validity are draco's, computed the same way on the final pose (AlignIcp below), so the
// gates downstream see comparable numbers.
//  kDraco    draco's 2D ICP below (the default).
//  kPclIcp   pcl::IterativeClosestPoint with pcl::registration::TransformationEstimation2D
//            (x, y, yaw only), the same trimming (CorrespondenceRejectorTrimmed) and
//            correspondence distance.
//  kPclGicp  pcl::GeneralizedIterativeClosestPoint in 3D with z = 0. A planar sonar return is
//            taken as a vertical wall: each point's covariance is flat across the local line
//            (its 2D neighbours' principal axis) and wide along it and along z, so GICP's
//            plane-to-plane term is line-to-line in the plane. The answer is projected to
//            SE(2): x, y of the translation, yaw of the closest planar rotation to the xy
//            block; z, roll and pitch are dropped.
//  kPclNdt   pcl::NormalDistributionsTransform in 3D with z = 0 (voxels ndt_resolution_m;
//            the flat z extent of each cell is PCL's own eigenvalue floor), projected to
//            SE(2) as GICP. Uses max_iterations and the convergence translation only.
//  kMrptIcp  mrpt::slam::CICP (classic 2D ICP, x, y, yaw): the correspondence distance starts
//            at max_correspondence_distance_m and is halved each time the steps fall below
//            the convergence thresholds, down to 0.1 m (MRPT's annealing instead of
//            trimming); every source point matched. Uses max_iterations and the
//            convergence thresholds; trim_fraction is not used.
enum class Backend { kDraco, kPclIcp, kPclGicp, kPclNdt, kMrptIcp };
// "draco", "pcl_icp", "pcl_gicp", "pcl_ndt", "mrpt_icp"
const char* BackendName(Backend backend);
const std::vector<std::string>& BackendNames();
// Throws std::invalid_argument naming the choices.
Backend ParseBackend(std::string_view name);

struct IcpOptions {
  Metric metric = Metric::kPointToPoint;  // kDraco only
  Backend backend = Backend::kDraco;
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
  // false: IcpResult::covariance is left zero (no target normals, no information matrix),
  // for callers that use the pose, validity and overlap only; every other field is the same.
  bool covariance = true;
  // PCL back ends only.
  double ndt_resolution_m = 2.0;  // kPclNdt voxel size
  int gicp_neighbors = 10;        // kPclGicp: neighbours of a point's local line
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
  // and sigma^2 their residual variance (zero with IcpOptions::covariance false).
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
  // What a back end other than draco's keeps of the target between alignments (its own
  // cloud, search tree, voxels); defined in that back end's .cpp file.
  struct BackendCache {
    virtual ~BackendCache() = default;
  };

  explicit IcpTarget(Cloud2 points);
  IcpTarget(const IcpTarget&) = delete;
  IcpTarget& operator=(const IcpTarget&) = delete;
  const Cloud2& points() const { return points_; }
  const KdTree2& tree() const { return tree_; }
  // Unit normal of target point i (principal axis of its neighbourhood), computed on first use.
  const Eigen::Vector2d& Normal(int i, int neighbors);
  std::unique_ptr<BackendCache>& backend_cache() { return backend_cache_; }

 private:
  Cloud2 points_;
  KdTree2 tree_;
  std::vector<Eigen::Vector2d> normals_;
  std::vector<char> has_normal_;
  std::vector<int> scratch_;
  std::unique_ptr<BackendCache> backend_cache_;
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
