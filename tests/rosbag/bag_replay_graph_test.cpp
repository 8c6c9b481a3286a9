// A ROS 1 bag replayed through the runtime: sonar.BagReader feeding sonar.Cfar in a YAML
// graph, deterministic executor, run twice with identical statistics.
#include <string>

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

}  // namespace
}  // namespace draco::rosbag
