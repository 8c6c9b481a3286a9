// Sonar image formation on small hand-built scenes: bright returns, shadows, first hit,
// determinism.
#include <gtest/gtest.h>

#include <cmath>

#include "draco/sim/sonar_model.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

World PileWorld(const std::string& extra = "") {
  return ParseWorld(
      "name: piles\nseabed: {depth_m: 5.0, texture_contrast: 0.0}\nobjects:\n"
      "  - {type: pile, center_m: [10, 0], diameter_m: 0.5, material: timber}\n" +
          extra,
      "piles.yaml");
}

SonarPose Pose() {
  SonarPose p;
  p.z_m = -2.0;  // 3 m above the seabed
  p.tilt_rad = 10.0 * kDeg;
  return p;
}

int BeamAt(const std::vector<float>& bearings, double bearing_rad) {
  int best = 0;
  for (int b = 0; b < static_cast<int>(bearings.size()); ++b) {
    if (std::abs(bearings[b] - bearing_rad) < std::abs(bearings[best] - bearing_rad)) best = b;
  }
  return best;
}

// Mean intensity over beams [b0, b1] and ranges [r0, r1] m.
double MeanIntensity(const msgs::SonarPing& ping, int b0, int b1, double r0, double r1) {
  double sum = 0.0;
  int n = 0;
  for (int i = 0; i < ping.num_ranges; ++i) {
    const double r = (i + 1) * ping.range_resolution_m;
    if (r < r0 || r > r1) continue;
    for (int b = b0; b <= b1; ++b) {
      sum += ping.At(i, b);
      ++n;
    }
  }
  return sum / std::max(1, n);
}

TEST(SonarModel, BearingTableIsIncreasingAndSpansTheAperture) {
  const World w = PileWorld();
  const SonarModel sonar(w, SonarOptions{});
  const auto& b = sonar.bearings_rad();
  ASSERT_EQ(b.size(), 512u);
  EXPECT_NEAR(b.front(), -65.0 * kDeg, 1e-6);
  EXPECT_NEAR(b.back(), 65.0 * kDeg, 1e-6);
  for (std::size_t i = 1; i < b.size(); ++i) ASSERT_GT(b[i], b[i - 1]);
  // Not uniform: the edge spacing is wider than the centre spacing.
  EXPECT_GT(b[1] - b[0], 1.1 * (b[256] - b[255]));
}

TEST(SonarModel, PileIsBrightAndCastsAShadowOnTheSeabed) {
  const World w = PileWorld();
  const SonarModel sonar(w, SonarOptions{});
  SonarTruth truth;
  const msgs::SonarPing ping = sonar.Render(Pose(), 0.0, 0, 42, &truth);
  ASSERT_EQ(ping.num_beams, 512);
  ASSERT_EQ(ping.num_ranges, 512);
  const auto& bearings = sonar.bearings_rad();
  const int centre = BeamAt(bearings, 0.0);

  // The pile's front face at 9.75 m: the brightest cells around it reach the top of the scale.
  int peak = 0;
  for (int i = 0; i < ping.num_ranges; ++i) {
    const double r = (i + 1) * ping.range_resolution_m;
    if (r < 9.4 || r > 10.6) continue;
    for (int b = centre - 3; b <= centre + 3; ++b) peak = std::max(peak, int{ping.At(i, b)});
  }
  EXPECT_GE(peak, 150);

  // Geometric truth: no seabed energy behind the pile in its beam (a full-height pile blocks
  // every elevation ray), plenty at the same ranges 15 deg to the side.
  double behind = 0.0;
  double beside = 0.0;
  const int side = BeamAt(bearings, 15.0 * kDeg);
  for (int i = 0; i < ping.num_ranges; ++i) {
    const double r = (i + 1) * ping.range_resolution_m;
    if (r < 14.0 || r > 28.0) continue;
    behind += truth.seabed_energy[static_cast<std::size_t>(i) * 512 + centre];
    beside += truth.seabed_energy[static_cast<std::size_t>(i) * 512 + side];
  }
  EXPECT_EQ(behind, 0.0);
  EXPECT_GT(beside, 0.0);

  // In the image: the shadow is much darker than the seabed beside it.
  const double shadow = MeanIntensity(ping, centre - 1, centre + 1, 14.0, 28.0);
  const double seabed = MeanIntensity(ping, side - 1, side + 1, 14.0, 28.0);
  EXPECT_LT(shadow, 0.5 * seabed) << "shadow " << shadow << " seabed " << seabed;
}

TEST(SonarModel, OnlyTheFirstHitIsSeen) {
  // A second pile straight behind the first is hidden; one beside it is seen.
  const World w = PileWorld(
      "  - {type: pile, center_m: [16, 0], diameter_m: 0.5, material: steel}\n"
      "  - {type: pile, center_m: [16, 4], diameter_m: 0.5, material: steel}\n");
  const SonarModel sonar(w, SonarOptions{});
  SonarTruth truth;
  sonar.Render(Pose(), 0.0, 0, 1, &truth);
  const auto& bearings = sonar.bearings_rad();
  auto object_energy_near = [&](double bearing_rad, double range_m) {
    const int beam = BeamAt(bearings, bearing_rad);
    double e = 0.0;
    for (int i = 0; i < 512; ++i) {
      const double r = (i + 1) * (30.0 / 512);
      if (std::abs(r - range_m) < 0.4)
        e += truth.object_energy[static_cast<std::size_t>(i) * 512 + beam];
    }
    return e;
  };
  EXPECT_GT(object_energy_near(0.0, 9.75), 0.0);
  EXPECT_EQ(object_energy_near(0.0, 15.75), 0.0);
  EXPECT_GT(object_energy_near(std::atan2(4.0, 16.0), std::hypot(16.0, 4.0) - 0.25), 0.0);
}

TEST(SonarModel, NormalIncidenceOnAWallIsBrighterThanGrazing) {
  const World w = ParseWorld(
      "seabed: {depth_m: 5.0}\nobjects:\n"
      "  - {type: wall, points_m: [[10, -3], [10, 3]], material: concrete}\n"
      "  - {type: wall, points_m: [[3, 6], [20, 11]], material: concrete}\n",
      "walls.yaml");
  const SonarModel sonar(w, SonarOptions{});
  SonarTruth truth;
  sonar.Render(Pose(), 0.0, 0, 3, &truth);
  const auto& bearings = sonar.bearings_rad();
  auto column_energy = [&](double bearing_rad) {
    const int beam = BeamAt(bearings, bearing_rad);
    double e = 0.0;
    for (int i = 0; i < 512; ++i)
      e += truth.object_energy[static_cast<std::size_t>(i) * 512 + beam];
    return e;
  };
  // Facing wall at bearing 0 (incidence 0) vs the oblique wall at bearing ~45 deg
  // (incidence ~ 61 deg): cos^2 ratio ~ 4.3, less absorption difference.
  EXPECT_GT(column_energy(0.0), 2.5 * column_energy(45.0 * kDeg));
}

TEST(SonarModel, DeterministicFromTheSeed) {
  const World w = PileWorld();
  const SonarModel sonar(w, SonarOptions{});
  const auto a = sonar.Render(Pose(), 1.0, 7, 99);
  const auto b = sonar.Render(Pose(), 1.0, 7, 99);
  const auto c = sonar.Render(Pose(), 1.0, 7, 100);
  EXPECT_EQ(a.intensity, b.intensity);
  int differ = 0;
  for (std::size_t i = 0; i < a.intensity.size(); ++i) differ += a.intensity[i] != c.intensity[i];
  EXPECT_GT(differ, static_cast<int>(a.intensity.size() / 3));
  // A separately built model (same world, same options) gives the same image.
  const SonarModel again(w, SonarOptions{});
  EXPECT_EQ(again.Render(Pose(), 1.0, 7, 99).intensity, a.intensity);
}

TEST(SonarModel, EmptyWaterIsDark) {
  // Nothing but the seabed: median low, almost no pixel above the CFAR threshold 65.
  const World w = ParseWorld("seabed: {depth_m: 5.0}\n", "empty.yaml");
  const SonarModel sonar(w, SonarOptions{});
  const auto ping = sonar.Render(Pose(), 0.0, 0, 5);
  std::vector<int> hist(256, 0);
  for (auto v : ping.intensity) ++hist[v];
  int above = 0;
  for (int v = 66; v < 256; ++v) above += hist[v];
  int cum = 0;
  int median = 0;
  for (int v = 0; v < 256; ++v) {
    cum += hist[v];
    if (cum * 2 >= static_cast<int>(ping.intensity.size())) {
      median = v;
      break;
    }
  }
  EXPECT_LT(static_cast<double>(above) / ping.intensity.size(), 0.005);
  EXPECT_GE(median, 3);
  EXPECT_LE(median, 40);
}

}  // namespace
}  // namespace draco::sim
