// A PoseSource over each robot's whole pose graph: the marginal covariances come from the
// graph's information (odometry and loop-closure factors), not from an open chain. Where a
// robot's own loop closures hold its map together, two keyframes far apart along the
// trajectory but close in the map have a tight relative pose, which an open chain (whose
// uncertainty grows with every step) cannot express.
//
// First order at the given poses: H = sum_f J_f^T Omega_f J_f over the factors (the residual
// of pose_graph_2d / Ceres' example: R_i^T (p_j - p_i) - t_ij, yaw_j - yaw_i - yaw_ij), the
// first keyframe held fixed (it defines the map frame), and the joint covariance H^-1
// (dense, O(n^3) in 3(n-1) unknowns: 0.38 s at 400 keyframes; an offline tool, not a
// per-step one). Covariances are of the additive
// parameters, the convention of se2.hpp.
#pragma once

#include <Eigen/Core>

#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "draco/consistency/pairwise.hpp"

namespace draco::consistency {

struct RelativeFactor {
  int from = 0;
  int to = 0;
  Pose2 T_from_to;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
};

// What InMap's covariance (a keyframe's pose in its map frame, used against the map-to-map
// guesses) holds.
enum class MapFrameCovariance {
  // The marginal relative to the first keyframe: the drift of the whole trajectory so far.
  kFromFirstKeyframe,
  // None: the map-to-map guess was fitted to the maps as estimated (their objects carry the
  // keyframes' drift), so a loop is compared with the guess in the drifted map and only the
  // loop's and the guess's own uncertainties count. Measured (docs/back-end.md): with
  // injected correlated outliers GCM keeps precision 1.000 where the drift model lets
  // wrong groups through, and no true loop is lost on the clean streams.
  kNone,
};

struct GraphPoseSourceOptions {
  MapFrameCovariance map_frame = MapFrameCovariance::kNone;
};

class GraphPoseSource : public PoseSource {
 public:
  explicit GraphPoseSource(const GraphPoseSourceOptions& options = {}) : options_(options) {}
  // The robot's keyframes (index k = position, poses in its map frame) and factors between
  // them. Throws std::invalid_argument on a factor naming an unknown keyframe or a graph
  // whose information is singular (a keyframe no factor reaches).
  void SetRobot(int robot, const std::vector<Pose2>& T_map_kf,
                const std::vector<RelativeFactor>& factors);
  void SetMapTransform(int own_robot, int teammate, const UncertainPose& T_own_teammate);
  int NumKeyframes(int robot) const;

  std::optional<UncertainPose> Relative(int robot, int from_keyframe,
                                        int to_keyframe) const override;
  std::optional<UncertainPose> MapTransform(int own_robot, int teammate) const override;
  std::optional<UncertainPose> InMap(int robot, int keyframe) const override;

 private:
  struct Robot {
    std::vector<Pose2> poses;
    Eigen::MatrixXd covariance;  // 3n x 3n, keyframe 0's rows and columns zero
  };
  Eigen::Matrix3d Block(const Robot& r, int i, int j) const;
  GraphPoseSourceOptions options_;
  std::map<int, Robot> robots_;
  std::map<std::pair<int, int>, UncertainPose> map_transforms_;
};

}  // namespace draco::consistency
