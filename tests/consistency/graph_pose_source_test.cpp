#include "draco/consistency/graph_pose_source.hpp"

#include <gtest/gtest.h>

#include <Eigen/LU>

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace cons = draco::consistency;
using draco::msgs::Pose2;

namespace {

// A square loop: 4 sides of 5 steps of 2 m, turning 90 deg at each corner.
std::vector<Pose2> Square() {
  std::vector<Pose2> poses;
  Pose2 p{3.0, -1.0, 0.3};  // the map frame need not start at the origin
  poses.push_back(p);
  for (int side = 0; side < 4; ++side) {
    for (int k = 0; k < 5; ++k) {
      p = cons::Compose(p, Pose2{2.0, 0.0, k == 4 ? std::numbers::pi / 2 : 0.0});
      poses.push_back(p);
    }
  }
  return poses;  // 21 poses, the last back at the first's position
}

Eigen::Matrix3d StepCovariance() { return Eigen::Vector3d(0.01, 0.004, 1e-4).asDiagonal(); }

std::vector<cons::RelativeFactor> Chain(const std::vector<Pose2>& poses) {
  std::vector<cons::RelativeFactor> out;
  for (std::size_t k = 1; k < poses.size(); ++k) {
    out.push_back({static_cast<int>(k - 1), static_cast<int>(k),
                   cons::Between(poses[k - 1], poses[k]), StepCovariance().inverse()});
  }
  return out;
}

}  // namespace

TEST(GraphPoseSource, OpenChainMatchesChainPoseSource) {
  const auto poses = Square();
  cons::GraphPoseSource graph({cons::MapFrameCovariance::kFromFirstKeyframe});
  graph.SetRobot(2, poses, Chain(poses));
  cons::ChainPoseSource chain;
  for (const auto& p : poses) chain.AddKeyframe(2, p, StepCovariance());
  for (const auto& [i, j] : {std::pair{0, 20}, {3, 17}, {17, 3}, {5, 6}, {10, 10}}) {
    const auto g = graph.Relative(2, i, j);
    const auto c = chain.Relative(2, i, j);
    ASSERT_TRUE(g && c);
    EXPECT_NEAR(g->pose.x_m, c->pose.x_m, 1e-9);
    EXPECT_NEAR(g->pose.yaw_rad, c->pose.yaw_rad, 1e-9);
    EXPECT_LT((g->covariance - c->covariance).norm(), 1e-9 * (1.0 + c->covariance.norm()))
        << i << "->" << j << "\n"
        << g->covariance << "\n"
        << c->covariance;
    const auto gm = graph.InMap(2, j);
    const auto cm = chain.InMap(2, j);
    EXPECT_LT((gm->covariance - cm->covariance).norm(), 1e-9 * (1.0 + cm->covariance.norm()));
  }
}

TEST(GraphPoseSource, LoopClosureTightensFarApartPairs) {
  const auto poses = Square();
  auto factors = Chain(poses);
  cons::GraphPoseSource open;
  open.SetRobot(0, poses, factors);
  // The robot recognises its start: a loop factor 20 -> 0 as tight as one step.
  factors.push_back({20, 0, cons::Between(poses[20], poses[0]), StepCovariance().inverse()});
  cons::GraphPoseSource closed;
  closed.SetRobot(0, poses, factors);
  const auto a = open.Relative(0, 2, 19);
  const auto b = closed.Relative(0, 2, 19);
  ASSERT_TRUE(a && b);
  // Keyframes 2 and 19 are 3 steps apart through the loop, 17 along the chain.
  EXPECT_LT(b->covariance.trace(), 0.3 * a->covariance.trace());
  // Adjacent keyframes hardly change; nothing gets more uncertain.
  const auto c = open.Relative(0, 9, 10), d = closed.Relative(0, 9, 10);
  EXPECT_LE(d->covariance.trace(), c->covariance.trace() + 1e-12);
  EXPECT_GT(d->covariance.trace(), 0.5 * c->covariance.trace());
  // The first keyframe is fixed: no uncertainty of its own.
  EXPECT_EQ(closed.InMap(0, 0)->covariance.norm(), 0.0);
}

TEST(GraphPoseSource, MapFrameCovarianceChoice) {
  const auto poses = Square();
  cons::GraphPoseSource drift({cons::MapFrameCovariance::kFromFirstKeyframe});
  cons::GraphPoseSource none;  // the default: the map as estimated
  drift.SetRobot(0, poses, Chain(poses));
  none.SetRobot(0, poses, Chain(poses));
  EXPECT_GT(drift.InMap(0, 10)->covariance.trace(), 0.1);
  EXPECT_EQ(none.InMap(0, 10)->covariance.norm(), 0.0);
  EXPECT_NEAR(none.InMap(0, 10)->pose.x_m, poses[10].x_m, 1e-12);
  // Relative poses are the same either way.
  EXPECT_NEAR((drift.Relative(0, 3, 15)->covariance - none.Relative(0, 3, 15)->covariance).norm(),
              0.0, 1e-12);
}

TEST(GraphPoseSource, BadGraphsAreErrors) {
  const auto poses = Square();
  auto factors = Chain(poses);
  factors.pop_back();  // keyframe 20 unreachable
  cons::GraphPoseSource g;
  EXPECT_THROW(g.SetRobot(0, poses, factors), std::invalid_argument);
  factors = Chain(poses);
  factors.push_back({3, 21, Pose2{}, Eigen::Matrix3d::Identity()});
  EXPECT_THROW(g.SetRobot(0, poses, factors), std::invalid_argument);
  EXPECT_FALSE(g.Relative(0, 0, 1).has_value());
}
