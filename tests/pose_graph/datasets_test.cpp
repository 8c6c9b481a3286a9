// The public 2D benchmarks (tests/data/pose-graphs/README.md) reach the reference final chi2
// from a spanning-tree start with the default solver settings.
#include <gtest/gtest.h>

#include <filesystem>

#include "draco/pose_graph/g2o.hpp"

namespace draco::pose_graph {
namespace {

const std::filesystem::path kData =
    std::filesystem::path(DRACO_SOURCE_DIR) / "tests/data/pose-graphs";

// reference_chi2: the datasets README (measured with Ceres' pose_graph_2d residual, i.e.
// ErrorConvention::kCeresExample); g2o_chi2: the optimum under g2o's EDGE_SE2 error, which
// differs on the graphs with anisotropic information (intel, manhattan).
struct Dataset {
  const char* file;
  std::size_t poses;
  std::size_t edges;
  double reference_chi2;
  double g2o_chi2;
};

class G2oDataset : public ::testing::TestWithParam<Dataset> {};

void SolveFromSpanningTree(const Dataset& d, ErrorConvention convention, double expected_chi2) {
  PoseGraph2d graph = ToPoseGraph(ReadG2o(kData / d.file), FactorKind::kOdometry, convention);
  ASSERT_EQ(graph.NumPoses(), d.poses);
  ASSERT_EQ(graph.NumFactors(), d.edges);
  EXPECT_EQ(graph.InitializeFromSpanningTree(), d.poses - 1);
  const SolveSummary s = graph.Optimize();
  ASSERT_TRUE(s.usable) << s.report;
  std::printf("%s (%s): chi2 %.2f -> %.2f in %d iterations, %.3f s\n", d.file,
              convention == ErrorConvention::kG2o ? "g2o" : "ceres-example", s.initial_chi2,
              s.final_chi2, s.iterations, s.time_s);
  EXPECT_NEAR(s.final_chi2, expected_chi2, 0.01 * expected_chi2) << s.report;
}

TEST_P(G2oDataset, ReachesReferenceChi2WithCeresExampleError) {
  SolveFromSpanningTree(GetParam(), ErrorConvention::kCeresExample, GetParam().reference_chi2);
}

TEST_P(G2oDataset, ReachesOptimumOfG2oError) {
  const Dataset d = GetParam();
  SolveFromSpanningTree(d, ErrorConvention::kG2o, d.g2o_chi2);
}

INSTANTIATE_TEST_SUITE_P(Public, G2oDataset,
                         ::testing::Values(Dataset{"intel.g2o", 1728, 2512, 44.42, 45.00},
                                           Dataset{"manhattan.g2o", 3500, 5453, 3533.46, 3549.04},
                                           Dataset{"city10000.g2o", 10000, 20687, 511.99, 511.99}),
                         [](const auto& param_info) {
                           std::string name = param_info.param.file;
                           return name.substr(0, name.find('.'));
                         });

}  // namespace
}  // namespace draco::pose_graph
