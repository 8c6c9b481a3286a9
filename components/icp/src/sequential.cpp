// Sequential scan matching (see sequential.hpp).
#include "draco/icp/sequential.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "draco/navigation/se2.hpp"

namespace draco::icp {

std::optional<msgs::SequentialFactor> SequentialScanMatcher::AddKeyframe(const msgs::Keyframe& kf) {
  Cloud2 source = ToCloud(kf.points_body);
  if (window_.empty()) {
    window_.push_back(Stored{kf.index, kf.T_odom_body, std::move(source)});
    return std::nullopt;
  }
  const Stored& prev = window_.back();
  msgs::SequentialFactor f;
  f.from_index = prev.index;
  f.to_index = kf.index;
  f.time_s = kf.time_s;
  f.T_from_to = kf.T_prevkf_kf;
  f.covariance = kf.covariance_prevkf_kf;

  // Target: the window's points in the previous keyframe's frame.
  Cloud2 target;
  for (const Stored& s : window_) {
    const msgs::Pose2 T = se2::Between(prev.T_odom_body, s.T_odom_body);
    const Eigen::Rotation2Dd R(T.yaw_rad);
    const Eigen::Vector2d t(T.x_m, T.y_m);
    for (const Eigen::Vector2d& p : s.points_body) target.push_back(R * p + t);
  }
  const auto min_points = static_cast<std::size_t>(options_.min_points);
  if (source.size() >= min_points && target.size() >= min_points) {
    const IcpResult r = AlignIcp(source, target, kf.T_prevkf_kf, options_.icp);
    const msgs::Pose2 d = se2::Between(kf.T_prevkf_kf, r.T_target_source);
    if (r.valid && se2::Translation(d) <= options_.max_translation_from_seed_m &&
        std::abs(d.yaw_rad) <= options_.max_rotation_from_seed_rad &&
        r.overlap_ratio >= options_.min_overlap_ratio) {
      f.T_from_to = r.T_target_source;
      f.covariance = r.covariance;
      f.scan_matched = true;
      f.overlap_ratio = r.overlap_ratio;
      f.iterations = r.iterations;
    }
  }
  window_.push_back(
      Stored{kf.index, se2::Compose(prev.T_odom_body, f.T_from_to), std::move(source)});
  while (static_cast<int>(window_.size()) > std::max(options_.num_previous_keyframes, 1)) {
    window_.pop_front();
  }
  return f;
}

}  // namespace draco::icp
