// Object map and object-graph matching timing (docs/benchmarks.md). Not run by CTest:
//   build-obj/tests/objects/objects_bench --benchmark_repetitions=3
//     --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "draco/objects/dbscan.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "draco/objects/object_mapper.hpp"
#include "object_world.hpp"

namespace {

using namespace draco::objects;  // NOLINT
using draco::msgs::ObjectMap;
using draco::msgs::Pose2;

// Two views of one world with n objects (constant density: 30 objects per 150 m square),
// each object seen with probability 0.8, plus n / 10 clutter objects.
std::pair<ObjectMap, ObjectMap> Views(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  world::WorldOptions wo;
  wo.num_objects = n;
  wo.size_m = 150.0 * std::sqrt(n / 30.0);
  const auto objects = world::RandomWorld(&rng, wo);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<int> va, vb;
  for (int i = 0; i < n; ++i) {
    if (u(rng) < 0.8) va.push_back(i);
    if (u(rng) < 0.8) vb.push_back(i);
  }
  return {world::View(objects, va, {10.0, -5.0, 0.4}, n / 10, wo, &rng),
          world::View(objects, vb, {-20.0, 30.0, 2.0}, n / 10, wo, &rng)};
}

void Match(benchmark::State& state, MatcherOptions options) {
  const auto [a, b] = Views(static_cast<int>(state.range(0)), 42);
  draco::msgs::ObjectMatch m;
  for (auto _ : state) {
    m = MatchObjectMaps(a, b, options);
    benchmark::DoNotOptimize(m);
  }
  state.counters["n_a"] = double(a.objects.size());
  state.counters["n_b"] = double(b.objects.size());
  state.counters["entries"] = m.num_affinity_entries;
  state.counters["inliers"] = m.num_inliers;
  state.counters["matched"] = m.status == draco::msgs::MatchStatus::kMatched;
}

void BM_MatchSparseCode(benchmark::State& state) { Match(state, {}); }
void BM_MatchSparsePaper(benchmark::State& state) {
  Match(state, {.affinity = AffinityForm::kPaper, .mu_per_m = 4.0});
}
void BM_MatchDenseCode(benchmark::State& state) { Match(state, {.dense = true}); }
void BM_MatchSparseComponents(benchmark::State& state) {
  Match(state, {.spectral_components = true});
}

BENCHMARK(BM_MatchSparseCode)
    ->Arg(10)
    ->Arg(20)
    ->Arg(25)
    ->Arg(30)
    ->Arg(50)
    ->Arg(100)
    ->Arg(200)
    ->Arg(500)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MatchSparseComponents)
    ->Arg(30)
    ->Arg(100)
    ->Arg(200)
    ->Arg(500)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MatchSparsePaper)->Arg(25)->Arg(200)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MatchDenseCode)->Arg(10)->Arg(20)->Arg(25)->Unit(benchmark::kMillisecond);

// Landmark matching (landmark_matcher.hpp) on the object centres of the same two views as
// points; the peer is the sparse object-graph matching of the same maps above.
void BM_MatchLandmarkPoints(benchmark::State& state) {
  const auto [a, b] = Views(static_cast<int>(state.range(0)), 42);
  std::vector<draco::msgs::Point2> pa, pb;
  for (const auto& o : a.objects) pa.push_back(o.center);
  for (const auto& o : b.objects) pb.push_back(o.center);
  LandmarkMatchOptions options;
  options.max_points = 1000;
  LandmarkMatchResult r;
  for (auto _ : state) {
    r = MatchLandmarkPoints(pa, pb, options);
    benchmark::DoNotOptimize(r);
  }
  state.counters["n_a"] = double(pa.size());
  state.counters["n_b"] = double(pb.size());
  state.counters["support"] = r.support;
  state.counters["runner_up"] = r.runner_up_support;
  state.counters["hypotheses"] = r.hypotheses;
}
BENCHMARK(BM_MatchLandmarkPoints)
    ->Arg(25)
    ->Arg(50)
    ->Arg(100)
    ->Arg(200)
    ->Arg(500)
    ->Unit(benchmark::kMillisecond);

// A robot on a lawnmower path over a 200 m square of 60 piles; each keyframe sees the
// outline of every pile within 30 m (12 points each) and 5 clutter points.
struct Mission {
  std::vector<Pose2> poses;
  std::vector<std::vector<draco::msgs::Point2>> scans;  // keyframe frame
};

Mission MakeMission(int keyframes) {
  std::mt19937_64 rng(5);
  world::WorldOptions wo;
  wo.num_objects = 60;
  wo.size_m = 200.0;
  wo.min_separation_m = 10.0;
  const auto piles = world::RandomWorld(&rng, wo);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::normal_distribution<double> g(0.0, 0.2);
  Mission m;
  for (int k = 0; k < keyframes; ++k) {
    const double s = 2.0 * k;  // 2 m per keyframe
    const int lane = static_cast<int>(s / 200.0);
    const double along = std::fmod(s, 200.0);
    const Pose2 pose{lane % 2 ? 200.0 - along : along, 20.0 * lane, lane % 2 ? M_PI : 0.0};
    const Pose2 inv = world::Inverse(pose);
    std::vector<draco::msgs::Point2> scan;
    for (const auto& p : piles) {
      if (std::hypot(p.center.x_m - pose.x_m, p.center.y_m - pose.y_m) > 30.0) continue;
      for (int i = 0; i < 12; ++i) {
        const draco::msgs::Point2 w{p.center.x_m + p.length_m * u(rng) + g(rng),
                                    p.center.y_m + p.breadth_m * u(rng) + g(rng)};
        scan.push_back(Transform(inv, w));
      }
    }
    for (int i = 0; i < 5; ++i) scan.push_back({60.0 * u(rng), 60.0 * u(rng)});
    m.poses.push_back(pose);
    m.scans.push_back(std::move(scan));
  }
  return m;
}

// Adding the last keyframe to a map of state.range(0) - 1 keyframes.
void BM_DbscanIncrementalKeyframe(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Mission m = MakeMission(n);
  ObjectMapper before;
  for (int k = 0; k + 1 < n; ++k) before.AddKeyframe(k, m.poses[k], m.scans[k]);
  for (auto _ : state) {
    state.PauseTiming();
    ObjectMapper mapper = before;
    state.ResumeTiming();
    mapper.AddKeyframe(n - 1, m.poses[n - 1], m.scans[n - 1]);
    benchmark::DoNotOptimize(mapper);
  }
  state.counters["points"] = double(before.clusters().size());
}

// The reference's step: DBSCAN over every point of the map.
void BM_DbscanBatch(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Mission m = MakeMission(n);
  std::vector<draco::msgs::Point2> points;
  for (int k = 0; k < n; ++k) {
    for (const auto& p : m.scans[k]) points.push_back(Transform(m.poses[k], p));
  }
  for (auto _ : state) benchmark::DoNotOptimize(DbscanBatch(points, {}));
  state.counters["points"] = double(points.size());
}

// Object extraction (rectangles, centres, keyframes) from the clustered map, every cluster
// described (a mapper never asked before).
void BM_ObjectsFromMap(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Mission m = MakeMission(n);
  ObjectMapper before;
  for (int k = 0; k < n; ++k) before.AddKeyframe(k, m.poses[k], m.scans[k]);
  std::size_t objects = 0;
  for (auto _ : state) {
    state.PauseTiming();
    ObjectMapper mapper = before;
    state.ResumeTiming();
    const auto map = mapper.Objects();
    objects = map.objects.size();
    benchmark::DoNotOptimize(map);
  }
  state.counters["objects"] = double(objects);
}

// The step's case: the map asked after the previous keyframe, then one keyframe more; only the
// clusters it changed are described again.
void BM_ObjectsAfterKeyframe(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Mission m = MakeMission(n);
  ObjectMapper before;
  for (int k = 0; k + 1 < n; ++k) before.AddKeyframe(k, m.poses[k], m.scans[k]);
  benchmark::DoNotOptimize(before.Objects());
  for (auto _ : state) {
    state.PauseTiming();
    ObjectMapper mapper = before;
    mapper.AddKeyframe(n - 1, m.poses[n - 1], m.scans[n - 1]);
    state.ResumeTiming();
    benchmark::DoNotOptimize(mapper.Objects());
  }
}

// A loop closure moves every keyframe: re-place all points, re-cluster, carry ids over.
void BM_ReclusterAfterLoopClosure(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Mission m = MakeMission(n);
  ObjectMapper before;
  for (int k = 0; k < n; ++k) before.AddKeyframe(k, m.poses[k], m.scans[k]);
  std::vector<KeyframePose> moved;
  for (int k = 0; k < n; ++k) {
    moved.push_back({k, {m.poses[k].x_m + 0.3, m.poses[k].y_m - 0.2, m.poses[k].yaw_rad + 0.01}});
  }
  for (auto _ : state) {
    state.PauseTiming();
    ObjectMapper mapper = before;
    state.ResumeTiming();
    benchmark::DoNotOptimize(mapper.UpdatePoses(moved));
  }
}

// The same re-clustering keyframe by keyframe through the incremental form (Clear, then Add
// per keyframe), the peer of IncrementalDbscan::Rebuild's batch computation above.
void BM_ReclusterKeyframeByKeyframe(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Mission m = MakeMission(n);
  std::vector<std::vector<draco::msgs::Point2>> placed;
  std::size_t total = 0;
  for (int k = 0; k < n; ++k) {
    const Pose2 T{m.poses[k].x_m + 0.3, m.poses[k].y_m - 0.2, m.poses[k].yaw_rad + 0.01};
    placed.emplace_back();
    for (const auto& p : m.scans[k]) placed.back().push_back(Transform(T, p));
    total += placed.back().size();
  }
  IncrementalDbscan before;
  for (const auto& p : placed) before.Add(p);
  const std::vector<int> previous = before.Labels();
  for (auto _ : state) {
    state.PauseTiming();
    IncrementalDbscan dbscan = before;
    state.ResumeTiming();
    const std::vector<int> labels = dbscan.Labels();
    dbscan.Clear();
    for (const auto& p : placed) dbscan.Add(p);
    dbscan.RemapIds(labels);
    benchmark::DoNotOptimize(dbscan);
  }
  state.counters["points"] = double(total);
}

BENCHMARK(BM_DbscanIncrementalKeyframe)
    ->Arg(100)
    ->Arg(500)
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DbscanBatch)->Arg(100)->Arg(500)->Arg(1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ObjectsFromMap)->Arg(100)->Arg(500)->Arg(1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ObjectsAfterKeyframe)->Arg(100)->Arg(500)->Arg(1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReclusterKeyframeByKeyframe)
    ->Arg(100)
    ->Arg(500)
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReclusterAfterLoopClosure)
    ->Arg(100)
    ->Arg(500)
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
