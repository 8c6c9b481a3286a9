#include "draco/consistency/pairwise.hpp"

#include <stdexcept>

#include <Eigen/LU>

namespace draco::consistency {
namespace {

UncertainPose LoopMeasurement(const msgs::InterRobotLoop& z) {
  return {z.T_ownkf_teammatekf, ToMatrix(z.covariance)};
}

}  // namespace

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
  const Pose2& origin = chain.poses.front();
  const Pose2 T_0_lo = Between(origin, chain.poses[static_cast<std::size_t>(lo)]);
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

PairwiseResult TestPair(const msgs::InterRobotLoop& z1, const msgs::InterRobotLoop& z2,
                        const PoseSource& poses, const PairwiseOptions& options) {
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
  } else {
    const auto T_a_b = poses.MapTransform(z1.own_robot, z1.teammate_robot);
    const auto T_a_c = poses.MapTransform(z1.own_robot, z2.teammate_robot);
    const auto x_b = poses.Relative(z1.teammate_robot, 0, z1.teammate_keyframe);
    const auto x_c = poses.Relative(z2.teammate_robot, 0, z2.teammate_keyframe);
    if (!T_a_b || !T_a_c || !x_b || !x_c) return result;
    x_team = Compose(Compose(Inverse(*x_c), Inverse(*T_a_c)), Compose(*T_a_b, *x_b));
  }
  if (!x_team) return result;

  const UncertainPose m1 = LoopMeasurement(z1);
  const UncertainPose m2 = LoopMeasurement(z2);
  const UncertainPose e = Compose(Compose(Inverse(m1), *x_own), Compose(m2, *x_team));
  result.evaluated = true;
  result.error = ErrorVector(e.pose);
  const Eigen::Matrix3d covariance =
      options.covariance == CovarianceModel::kFirstLoop ? m1.covariance : e.covariance;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(covariance);
  if (!lu.isInvertible()) return result;  // evaluated, inconsistent
  result.mahalanobis_squared = result.error.dot(lu.solve(result.error));
  result.consistent = result.mahalanobis_squared < options.chi2_threshold;
  return result;
}

}  // namespace draco::consistency
