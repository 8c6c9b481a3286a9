// A ROS 1 bag replayed through the runtime: sonar.BagReader feeding sonar.Cfar in a YAML
// graph, deterministic executor, run twice with identical statistics.
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "draco/graph/executor.hpp"
#include "draco/graph/graph.hpp"
#include "test_bags.hpp"

namespace draco::rosbag {
namespace {

const graph::ComponentStats* Find(const graph::RunStats& stats, const std::string& id) {
  for (const auto& c : stats.components) {
    if (c.id == id) return &c;
  }
  return nullptr;
}

graph::RunResult RunOnce() {
  const std::string yaml =
      "schema: 1\nname: bag_replay\nexecutor: deterministic\ncomponents:\n"
      "  - id: robot\n    type: sonar.BagReader\n    params: { bag: \"" +
      testbags::Path("bz2.bag") +
      "\" }\n"
      "  - id: cfar\n    type: sonar.Cfar\n    inputs: { ping: robot/ping }\n";
  auto graph = graph::LoadGraphString(yaml, "bag_replay.yaml");
  return graph::RunDeterministic(*graph);
}

TEST(BagReplayGraph, PingsReachTheFeatureExtractorDeterministically) {
  const graph::RunResult first = RunOnce();
  ASSERT_TRUE(first.ok) << first.error;
  const auto* robot = Find(first.stats, "robot");
  const auto* cfar = Find(first.stats, "cfar");
  ASSERT_NE(robot, nullptr);
  ASSERT_NE(cfar, nullptr);
  EXPECT_EQ(cfar->calls, 3u);                                                 // one per ping
  EXPECT_NEAR(first.stats.mission_s, 0.452 - testbags::kReceiptDelay, 1e-6);  // last IMU

  const graph::RunResult second = RunOnce();
  ASSERT_TRUE(second.ok) << second.error;
  EXPECT_EQ(Find(second.stats, "robot")->calls, robot->calls);
  EXPECT_EQ(Find(second.stats, "cfar")->calls, cfar->calls);
  EXPECT_EQ(second.stats.mission_s, first.stats.mission_s);
}

// The shipped local-SLAM graph for bags (config/graphs/local-slam-bag.yaml) runs end to end on
// a bag and writes every local-SLAM output; its ground truth holds the bag's poses.
TEST(BagReplayGraph, ShippedLocalSlamGraphRunsOnABag) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("draco_bag_local_slam_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  graph::LoadOptions load;
  load.overrides = {"reader.bag=" + testbags::Path("full.bag")};
  auto g = graph::LoadGraphFile(DRACO_SOURCE_DIR "/config/graphs/local-slam-bag.yaml", load);
  graph::RunOptions run;
  run.output_dir = dir.string();
  const auto result = graph::RunDeterministic(*g, run);
  ASSERT_TRUE(result.ok) << result.error;
  for (const char* name : {"trajectory.tum", "dead_reckoning.tum", "ground_truth.tum",
                           "pose_graph.g2o", "map.ply", "map.pcd"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / name)) << name;
  }
  // Every ping of the bag reaches the keyframe gate; CFAR runs on the keyframes' pings only,
  // one per line of the trajectory.
  const auto* pings = Find(result.stats, "pings");
  const auto* cfar = Find(result.stats, "cfar");
  ASSERT_NE(pings, nullptr);
  ASSERT_NE(cfar, nullptr);
  ASSERT_FALSE(pings->inputs.empty());
  std::uint64_t pings_in = 0;
  for (const auto& in : pings->inputs) {
    if (in.name == "ping") pings_in = in.received;
  }
  EXPECT_EQ(pings_in, 3u);
  std::ifstream trajectory(dir / "trajectory.tum");
  std::uint64_t keyframes = 0;
  for (std::string line; std::getline(trajectory, line);) {
    if (!line.empty() && line[0] != '#') ++keyframes;
  }
  EXPECT_GE(keyframes, 1u);
  EXPECT_EQ(cfar->calls, keyframes);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace draco::rosbag
