// Registration back ends (icp.hpp): PCL's ICP, GICP and NDT and MRPT's ICP recover a known planar
// transform on the marina-like scene as draco's ICP does; a prepared target serves many sources and
// a change of back end; the back end is chosen by name in YAML, unknown names are refused with the
// choices listed.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>

#include "draco/graph/graph.hpp"
#include "draco/graph/testing/harness.hpp"
#include "draco/icp/icp.hpp"
#include "scene.hpp"

namespace draco::icp {
namespace {

struct Pair {
  Cloud2 source, target;
  msgs::Pose2 truth{1.2, -0.7, 0.15};  // T_target_source
};

// Two views of the scene, 3 cm noise, 10 % outliers in the source.
Pair MakePair(std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, 0.03);
  std::uniform_real_distribution<double> u(-10.0, 25.0);
  Pair p;
  p.target = testing::Scene(rng, 600);
  const Eigen::Rotation2Dd R(-p.truth.yaw_rad);
  const Eigen::Vector2d t = -(R * Eigen::Vector2d(p.truth.x_m, p.truth.y_m));
  for (const auto& w : testing::Scene(rng, 600)) {
    p.source.push_back(R * w + t + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  for (int i = 0; i < 60; ++i) p.source[i] = {u(rng), u(rng)};
  return p;
}

class BackendRecovers : public ::testing::TestWithParam<Backend> {};

TEST_P(BackendRecovers, KnownTransformWithNoiseAndOutliers) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 3; ++trial) {
    const Pair p = MakePair(rng);
    IcpOptions o;
    o.backend = GetParam();
    // Seeded like dead reckoning would: 0.5 m and 5 deg off.
    const msgs::Pose2 seed{p.truth.x_m + 0.4, p.truth.y_m - 0.3, p.truth.yaw_rad + 0.09};
    const IcpResult r = AlignIcp(p.source, p.target, seed, o);
    ASSERT_TRUE(r.valid) << BackendName(o.backend);
    EXPECT_GT(r.iterations, 0);
    EXPECT_NEAR(r.T_target_source.x_m, p.truth.x_m, 0.05) << BackendName(o.backend) << trial;
    EXPECT_NEAR(r.T_target_source.y_m, p.truth.y_m, 0.05) << BackendName(o.backend) << trial;
    EXPECT_NEAR(r.T_target_source.yaw_rad, p.truth.yaw_rad, 0.005)
        << BackendName(o.backend) << trial;
    // Covariance and overlap are draco's, whatever the back end.
    EXPECT_GT(r.overlap_ratio, 0.8);
    EXPECT_GT(r.covariance[0], 0.0);
    EXPECT_GT(r.covariance[8], 0.0);
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, BackendRecovers,
                         ::testing::Values(Backend::kDraco, Backend::kPclIcp, Backend::kPclGicp,
                                           Backend::kPclNdt, Backend::kMrptIcp),
                         [](const auto& i) { return std::string(BackendName(i.param)); });

TEST(Backends, PreparedTargetServesManySourcesAndBackEnds) {
  std::mt19937_64 rng(5);
  const Pair a = MakePair(rng);
  Cloud2 other;
  const Cloud2* sources[] = {&a.source, &other};
  const Eigen::Rotation2Dd R(0.05);
  for (const auto& p : a.source) other.push_back(R * p + Eigen::Vector2d(0.1, 0.2));
  IcpTarget prepared(a.target);
  for (const Backend b : {Backend::kPclIcp, Backend::kPclGicp, Backend::kPclNdt, Backend::kMrptIcp,
                          Backend::kDraco, Backend::kPclIcp, Backend::kMrptIcp}) {
    IcpOptions o;
    o.backend = b;
    for (const Cloud2* source : sources) {
      const IcpResult fresh = AlignIcp(*source, a.target, a.truth, o);
      const IcpResult reused = AlignIcp(*source, prepared, a.truth, o);
      EXPECT_EQ(fresh.T_target_source.x_m, reused.T_target_source.x_m) << BackendName(b);
      EXPECT_EQ(fresh.T_target_source.yaw_rad, reused.T_target_source.yaw_rad) << BackendName(b);
      EXPECT_EQ(fresh.iterations, reused.iterations) << BackendName(b);
    }
  }
}

TEST(Backends, FewPointsAreInvalidNotACrash) {
  const Cloud2 target{{0, 0}, {1, 0}, {0, 1}};
  const Cloud2 source{{0.1, 0}, {5, 5}};
  for (const Backend b :
       {Backend::kPclIcp, Backend::kPclGicp, Backend::kPclNdt, Backend::kMrptIcp}) {
    IcpOptions o;
    o.backend = b;
    const IcpResult r = AlignIcp(source, target, {}, o);
    EXPECT_FALSE(r.valid) << BackendName(b);
    EXPECT_FALSE(AlignIcp(Cloud2{}, target, {}, o).valid) << BackendName(b);
  }
}

TEST(Backends, NamesRoundTripAndUnknownNamesListTheChoices) {
  for (const auto& name : BackendNames()) EXPECT_EQ(BackendName(ParseBackend(name)), name);
  EXPECT_EQ(ParseBackend("draco"), Backend::kDraco);
  try {
    ParseBackend("ndt");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("draco, pcl_icp, pcl_gicp, pcl_ndt, mrpt_icp"),
              std::string::npos)
        << e.what();
  }
}

TEST(Backends, ChosenInYamlAndValidated) {
  for (const char* name : {"pcl_icp", "pcl_gicp", "pcl_ndt", "mrpt_icp"}) {
    EXPECT_NO_THROW(
        graph::testing::Harness("slam.IcpOdometry", std::string("backend: ") + name + "\n"));
  }
  try {
    graph::testing::Harness h("slam.IcpOdometry", "backend: gicp\n");
    FAIL() << "no exception";
  } catch (const std::exception& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("gicp"), std::string::npos) << what;
    EXPECT_NE(what.find("mrpt_icp"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace draco::icp
