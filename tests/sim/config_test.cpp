// World and mission YAML: expansion of convenience objects, strict keys, errors with lines.
#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "draco/sim/mission.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim {
namespace {

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(WorldConfig, ParsesPrimitivesAndExpandsPiers) {
  const World w = ParseWorld(R"(name: test
seabed: {depth_m: 6.0}
materials: {timber: 0.2, glass: 0.5}
objects:
  - {type: pile, center_m: [1, 2], diameter_m: 0.4}
  - {type: box, center_m: [0, 0], size_m: [2, 1], yaw_deg: 90, height_m: [0, 1], material: steel}
  - {type: pier, polyline_m: [[0, 10], [12, 10]], width_m: 3, bent_spacing_m: 3, piles_per_bent: 2,
     jitter_m: 0}
  - {type: wall, points_m: [[0, 20], [5, 20], [5, 25]], material: glass}
)",
                             "inline.yaml");
  EXPECT_EQ(w.name, "test");
  EXPECT_DOUBLE_EQ(w.seabed.depth_m, 6.0);
  EXPECT_DOUBLE_EQ(w.materials[w.FindMaterial("timber")].reflectivity, 0.2);
  // 1 pile + 1 box + 5 bents x 2 piles + 2 wall segments.
  ASSERT_EQ(w.primitives.size(), 1u + 1u + 10u + 2u);
  EXPECT_EQ(w.primitives[0].kind, ShapeKind::kCircle);
  EXPECT_DOUBLE_EQ(w.primitives[0].radius_m, 0.2);
  // Default pile height: from below the seabed to above the surface.
  EXPECT_LT(w.primitives[0].z_min_m, -6.0);
  EXPECT_GT(w.primitives[0].z_max_m, 0.0);
  // Box on the seabed: height_m is relative to the seabed.
  EXPECT_DOUBLE_EQ(w.primitives[1].z_min_m, -6.0);
  EXPECT_DOUBLE_EQ(w.primitives[1].z_max_m, -5.0);
  // Pier piles at x = 0, 3, ..., 12 and y = 8.5, 11.5.
  EXPECT_NEAR(w.primitives[2].center_m.x, 0.0, 1e-9);
  EXPECT_NEAR(w.primitives[2].center_m.y, 8.5, 1e-9);
  EXPECT_NEAR(w.primitives[11].center_m.x, 12.0, 1e-9);
  EXPECT_EQ(w.primitives[12].kind, ShapeKind::kSegment);
  EXPECT_EQ(w.primitives[13].material, w.FindMaterial("glass"));
}

TEST(WorldConfig, UnknownKeyNamesFileLineAndExpectedKeys) {
  const std::string msg = ErrorOf([] {
    ParseWorld("name: t\nobjects:\n  - type: pile\n    center_m: [0, 0]\n    diamter_m: 0.3\n",
               "w.yaml");
  });
  EXPECT_NE(msg.find("w.yaml:5:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown key 'diamter_m'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("diameter_m"), std::string::npos) << msg;
}

TEST(WorldConfig, BadValuesNameTheLine) {
  std::string msg = ErrorOf([] {
    ParseWorld("name: t\nobjects:\n  - {type: pile, center_m: [0, 0], diameter_m: wide}\n",
               "w.yaml");
  });
  EXPECT_NE(msg.find("w.yaml:3:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected a number"), std::string::npos) << msg;

  msg = ErrorOf([] { ParseWorld("name: t\nobjects:\n  - {type: spaceship}\n", "w.yaml"); });
  EXPECT_NE(msg.find("w.yaml:3:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown object type 'spaceship'"), std::string::npos) << msg;

  msg = ErrorOf([] {
    ParseWorld("objects:\n  - {type: pile, center_m: [0, 0], diameter_m: 1, material: jelly}\n",
               "w.yaml");
  });
  EXPECT_NE(msg.find("w.yaml:2:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown material 'jelly'"), std::string::npos) << msg;

  msg = ErrorOf([] {
    ParseWorld(
        "objects:\n  - {type: polygon, points_m: [[0, 0], [2, 0], [1, 0.5], [2, 2], "
        "[0, 2]]}\n",
        "w.yaml");
  });
  EXPECT_NE(msg.find("convex"), std::string::npos) << msg;

  msg = ErrorOf([] { ParseWorld("name: [unclosed\n", "w.yaml"); });
  EXPECT_NE(msg.find("w.yaml:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("YAML syntax error"), std::string::npos) << msg;

  msg = ErrorOf([] { LoadWorld("/nonexistent/world.yaml"); });
  EXPECT_NE(msg.find("/nonexistent/world.yaml: cannot open file"), std::string::npos) << msg;
}

// Bad input (docs/hardening.md): counts that expand past the world's bound, segments without a
// direction, NaN and infinity, and keys that are not names are errors naming the file and
// line. Before, a pier 1e300 m long was undefined behaviour (a double beyond int cast to int;
// fuzz_recording, UBSan), 10^8 piles per bent ran out of memory, a zero-length segment gave
// NaN piles and .nan was accepted as a depth.
TEST(WorldConfig, AbsurdSizesNaNAndBadKeysAreErrors) {
  const auto error = [](const std::string& yaml) {
    return ErrorOf([&] { ParseWorld(yaml, "w.yaml"); });
  };
  std::string msg =
      error("objects:\n  - {type: pier, polyline_m: [[0, 0], [1e300, 0]], width_m: 4}\n");
  EXPECT_NE(msg.find("w.yaml:2:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("pier would expand to"), std::string::npos) << msg;
  EXPECT_NE(msg.find("a world holds at most 100000"), std::string::npos) << msg;

  msg = error(
      "objects:\n  - {type: pier, polyline_m: [[0, 0], [10, 0]], width_m: 4, "
      "piles_per_bent: 100000000}\n");
  EXPECT_NE(msg.find("pier would expand to"), std::string::npos) << msg;

  msg = error(
      "objects:\n  - {type: dock, polyline_m: [[0, 0], [30, 0]], width_m: 3, "
      "guide_pile_spacing_m: 1e-9}\n");
  EXPECT_NE(msg.find("dock would expand to"), std::string::npos) << msg;

  msg = error("objects:\n  - {type: pier, polyline_m: [[0, 0], [0, 0]], width_m: 4}\n");
  EXPECT_NE(msg.find("polyline_m point 1 equals the one before it"), std::string::npos) << msg;

  msg = error("seabed:\n  depth_m: .nan\n");
  EXPECT_NE(msg.find("w.yaml:2:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected a finite number for depth_m"), std::string::npos) << msg;

  msg = error("objects:\n  - {type: pile, center_m: [.inf, 0], diameter_m: 0.3}\n");
  EXPECT_NE(msg.find("expected a finite number"), std::string::npos) << msg;

  msg = error("materials:\n  [glass]: 0.2\n");
  EXPECT_NE(msg.find("w.yaml:2:"), std::string::npos) << msg;
  msg = error("seabed:\n  {depth_m: 1}: 2\n");
  EXPECT_NE(msg.find("expected a name as key"), std::string::npos) << msg;

  // A pier of 970 piles is fine.
  const World w = ParseWorld(
      "objects:\n  - {type: pier, polyline_m: [[0, 0], [240, 0]], width_m: 4, "
      "bent_spacing_m: 2.5, piles_per_bent: 10}\n",
      "w.yaml");
  EXPECT_EQ(w.primitives.size(), 970u);  // (240 / 2.5 + 1) bents of 10
}

TEST(MissionConfig, NaNAndInfinityAreErrors) {
  const std::string msg = ErrorOf([] {
    ParseMission(
        "world: w.yaml\nrobots:\n  - {name: a, start_m: [0, 0], speed_mps: .inf, "
        "pattern: {type: orbit, center_m: [0, 0], radius_m: 5}}\n",
        "m.yaml", ".");
  });
  EXPECT_NE(msg.find("m.yaml:3:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected a finite number for speed_mps"), std::string::npos) << msg;
}

TEST(MissionConfig, AbsurdSonarSizesNameTheFile) {
  const std::string msg = ErrorOf([] {
    ParseMission(
        "world: w.yaml\nsonar: {num_beams: 100000, num_ranges: 512}\nrobots:\n"
        "  - {name: a, start_m: [0, 0], pattern: {type: orbit, center_m: [0, 0], "
        "radius_m: 5}}\n",
        "m.yaml", ".");
  });
  EXPECT_NE(msg.find("m.yaml:2:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("sonar images of 512 x 100000 exceed what a recording holds"),
            std::string::npos)
      << msg;
}

TEST(MissionConfig, ParsesRobotsPatternsAndOverrides) {
  const Mission m = ParseMission(R"(name: m
world: worlds/w.yaml
seed: 5
duration_s: 100
sonar: {num_beams: 256, range_max_m: 20, tilt_deg: 12}
navigation: {dvl: {rate_hz: 10}, ahrs: {yaw_drift_sigma_deg: 1.5}}
robots:
  - name: a
    start_m: [1, 2]
    pattern: {type: lawnmower, origin_m: [0, 0], lanes: 3}
  - name: b
    start_m: [3, 4]
    start_yaw_deg: 90
    patterns:
      - {type: orbit, center_m: [0, 0], radius_m: 5}
      - {type: waypoints, waypoints_m: [[1, 1]]}
)",
                                 "m.yaml", "/base");
  EXPECT_EQ(m.world_path, std::filesystem::path("/base/worlds/w.yaml"));
  EXPECT_EQ(m.seed, 5u);
  EXPECT_EQ(m.sonar.num_beams, 256);
  EXPECT_DOUBLE_EQ(m.sonar.range_max_m, 20.0);
  EXPECT_NEAR(m.sonar_tilt_rad, 12.0 * M_PI / 180.0, 1e-12);
  EXPECT_DOUBLE_EQ(m.navigation.dvl.rate_hz, 10.0);
  ASSERT_EQ(m.robots.size(), 2u);
  EXPECT_EQ(m.robots[0].patterns[0].type, PatternSpec::Type::kLawnmower);
  EXPECT_EQ(m.robots[0].patterns[0].lanes, 3);
  EXPECT_EQ(m.robots[1].patterns.size(), 2u);
  EXPECT_NEAR(m.robots[1].start_yaw_rad, M_PI / 2, 1e-12);
}

TEST(MissionConfig, ErrorsNameFileAndLine) {
  std::string msg = ErrorOf([] {
    ParseMission(
        "world: w.yaml\nrobots:\n  - name: a\n    start_m: [0, 0]\n    speed: 1\n"
        "    pattern: {type: orbit, center_m: [0, 0], radius_m: 3}\n",
        "m.yaml", ".");
  });
  EXPECT_NE(msg.find("m.yaml:5:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown key 'speed'"), std::string::npos) << msg;

  msg = ErrorOf([] {
    ParseMission(
        "world: w.yaml\nrobots:\n  - name: a\n    start_m: [0, 0]\n"
        "    pattern: {type: spiral}\n",
        "m.yaml", ".");
  });
  EXPECT_NE(msg.find("m.yaml:5:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown pattern type 'spiral'"), std::string::npos) << msg;

  msg = ErrorOf([] { ParseMission("robots: []\n", "m.yaml", "."); });
  EXPECT_NE(msg.find("missing key 'world'"), std::string::npos) << msg;

  msg = ErrorOf([] {
    ParseMission(
        "world: w.yaml\nrobots:\n  - {name: a, start_m: [0, 0], pattern: {type: "
        "orbit, center_m: [0, 0], radius_m: 3}}\n  - {name: a, start_m: [1, 0], "
        "pattern: {type: orbit, center_m: [0, 0], radius_m: 3}}\n",
        "m.yaml", ".");
  });
  EXPECT_NE(msg.find("m.yaml:4:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("duplicate robot name"), std::string::npos) << msg;
}

TEST(ShippedConfigs, AllWorldsAndMissionsLoad) {
  for (const char* name : {"marina", "airplane", "sparse"}) {
    const std::string dir = DRACO_SOURCE_DIR;
    const Mission m = LoadMission(dir + "/config/missions/" + name + ".yaml");
    EXPECT_EQ(m.robots.size(), 3u) << name;
    const World w = LoadWorld(m.world_path);
    EXPECT_EQ(w.name, name);
    EXPECT_GT(w.primitives.size(), 5u) << name;
  }
}

}  // namespace
}  // namespace draco::sim
