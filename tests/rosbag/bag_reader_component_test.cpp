// sonar.BagReader through the runtime's one-component harness, on the test bags.
#include <string>

#include <gtest/gtest.h>

#include "draco/graph/testing/harness.hpp"
#include "draco/msgs/sensors.hpp"
#include "test_bags.hpp"

namespace draco::rosbag {
namespace {

using graph::Seconds;
using graph::testing::Harness;

std::string Params(const std::string& bag, const std::string& extra = "") {
  return "bag: \"" + testbags::Path(bag) + "\"\n" + extra;
}

TEST(BagReaderComponent, ReplaysEveryStreamStampedInMissionTime) {
  Harness h("sonar.BagReader", Params("lz4.bag"));
  h.RunUntilIdle();
  EXPECT_EQ(h.error(), "");
  const auto pings = h.Outputs<msgs::SonarPing>("ping");
  ASSERT_EQ(pings.size(), 3u);
  for (std::size_t k = 0; k < pings.size(); ++k) {
    EXPECT_EQ(pings[k]->ping_id, 100 + k);
    EXPECT_EQ(pings[k]->num_beams, testbags::kNumBeams);
    EXPECT_NEAR(pings[k]->time_s, 0.2 * k - testbags::kReceiptDelay, 1e-6);
  }
  // The first header stamp precedes the bag start: its envelope is clamped to 0.
  EXPECT_EQ(pings[0].stamp, Seconds(0.0));
  EXPECT_EQ(pings[2].stamp, Seconds(pings[2]->time_s));
  for (std::size_t i = 1; i < pings.size(); ++i) EXPECT_LT(pings[i - 1].stamp, pings[i].stamp);
  EXPECT_EQ(h.Outputs<msgs::DvlVelocity>("dvl").size(), 3u);
  EXPECT_EQ(h.Outputs<msgs::Ahrs>("ahrs").size(), 10u);
  EXPECT_EQ(h.Outputs<msgs::Depth>("depth").size(), 5u);
  const auto truth = h.Outputs<msgs::GroundTruthPose>("ground_truth");
  ASSERT_EQ(truth.size(), 5u);
  EXPECT_EQ(truth[4]->position_m[0], 4.0);
}

TEST(BagReaderComponent, ParametersReachTheReader) {
  Harness h("sonar.BagReader",
            Params("full.bag", "frd_to_flu: false\nimu_topic: \"\"\nuse_header_stamp: false\n"));
  h.RunUntilIdle();
  EXPECT_EQ(h.error(), "");
  EXPECT_TRUE(h.Outputs<msgs::Ahrs>("ahrs").empty());
  const auto dvl = h.Outputs<msgs::DvlVelocity>("dvl");
  ASSERT_EQ(dvl.size(), 3u);
  EXPECT_EQ(dvl[1]->velocity_body_mps[1], -0.1);
  // Receipt time - bag start; the writer's stamps are within a microsecond of the script's.
  EXPECT_NEAR(dvl[1].stamp.Seconds(), 0.2 + 0.001, 1e-6);
}

TEST(BagReaderComponent, StartFailsNamingTheProblem) {
  auto start_error = [](const std::string& params) -> std::string {
    try {
      Harness h("sonar.BagReader", params);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(start_error("").find("'bag' is not set"), std::string::npos);
  EXPECT_NE(start_error(Params("nope.bag")).find("nope.bag: cannot open"), std::string::npos);
  EXPECT_NE(start_error(Params("not_a_bag.bag")).find("not_a_bag.bag"), std::string::npos);
}

TEST(BagReaderComponent, BadMessageStopsTheRunOrIsSkipped) {
  {
    Harness h("sonar.BagReader", Params("truncated_message.bag"));
    h.RunUntilIdle();
    EXPECT_NE(h.error().find("truncated_message.bag: topic /sonar_oculus_node/M750d/ping, "
                             "message 1"),
              std::string::npos)
        << h.error();
    EXPECT_LE(h.Outputs<msgs::SonarPing>("ping").size(), 1u);
  }
  {
    Harness h("sonar.BagReader", Params("truncated_message.bag", "skip_bad_messages: true\n"));
    h.RunUntilIdle();
    EXPECT_EQ(h.error(), "");
    EXPECT_EQ(h.Outputs<msgs::SonarPing>("ping").size(), 1u);
  }
}

}  // namespace
}  // namespace draco::rosbag
