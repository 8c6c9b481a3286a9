// Generated worlds and missions (draco/sim/generator.hpp): same seed same bytes, different
// seeds different worlds, every file loads with the simulator's loaders, objects apart, planned
// paths clear of them, at least half the worlds periodic, style errors with file and line.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <string>

#include "draco/sim/generator.hpp"
#include "draco/sim/mission.hpp"
#include "draco/sim/trajectory.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim {
namespace {

namespace fs = std::filesystem;

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// The world without its header lines (which name the seed).
std::string WorldBody(const std::string& yaml) { return yaml.substr(yaml.find("seabed:")); }

TEST(Generator, SameSeedSameBytes) {
  const GeneratorOptions options;
  const Scenario a = GenerateScenario(options, 7);
  const Scenario b = GenerateScenario(options, 7);
  EXPECT_EQ(a.world_yaml, b.world_yaml);
  EXPECT_EQ(a.mission_yaml, b.mission_yaml);
  EXPECT_EQ(a.summary, b.summary);
}

TEST(Generator, DifferentSeedsDifferentWorlds) {
  const GeneratorOptions options;
  std::set<std::string> worlds;
  std::set<std::string> missions;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const Scenario s = GenerateScenario(options, seed);
    worlds.insert(WorldBody(s.world_yaml));
    missions.insert(s.mission_yaml.substr(s.mission_yaml.find("robots:")));
  }
  EXPECT_EQ(worlds.size(), 10u);
  EXPECT_EQ(missions.size(), 10u);
}

TEST(Generator, ShippedHarbourStyleIsTheDefault) {
  const GeneratorOptions shipped =
      LoadGeneratorOptions(std::string(DRACO_SOURCE_DIR) + "/config/generator/harbour.yaml");
  for (std::uint64_t seed : {3u, 4u}) {
    const Scenario a = GenerateScenario(shipped, seed);
    const Scenario b = GenerateScenario(GeneratorOptions{}, seed);
    EXPECT_EQ(a.world_yaml, b.world_yaml);
    EXPECT_EQ(a.mission_yaml, b.mission_yaml);
    EXPECT_EQ(a.summary, b.summary);
  }
}

TEST(Generator, Seeds1To40LoadKeepApartAndKeepClear) {
  const GeneratorOptions options;
  const fs::path dir = fs::temp_directory_path() / "draco_generator_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  int periodic_worlds = 0;
  int robots_total = 0;
  int overlap_in_range = 0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Scenario s = GenerateScenario(options, seed);
    std::ofstream(dir / "world.yaml") << s.world_yaml;
    std::ofstream(dir / "mission.yaml") << s.mission_yaml;
    const World world = LoadWorld(dir / "world.yaml");
    const Mission mission = LoadMission(dir / "mission.yaml");
    EXPECT_EQ(mission.world_path, dir / "world.yaml");

    const int n = static_cast<int>(mission.robots.size());
    EXPECT_GE(n, 3);
    EXPECT_LE(n, 8);
    EXPECT_EQ(static_cast<int>(s.path_length_m.size()), n);
    robots_total += n;

    // Periodic: a pile grid or pier is present exactly when the summary says so.
    bool has_periodic = false;
    for (const auto& g : world.groups) {
      has_periodic = has_periodic || g.rfind("pile_grid_", 0) == 0 || g.rfind("pier_", 0) == 0;
    }
    EXPECT_EQ(has_periodic, s.periodic);
    EXPECT_NE(s.summary.find(std::string("periodic: ") + (s.periodic ? "true" : "false")),
              std::string::npos);
    periodic_worlds += s.periodic;

    // Objects (named structures) do not overlap each other.
    const auto& prims = world.primitives;
    for (std::size_t i = 0; i < prims.size(); ++i) {
      for (std::size_t j = i + 1; j < prims.size(); ++j) {
        if (world.groups[prims[i].group] == world.groups[prims[j].group]) continue;
        if (Norm(prims[i].center_m - prims[j].center_m) > prims[i].radius_m + prims[j].radius_m) {
          continue;
        }
        EXPECT_GT(FootprintGap(prims[i], prims[j]), 0.0)
            << world.groups[prims[i].group] << " touches " << world.groups[prims[j].group];
      }
    }

    // Planned paths keep 3 m from every object; robots within the style's ranges.
    for (int r = 0; r < n; ++r) {
      const RobotSpec& robot = mission.robots[r];
      const std::vector<Vec2> path = PatternPath(robot);
      double length = 0.0;
      double clearance = 1e9;
      double altitude = 1e9, max_altitude = 0.0;
      for (std::size_t k = 0; k < path.size(); ++k) {
        if (k > 0) length += Norm(path[k] - path[k - 1]);
        altitude = std::min(altitude, -world.seabed.ZAt(path[k].x, path[k].y) - robot.depth_m);
        max_altitude =
            std::max(max_altitude, -world.seabed.ZAt(path[k].x, path[k].y) - robot.depth_m);
        for (const auto& p : prims) {
          if (Norm(path[k] - p.center_m) - p.radius_m > clearance) continue;
          clearance = std::min(clearance, FootprintDistance(p, path[k]));
        }
      }
      EXPECT_GE(clearance, 3.0) << robot.name;
      EXPECT_NEAR(length, s.path_length_m[r], 1e-6) << robot.name;
      EXPECT_GE(length, 200.0) << robot.name;
      EXPECT_LE(length, 350.0) << robot.name;
      EXPECT_GE(robot.speed_mps, 0.3);
      EXPECT_LE(robot.speed_mps, 0.4);
      // Within the style's 1-3 m, deeper only where the bed is deeper than 3 + 8 m (the DVL
      // keeps bottom lock within 10 m).
      EXPECT_GE(robot.depth_m, 1.0);
      if (robot.depth_m > 3.0) {
        EXPECT_LE(max_altitude, 8.05) << robot.name;
      }
      EXPECT_LE(max_altitude, 9.5) << robot.name;
      EXPECT_GE(altitude, 2.0) << robot.name;
      EXPECT_GE(robot.start_time_s, 0.0);
      EXPECT_LE(robot.start_time_s, 120.0);
      EXPECT_GE(s.near_structure[r], 0.6) << robot.name;
      overlap_in_range += s.overlap[r] >= 0.2 && s.overlap[r] <= 0.8;
    }
    const double tilt_deg = mission.sonar_tilt_rad * 180.0 / M_PI;
    EXPECT_GE(tilt_deg, 5.0 - 1e-9);
    EXPECT_LE(tilt_deg, 10.0 + 1e-9);
  }
  EXPECT_GE(periodic_worlds, 20);
  // Overlap is re-drawn for, not guaranteed: nearly every robot must be in [20, 80] %.
  EXPECT_GE(overlap_in_range, robots_total * 95 / 100);
  std::printf("seeds 1-40: %d periodic worlds, %d robots, %d with overlap in [20, 80] %%\n",
              periodic_worlds, robots_total, overlap_in_range);
  fs::remove_all(dir);
}

TEST(Generator, RobotsOverride) {
  GeneratorOptions options;
  options.robots = {8, 8};
  const Scenario s = GenerateScenario(options, 5);
  const Mission m = ParseMission(s.mission_yaml, "mission.yaml", ".");
  EXPECT_EQ(m.robots.size(), 8u);
  EXPECT_EQ(m.robots.back().name, "hotel");
}

TEST(Generator, MalformedStyleNamesFileAndLine) {
  std::string msg = ErrorOf([] {
    ParseGeneratorOptions("name: x\npier:\n  length_m: [20, 50]\n  widht_m: [4, 8]\n", "s.yaml");
  });
  EXPECT_NE(msg.find("s.yaml:4:3:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown key 'widht_m'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("width_m"), std::string::npos) << msg;

  msg = ErrorOf([] { ParseGeneratorOptions("mission:\n  overlap: [0.9, 0.2]\n", "s.yaml"); });
  EXPECT_NE(msg.find("s.yaml:2:"), std::string::npos) << msg;

  msg = ErrorOf([] { ParseGeneratorOptions("boat:\n  count: [two, 3]\n", "s.yaml"); });
  EXPECT_NE(msg.find("s.yaml:2:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected an integer"), std::string::npos) << msg;

  msg = ErrorOf([] { ParseGeneratorOptions("wrecks:\n  probability: 0.5\n", "s.yaml"); });
  EXPECT_NE(msg.find("s.yaml:1:1:"), std::string::npos) << msg;

  const fs::path file = fs::temp_directory_path() / "draco_bad_style.yaml";
  std::ofstream(file) << "name: bad\nworld:\n  size_m: [80, 160]\n  sise_m: 3\n";
  msg = ErrorOf([&] { LoadGeneratorOptions(file); });
  EXPECT_NE(msg.find(file.string() + ":4:3:"), std::string::npos) << msg;
  fs::remove(file);
}

}  // namespace
}  // namespace draco::sim
