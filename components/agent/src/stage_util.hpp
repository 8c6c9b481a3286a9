// Small pieces the stages share (stages.hpp): pose conversions, covariance checks, the
// SE(2) alignment of placed positions, a wall-time accumulator. Private to draco_agent.
#pragma once

#include <Eigen/Cholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "draco/agent/stages.hpp"
#include "draco/consistency/pairwise.hpp"
#include "draco/consistency/se2.hpp"
#include "draco/msgs/rigid_fit.hpp"

namespace draco::agent::stage_util {

using msgs::Point2;
using msgs::Pose2;
namespace reg = registration;
namespace cons = consistency;
namespace pg = pose_graph;

inline constexpr double kNever = -std::numeric_limits<double>::infinity();

inline pg::Pose2 ToPg(const Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }
inline Pose2 FromPg(const pg::Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }

inline bool Finite(const Pose2& p) {
  return std::isfinite(p.x_m) && std::isfinite(p.y_m) && std::isfinite(p.yaw_rad);
}

inline bool PositiveDefinite(const msgs::Covariance3& c) {
  for (const double v : c) {
    if (!std::isfinite(v)) return false;
  }
  const Eigen::Matrix3d m = cons::ToMatrix(c);
  if ((m - m.transpose()).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + m.cwiseAbs().maxCoeff())) {
    return false;
  }
  const Eigen::LLT<Eigen::Matrix3d> llt(m);
  return llt.info() == Eigen::Success;
}

inline Eigen::Matrix3d DiagonalCovariance(double sigma_xy, double sigma_yaw) {
  return Eigen::Vector3d(sigma_xy * sigma_xy, sigma_xy * sigma_xy, sigma_yaw * sigma_yaw)
      .asDiagonal();
}

inline pg::Matrix3 Information(double sigma_xy, double sigma_yaw) {
  return pg::Diagonal3(1.0 / (sigma_xy * sigma_xy), 1.0 / (sigma_xy * sigma_xy),
                       1.0 / (sigma_yaw * sigma_yaw));
}

// T with placed[i] ~ T * local[i] (least squares over the positions; SE(2) alignment).
inline std::optional<Pose2> AlignSe2(const std::vector<Pose2>& local,
                                     const std::vector<Pose2>& placed) {
  if (std::min(local.size(), placed.size()) < 2) return std::nullopt;
  return msgs::FitRigid2d(local, placed);
}

using LoopKey = std::tuple<int, int, int>;  // teammate, own keyframe, teammate keyframe

class WallTimer {
 public:
  explicit WallTimer(msgs::TeamStepStats* stats)
      : stats_(stats), t0_(std::chrono::steady_clock::now()) {}
  ~WallTimer() {
    if (stats_ == nullptr) return;
    stats_->wall_ms +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0_).count();
  }
  WallTimer(const WallTimer&) = delete;
  WallTimer& operator=(const WallTimer&) = delete;

 private:
  msgs::TeamStepStats* stats_;
  std::chrono::steady_clock::time_point t0_;
};

// The number of distinct values.
inline int CountDistinct(std::vector<int> v) {
  std::sort(v.begin(), v.end());
  return static_cast<int>(std::unique(v.begin(), v.end()) - v.begin());
}

// Distinct keyframes of each robot named by a set of loops: the smaller of the two counts.
inline int DistinctKeyframes(const std::vector<const msgs::InterRobotLoop*>& loops) {
  std::vector<int> own, mate;
  own.reserve(loops.size());
  mate.reserve(loops.size());
  for (const auto* l : loops) {
    own.push_back(l->own_keyframe);
    mate.push_back(l->teammate_keyframe);
  }
  return std::min(CountDistinct(std::move(own)), CountDistinct(std::move(mate)));
}

// Distance between two map-to-map transforms where it matters: at the point c (teammate map
// frame) they both move, and the yaw difference.
inline std::pair<double, double> TransformGap(const Pose2& a, const Pose2& b,
                                              const msgs::Point2& c) {
  const auto pa = reg::Apply(a, c), pb = reg::Apply(b, c);
  return {std::hypot(pa.x_m - pb.x_m, pa.y_m - pb.y_m),
          std::abs(reg::WrapAngle(a.yaw_rad - b.yaw_rad))};
}

}  // namespace draco::agent::stage_util
