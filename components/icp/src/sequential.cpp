// Sequential scan matching (see sequential.hpp).
#include "draco/icp/sequential.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "draco/navigation/se2.hpp"

namespace draco::icp {

double CovarianceAnisotropy(const msgs::Covariance3& c) {
  const double a = c[0], b = 0.5 * (c[1] + c[3]), d = c[4];
  const double mean = 0.5 * (a + d), half = std::sqrt(0.25 * (a - d) * (a - d) + b * b);
  const double lo = mean - half, hi = mean + half;
  if (!(lo > 0.0) || !std::isfinite(hi)) return std::numeric_limits<double>::infinity();
  return std::sqrt(hi / lo);
}

double Mahalanobis2(const msgs::Pose2& a, const msgs::Covariance3& cov_a, const msgs::Pose2& b,
                    const msgs::Covariance3& cov_b) {
  const msgs::Pose2 d = se2::Between(a, b);
  const Eigen::Vector3d e(d.x_m, d.y_m, d.yaw_rad);
  Eigen::Matrix3d c;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const auto k = static_cast<std::size_t>(3 * i + j);
      c(i, j) = cov_a[k] + cov_b[k];
    }
  }
  c = 0.5 * (c + c.transpose());
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(c);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) {
    return std::numeric_limits<double>::infinity();
  }
  return e.dot(ldlt.solve(e));
}

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
      msgs::Covariance3 cov = r.covariance;
      for (double& v : cov) v *= options_.covariance_scale;
      const bool degenerate =
          options_.max_anisotropy > 0 && CovarianceAnisotropy(cov) > options_.max_anisotropy;
      const bool inconsistent = options_.max_dr_mahalanobis2 > 0 &&
                                Mahalanobis2(kf.T_prevkf_kf, kf.covariance_prevkf_kf,
                                             r.T_target_source, cov) > options_.max_dr_mahalanobis2;
      if (!degenerate && !inconsistent) {
        f.T_from_to = r.T_target_source;
        f.covariance = cov;
        f.scan_matched = true;
        f.overlap_ratio = r.overlap_ratio;
        f.iterations = r.iterations;
      }
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
