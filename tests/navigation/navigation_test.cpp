// Dead reckoning against hand-computed trajectories, SE(2) covariance propagation, keyframe
// selection and the nav.DeadReckoning / slam.KeyframeSelector adapters.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <random>

#include "draco/graph/testing/harness.hpp"
#include "draco/navigation/dead_reckoning.hpp"
#include "draco/navigation/keyframes.hpp"
#include "draco/navigation/se2.hpp"

namespace draco::navigation {
namespace {

using msgs::Pose2;

msgs::DvlVelocity Dvl(double t, double vx, double vy = 0.0, bool valid = true) {
  msgs::DvlVelocity d;
  d.time_s = t;
  d.velocity_body_mps = {vx, vy, 0.0};
  d.valid = valid;
  return d;
}

msgs::Ahrs Yaw(double t, double yaw) {
  msgs::Ahrs a;
  a.time_s = t;
  a.yaw_rad = yaw;
  return a;
}

TEST(DeadReckoner, WaitsForTheAhrs) {
  DeadReckoner dr;
  EXPECT_FALSE(dr.AddDvl(Dvl(0.0, 0.5)));
  dr.AddAhrs(Yaw(0.05, 1.0));
  EXPECT_TRUE(dr.AddDvl(Dvl(0.1, 0.5)));
}

TEST(DeadReckoner, StraightLineRelativeAndAbsoluteYaw) {
  for (bool relative : {true, false}) {
    DeadReckoner dr(DeadReckoningOptions{.yaw_relative_to_first = relative});
    dr.AddAhrs(Yaw(0.0, 0.3));
    std::optional<msgs::DeadReckoning> last;
    for (int k = 0; k <= 100; ++k) last = dr.AddDvl(Dvl(0.1 * k, 0.5, 0.1));
    ASSERT_TRUE(last);
    // 10 s at (0.5, 0.1) m/s in the body frame.
    const double yaw = relative ? 0.0 : 0.3;
    EXPECT_NEAR(last->T_odom_body.x_m, 5.0 * std::cos(yaw) - 1.0 * std::sin(yaw), 1e-9);
    EXPECT_NEAR(last->T_odom_body.y_m, 5.0 * std::sin(yaw) + 1.0 * std::cos(yaw), 1e-9);
    EXPECT_NEAR(last->T_odom_body.yaw_rad, yaw, 1e-12);
    EXPECT_NEAR(last->T_prev_body.x_m, 0.05, 1e-12);
    EXPECT_NEAR(last->T_prev_body.y_m, 0.01, 1e-12);
    EXPECT_TRUE(last->dvl_ok);
  }
}

// The odom frame's absolute heading (the AHRS reading taken as yaw 0) goes out with every
// sample and on every keyframe; a gyro-only AHRS (absolute_heading false) reports none.
TEST(DeadReckoner, ReportsTheOdomFramesHeading) {
  for (const bool absolute : {true, false}) {
    DeadReckoner dr(DeadReckoningOptions{.absolute_heading = absolute});
    dr.AddAhrs(Yaw(0.0, 0.3));
    KeyframeSelector sel;
    for (int k = 0; k <= 100; ++k) {
      dr.AddAhrs(Yaw(0.1 * k, 0.3 + 0.001 * k));  // later readings do not move the frame
      const auto d = dr.AddDvl(Dvl(0.1 * k, 0.5));
      ASSERT_TRUE(d);
      if (absolute) {
        EXPECT_DOUBLE_EQ(d->odom_heading_rad, 0.3);
      } else {
        EXPECT_TRUE(std::isnan(d->odom_heading_rad));
      }
      sel.AddDeadReckoning(*d);
    }
    msgs::SonarFeatures f;
    f.time_s = 5.0;
    sel.AddFeatures(f);
    const auto kfs = sel.Poll();
    ASSERT_EQ(kfs.size(), 1u);
    if (absolute) {
      EXPECT_DOUBLE_EQ(kfs[0].odom_heading_rad, 0.3);
    } else {
      EXPECT_TRUE(std::isnan(kfs[0].odom_heading_rad));
    }
  }
}

// Constant speed and turn rate: x_N = sum_k R(w k dt) v dt, a geometric series.
TEST(DeadReckoner, CircleMatchesTheClosedFormSum) {
  const double v = 0.5, w = 0.1, dt = 0.1;
  const int n = 600;  // a full circle (2 pi / 0.1 = 62.8 s) is 628 samples
  DeadReckoner dr;
  std::optional<msgs::DeadReckoning> last;
  for (int k = 0; k <= n; ++k) {
    // AHRS at 100 Hz up to the DVL sample (the first reading at t = 0 is the yaw origin).
    for (int j = k == 0 ? 10 : 1; j <= 10; ++j) {
      const double ta = (k - 1) * dt + 0.01 * j;
      dr.AddAhrs(Yaw(ta, w * ta));
    }
    last = dr.AddDvl(Dvl(k * dt, v));
  }
  const std::complex<double> q = std::polar(1.0, w * dt);
  const std::complex<double> sum = v * dt * q * (1.0 - std::pow(q, n)) / (1.0 - q);
  EXPECT_NEAR(last->T_odom_body.x_m, sum.real(), 1e-9);
  EXPECT_NEAR(last->T_odom_body.y_m, sum.imag(), 1e-9);
  EXPECT_NEAR(last->T_odom_body.yaw_rad, se2::WrapAngle(w * n * dt), 1e-9);
  // And close to the continuous circle of radius v / w (end-of-interval yaw leads by dt/2).
  const double t = n * dt;
  EXPECT_NEAR(last->T_odom_body.x_m, v / w * std::sin(w * t), 0.05);
  EXPECT_NEAR(last->T_odom_body.y_m, v / w * (1.0 - std::cos(w * t)), 0.05);
}

TEST(DeadReckoner, SpikeHoldsTheLastGoodVelocity) {
  DeadReckoner dr;
  dr.AddAhrs(Yaw(0.0, 0.0));
  std::optional<msgs::DeadReckoning> last;
  for (int k = 0; k <= 20; ++k) {
    last = dr.AddDvl(Dvl(0.1 * k, k == 10 ? 5.0 : 0.5));
    if (k == 10) {
      EXPECT_FALSE(last->dvl_ok);
      EXPECT_DOUBLE_EQ(last->velocity_body_mps[0], 0.5);
    }
  }
  EXPECT_NEAR(last->T_odom_body.x_m, 1.0, 1e-12);
}

TEST(DeadReckoner, DropoutHoldsThenDecaysWithGrowingCovariance) {
  DeadReckoningOptions o;
  o.hold_time_s = 2.0;
  o.decay_time_s = 5.0;
  DeadReckoner dr(o);
  dr.AddAhrs(Yaw(0.0, 0.0));
  // 1 s good at 0.5 m/s, 4 s invalid, 1 s good at 0.5 m/s; 10 Hz.
  double expected_x = 0.0, prev_v = 0.5;
  std::optional<msgs::DeadReckoning> out;
  double good_var = 0.0, last_dropout_var = 0.0;
  for (int k = 0; k <= 60; ++k) {
    const double t = 0.1 * k;
    const bool valid = !(k > 10 && k <= 50);
    out = dr.AddDvl(Dvl(t, valid ? 0.5 : 0.0, 0.0, valid));
    double v = 0.5;
    if (!valid) {
      const double age = t - 1.0;
      v = age <= 2.0 ? 0.5 : 0.5 * std::exp(-(age - 2.0) / 5.0);
    }
    if (k > 0) expected_x += 0.5 * (v + prev_v) * 0.1;
    prev_v = v;
    EXPECT_NEAR(out->velocity_body_mps[0], v, 1e-12) << k;
    EXPECT_NEAR(out->T_odom_body.x_m, expected_x, 1e-9) << k;
    EXPECT_EQ(out->dvl_ok, valid);
    if (k == 5) good_var = out->covariance_prev_body[0];
    if (k == 50) last_dropout_var = out->covariance_prev_body[0];
  }
  // Sigma 0.02 + 0.05 * 4 s = 0.22 m/s against 0.02 m/s: (11)^2 times the variance.
  EXPECT_NEAR(last_dropout_var / good_var, 121.0, 1e-6);
}

TEST(DeadReckoner, GapInflatesTheCovariance) {
  DeadReckoner dr;
  dr.AddAhrs(Yaw(0.0, 0.0));
  dr.AddDvl(Dvl(0.0, 0.5));
  const auto normal = dr.AddDvl(Dvl(0.1, 0.5));
  const auto after_gap = dr.AddDvl(Dvl(2.1, 0.5));  // 2 s without samples
  EXPECT_NEAR(after_gap->T_odom_body.x_m, 1.05, 1e-12);
  // Sigma grows by 0.05 m/s per second of gap, and the step is 20 times longer.
  const double expected = std::pow((0.02 + 0.05 * 2.0) * 2.0, 2);
  EXPECT_NEAR(after_gap->covariance_prev_body[0], expected, 1e-12);
  EXPECT_GT(after_gap->covariance_prev_body[0], 100 * normal->covariance_prev_body[0]);
}

// Numerical Jacobian of T_a_c = T_a_b Exp(d1) T_b_c with respect to d1 (right perturbation).
TEST(Se2, ComposeCovarianceMatchesNumericalJacobian) {
  const Pose2 a_b{1.0, -2.0, 0.7}, b_c{3.0, 1.5, -1.1};
  const Pose2 a_c = se2::Compose(a_b, b_c);
  double jac[3][3];
  const double h = 1e-6;
  for (int j = 0; j < 3; ++j) {
    Pose2 d{0, 0, 0};
    (j == 0 ? d.x_m : j == 1 ? d.y_m : d.yaw_rad) = h;
    const Pose2 e = se2::Between(a_c, se2::Compose(se2::Compose(a_b, d), b_c));
    jac[0][j] = e.x_m / h;
    jac[1][j] = e.y_m / h;
    jac[2][j] = e.yaw_rad / h;
  }
  const msgs::Covariance3 s_ab{0.04, 0.01, 0.002, 0.01, 0.09, -0.003, 0.002, -0.003, 0.01};
  const msgs::Covariance3 zero{};
  const msgs::Covariance3 got = se2::ComposeCovariance(s_ab, b_c, zero);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double v = 0.0;
      for (int k = 0; k < 3; ++k) {
        for (int l = 0; l < 3; ++l) v += jac[i][k] * s_ab[k * 3 + l] * jac[j][l];
      }
      EXPECT_NEAR(got[i * 3 + j], v, 1e-6) << i << "," << j;
    }
  }
  // The second factor's covariance adds as is.
  const msgs::Covariance3 only_second = se2::ComposeCovariance(zero, b_c, s_ab);
  for (int i = 0; i < 9; ++i) EXPECT_DOUBLE_EQ(only_second[i], s_ab[i]);
}

TEST(IsKeyframe, TimeAndMotionThresholds) {
  const KeyframeOptions o;
  EXPECT_TRUE(IsKeyframe(o, std::nullopt, {}, 0.0, {}));
  EXPECT_FALSE(IsKeyframe(o, 0.0, {}, 0.5, Pose2{10.0, 0.0, 0.0}));  // too soon
  EXPECT_TRUE(IsKeyframe(o, 0.0, {}, 1.0, Pose2{3.01, 0.0, 0.0}));
  EXPECT_FALSE(IsKeyframe(o, 0.0, {}, 5.0, Pose2{2.0, 2.0, 0.5}));  // 2.83 m, 28.6 deg
  EXPECT_TRUE(IsKeyframe(o, 0.0, {}, 5.0, Pose2{0.0, 0.0, -0.53}));
  // Motion is measured in the last keyframe's frame, and yaw wraps.
  EXPECT_FALSE(IsKeyframe(o, 0.0, Pose2{5.0, 5.0, 3.1}, 5.0, Pose2{5.0, 5.0, -3.1}));
}

std::vector<msgs::DeadReckoning> Straight(double speed, double rate_hz, double duration_s) {
  DeadReckoner dr;
  dr.AddAhrs(Yaw(0.0, 0.0));
  std::vector<msgs::DeadReckoning> out;
  for (int k = 0; k * (1.0 / rate_hz) <= duration_s + 1e-9; ++k) {
    out.push_back(*dr.AddDvl(Dvl(k / rate_hz, speed)));
  }
  return out;
}

TEST(KeyframeSelector, StraightLineEveryThreeMetresWithInterpolatedPoses) {
  KeyframeSelector sel(KeyframeOptions{}, Pose2{0.5, 0.0, 0.0});
  for (const auto& d : Straight(0.4, 20.0, 30.0)) sel.AddDeadReckoning(d);
  msgs::SonarFeatures early;
  early.time_s = -1.0;
  sel.AddFeatures(early);  // before dead reckoning: dropped
  for (int k = 0; k < 150; ++k) {
    msgs::SonarFeatures f;
    f.time_s = 0.2 * k + 0.013;  // between DVL samples
    f.points_sensor = {{1.0, 2.0}};
    sel.AddFeatures(f);
  }
  const auto kfs = sel.Poll();
  EXPECT_EQ(sel.dropped(), 1);
  ASSERT_EQ(kfs.size(), 4u);  // 0.013 s, then every 3.2 m (> 3 m at 0.2 s steps: 8 s)
  for (std::size_t i = 0; i < kfs.size(); ++i) {
    EXPECT_EQ(kfs[i].index, static_cast<int>(i));
    EXPECT_NEAR(kfs[i].T_odom_body.x_m, 0.4 * kfs[i].time_s, 1e-9);
    EXPECT_NEAR(kfs[i].points_body[0].x_m, 1.5, 1e-12);
    if (i > 0) {
      EXPECT_NEAR(kfs[i].time_s - kfs[i - 1].time_s, 7.6, 1e-9);  // 3.04 m
      EXPECT_NEAR(kfs[i].T_prevkf_kf.x_m, 3.04, 1e-9);
      // 7.6 s of 0.02 m/s velocity noise, per 0.05 s step: 152 * (0.001)^2.
      EXPECT_NEAR(kfs[i].covariance_prevkf_kf[0], 152 * 1e-6, 2e-6);
      EXPECT_GT(kfs[i].covariance_prevkf_kf[4], kfs[i].covariance_prevkf_kf[0]);  // yaw term
      EXPECT_GT(kfs[i].covariance_prevkf_kf[8], 0.0);
    }
  }
}

TEST(KeyframeSelector, WaitsForDeadReckoningToReachThePing) {
  KeyframeSelector sel;
  const auto dr = Straight(0.5, 10.0, 2.0);
  sel.AddDeadReckoning(dr[0]);
  msgs::SonarFeatures f;
  f.time_s = 0.05;
  sel.AddFeatures(f);
  EXPECT_TRUE(sel.Poll().empty());
  sel.AddDeadReckoning(dr[1]);
  EXPECT_EQ(sel.Poll().size(), 1u);
}

// A lawnmower-like path: straight legs and turns, so both the 3 m and the 30 deg rules fire.
std::vector<msgs::DeadReckoning> Turning(double duration_s) {
  DeadReckoner dr;
  std::vector<msgs::DeadReckoning> out;
  for (int k = 0; k * 0.05 <= duration_s + 1e-9; ++k) {
    const double t = 0.05 * k;
    const double yaw = std::fmod(t, 40.0) < 30.0 ? 0.0 : 0.15 * (std::fmod(t, 40.0) - 30.0);
    dr.AddAhrs(Yaw(t, yaw + M_PI * std::floor(t / 40.0)));
    out.push_back(*dr.AddDvl(Dvl(t, 0.5)));
  }
  return out;
}

TEST(KeyframeGate, KeepsExactlyThePingsTheSelectorMakesKeyframes) {
  const auto dr = Turning(200.0);
  std::vector<double> pings;
  for (int k = 0; k < 1500; ++k) pings.push_back(-0.3 + 0.1337 * k);  // first ones before DR
  // The selector on every ping.
  KeyframeSelector all;
  for (const auto& d : dr) all.AddDeadReckoning(d);
  for (double t : pings) {
    msgs::SonarFeatures f;
    f.time_s = t;
    all.AddFeatures(f);
  }
  const auto expected = all.Poll();
  ASSERT_GT(expected.size(), 20u);
  // The gate, fed dead reckoning in chunks interleaved with the pings (undecided pings wait),
  // then the selector on the pings it passed.
  KeyframeGate gate;
  KeyframeSelector gated;
  std::size_t next_dr = 0, undecided = 0;
  std::vector<double> passed;
  for (std::size_t i = 0; i < pings.size(); ++i) {
    while (next_dr < dr.size() && dr[next_dr].time_s < pings[i] - 0.2) {
      gate.AddDeadReckoning(dr[next_dr]);
      gated.AddDeadReckoning(dr[next_dr++]);
    }
    auto verdict = gate.Decide(pings[i]);
    while (verdict == KeyframeGate::Verdict::kUndecided && next_dr < dr.size()) {
      ++undecided;
      gate.AddDeadReckoning(dr[next_dr]);
      gated.AddDeadReckoning(dr[next_dr++]);
      verdict = gate.Decide(pings[i]);
    }
    if (verdict != KeyframeGate::Verdict::kKeyframe) continue;
    passed.push_back(pings[i]);
    msgs::SonarFeatures f;
    f.time_s = pings[i];
    gated.AddFeatures(f);
  }
  while (next_dr < dr.size()) gated.AddDeadReckoning(dr[next_dr++]);
  const auto got = gated.Poll();
  EXPECT_GT(undecided, 0u);
  ASSERT_EQ(passed.size(), expected.size());
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_DOUBLE_EQ(passed[i], expected[i].time_s);
    EXPECT_DOUBLE_EQ(got[i].time_s, expected[i].time_s);
    EXPECT_DOUBLE_EQ(got[i].T_odom_body.yaw_rad, expected[i].T_odom_body.yaw_rad);
  }
}

TEST(NavigationComponents, KeyframePingsPassesOnlyKeyframePings) {
  graph::testing::Harness h("slam.KeyframePings", "min_translation_m: 0.95\n");
  const auto dr = Straight(0.5, 10.0, 10.0);  // 0.5 m/s: 1 m every 2 s
  for (int i = 0; i < 50; ++i) {
    msgs::SonarPing p;
    p.time_s = 0.2 * i + 0.05;
    p.ping_id = static_cast<std::uint32_t>(i);
    h.Feed("ping", graph::Seconds(p.time_s), p);
  }
  for (const auto& d : dr) h.Feed("odometry", graph::Seconds(d.time_s), d);
  h.RunUntilIdle();
  const auto out = h.Outputs<msgs::SonarPing>("keyframe_ping");
  // Pings 0.1 m apart: the first, then every tenth (1.0 m > 0.95 m; 0.9 m is not).
  ASSERT_EQ(out.size(), 5u);
  for (std::size_t i = 0; i < out.size(); ++i) EXPECT_EQ(out[i]->ping_id, 10u * i) << i;
}

TEST(NavigationComponents, DeadReckoningThenKeyframes) {
  graph::testing::Harness h("nav.DeadReckoning", "max_speed_mps: 2.0\n");
  h.Feed("ahrs", graph::Seconds(0.0), Yaw(0.0, 1.0));
  for (int k = 0; k <= 10; ++k) h.Feed("dvl", graph::Seconds(0.1 * k), Dvl(0.1 * k, 1.5));
  h.RunUntilIdle();
  const auto out = h.Outputs<msgs::DeadReckoning>("odometry");
  ASSERT_EQ(out.size(), 11u);
  EXPECT_NEAR(out.back()->T_odom_body.x_m, 1.5, 1e-9);

  graph::testing::Harness k("slam.KeyframeSelector", "min_translation_m: 1.0\n");
  for (const auto& m : out) k.Feed("odometry", m.stamp, m.value);
  for (int i = 0; i < 10; ++i) {
    msgs::SonarFeatures f;
    f.time_s = 0.1 * i + 0.05;
    k.Feed("features", graph::Seconds(f.time_s), f);
  }
  k.RunUntilIdle();
  const auto kfs = k.Outputs<msgs::Keyframe>("keyframe");
  ASSERT_EQ(kfs.size(), 1u);  // 1 s minimum interval
  EXPECT_NEAR(kfs[0].stamp.Seconds(), 0.05, 1e-9);
}

}  // namespace
}  // namespace draco::navigation
