// CFAR: threshold factors, measured false-alarm rates on exponential noise, targets, edges,
// downsampling, the outlier filter and the sonar.Cfar adapter.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "draco/cfar/cfar.hpp"
#include "draco/graph/testing/harness.hpp"
#include "draco/msgs/sensors.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::cfar {
namespace {

std::vector<float> ExponentialNoise(int rows, int cols, double mean, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::exponential_distribution<double> dist(1.0 / mean);
  std::vector<float> image(static_cast<std::size_t>(rows) * cols);
  for (float& v : image) v = static_cast<float>(dist(rng));
  return image;
}

TEST(ThresholdFactor, MatchesTableFor40Cells) {
  EXPECT_NEAR(ThresholdFactor(Method::kSoca, 40, 0.1), 2.749, 1e-3);
  EXPECT_NEAR(ThresholdFactor(Method::kSoca, 40, 0.01), 5.755, 1e-3);
  EXPECT_NEAR(ThresholdFactor(Method::kCa, 40, 0.1), 2.370, 1e-3);
  EXPECT_NEAR(ThresholdFactor(Method::kCa, 40, 0.01), 4.881, 1e-3);
  EXPECT_NEAR(ThresholdFactor(Method::kGoca, 40, 0.1), 2.122, 1e-3);
  EXPECT_NEAR(ThresholdFactor(Method::kGoca, 40, 0.01), 4.398, 1e-3);
}

TEST(ThresholdFactor, InvertsFalseAlarmProbability) {
  for (Method m : {Method::kCa, Method::kSoca, Method::kGoca, Method::kOs}) {
    for (int n : {8, 16, 40, 64}) {
      for (double pfa : {0.2, 0.1, 1e-2, 1e-4}) {
        const double tau = ThresholdFactor(m, n, pfa);
        EXPECT_NEAR(FalseAlarmProbability(m, n, tau) / pfa, 1.0, 1e-9)
            << MethodName(m) << " n=" << n << " pfa=" << pfa;
      }
    }
  }
  // Zero threshold: every cell is a detection.
  EXPECT_NEAR(FalseAlarmProbability(Method::kSoca, 40, 0.0), 1.0, 1e-12);
  EXPECT_NEAR(FalseAlarmProbability(Method::kGoca, 40, 0.0), 1.0, 1e-12);
}

TEST(ThresholdFactor, RejectsBadOptions) {
  EXPECT_THROW(ThresholdFactor(Method::kSoca, 41, 0.1), std::invalid_argument);
  EXPECT_THROW(ThresholdFactor(Method::kSoca, 40, 0.0), std::invalid_argument);
  EXPECT_THROW(ThresholdFactor(Method::kOs, 40, 0.1, 41), std::invalid_argument);
  EXPECT_THROW(CfarDetector(CfarOptions{.guard_cells = 3}), std::invalid_argument);
}

// Square-law noise: the measured rate over the fully tested cells is within 10 % of Pfa.
TEST(CfarDetector, FalseAlarmRateOnExponentialNoise) {
  const int rows = 1000, cols = 1000;
  const std::vector<float> image = ExponentialNoise(rows, cols, 3.0, 42);
  for (Method m : {Method::kSoca, Method::kCa, Method::kGoca, Method::kOs}) {
    for (double pfa : {0.1, 0.01}) {
      CfarDetector detector(CfarOptions{.method = m, .false_alarm_probability = pfa});
      std::vector<Cell> cells;
      detector.Detect(image.data(), rows, cols, -1.0f, &cells);
      const int reach = 30;
      const double tested = static_cast<double>(rows - 2 * reach) * cols;
      const double rate = cells.size() / tested;
      EXPECT_NEAR(rate / pfa, 1.0, 0.1) << MethodName(m) << " pfa " << pfa << " rate " << rate;
      for (const Cell& c : cells) {
        ASSERT_GE(c.range_bin, reach);
        ASSERT_LT(c.range_bin, rows - reach);
      }
    }
  }
}

TEST(CfarDetector, EdgeCells) {
  const int rows = 200, cols = 20000;  // many columns: statistics on the 30 edge rows
  std::vector<float> image = ExponentialNoise(rows, cols, 1.0, 7);
  // Strong targets on the first and last rows and in the middle.
  for (int b = 0; b < cols; b += 1000) {
    image[static_cast<std::size_t>(0) * cols + b] = 1000.0f;
    image[static_cast<std::size_t>(rows - 1) * cols + b] = 1000.0f;
    image[static_cast<std::size_t>(100) * cols + b] = 1000.0f;
  }
  auto is_target = [&](const Cell& c) {
    return c.beam % 1000 == 0 &&
           (c.range_bin == 0 || c.range_bin == rows - 1 || c.range_bin == 100);
  };
  std::vector<Cell> cells;
  CfarDetector none(CfarOptions{.false_alarm_probability = 0.01});
  none.Detect(image.data(), rows, cols, -1.0f, &cells);
  int mid_targets = 0;
  for (const Cell& c : cells) {
    EXPECT_GE(c.range_bin, 30);
    EXPECT_LT(c.range_bin, rows - 30);
    mid_targets += is_target(c);
  }
  EXPECT_EQ(mid_targets, cols / 1000);

  CfarDetector one_sided(
      CfarOptions{.false_alarm_probability = 0.01, .edge_mode = EdgeMode::kOneSided});
  one_sided.Detect(image.data(), rows, cols, -1.0f, &cells);
  int targets = 0;
  double edge_false = 0.0;
  for (const Cell& c : cells) {
    if (is_target(c)) {
      ++targets;
    } else if (c.range_bin < 30 || c.range_bin >= rows - 30) {
      ++edge_false;
    }
  }
  EXPECT_EQ(targets, 3 * cols / 1000);
  // The one-sided test keeps the false-alarm rate on the edge rows.
  const double edge_rate = edge_false / (60.0 * cols - 2.0 * cols / 1000);
  EXPECT_NEAR(edge_rate / 0.01, 1.0, 0.1) << edge_rate;
}

TEST(CfarDetector, ShortColumnsHaveNoDetections) {
  const std::vector<float> image = ExponentialNoise(60, 10, 1.0, 3);  // 2 * 30 rows: none tested
  std::vector<Cell> cells{{1, 1}};
  CfarDetector(CfarOptions{}).Detect(image.data(), 60, 10, -1.0f, &cells);
  EXPECT_TRUE(cells.empty());
}

msgs::SonarPing MakePing(int rows, int cols, double res, double fov_rad, std::uint64_t seed) {
  msgs::SonarPing ping;
  ping.time_s = 12.5;
  ping.ping_id = 9;
  ping.num_ranges = rows;
  ping.num_beams = cols;
  ping.range_resolution_m = res;
  for (int b = 0; b < cols; ++b) {
    ping.bearings_rad.push_back(static_cast<float>(-fov_rad / 2 + fov_rad * b / (cols - 1)));
  }
  std::mt19937_64 rng(seed);
  std::exponential_distribution<double> dist(1.0 / 5.0);  // P(noise > 85) = 4e-8
  ping.intensity.resize(static_cast<std::size_t>(rows) * cols);
  for (auto& v : ping.intensity) v = static_cast<std::uint8_t>(std::min(255.0, dist(rng)));
  return ping;
}

TEST(FeatureExtractor, DetectsTargetsAtTheirRangeAndBearing) {
  msgs::SonarPing ping = MakePing(512, 256, 0.05, 2.0, 11);
  const int targets[][2] = {{100, 30}, {250, 128}, {400, 200}};
  for (const auto& t : targets) ping.intensity[t[0] * 256 + t[1]] = 220;
  FeatureOptions o;
  o.downsample = Downsample::kNone;
  o.outlier_radius_m = 0.0;
  FeatureExtractor extractor(o);
  FeatureStats stats;
  const auto points = extractor.Extract(ping, &stats);
  ASSERT_EQ(points.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const double r = (targets[i][0] + 1) * 0.05;
    const double b = ping.bearings_rad[targets[i][1]];
    EXPECT_NEAR(points[i].x_m, r * std::cos(b), 1e-9);
    EXPECT_NEAR(points[i].y_m, r * std::sin(b), 1e-9);
  }
  EXPECT_EQ(stats.detections, 3);
}

TEST(FeatureExtractor, WallSurvivesDownsamplingAndFilterNoiseDoesNot) {
  msgs::SonarPing ping = MakePing(512, 512, 30.0 / 512, 120.0 * M_PI / 180.0, 5);
  // A wall x = 15 m in the sensor frame, bright, plus isolated bright speckles.
  for (int b = 0; b < 512; ++b) {
    const double bearing = ping.bearings_rad[b];
    if (std::abs(bearing) > 0.5) continue;
    const int row =
        static_cast<int>(std::lround(15.0 / std::cos(bearing) / ping.range_resolution_m)) - 1;
    ping.intensity[row * 512 + b] = 240;
  }
  // Speckles away from the wall (|bearing| > 0.6 rad): no neighbours there.
  for (int k = 0; k < 20; ++k) {
    ping.intensity[(60 + 20 * k) * 512 + (k % 2 ? 5 + 5 * k : 500 - 5 * k)] = 250;
  }
  FeatureExtractor extractor(FeatureOptions{});
  FeatureStats stats;
  const auto points = extractor.Extract(ping, &stats);
  EXPECT_GT(stats.detections, stats.downsampled);
  ASSERT_GT(points.size(), 10u);
  for (const auto& p : points) {
    EXPECT_NEAR(p.x_m, 15.0, 0.1);
    EXPECT_LT(std::abs(p.y_m), 15.0 * std::tan(0.5) + 0.1);
  }
}

TEST(VoxelDownsample, MedoidIsAMemberCentroidIsTheMean) {
  const std::vector<msgs::Point2> pts{{0.1, 0.1}, {0.2, 0.1}, {0.4, 0.4}, {1.2, 0.1}};
  const auto medoid = VoxelDownsample(pts, 0.5, Downsample::kMedoid);
  ASSERT_EQ(medoid.size(), 2u);
  EXPECT_DOUBLE_EQ(medoid[0].x_m, 0.2);
  EXPECT_DOUBLE_EQ(medoid[0].y_m, 0.1);
  EXPECT_DOUBLE_EQ(medoid[1].x_m, 1.2);
  const auto centroid = VoxelDownsample(pts, 0.5, Downsample::kCentroid);
  ASSERT_EQ(centroid.size(), 2u);
  EXPECT_NEAR(centroid[0].x_m, 0.7 / 3, 1e-12);
  EXPECT_NEAR(centroid[0].y_m, 0.2, 1e-12);
  // Negative coordinates fall in their own cells.
  EXPECT_EQ(VoxelDownsample({{-0.1, 0.1}, {0.1, 0.1}}, 0.5, Downsample::kMedoid).size(), 2u);
}

TEST(RadiusOutlierFilter, KeepsClustersDropsIsolatedPoints) {
  std::vector<msgs::Point2> pts;
  for (int i = 0; i < 6; ++i) pts.push_back({-3.0 + 0.15 * i, 2.0});  // 6 points: 5 neighbours
  pts.push_back({10.0, 10.0});
  for (int i = 0; i < 5; ++i) pts.push_back({5.0 + 0.1 * i, -5.0});  // 5 points: 4 neighbours
  const auto kept = RadiusOutlierFilter(pts, 1.0, 5);
  ASSERT_EQ(kept.size(), 6u);
  for (const auto& p : kept) EXPECT_DOUBLE_EQ(p.y_m, 2.0);
  EXPECT_EQ(RadiusOutlierFilter(pts, 1.0, 4).size(), 11u);
}

TEST(CfarComponent, PublishesFeaturesWithThePingTime) {
  graph::testing::Harness h("sonar.Cfar", "downsample: none\noutlier_radius_m: 0.0\nmethod: CA\n");
  msgs::SonarPing ping = MakePing(512, 256, 0.05, 2.0, 11);
  ping.intensity[200 * 256 + 50] = 230;
  h.Feed("ping", graph::Seconds(12.5), ping);
  h.RunUntilIdle();
  const auto out = h.Outputs<msgs::SonarFeatures>("features");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0]->time_s, 12.5);
  EXPECT_EQ(out[0]->ping_id, 9u);
  ASSERT_EQ(out[0]->points_sensor.size(), 1u);
  EXPECT_NEAR(std::hypot(out[0]->points_sensor[0].x_m, out[0]->points_sensor[0].y_m), 201 * 0.05,
              1e-9);
}

}  // namespace
}  // namespace draco::cfar
