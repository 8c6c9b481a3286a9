// Consistency-filter timing (docs/benchmarks.md). Not run by CTest:
//   build-cons/tests/consistency/consistency_bench --benchmark_repetitions=3
//     --benchmark_report_aggregates_only=true
// Candidates: the synthetic 3-robot mission (tests/consistency/synthetic.hpp), 40 % true
// loops, 60 % wrong ones (half random, half in correlated groups of 6).
#include <benchmark/benchmark.h>

#include <vector>

#include "draco/consistency/filter.hpp"
#include "draco/consistency/graph_pose_source.hpp"
#include "draco/consistency/max_clique.hpp"
#include "synthetic.hpp"

namespace {

using namespace draco::consistency;

synthetic::Mission MakeCandidates(int n) {
  synthetic::MissionOptions mo;
  mo.keyframes_per_robot = 160;
  mo.inliers = n * 2 / 5;
  mo.outlier_fraction = 0.3;  // random
  mo.seed = 7;
  synthetic::Mission m = synthetic::MakeMission(mo);
  mo.inliers = 0;
  mo.outlier_fraction = 0.0;
  // Top up with correlated groups until n candidates.
  synthetic::MissionOptions go = mo;
  go.inliers = n - static_cast<int>(m.loops.size());
  go.outlier_fraction = 0.5;
  go.outliers = synthetic::OutlierKind::kCorrelated;
  go.seed = 8;
  const synthetic::Mission g = synthetic::MakeMission(go);
  for (std::size_t i = 0; i < g.loops.size() && static_cast<int>(m.loops.size()) < n; ++i) {
    if (g.inlier[i]) continue;
    auto loop = g.loops[i];
    loop.id = m.loops.size();
    m.loops.push_back(loop);
    m.inlier.push_back(false);
  }
  return m;
}

Graph ConsistencyGraph(const synthetic::Mission& m) {
  Graph graph(static_cast<int>(m.loops.size()));
  for (std::size_t a = 0; a < m.loops.size(); ++a) {
    for (std::size_t b = a + 1; b < m.loops.size(); ++b) {
      if (TestPair(m.loops[a], m.loops[b], m.poses, {}).consistent) {
        graph.AddEdge(static_cast<int>(a), static_cast<int>(b));
      }
    }
  }
  return graph;
}

// One decision from scratch: all pair tests and the maximum clique (GCM, default options).
// Args: candidates, covariance (0 propagated, 1 first-loop), pair tests (1 PairTester,
// 0 TestPair per pair: the straightforward path, the peer of the same run).
void BM_DecisionBatch(benchmark::State& state) {
  const auto m = MakeCandidates(static_cast<int>(state.range(0)));
  FilterOptions fo;
  fo.pairwise.covariance =
      state.range(1) == 0 ? CovarianceModel::kPropagated : CovarianceModel::kFirstLoop;
  fo.fast_pair_tests = state.range(2) != 0;
  fo.map_prior_gate = false;  // every pair tested (the gate would spare the gated loops')
  bool exact = true;
  std::int64_t nodes = 0;
  std::int64_t pairs = 0;
  for (auto _ : state) {
    ConsistencyFilter filter(fo);
    const Decision d = filter.Add(m.loops, m.poses);
    exact = exact && d.exact;
    nodes = d.clique_nodes;
    pairs = d.pair_tests;
    benchmark::DoNotOptimize(d.accepted.data());
  }
  state.counters["candidates"] = static_cast<double>(m.loops.size());
  state.counters["nodes"] = static_cast<double>(nodes);
  state.counters["pairs"] = static_cast<double>(pairs);
  state.SetLabel(std::string(CovarianceModelName(fo.pairwise.covariance)) +
                 (fo.fast_pair_tests ? " PairTester" : " TestPair") + (exact ? "" : " heuristic"));
}
BENCHMARK(BM_DecisionBatch)
    ->Args({200, 0, 1})
    ->Args({200, 0, 0})
    ->Args({1000, 0, 1})
    ->Args({1000, 0, 0})
    ->Args({200, 1, 1})
    ->Args({1000, 1, 1})
    ->Unit(benchmark::kMillisecond);

// One incremental step: 10 new candidates against n - 10 held ones.
void BM_DecisionIncremental(benchmark::State& state) {
  const auto m = MakeCandidates(static_cast<int>(state.range(0)));
  const std::vector<draco::msgs::InterRobotLoop> held(m.loops.begin(), m.loops.end() - 10);
  const std::vector<draco::msgs::InterRobotLoop> fresh(m.loops.end() - 10, m.loops.end());
  FilterOptions fo;
  fo.fast_pair_tests = state.range(1) != 0;
  fo.map_prior_gate = false;
  for (auto _ : state) {
    state.PauseTiming();
    ConsistencyFilter filter(fo);
    filter.Add(held, m.poses);
    state.ResumeTiming();
    const Decision d = filter.Add(fresh, m.poses);
    benchmark::DoNotOptimize(d.accepted.data());
  }
}
BENCHMARK(BM_DecisionIncremental)
    ->Args({200, 1})
    ->Args({1000, 1})
    ->Args({1000, 0})
    ->Unit(benchmark::kMillisecond);

// Maximum clique alone on the consistency graph: ours vs naive Bron-Kerbosch (no pivot).
// The naive peer is exponential in the inlier clique, so the ratio rows use small sets.
void BM_CliqueExact(benchmark::State& state) {
  const Graph g = ConsistencyGraph(MakeCandidates(static_cast<int>(state.range(0))));
  std::size_t size = 0;
  for (auto _ : state) {
    const CliqueResult r = MaximumClique(g);
    size = r.vertices.size();
    benchmark::DoNotOptimize(r.vertices.data());
  }
  state.counters["clique"] = static_cast<double>(size);
}
BENCHMARK(BM_CliqueExact)->Arg(40)->Arg(60)->Arg(200)->Arg(1000)->Unit(benchmark::kMillisecond);

void BM_CliqueNaiveBronKerbosch(benchmark::State& state) {
  const Graph g = ConsistencyGraph(MakeCandidates(static_cast<int>(state.range(0))));
  std::size_t size = 0;
  for (auto _ : state) {
    const auto c = MaximumCliqueBronKerboschNaive(g);
    size = c.size();
    benchmark::DoNotOptimize(c.data());
  }
  state.counters["clique"] = static_cast<double>(size);
}
BENCHMARK(BM_CliqueNaiveBronKerbosch)->Arg(40)->Arg(60)->Unit(benchmark::kMillisecond);

// Relative-pose covariances from a robot's whole pose graph (GraphPoseSource::SetRobot: the
// dense inverse of the information) against the open chain's cumulative covariances
// (ChainPoseSource, the peer). Arg: keyframes; the graph holds the chain plus a loop factor
// every 20 keyframes back to keyframe k - 15.
std::vector<Pose2> Lawn(int n) {
  std::vector<Pose2> poses;
  Pose2 p{};
  for (int k = 0; k < n; ++k) {
    poses.push_back(p);
    p = Compose(p, Pose2{2.0, 0.0, (k % 25 == 24) ? 1.2 : 0.0});
  }
  return poses;
}

void BM_GraphPoseSourceSetRobot(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto poses = Lawn(n);
  const Eigen::Matrix3d info = Eigen::Vector3d(2500.0, 2500.0, 1e6).asDiagonal();
  std::vector<RelativeFactor> factors;
  for (int k = 1; k < n; ++k) factors.push_back({k - 1, k, Between(poses[k - 1], poses[k]), info});
  for (int k = 20; k < n; k += 20)
    factors.push_back({k, k - 15, Between(poses[k], poses[k - 15]), info});
  for (auto _ : state) {
    GraphPoseSource g;
    g.SetRobot(0, poses, factors);
    benchmark::DoNotOptimize(g.NumKeyframes(0));
  }
}
BENCHMARK(BM_GraphPoseSourceSetRobot)->Arg(100)->Arg(200)->Arg(400)->Unit(benchmark::kMillisecond);

void BM_ChainPoseSourceBuild(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto poses = Lawn(n);
  const Eigen::Matrix3d step = Eigen::Vector3d(4e-4, 4e-4, 1e-6).asDiagonal();
  for (auto _ : state) {
    ChainPoseSource c;
    for (const auto& p : poses) c.AddKeyframe(0, p, step);
    benchmark::DoNotOptimize(c.NumKeyframes(0));
  }
}
BENCHMARK(BM_ChainPoseSourceBuild)->Arg(100)->Arg(200)->Arg(400)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
