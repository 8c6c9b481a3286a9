#include "draco/eval/trajectory.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

namespace draco::eval {
namespace {

Trajectory Circle(int n, double radius) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    t.push_back({0.1 * i, radius * std::cos(a), radius * std::sin(a), WrapAngle(a + M_PI / 2)});
  }
  return t;
}

TEST(Trajectory, AlignmentRecoversAKnownTransform) {
  const Trajectory truth = Circle(100, 10.0);
  const Se2 T{3.0, -2.0, 0.7};
  // estimate = inv(T) * truth, so T_truth_estimate = T.
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  Trajectory est;
  for (const auto& p : truth) {
    const double dx = p.x_m - T.x_m, dy = p.y_m - T.y_m;
    est.push_back({p.time_s, c * dx + s * dy, -s * dx + c * dy, WrapAngle(p.yaw_rad - T.yaw_rad)});
  }
  const AteResult r = Ate(est, truth);
  EXPECT_EQ(r.pairs, 100u);
  EXPECT_NEAR(r.rmse_m, 0.0, 1e-9);
  EXPECT_NEAR(r.T_truth_estimate.x_m, 3.0, 1e-9);
  EXPECT_NEAR(r.T_truth_estimate.y_m, -2.0, 1e-9);
  EXPECT_NEAR(r.T_truth_estimate.yaw_rad, 0.7, 1e-9);
  // Without alignment the error is the offset itself.
  EXPECT_GT(Ate(est, truth, /*align=*/false).rmse_m, 1.0);
}

TEST(Trajectory, AteOfAConstantLateralErrorOnALine) {
  // Straight line; the estimate is +-0.5 m sideways in a pattern with zero mean and zero
  // correlation with x (+ - - + + - - +), so the best alignment is the identity.
  const double offset[8] = {0.5, -0.5, -0.5, 0.5, 0.5, -0.5, -0.5, 0.5};
  Trajectory truth, est;
  for (int i = 0; i < 8; ++i) {
    truth.push_back({1.0 * i, 1.0 * i, 0.0, 0.0});
    est.push_back({1.0 * i, 1.0 * i, offset[i], 0.0});
  }
  const AteResult r = Ate(est, truth);
  EXPECT_NEAR(r.rmse_m, 0.5, 1e-9);
  EXPECT_NEAR(r.max_m, 0.5, 1e-9);
}

TEST(Trajectory, AssociationInterpolatesAndSkipsOutsideSpan) {
  const Trajectory truth = {{0.0, 0.0, 0.0, 0.0}, {1.0, 2.0, 0.0, 0.2}};
  const Trajectory est = {{-0.5, 0, 0, 0}, {0.25, 0, 0, 0}, {2.0, 0, 0, 0}};
  const Association a = Associate(est, truth, 2.0);
  EXPECT_TRUE(Associate(est, truth, 0.5).truth.empty());  // samples 1 s apart: a hole
  ASSERT_EQ(a.truth.size(), 1u);
  EXPECT_NEAR(a.truth[0].x_m, 0.5, 1e-12);
  EXPECT_NEAR(a.truth[0].yaw_rad, 0.05, 1e-12);
  // Interpolated yaw takes the short way across +-pi.
  const Trajectory wrap = {{0.0, 0, 0, M_PI - 0.1}, {1.0, 0, 0, -M_PI + 0.1}};
  const Association b = Associate({{0.5, 0, 0, 0}}, wrap, 2.0);
  EXPECT_NEAR(std::abs(b.truth[0].yaw_rad), M_PI, 1e-12);
}

TEST(Trajectory, RpeOfAScaledTrajectory) {
  // Estimate moves 1.1 m per step where truth moves 1 m: RPE translation 0.1 m per step.
  Trajectory truth, est;
  for (int i = 0; i < 20; ++i) {
    truth.push_back({1.0 * i, 1.0 * i, 0.0, 0.0});
    est.push_back({1.0 * i, 1.1 * i, 0.0, 0.0});
  }
  const RpeResult r = Rpe(est, truth, 1);
  EXPECT_EQ(r.pairs, 19u);
  EXPECT_NEAR(r.trans_rmse_m, 0.1, 1e-9);
  EXPECT_NEAR(r.rot_rmse_rad, 0.0, 1e-12);
}

TEST(Trajectory, TumRoundTripAndErrors) {
  const auto dir = std::filesystem::temp_directory_path() / "draco_eval_test";
  std::filesystem::create_directories(dir);
  const Trajectory t = Circle(20, 5.0);
  WriteTum((dir / "a.tum").string(), t);
  const Trajectory back = ReadTum((dir / "a.tum").string());
  ASSERT_EQ(back.size(), t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_NEAR(back[i].x_m, t[i].x_m, 1e-6);
    EXPECT_NEAR(WrapAngle(back[i].yaw_rad - t[i].yaw_rad), 0.0, 1e-8);
  }
  std::ofstream((dir / "bad.tum").string()) << "# header\n0 1 2 0 0 0 0 1\n1 2 three 0 0 0 0 1\n";
  try {
    ReadTum((dir / "bad.tum").string());
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.tum:3: expected 8 numbers"), std::string::npos);
  }
  EXPECT_THROW(ReadTum((dir / "missing.tum").string()), std::runtime_error);
}

TEST(Trajectory, PathLength) {
  EXPECT_NEAR(PathLengthM(Circle(1000, 1.0)), 2 * M_PI * (999.0 / 1000.0), 1e-3);
}

}  // namespace
}  // namespace draco::eval
