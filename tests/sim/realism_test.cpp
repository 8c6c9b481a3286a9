// Realism checks on the default missions (config/missions/*.yaml), against computed ground
// truth: dead-reckoning drift, CFAR bright returns on frames that see structure, background
// clutter, acoustic shadows. The figures are printed; docs/simulator.md quotes them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "draco/cfar/cfar.hpp"
#include "draco/sim/simulator.hpp"

namespace draco::sim {
namespace {

constexpr int kFramesPerRobot = 40;

struct Loaded {
  Mission mission;
  World world;
};

Loaded Load(const std::string& name) {
  Loaded l{LoadMission(std::string(DRACO_SOURCE_DIR) + "/config/missions/" + name + ".yaml"), {}};
  l.world = LoadWorld(l.mission.world_path);
  return l;
}

// Dead reckoning as the reference does it, compared with ground truth at every DVL reading.
struct DriftSink : RobotSink {
  DeadReckoning dr;
  bool have_start = false;
  msgs::GroundTruthPose start;
  msgs::GroundTruthPose last;
  double distance_m = 0.0;
  double final_error_m = 0.0;
  double max_error_m = 0.0;
  void OnPing(const msgs::SonarPing&, const TrajectorySample&) override {}
  void OnDvl(const msgs::DvlVelocity& d) override { dr.AddDvl(d); }
  void OnAhrs(const msgs::Ahrs& a) override { dr.AddAhrs(a); }
  void OnDepth(const msgs::Depth&) override {}
  void OnGroundTruth(const msgs::GroundTruthPose& g) override {
    if (!have_start) {
      start = g;
      last = g;
      have_start = true;
    }
    distance_m +=
        std::hypot(g.position_m[0] - last.position_m[0], g.position_m[1] - last.position_m[1]);
    last = g;
    const double dx = g.position_m[0] - start.position_m[0];
    const double dy = g.position_m[1] - start.position_m[1];
    const double c = std::cos(start.yaw_rad);
    const double s = std::sin(start.yaw_rad);
    final_error_m = std::hypot(c * dx + s * dy - dr.x_m(), -s * dx + c * dy - dr.y_m());
    max_error_m = std::max(max_error_m, final_error_m);
  }
};

class Realism : public ::testing::TestWithParam<std::string> {};

TEST_P(Realism, DeadReckoningDriftIsOneToThreePercentOfDistance) {
  // The mission's own seed and four more: the drift of one run is one draw of the sensor
  // errors, the check is on the model's typical drift.
  Loaded l = Load(GetParam());
  const std::uint64_t seed0 = l.mission.seed;
  double sum_percent = 0.0;
  int runs = 0;
  for (std::uint64_t seed = seed0; seed < seed0 + 5; ++seed) {
    l.mission.seed = seed;
    for (int r = 0; r < static_cast<int>(l.mission.robots.size()); ++r) {
      DriftSink sink;
      SimulateRobot(l.world, l.mission, r, nullptr, sink);
      // Drift: the largest position error over the run (closed loops hide heading errors in
      // the final error) as a fraction of the distance travelled.
      const double percent = 100.0 * sink.max_error_m / sink.distance_m;
      if (seed == seed0) {
        std::printf(
            "[realism] %s %s (seed %llu): %.0f m travelled, dead-reckoning error max "
            "%.2f m = %.2f %%, final %.2f m\n",
            GetParam().c_str(), l.mission.robots[r].name.c_str(),
            static_cast<unsigned long long>(seed), sink.distance_m, sink.max_error_m, percent,
            sink.final_error_m);
        // Mission lengths like the paper's.
        EXPECT_GT(sink.distance_m, 300.0);
        EXPECT_LT(sink.distance_m, 520.0);
      }
      EXPECT_GT(percent, 0.2);
      EXPECT_LT(percent, 6.0);
      sum_percent += percent;
      ++runs;
    }
  }
  const double mean = sum_percent / runs;
  std::printf("[realism] %s: mean drift over %d runs (5 seeds) %.2f %%\n", GetParam().c_str(), runs,
              mean);
  EXPECT_GE(mean, 1.0);
  EXPECT_LE(mean, 3.0);
}

TEST_P(Realism, SonarFramesLookLikeSonar) {
  const Loaded l = Load(GetParam());
  const SonarModel sonar(l.world, l.mission.sonar);
  const int nb = l.mission.sonar.num_beams;
  const int nr = l.mission.sonar.num_ranges;
  const double dr = l.mission.sonar.range_max_m / nr;
  cfar::CfarOptions cfar_options;  // reference: SOCA, 40 training, 20 guard, Pfa 0.1
  cfar::CfarDetector detector(cfar_options);
  std::vector<float> image(static_cast<std::size_t>(nb) * nr);
  std::vector<cfar::Cell> cells;

  std::vector<int> structure_detections;
  std::size_t background = 0;
  std::size_t background_bright = 0;
  double shadow_sum = 0.0, lit_sum = 0.0;
  std::size_t shadow_n = 0, lit_n = 0;
  for (int r = 0; r < static_cast<int>(l.mission.robots.size()); ++r) {
    const Trajectory traj = GenerateTrajectory(l.mission.robots[r], l.mission.vehicle, 0.0);
    for (int k = 0; k < kFramesPerRobot; ++k) {
      const double t =
          traj.StartTime() + (k + 0.5) / kFramesPerRobot * (traj.EndTime() - traj.StartTime());
      SonarTruth truth;
      const msgs::SonarPing ping =
          sonar.Render(SonarPoseAt(traj.At(t), l.mission.sonar_tilt_rad), t, k,
                       DeriveSeed(l.mission.seed, r + 1, k + 1), &truth);
      for (std::size_t i = 0; i < image.size(); ++i) image[i] = ping.intensity[i];
      detector.Detect(image.data(), nr, nb, 85.0f, &cells);
      // Structure seen: noise-free object returns above amplitude 0.2 (u8 51) in at least
      // 100 cells, i.e. frames a scan matcher would use.
      int lit_object_cells = 0;
      for (std::size_t i = 0; i < image.size(); ++i) {
        lit_object_cells += l.mission.sonar.gain * truth.object_energy[i] > 0.04;
        if (!truth.object_mask[i]) {
          ++background;
          background_bright += ping.intensity[i] > 65;
        }
      }
      if (lit_object_cells >= 100) structure_detections.push_back(static_cast<int>(cells.size()));
      // Shadows: per beam, the seabed beyond the first object hit that receives no seabed
      // energy, against seabed-lit cells without objects at the same ranges.
      for (int b = 0; b < nb; ++b) {
        int first_hit = -1;
        for (int i = 0; i < nr && first_hit < 0; ++i) {
          if (truth.object_energy[static_cast<std::size_t>(i) * nb + b] > 0.0f) first_hit = i;
        }
        for (int i = 0; i < nr; ++i) {
          const std::size_t c = static_cast<std::size_t>(i) * nb + b;
          if (truth.object_mask[c]) continue;
          if (truth.seabed_energy[c] > 0.0f) {
            lit_sum += ping.intensity[c];
            ++lit_n;
          } else if (first_hit >= 0 && i > first_hit + static_cast<int>(2.0 / dr)) {
            // Only where the seabed would be lit without the object: rows where this beam's
            // neighbours 10 beams away see seabed.
            const int nbeam = b + 10 < nb ? b + 10 : b - 10;
            if (truth.seabed_energy[static_cast<std::size_t>(i) * nb + nbeam] > 0.0f) {
              shadow_sum += ping.intensity[c];
              ++shadow_n;
            }
          }
        }
      }
    }
  }
  std::sort(structure_detections.begin(), structure_detections.end());
  const std::size_t n = structure_detections.size();
  ASSERT_GT(n, 10u) << "too few frames see structure";
  const int median = structure_detections[n / 2];
  const auto in_range = std::count_if(structure_detections.begin(), structure_detections.end(),
                                      [](int d) { return d >= 50 && d <= 500; });
  const double bright_fraction = static_cast<double>(background_bright) / background;
  std::printf(
      "[realism] %s: %zu of %d frames see structure; CFAR detections (SOCA, min 85) "
      "p10 %d median %d p90 %d, %.0f %% in [50, 500]; background pixels > 65: %.3f %%; "
      "shadow mean %.1f vs lit seabed %.1f (%zu shadow cells)\n",
      GetParam().c_str(), n, kFramesPerRobot * 3, structure_detections[n / 10], median,
      structure_detections[n * 9 / 10], 100.0 * in_range / n, 100.0 * bright_fraction,
      shadow_sum / std::max<std::size_t>(1, shadow_n), lit_sum / std::max<std::size_t>(1, lit_n),
      shadow_n);
  EXPECT_GE(median, 50);
  EXPECT_LE(median, 500);
  EXPECT_GE(static_cast<double>(in_range) / n, 0.6);
  EXPECT_LT(bright_fraction, 0.005);
  ASSERT_GT(shadow_n, 1000u) << "no acoustic shadows";
  EXPECT_LT(shadow_sum / shadow_n, 0.6 * lit_sum / lit_n);
}

INSTANTIATE_TEST_SUITE_P(DefaultMissions, Realism,
                         ::testing::Values("marina", "airplane", "sparse"),
                         [](const auto& param_info) { return param_info.param; });

}  // namespace
}  // namespace draco::sim
