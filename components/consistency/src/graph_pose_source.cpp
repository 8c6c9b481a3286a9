#include "draco/consistency/graph_pose_source.hpp"

#include <Eigen/Cholesky>

#include <cmath>
#include <stdexcept>
#include <string>

#include "draco/consistency/se2.hpp"

namespace draco::consistency {

void GraphPoseSource::SetRobot(int robot, const std::vector<Pose2>& T_map_kf,
                               const std::vector<RelativeFactor>& factors) {
  const int n = static_cast<int>(T_map_kf.size());
  Robot r;
  r.poses = T_map_kf;
  r.covariance = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  if (n <= 1) {
    robots_[robot] = std::move(r);
    return;
  }
  // Unknowns: keyframes 1..n-1 (keyframe 0 fixed), 3 each.
  const int m = 3 * (n - 1);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m, m);
  for (const RelativeFactor& f : factors) {
    if (f.from < 0 || f.to < 0 || f.from >= n || f.to >= n || f.from == f.to) {
      throw std::invalid_argument("GraphPoseSource: robot " + std::to_string(robot) + " factor " +
                                  std::to_string(f.from) + " -> " + std::to_string(f.to) +
                                  " outside keyframes 0.." + std::to_string(n - 1));
    }
    const Pose2& a = T_map_kf[static_cast<std::size_t>(f.from)];
    const Pose2& b = T_map_kf[static_cast<std::size_t>(f.to)];
    const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
    const double dx = b.x_m - a.x_m, dy = b.y_m - a.y_m;
    Eigen::Matrix<double, 3, 6> J = Eigen::Matrix<double, 3, 6>::Zero();
    // d/d(x_a, y_a, yaw_a)
    J(0, 0) = -c;
    J(0, 1) = -s;
    J(0, 2) = -s * dx + c * dy;
    J(1, 0) = s;
    J(1, 1) = -c;
    J(1, 2) = -c * dx - s * dy;
    J(2, 2) = -1.0;
    // d/d(x_b, y_b, yaw_b)
    J(0, 3) = c;
    J(0, 4) = s;
    J(1, 3) = -s;
    J(1, 4) = c;
    J(2, 5) = 1.0;
    const Eigen::Matrix<double, 6, 6> h = J.transpose() * f.information * J;
    const int idx[2] = {f.from, f.to};
    for (int u = 0; u < 2; ++u) {
      if (idx[u] == 0) continue;
      for (int v = 0; v < 2; ++v) {
        if (idx[v] == 0) continue;
        H.block<3, 3>(3 * (idx[u] - 1), 3 * (idx[v] - 1)) += h.block<3, 3>(3 * u, 3 * v);
      }
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(H);
  if (llt.info() != Eigen::Success) {
    throw std::invalid_argument("GraphPoseSource: robot " + std::to_string(robot) +
                                ": singular information (a keyframe without factors?)");
  }
  r.covariance.bottomRightCorner(m, m) = llt.solve(Eigen::MatrixXd::Identity(m, m));
  robots_[robot] = std::move(r);
}

void GraphPoseSource::SetMapTransform(int own_robot, int teammate,
                                      const UncertainPose& T_own_teammate) {
  map_transforms_[{own_robot, teammate}] = T_own_teammate;
}

int GraphPoseSource::NumKeyframes(int robot) const {
  const auto it = robots_.find(robot);
  return it == robots_.end() ? 0 : static_cast<int>(it->second.poses.size());
}

Eigen::Matrix3d GraphPoseSource::Block(const Robot& r, int i, int j) const {
  return r.covariance.block<3, 3>(3 * i, 3 * j);
}

std::optional<UncertainPose> GraphPoseSource::Relative(int robot, int from_keyframe,
                                                       int to_keyframe) const {
  const auto it = robots_.find(robot);
  if (it == robots_.end()) return std::nullopt;
  const Robot& r = it->second;
  const int n = static_cast<int>(r.poses.size());
  if (from_keyframe < 0 || to_keyframe < 0 || from_keyframe >= n || to_keyframe >= n) {
    return std::nullopt;
  }
  const Pose2& a = r.poses[static_cast<std::size_t>(from_keyframe)];
  const Pose2& b = r.poses[static_cast<std::size_t>(to_keyframe)];
  Eigen::Matrix3d J_inv, J_ia, J_b;
  const Pose2 a_inv = Inverse(a, &J_inv);
  UncertainPose out;
  out.pose = Compose(a_inv, b, &J_ia, &J_b);
  const Eigen::Matrix3d J_a = J_ia * J_inv;
  const Eigen::Matrix3d S_aa = Block(r, from_keyframe, from_keyframe);
  const Eigen::Matrix3d S_ab = Block(r, from_keyframe, to_keyframe);
  const Eigen::Matrix3d S_bb = Block(r, to_keyframe, to_keyframe);
  const Eigen::Matrix3d cross = J_a * S_ab * J_b.transpose();
  out.covariance =
      J_a * S_aa * J_a.transpose() + cross + cross.transpose() + J_b * S_bb * J_b.transpose();
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  return out;
}

std::optional<UncertainPose> GraphPoseSource::MapTransform(int own_robot, int teammate) const {
  const auto it = map_transforms_.find({own_robot, teammate});
  if (it == map_transforms_.end()) return std::nullopt;
  return it->second;
}

std::optional<UncertainPose> GraphPoseSource::InMap(int robot, int keyframe) const {
  const auto it = robots_.find(robot);
  if (it == robots_.end()) return std::nullopt;
  const Robot& r = it->second;
  if (keyframe < 0 || keyframe >= static_cast<int>(r.poses.size())) return std::nullopt;
  if (options_.map_frame == MapFrameCovariance::kNone) {
    return UncertainPose{r.poses[static_cast<std::size_t>(keyframe)], Eigen::Matrix3d::Zero()};
  }
  return UncertainPose{r.poses[static_cast<std::size_t>(keyframe)], Block(r, keyframe, keyframe)};
}

}  // namespace draco::consistency
