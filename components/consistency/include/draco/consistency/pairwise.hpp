// Pairwise consistency of two inter-robot loop closures (PCM, Mangelson et al. 2018) and its
// group-wise form across teammates (GCM, DRACo-SLAM2 section III-E).
//
// Loops z1 = T_{a_i}^{b_k} (teammate b's keyframe k in own keyframe i) and z2 = T_{a_j}^{c_l}.
// The cycle a_i -> b_k -> c_l -> a_j -> a_i must be the identity:
//   e = inv(z1) * x_{a_i a_j} * z2 * x_{c_l b_k}
// with x_{a_i a_j} the own relative pose (own pose graph). For one teammate (b = c, PCM and
// the same-teammate pairs of GCM) x_{c_l b_k} = inv(x_{b_k b_l}) from the teammate's graph.
// For two teammates (GCM, the paper's eq. for x^{beta_i}_{gamma_j}) the teammate poses are
// expressed in the own map frame a_0 through the map-to-map transforms:
//   x_{c_l b_k} = inv(x_{c_0 c_l}) * inv(T_{a_0 c_0}) * T_{a_0 b_0} * x_{b_0 b_k}.
// The loops are consistent when the squared Mahalanobis distance of e is below the
// chi-square threshold (11.34: 3 dof at 0.99).
//
// TestPair is the straightforward test. PairTester gives the same decisions over many loops
// at a few dozen flops per pair: every loop is placed once in the own map frame (the
// teammate keyframe it predicts, the map transform it implies and its covariance there, as
// a perturbation on the left), so a pair needs two compositions, a sum of 3x3 covariances,
// one transport and a 3x3 LDL solve, without trigonometry or allocation.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "draco/consistency/se2.hpp"
#include "draco/msgs/loops.hpp"

namespace draco::consistency {

// Which covariance the distance uses.
enum class CovarianceModel {
  kFirstLoop,   // the reference: the first loop's covariance only
  kPropagated,  // both loops' covariances, the relative poses' marginals and (GCM across
                // teammates) the map-to-map transforms', propagated to first order
};
const char* CovarianceModelName(CovarianceModel model);

// Pose estimates the test needs; implemented by the caller over its pose graphs.
class PoseSource {
 public:
  virtual ~PoseSource() = default;
  // T_{r_from}^{r_to}: keyframe `to` of robot r in keyframe `from`'s frame, with the marginal
  // covariance of that relative pose. nullopt when unknown.
  virtual std::optional<UncertainPose> Relative(int robot, int from_keyframe,
                                                int to_keyframe) const = 0;
  // T_{own_0}^{teammate_0}: the teammate's map frame in the own map frame (graph matching
  // or accepted loops), with covariance. nullopt when not known yet.
  virtual std::optional<UncertainPose> MapTransform(int own_robot, int teammate) const = 0;
  // The keyframe's pose in the robot's map frame (the frame MapTransform relates), with the
  // covariance of that pose relative to the first keyframe. Default: Relative(robot, 0, k),
  // the first keyframe being the map origin.
  virtual std::optional<UncertainPose> InMap(int robot, int keyframe) const {
    return Relative(robot, 0, keyframe);
  }

  // Optional, for PairTester: when the robot's poses form an open chain, its keyframes in the
  // first keyframe's frame (T_{r_0 r_k}) and their covariances, such that Relative(r, i, j)
  // is the first-order marginal of inv(T_0i) * T_0j with T_0j = T_0i * (an independent
  // step). nullptr (the default): PairTester is not used and every pair calls Relative.
  struct Chain {
    const std::vector<Pose2>* from_first = nullptr;
    const std::vector<Eigen::Matrix3d>* covariance = nullptr;
  };
  virtual Chain OpenChain(int /*robot*/) const { return {}; }
};

// A simple PoseSource: each robot's keyframes as an open odometry chain (poses in its map
// frame plus per-step covariances); relative marginals are exact for a chain (first order).
class ChainPoseSource : public PoseSource {
 public:
  // Appends the next keyframe of `robot` (its pose in the robot's map frame) and the
  // covariance of the step from the previous keyframe (ignored for the first keyframe).
  void AddKeyframe(int robot, const Pose2& T_map_kf, const Eigen::Matrix3d& step_covariance);
  void SetMapTransform(int own_robot, int teammate, const UncertainPose& T_own_teammate);
  int NumKeyframes(int robot) const;
  const Pose2& KeyframePose(int robot, int keyframe) const;

  std::optional<UncertainPose> Relative(int robot, int from_keyframe,
                                        int to_keyframe) const override;
  std::optional<UncertainPose> MapTransform(int own_robot, int teammate) const override;
  // The pose as added (its map frame need not start at the first keyframe).
  std::optional<UncertainPose> InMap(int robot, int keyframe) const override;
  Chain OpenChain(int robot) const override;

 private:
  struct Chain {
    std::vector<Pose2> poses;                 // T_map_kf
    std::vector<Pose2> from_first;            // T_kf0_kf
    std::vector<Eigen::Matrix3d> cumulative;  // covariance of T_kf0_kf
  };
  std::map<int, Chain> chains_;
  std::map<std::pair<int, int>, UncertainPose> map_transforms_;
};

struct PairwiseResult {
  bool evaluated = false;  // false when a pose or transform was missing
  bool consistent = false;
  double mahalanobis_squared = 0.0;
  Eigen::Vector3d error = Eigen::Vector3d::Zero();
};

struct PairwiseOptions {
  CovarianceModel covariance = CovarianceModel::kPropagated;
  double chi2_threshold = 11.34;
};

// The per-loop parts of the test, computed once per loop: inv(z) and the teammate keyframe
// in the own map frame, T_{a_0 b_k} = T_{a_0 b_0} * InMap(b, k) (when the map transform is
// known), both with covariances.
struct PreparedLoop {
  msgs::InterRobotLoop loop;
  UncertainPose z;
  UncertainPose z_inverse;
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();  // inverse of the loop covariance
  bool information_valid = false;
  bool in_own_map = false;
  UncertainPose teammate_in_own_map;
};
PreparedLoop Prepare(const msgs::InterRobotLoop& loop, const PoseSource& poses);

// The cycle error of two loops of the same own robot. Loops with different teammates need
// both map transforms (GCM); with the same teammate they are not used.
PairwiseResult TestPair(const PreparedLoop& z1, const PreparedLoop& z2, const PoseSource& poses,
                        const PairwiseOptions& options);
PairwiseResult TestPair(const msgs::InterRobotLoop& z1, const msgs::InterRobotLoop& z2,
                        const PoseSource& poses, const PairwiseOptions& options);

// Unary test of one loop against the map-to-map guess: the map transform the loop implies,
// T_{a_0 a_i} * z * inv(T_{b_0 b_k}), against MapTransform(own, teammate), i.e. the error
// (InMap(a, i) * z) * inv(T_{a_0 b_k}) with the loop's, the own keyframe's (InMap) and
// teammate_in_own_map's covariances. evaluated = false when a keyframe or the map
// transform is unknown.
PairwiseResult TestMapPrior(const PreparedLoop& z, const PoseSource& poses,
                            const PairwiseOptions& options);

// Symmetric 3x3 (xx, xy, xt, yy, yt, tt), the inner loops' covariance type.
struct Sym3 {
  double xx = 0, xy = 0, xt = 0, yy = 0, yt = 0, tt = 0;
};

// TestPair(loops[a], loops[b], poses, options).consistent for many pairs, cheaply (see the
// file comment). Reset() places every loop with the current poses (O(loops)); it returns
// false, and the tester must not be used, when a robot of the loops has no OpenChain().
// A pair whose distance is within a relative 1e-6 of the threshold (or whose covariance is
// nearly singular) is decided by TestPair itself, so decisions are TestPair's.
class PairTester {
 public:
  bool Reset(const std::vector<PreparedLoop>& loops, const PoseSource& poses,
             const PairwiseOptions& options);
  bool Consistent(int a, int b) const;
  // Pairs decided by a bound without the full distance, and pairs handed to TestPair.
  std::int64_t early_outs() const { return early_outs_; }
  std::int64_t fallbacks() const { return fallbacks_; }

 private:
  struct Placed {
    int teammate = 0;
    int own_keyframe = 0;
    int teammate_keyframe = 0;
    bool own_ok = false;       // own keyframe known
    bool teammate_ok = false;  // teammate keyframe known
    bool cross_ok = false;     // teammate keyframe in the own map (map transform known)
    // A = T_{a_0 a_i} * z: the teammate keyframe in the own map frame, through the loop.
    double ax = 0, ay = 0, ayaw = 0, ac = 1, as = 0;
    // M = A * inv(T_{b_0 b_k}): the map transform the loop implies (teammate map -> own).
    double mx = 0, my = 0, myaw = 0, mc = 1, ms = 0;
    // N = A * inv(T_{a_0 b_k}): its disagreement with the map transform (own map frame).
    double nx = 0, ny = 0, nyaw = 0, nc = 1, ns = 0;
    double hx = 0, hy = 0, hyaw = 0;  // T_{b_0 b_k}
    double qx = 0, qy = 0, qyaw = 0;  // T_{a_0 b_k} (map transform at arrival)
    Sym3 own;                         // covariance of T_{a_0 a_i}, left perturbation in a_0
    Sym3 team;                        // covariance of T_{b_0 b_k}, left perturbation in b_0
    Sym3 loop;                        // the loop's, carried to A, left perturbation in a_0
    Sym3 in_own;                      // T_{a_0 b_k}'s, left perturbation in a_0
    Sym3 information;                 // first-loop model: inverse of the loop covariance
    bool information_valid = false;
  };
  std::vector<Placed> placed_;
  const std::vector<PreparedLoop>* loops_ = nullptr;
  const PoseSource* poses_ = nullptr;
  PairwiseOptions options_;
  mutable std::int64_t early_outs_ = 0;
  mutable std::int64_t fallbacks_ = 0;
};

}  // namespace draco::consistency
