// Sequential scan matching (Bruce-SLAM's scheme): each new keyframe's points are matched by
// ICP against the points of the last few keyframes, expressed in the previous keyframe's
// frame, seeded by the dead-reckoning increment. The result is accepted when ICP is valid
// and stays within a gate around the seed (3 m / 30 deg); otherwise the dead-reckoning
// increment is used. No runtime dependency.
#pragma once

#include <deque>
#include <optional>

#include "draco/icp/icp.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::icp {

struct SequentialOptions {
  int num_previous_keyframes = 3;
  int min_points = 50;  // in the source and in the target, else dead reckoning
  double max_translation_from_seed_m = 3.0;
  double max_rotation_from_seed_rad = 30.0 * 3.14159265358979323846 / 180.0;
  double min_overlap_ratio = 0.0;  // the reference does not gate on overlap here
  // The ICP covariance of an accepted match is multiplied by this (trimming and correlated
  // residuals make it optimistic: docs/local-slam.md measures it against ground truth).
  double covariance_scale = 1.0;
  // Degeneracy gate (0: off): fall back to dead reckoning when the xy block of the ICP
  // covariance is more elongated than this (sqrt of its eigenvalue ratio): points along one
  // line or a small blob constrain one direction only.
  double max_anisotropy = 0.0;
  // Consistency gate with dead reckoning (0: off): fall back when the squared Mahalanobis
  // distance between the scan match and the dead-reckoning increment, under the sum of both
  // covariances (after covariance_scale), exceeds this.
  double max_dr_mahalanobis2 = 0.0;
  IcpOptions icp;
};

// sqrt(largest / smallest eigenvalue) of the xy block of a covariance (infinity when the
// smallest is not positive).
double CovarianceAnisotropy(const msgs::Covariance3& covariance);
// Squared Mahalanobis distance of `b` from `a` (error Between(a, b)) under cov_a + cov_b.
double Mahalanobis2(const msgs::Pose2& a, const msgs::Covariance3& cov_a, const msgs::Pose2& b,
                    const msgs::Covariance3& cov_b);

class SequentialScanMatcher {
 public:
  explicit SequentialScanMatcher(const SequentialOptions& options = {}) : options_(options) {}
  // The factor from the previous keyframe to this one (nullopt for the first keyframe).
  std::optional<msgs::SequentialFactor> AddKeyframe(const msgs::Keyframe& keyframe);
  // The chained estimate of the latest keyframe (first keyframe at its dead-reckoning pose).
  msgs::Pose2 latest_pose() const { return window_.back().T_odom_body; }

 private:
  struct Stored {
    int index;
    msgs::Pose2 T_odom_body;  // chained scan-matching estimate
    Cloud2 points_body;
  };
  SequentialOptions options_;
  std::deque<Stored> window_;
};

}  // namespace draco::icp
