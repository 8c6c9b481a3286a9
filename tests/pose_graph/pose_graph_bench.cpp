// Pose-graph benchmarks (not a test): solver settings on the public g2o datasets from a
// spanning-tree start, and the per-keyframe cost of incremental updates on a 1,000-keyframe
// graph. Every solve row reports the final chi2 so a faster setting that stops early shows.
//
//   build-pg/tests/pose_graph/pose_graph_bench --benchmark_repetitions=3
//       --benchmark_report_aggregates_only=true   (one command line)
//
// DRACO_BENCH_G2O=FILE adds the Solve rows for that file too (e.g. a run's
// <robot>.pose_graph.g2o, written by the local SLAM: its own graph, loops and landmarks).
//
// Rows named baseline use Ceres' defaults for this problem class (Levenberg-Marquardt,
// sparse normal Cholesky with SuiteSparse, one thread) so ratios stay meaningful on a noisy
// machine.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "draco/pose_graph/g2o.hpp"
#include "synthetic.hpp"

namespace draco::pose_graph {
namespace {

const std::filesystem::path kData =
    std::filesystem::path(DRACO_SOURCE_DIR) / "tests/data/pose-graphs";

// A bare name is one of tests/data/pose-graphs; a path is read as given.
const G2oGraph& Dataset(const std::string& file) {
  static std::map<std::string, G2oGraph> cache;
  auto it = cache.find(file);
  if (it == cache.end()) {
    const std::filesystem::path path(file);
    it = cache.emplace(file, ReadG2o(path.has_parent_path() ? path : kData / file)).first;
  }
  return it->second;
}

struct Config {
  const char* name;
  SolverOptions options;
};

// baseline: Ceres' defaults (LM, initial trust region 1e4, SuiteSparse, one thread).
// default: SolverOptions{} (LM, initial trust region 1e12, Eigen sparse Cholesky, two threads).
const Config kConfigs[] = {
    {"baseline_ceres_defaults",
     {.sparse_backend = SparseBackend::kSuiteSparse,
      .num_threads = 1,
      .initial_trust_region_radius = 1e4}},
    {"default", {}},
    {"default_1thread", {.num_threads = 1}},
    {"default_suitesparse", {.sparse_backend = SparseBackend::kSuiteSparse}},
    {"default_cxsparse", {.sparse_backend = SparseBackend::kCxSparse}},
    {"default_radius1e8", {.initial_trust_region_radius = 1e8}},
    {"default_noscaling", {.jacobi_scaling = false}},
    {"default_ftol1e-4", {.function_tolerance = 1e-4}},
    {"lm_radius1e4_2threads", {.initial_trust_region_radius = 1e4}},
    {"dogleg", {.algorithm = Algorithm::kDogleg, .initial_trust_region_radius = 1e4}},
    {"dogleg_suitesparse",
     {.algorithm = Algorithm::kDogleg,
      .sparse_backend = SparseBackend::kSuiteSparse,
      .initial_trust_region_radius = 1e4}},
};

// Build + spanning tree outside the timed region; one Optimize() timed per iteration.
void BM_Solve(benchmark::State& state, std::string file, SolverOptions options) {
  const G2oGraph& g2o = Dataset(file);
  double chi2 = 0.0, iterations = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    PoseGraph2d graph = ToPoseGraph(g2o);
    graph.InitializeFromSpanningTree();
    state.ResumeTiming();
    const SolveSummary s = graph.Optimize(options);
    state.PauseTiming();
    chi2 = s.final_chi2;
    iterations = s.iterations;
    {
      PoseGraph2d discard = std::move(graph);  // destruction outside the timed region
    }
    state.ResumeTiming();
  }
  state.counters["chi2"] = chi2;
  state.counters["iterations"] = iterations;
}

// The synthetic 1,000-keyframe mission: grid walk, odometry and loop closures.
const testing::SyntheticGraph& Mission() {
  static const testing::SyntheticGraph g = testing::MakeGridWalk(
      {.num_poses = 1000, .sigma_xy_m = 0.1, .sigma_yaw_rad = 0.01, .loop_every = 10});
  return g;
}

// Feeds keyframes 1..n-1 one at a time (pose from odometry, its odometry and loop factors,
// then one solve) and reports the mean and worst wall time per keyframe; Update() with the
// given full_solve_max_boundary_chi2, or a full solve every keyframe.
void BM_IncrementalMission(benchmark::State& state, bool full_every_keyframe,
                           double max_boundary_chi2) {
  const auto& g = Mission();
  const IncrementalOptions options{.full_solve_max_boundary_chi2 = max_boundary_chi2};
  double total_s = 0.0, worst_s = 0.0, fulls = 0.0, loops = 0.0, keyframes = 0.0;
  for (auto _ : state) {
    PoseGraph2d graph;
    graph.AddPose(0, g.truth[0]);
    graph.AddPrior(0, g.truth[0], InformationFromSigmas(0.1, 0.1, 0.01));
    total_s = worst_s = fulls = loops = keyframes = 0.0;
    std::size_t e = 0;
    for (int k = 1; k < static_cast<int>(g.truth.size()); ++k) {
      const auto start = std::chrono::steady_clock::now();
      graph.AddPose(k, Compose(graph.Pose(k - 1), g.edges[e].T_i_j));
      for (; e < g.edges.size() && g.edges[e].j == k; ++e) {
        graph.AddBetween(g.edges[e].i, k, g.edges[e].T_i_j, g.Information(),
                         g.edges[e].loop ? FactorKind::kLoop : FactorKind::kOdometry);
        loops += g.edges[e].loop ? 1 : 0;
      }
      const SolveSummary s = full_every_keyframe ? graph.Optimize() : graph.Update(options);
      const double dt =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      total_s += dt;
      worst_s = std::max(worst_s, dt);
      fulls += s.full ? 1 : 0;
      keyframes += 1;
    }
    benchmark::DoNotOptimize(graph.Chi2());
  }
  state.counters["ms_per_keyframe"] = 1e3 * total_s / keyframes;
  state.counters["worst_ms"] = 1e3 * worst_s;
  state.counters["full_solves"] = fulls;
  state.counters["loops"] = loops;
}

// One more keyframe on an already solved graph of about 1,000 keyframes.
void BM_KeyframeAt1000(benchmark::State& state, int mode) {
  const auto& g = Mission();
  PoseGraph2d graph;
  graph.AddPose(0, g.truth[0]);
  graph.AddPrior(0, g.truth[0], InformationFromSigmas(0.1, 0.1, 0.01));
  for (std::size_t e = 0; e < g.edges.size(); ++e) {
    if (!g.edges[e].loop)
      graph.AddPose(g.edges[e].j, Compose(graph.Pose(g.edges[e].i), g.edges[e].T_i_j));
    graph.AddBetween(g.edges[e].i, g.edges[e].j, g.edges[e].T_i_j, g.Information());
  }
  graph.Optimize();
  PoseId next = static_cast<PoseId>(g.truth.size());
  const Pose2 step{1.0, 0.0, 0.01};
  for (auto _ : state) {
    graph.AddPose(next, Compose(graph.Pose(next - 1), step));
    graph.AddBetween(next - 1, next, step, g.Information());
    ++next;
    const SolveSummary s = mode == 0   ? graph.Optimize()
                           : mode == 1 ? graph.OptimizeWindow(20, IncrementalOptions{}.local)
                                       : graph.Update();
    benchmark::DoNotOptimize(s.final_chi2);
  }
}

void Register() {
  std::vector<std::string> files{"intel.g2o", "manhattan.g2o", "city10000.g2o"};
  if (const char* extra = std::getenv("DRACO_BENCH_G2O"); extra && *extra)
    files.emplace_back(extra);
  for (const std::string& file : files) {
    const std::string label = std::filesystem::path(file).filename().string();
    for (const Config& c : kConfigs) {
      benchmark::RegisterBenchmark(("Solve/" + label + "/" + c.name).c_str(), BM_Solve, file,
                                   c.options)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime()
          ->Iterations(1);
    }
  }
  benchmark::RegisterBenchmark("Incremental1000/update", BM_IncrementalMission, false, 0.0)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->Iterations(1);
  benchmark::RegisterBenchmark("Incremental1000/update_window_first", BM_IncrementalMission, false,
                               11.34)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->Iterations(1);
  benchmark::RegisterBenchmark("Incremental1000/baseline_full_every_keyframe",
                               BM_IncrementalMission, true, 0.0)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->Iterations(1);
  benchmark::RegisterBenchmark("KeyframeAt1000/baseline_full", BM_KeyframeAt1000, 0)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("KeyframeAt1000/window20", BM_KeyframeAt1000, 1)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
}

}  // namespace
}  // namespace draco::pose_graph

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  draco::pose_graph::Register();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
