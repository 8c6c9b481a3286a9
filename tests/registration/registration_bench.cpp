// Not a test: one sliding-window inter-robot registration (target build, kd-tree, ICP,
// overlap) on the synthetic seabed of the tests, window 3 against window 0 (docs/benchmarks.md).
#include <benchmark/benchmark.h>

#include <numbers>

#include "draco/registration/registration.hpp"
#include "synthetic.hpp"

namespace draco::registration {
namespace {

void BM_WindowRegistration(benchmark::State& state) {
  const auto world = synthetic::World(7);
  const Pose2 T_world_own{5.0, -3.0, 0.3}, T_world_team{-7.0, 2.0, -0.8};
  const auto own = synthetic::Survey(world, {-20.0, 0.0, 0.0}, 21, T_world_own);
  const auto team = synthetic::Survey(world, {-6.0, -4.0, 0.17}, 10, T_world_team);
  const Pose2 truth =
      Between(Compose(T_world_own, own[10].T_map_kf), Compose(T_world_team, team[3].T_map_kf));
  // The graph-matching seed is off by 0.8 m, 0.5 m and 4 deg.
  const Pose2 seed = Compose(truth, Pose2{0.8, -0.5, 4.0 * std::numbers::pi / 180.0});
  RegistrationOptions o;
  o.window = static_cast<int>(state.range(0));
  if (state.range(1) == 0) {  // without the ambiguity test (19 more ICP runs when accepted)
    o.ambiguity_offsets_m.clear();
    o.ambiguity_turns_deg.clear();
  }
  int accepted = 0, iterations = 0, target = 0;
  for (auto _ : state) {
    const auto r = RegisterScan(own, 10, team[3].points_kf, seed, o);
    benchmark::DoNotOptimize(r.loop.T_ownkf_teammatekf);
    accepted += r.accepted();
    iterations = r.icp.iterations;
    target = r.target_points;
  }
  state.counters["accepted"] = static_cast<double>(accepted) / state.iterations();
  state.counters["icp_iters"] = iterations;
  state.counters["target_pts"] = target;
  state.counters["source_pts"] = static_cast<double>(team[3].points_kf.size());
}
BENCHMARK(BM_WindowRegistration)
    ->ArgsProduct({{0, 1, 3}, {0, 1}})
    ->ArgNames({"window", "ambiguity_test"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace draco::registration

BENCHMARK_MAIN();
