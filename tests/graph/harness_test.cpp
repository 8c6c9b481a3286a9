// The one-component harness: build from type name + inline YAML, feed, run, read outputs.
#include "draco/graph/testing/harness.hpp"

#include <gtest/gtest.h>

namespace draco::graph::testing {
namespace {

TEST(Harness, FeedsAndCollectsInStampOrder) {
  Harness h("example.Scale", "factor: 2.0");
  h.Feed("in", Seconds(0.2), 5.0);
  h.Feed("in", Seconds(0.1), 21.0);  // fed later, stamped earlier: delivered first
  h.RunUntilIdle();
  const auto out = h.Outputs<double>("out");
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(*out[0], 42.0);
  EXPECT_EQ(out[0].stamp, Seconds(0.1));
  EXPECT_EQ(*out[1], 10.0);
  EXPECT_EQ(*out[0].producer, "under_test");
}

TEST(Harness, NonTriggeringLatestInput) {
  Harness h("example.Sum");
  h.Feed("b", Seconds(0.0), 100.0);
  h.Feed("b", Seconds(0.1), 200.0);  // replaces 100: only the latest is kept
  h.RunUntilIdle();
  EXPECT_TRUE(h.Outputs<double>("out").empty());  // b does not trigger
  h.Feed("a", Seconds(0.2), 1.0);
  h.RunUntilIdle();
  ASSERT_EQ(h.Outputs<double>("out").size(), 1u);
  EXPECT_EQ(*h.Outputs<double>("out")[0], 201.0);
}

TEST(Harness, TimersFireWithRunUntil) {
  Harness h("example.RateMeter");
  for (int i = 0; i < 7; ++i) h.Feed("in", Seconds(0.1 * i), 1.0);
  h.RunUntil(Seconds(2.5));
  const auto out = h.Outputs<double>("count");
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(*out[0], 7.0);
  EXPECT_EQ(out[0].stamp, Seconds(1.0));
  EXPECT_EQ(*out[1], 0.0);
}

TEST(Harness, SourceRunsToExhaustion) {
  Harness h("example.Ticker", "count: 4\nperiod_s: 0.5\nfirst: 1\nstep: 2");
  h.RunUntilIdle();
  const auto out = h.Outputs<double>("value");
  ASSERT_EQ(out.size(), 4u);
  EXPECT_EQ(*out[3], 7.0);
  EXPECT_EQ(out[3].stamp, Seconds(1.5));
}

TEST(Harness, ErrorsAreCountedNotFatal) {
  Harness h("example.Scale", "fail_above: 1.0", RunOptions{.log_errors = false});
  h.Feed("in", Seconds(0.0), 5.0);
  h.RunUntilIdle();
  EXPECT_EQ(h.stats().components[0].errors, 1u);
  EXPECT_EQ(h.error(), "");
}

TEST(Harness, RejectsBadParamsPortsAndTypes) {
  EXPECT_THROW(Harness("example.Scale", "factr: 2"), GraphError);
  EXPECT_THROW(Harness("example.Nope"), GraphError);
  Harness h("example.Scale");
  EXPECT_THROW(h.Feed("nope", Seconds(0), 1.0), std::invalid_argument);
  EXPECT_THROW(h.Feed("in", Seconds(0), 1), std::invalid_argument);  // int, not double
  EXPECT_THROW(h.Outputs<int>("out"), std::invalid_argument);
}

}  // namespace
}  // namespace draco::graph::testing
