// Two-step vs full inter-robot PGO (docs/benchmarks.md): 3 robots x 150 keyframes, 50 loops
// (17/17/16 over the three pairs), robot 0 as own. Counters: the two-step's local and global
// step times, and full / two-step. Argument 1 (/1): anchors without the robust loss.
//   build-team/tests/team/team_bench --benchmark_repetitions=3
//   --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "draco/team/team_pgo.hpp"
#include "team_synthetic.hpp"

namespace {

using namespace draco::team;

synthetic::Mission Mission() {
  synthetic::Options o;
  o.keyframes = 150;
  o.loops_per_pair = 17;
  auto m = synthetic::MakeMission(o);
  m.problem.loops.pop_back();  // 50 loops
  return m;
}

// Argument 1: the global step's anchor priors without the robust loss.
TwoStepOptions TwoOpts(bool plain_anchors = false) {
  TwoStepOptions o;
  o.solver.num_threads = 1;
  if (plain_anchors) o.anchor_loss = {};
  return o;
}

FullOptions FullOpts() {
  FullOptions o;
  o.solver.num_threads = 1;
  return o;
}

void BM_TwoStep(benchmark::State& state) {
  const auto m = Mission();
  double local = 0, global = 0;
  for (auto _ : state) {
    const TeamEstimate e = TwoStepPgo(m.problem, 0, TwoOpts(state.range(0) != 0));
    local += e.local_time_s;
    global += e.global_time_s;
    benchmark::DoNotOptimize(e.trajectories.size());
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["local_ms"] = 1e3 * local / n;
  state.counters["global_ms"] = 1e3 * global / n;
}
BENCHMARK(BM_TwoStep)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_Full(benchmark::State& state) {
  const auto m = Mission();
  for (auto _ : state) {
    const TeamEstimate e = FullPgo(m.problem, 0, FullOpts());
    benchmark::DoNotOptimize(e.trajectories.size());
  }
}
BENCHMARK(BM_Full)->Unit(benchmark::kMillisecond);

// One pass of each, ratio full / two-step reported as a counter (medians are in the rows above).
void BM_Ratio(benchmark::State& state) {
  const auto m = Mission();
  double two = 0, full = 0;
  for (auto _ : state) {
    const TeamEstimate a = TwoStepPgo(m.problem, 0, TwoOpts(state.range(0) != 0));
    const TeamEstimate b = FullPgo(m.problem, 0, FullOpts());
    two += a.local_time_s + a.global_time_s;
    full += b.local_time_s;
  }
  state.counters["full_over_two_step"] = full / two;
}
BENCHMARK(BM_Ratio)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
