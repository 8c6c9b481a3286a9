// The team components as the graph loads them (graph::testing::Harness): parameters that need
// inputs the graph does not connect are a clear error at start.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "draco/graph/testing/harness.hpp"

namespace draco::agent {
namespace {

// The votes' negative evidence reads the own keyframes; a graph that does not connect them
// (the harness connects nothing) cannot run the matcher with it, and says which inputs.
TEST(GraphMatcherComponent, OwnSonarEvidenceNeedsTheOwnKeyframes) {
  EXPECT_NO_THROW(graph::testing::Harness("team.GraphMatcher", "robot_id: 0"));
  try {
    graph::testing::Harness h("team.GraphMatcher", "robot_id: 0\nvote_miss_weight: 2.0");
    FAIL() << "started without the own keyframes";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("keyframe and trajectory"), std::string::npos) << what;
    EXPECT_NE(what.find("vote_miss_weight"), std::string::npos) << what;
  }
  // A negative weight is refused when the parameters are read.
  EXPECT_ANY_THROW(graph::testing::Harness("team.GraphMatcher", "vote_miss_weight: -1"));
}

}  // namespace
}  // namespace draco::agent
