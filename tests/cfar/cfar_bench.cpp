// CFAR timing per 512 x 512 ping (docs/benchmarks.md). Not run by CTest:
//   build-lslam/tests/cfar/cfar_bench --benchmark_repetitions=3
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "draco/cfar/cfar.hpp"

namespace {

using draco::cfar::Cell;
using draco::cfar::CfarDetector;
using draco::cfar::CfarOptions;
using draco::cfar::Method;

constexpr int kRows = 512, kCols = 512;

// Speckle background with a few bright arcs and a wall, like a marina ping.
draco::msgs::SonarPing MakePing() {
  draco::msgs::SonarPing ping;
  ping.num_ranges = kRows;
  ping.num_beams = kCols;
  ping.range_resolution_m = 30.0 / kRows;
  const double fov = 120.0 * M_PI / 180.0;
  for (int b = 0; b < kCols; ++b)
    ping.bearings_rad.push_back(float(-fov / 2 + fov * b / (kCols - 1)));
  std::mt19937_64 rng(1);
  std::exponential_distribution<double> dist(1.0 / 20.0);
  ping.intensity.resize(kRows * kCols);
  for (auto& v : ping.intensity) v = static_cast<std::uint8_t>(std::min(255.0, dist(rng)));
  for (int b = 100; b < 400; ++b) {
    const int row =
        static_cast<int>(15.0 / std::cos(ping.bearings_rad[b]) / ping.range_resolution_m);
    if (row < kRows) ping.intensity[row * kCols + b] = 230;
  }
  for (int k = 0; k < 40; ++k) {
    for (int d = 0; d < 6; ++d) ping.intensity[(80 + 10 * k) * kCols + 11 * k + d] = 200;
  }
  return ping;
}

std::vector<float> ToFloat(const draco::msgs::SonarPing& ping) {
  return std::vector<float>(ping.intensity.begin(), ping.intensity.end());
}

void BM_Detect(benchmark::State& state, Method method) {
  const auto image = ToFloat(MakePing());
  CfarDetector detector(CfarOptions{.method = method});
  std::vector<Cell> cells;
  for (auto _ : state) {
    detector.Detect(image.data(), kRows, kCols, 85.0f, &cells);
    benchmark::DoNotOptimize(cells.data());
  }
  state.counters["detections"] = static_cast<double>(cells.size());
}
BENCHMARK_CAPTURE(BM_Detect, SOCA, Method::kSoca)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Detect, CA, Method::kCa)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Detect, GOCA, Method::kGoca)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Detect, OS, Method::kOs)->Unit(benchmark::kMillisecond);

// Peer: the textbook SOCA with a window loop per cell (what the running sums replace).
void BM_NaiveSoca(benchmark::State& state) {
  const auto image = ToFloat(MakePing());
  const double tau = draco::cfar::ThresholdFactor(Method::kSoca, 40, 0.1);
  const int n = 20, g = 10;
  std::vector<Cell> cells;
  for (auto _ : state) {
    cells.clear();
    for (int b = 0; b < kCols; ++b) {
      for (int r = n + g; r < kRows - n - g; ++r) {
        double lead = 0.0, lag = 0.0;
        for (int k = 1; k <= n; ++k) {
          lead += image[(r - g - k) * kCols + b];
          lag += image[(r + g + k) * kCols + b];
        }
        const double v = image[r * kCols + b];
        if (v > 85.0 && v > tau * std::min(lead, lag) / n) cells.push_back(Cell{r, b});
      }
    }
    benchmark::DoNotOptimize(cells.data());
  }
  state.counters["detections"] = static_cast<double>(cells.size());
}
BENCHMARK(BM_NaiveSoca)->Unit(benchmark::kMillisecond);

// The whole pipeline with the defaults: u8 to float, SOCA, threshold, polar to Cartesian,
// medoid voxel grid, radius filter.
void BM_FeatureExtractor(benchmark::State& state) {
  const auto ping = MakePing();
  draco::cfar::FeatureExtractor extractor{draco::cfar::FeatureOptions{}};
  draco::cfar::FeatureStats stats;
  for (auto _ : state) {
    auto points = extractor.Extract(ping, &stats);
    benchmark::DoNotOptimize(points.data());
  }
  state.counters["detections"] = stats.detections;
  state.counters["points"] = stats.kept;
}
BENCHMARK(BM_FeatureExtractor)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
