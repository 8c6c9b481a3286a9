// Scan-to-scan ICP timing, ~300 points each (docs/benchmarks.md). Not run by CTest:
//   build-lslam/tests/icp/icp_bench --benchmark_repetitions=3
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "draco/icp/icp.hpp"
#include "scene.hpp"

namespace {

using draco::icp::Cloud2;
using draco::icp::IcpOptions;
using draco::msgs::Pose2;

// Pier walls and piles seen from two poses 0.5 m / 3 deg apart, 2 cm noise.
struct Scans {
  Cloud2 source, target;
  Pose2 seed;
};

Scans MakeScans() {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0.0, 0.02);
  auto scene = [&](int n) { return draco::icp::testing::Scene(rng, n); };
  Scans s;
  const Eigen::Rotation2Dd R(-0.05);
  const Eigen::Vector2d t(0.5, 0.1);
  s.target = scene(300);
  for (const auto& p : scene(300)) {
    s.source.push_back(R * (p - t) + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  s.seed = Pose2{0.3, 0.2, 0.0};  // dead reckoning, 0.2 m / 3 deg off
  return s;
}

void Run(benchmark::State& state, const IcpOptions& o) {
  const Scans s = MakeScans();
  draco::icp::IcpResult r;
  for (auto _ : state) {
    r = draco::icp::AlignIcp(s.source, s.target, s.seed, o);  // includes the kd-tree build
    benchmark::DoNotOptimize(r);
  }
  state.counters["iterations"] = r.iterations;
  // Truth: T_target_source = (R(0.05), t).
  state.counters["err_t_mm"] =
      1000.0 * std::hypot(r.T_target_source.x_m - 0.5, r.T_target_source.y_m - 0.1);
  state.counters["err_yaw_mrad"] = 1000.0 * std::abs(r.T_target_source.yaw_rad - 0.05);
  state.counters["overlap"] = r.overlap_ratio;
}

void BM_IcpPointToPoint(benchmark::State& state) { Run(state, IcpOptions{}); }
BENCHMARK(BM_IcpPointToPoint)->Unit(benchmark::kMicrosecond);

void BM_IcpPointToLine(benchmark::State& state) {
  Run(state, IcpOptions{.metric = draco::icp::Metric::kPointToLine});
}
BENCHMARK(BM_IcpPointToLine)->Unit(benchmark::kMicrosecond);

void BM_IcpReferenceConvergence(benchmark::State& state) {
  Run(state, draco::icp::ReferenceIcpOptions());
}
BENCHMARK(BM_IcpReferenceConvergence)->Unit(benchmark::kMicrosecond);

// Peer for the nearest-neighbour step: 300 queries, kd-tree against a linear scan.
void BM_NearestKdTree(benchmark::State& state) {
  const Scans s = MakeScans();
  const draco::icp::KdTree2 tree(s.target);
  for (auto _ : state) {
    int sum = 0;
    for (const auto& p : s.source) sum += tree.Nearest(p, 9.0, nullptr);
    benchmark::DoNotOptimize(sum);
  }
}
BENCHMARK(BM_NearestKdTree)->Unit(benchmark::kMicrosecond);

// The 6 nearest neighbours of each target point (what the covariance's normals ask for).
void BM_KNearestNormals(benchmark::State& state) {
  const Scans s = MakeScans();
  const draco::icp::KdTree2 tree(s.target);
  std::vector<int> knn;
  for (auto _ : state) {
    int sum = 0;
    for (const auto& p : s.target) {
      tree.KNearest(p, 6, &knn);
      sum += knn.back();
    }
    benchmark::DoNotOptimize(sum);
  }
}
BENCHMARK(BM_KNearestNormals)->Unit(benchmark::kMicrosecond);

// Building the tree over a registration-sized target (the scene, 2,000 points).
void BM_KdTreeBuild(benchmark::State& state) {
  std::mt19937_64 rng(2);
  const Cloud2 target = draco::icp::testing::Scene(rng, 2000);
  for (auto _ : state) {
    const draco::icp::KdTree2 tree(target);
    benchmark::DoNotOptimize(tree.size());
  }
}
BENCHMARK(BM_KdTreeBuild)->Unit(benchmark::kMicrosecond);

void BM_NearestBruteForce(benchmark::State& state) {
  const Scans s = MakeScans();
  for (auto _ : state) {
    int sum = 0;
    for (const auto& p : s.source) {
      int best = -1;
      double best2 = 9.0;
      for (int i = 0; i < static_cast<int>(s.target.size()); ++i) {
        const double d2 = (s.target[i] - p).squaredNorm();
        if (d2 <= best2) best2 = d2, best = i;
      }
      sum += best;
    }
    benchmark::DoNotOptimize(sum);
  }
}
BENCHMARK(BM_NearestBruteForce)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
