#include "draco/consistency/pairwise.hpp"

#include <stdexcept>

#include <Eigen/LU>  // 3x3 inverse

namespace draco::consistency {

const char* CovarianceModelName(CovarianceModel model) {
  return model == CovarianceModel::kFirstLoop ? "first-loop" : "propagated";
}

void ChainPoseSource::AddKeyframe(int robot, const Pose2& T_map_kf,
                                  const Eigen::Matrix3d& step_covariance) {
  Chain& chain = chains_[robot];
  if (chain.poses.empty()) {
    chain.cumulative.push_back(Eigen::Matrix3d::Zero());
  } else {
    // T_0_k = T_0_{k-1} * step: the step's covariance in the first keyframe's frame.
    const Pose2 T_0_prev = Between(chain.poses.front(), chain.poses.back());
    const Pose2 step = Between(chain.poses.back(), T_map_kf);
    Eigen::Matrix3d J_a;
    Eigen::Matrix3d J_b;
    Compose(T_0_prev, step, &J_a, &J_b);
    chain.cumulative.push_back(J_a * chain.cumulative.back() * J_a.transpose() +
                               J_b * step_covariance * J_b.transpose());
  }
  chain.from_first.push_back(chain.poses.empty() ? Pose2{}
                                                 : Between(chain.poses.front(), T_map_kf));
  chain.poses.push_back(T_map_kf);
}

void ChainPoseSource::SetMapTransform(int own_robot, int teammate,
                                      const UncertainPose& T_own_teammate) {
  map_transforms_[{own_robot, teammate}] = T_own_teammate;
}

int ChainPoseSource::NumKeyframes(int robot) const {
  const auto it = chains_.find(robot);
  return it == chains_.end() ? 0 : static_cast<int>(it->second.poses.size());
}

const Pose2& ChainPoseSource::KeyframePose(int robot, int keyframe) const {
  return chains_.at(robot).poses.at(static_cast<std::size_t>(keyframe));
}

std::optional<UncertainPose> ChainPoseSource::Relative(int robot, int from_keyframe,
                                                       int to_keyframe) const {
  const auto it = chains_.find(robot);
  if (it == chains_.end()) return std::nullopt;
  const Chain& chain = it->second;
  const int n = static_cast<int>(chain.poses.size());
  if (from_keyframe < 0 || to_keyframe < 0 || from_keyframe >= n || to_keyframe >= n) {
    return std::nullopt;
  }
  const bool forward = from_keyframe <= to_keyframe;
  const int lo = forward ? from_keyframe : to_keyframe;
  const int hi = forward ? to_keyframe : from_keyframe;
  // T_0_hi = T_0_lo * T_lo_hi with T_lo_hi independent of T_0_lo: solve for Cov(T_lo_hi).
  const Pose2& T_0_lo = chain.from_first[static_cast<std::size_t>(lo)];
  UncertainPose rel;
  rel.pose =
      Between(chain.poses[static_cast<std::size_t>(lo)], chain.poses[static_cast<std::size_t>(hi)]);
  Eigen::Matrix3d J_a;
  Eigen::Matrix3d J_b;
  Compose(T_0_lo, rel.pose, &J_a, &J_b);
  const Eigen::Matrix3d rest =
      chain.cumulative[static_cast<std::size_t>(hi)] -
      J_a * chain.cumulative[static_cast<std::size_t>(lo)] * J_a.transpose();
  // J_b is a rotation (block): its inverse is its transpose.
  rel.covariance = J_b.transpose() * rest * J_b;
  rel.covariance = 0.5 * (rel.covariance + rel.covariance.transpose()).eval();
  if (forward) return rel;
  return Inverse(rel);
}

std::optional<UncertainPose> ChainPoseSource::MapTransform(int own_robot, int teammate) const {
  const auto it = map_transforms_.find({own_robot, teammate});
  if (it == map_transforms_.end()) return std::nullopt;
  return it->second;
}

PreparedLoop Prepare(const msgs::InterRobotLoop& loop, const PoseSource& poses) {
  PreparedLoop p;
  p.loop = loop;
  p.z = {loop.T_ownkf_teammatekf, ToMatrix(loop.covariance)};
  p.z_inverse = Inverse(p.z);
  bool invertible = false;
  double determinant = 0.0;
  p.z.covariance.computeInverseAndDetWithCheck(p.information, determinant, invertible);
  p.information_valid = invertible && determinant > 0.0;
  const auto T_a_b = poses.MapTransform(loop.own_robot, loop.teammate_robot);
  const auto x_b = poses.Relative(loop.teammate_robot, 0, loop.teammate_keyframe);
  if (T_a_b && x_b) {
    p.in_own_map = true;
    p.teammate_in_own_map = Compose(*T_a_b, *x_b);
  }
  return p;
}

PairwiseResult TestPair(const PreparedLoop& p1, const PreparedLoop& p2, const PoseSource& poses,
                        const PairwiseOptions& options) {
  const msgs::InterRobotLoop& z1 = p1.loop;
  const msgs::InterRobotLoop& z2 = p2.loop;
  if (z1.own_robot != z2.own_robot) {
    throw std::invalid_argument("TestPair: loops of different own robots");
  }
  PairwiseResult result;
  const auto x_own = poses.Relative(z1.own_robot, z1.own_keyframe, z2.own_keyframe);
  if (!x_own) return result;

  // x_{c_l b_k}: the second loop's teammate keyframe to the first's.
  std::optional<UncertainPose> x_team;
  if (z1.teammate_robot == z2.teammate_robot) {
    x_team = poses.Relative(z1.teammate_robot, z2.teammate_keyframe, z1.teammate_keyframe);
  } else if (p1.in_own_map && p2.in_own_map) {
    // inv(T_{a_0 c_l}) * T_{a_0 b_k}, the map transforms of the two teammates independent.
    x_team = Compose(Inverse(p2.teammate_in_own_map), p1.teammate_in_own_map);
  }
  if (!x_team) return result;
  result.evaluated = true;

  if (options.covariance == CovarianceModel::kFirstLoop) {
    const Pose2 e =
        Compose(Compose(p1.z_inverse.pose, x_own->pose), Compose(p2.z.pose, x_team->pose));
    result.error = ErrorVector(e);
    if (!p1.information_valid) return result;
    result.mahalanobis_squared = result.error.dot(p1.information * result.error);
  } else {
    const UncertainPose e = Compose(Compose(p1.z_inverse, *x_own), Compose(p2.z, *x_team));
    result.error = ErrorVector(e.pose);
    Eigen::Matrix3d information;
    bool invertible = false;
    double determinant = 0.0;
    e.covariance.computeInverseAndDetWithCheck(information, determinant, invertible);
    if (!invertible || determinant <= 0.0) return result;  // evaluated, inconsistent
    result.mahalanobis_squared = result.error.dot(information * result.error);
  }
  result.consistent = result.mahalanobis_squared < options.chi2_threshold;
  return result;
}

PairwiseResult TestPair(const msgs::InterRobotLoop& z1, const msgs::InterRobotLoop& z2,
                        const PoseSource& poses, const PairwiseOptions& options) {
  return TestPair(Prepare(z1, poses), Prepare(z2, poses), poses, options);
}

}  // namespace draco::consistency
