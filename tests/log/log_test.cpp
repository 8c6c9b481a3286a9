// The logger's level filter and per-place rate limit, observed through an injected sink and
// a hand-driven clock (no stderr, no global state).
#include "draco/log/log.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace draco::log {
namespace {

struct Captured {
  std::vector<std::pair<Level, std::string>> lines;
  double now_s = 100.0;

  Logger Make(Options options = {}) {
    return Logger(
        options, [this](Level l, std::string_view m) { lines.emplace_back(l, std::string(m)); },
        [this] { return now_s; });
  }
};

// Logs from one source line, so every call is the same place.
void LogFromOnePlace(Logger& logger, Level level, const std::string& message,
                     std::string_view key = {}) {
  logger.Write(level, message, std::source_location::current(), key);
}

TEST(Log, ParsesEveryLevelAndRejectsOthersNamingTheChoices) {
  EXPECT_EQ(ParseLevel("trace"), Level::kTrace);
  EXPECT_EQ(ParseLevel("debug"), Level::kDebug);
  EXPECT_EQ(ParseLevel("info"), Level::kInfo);
  EXPECT_EQ(ParseLevel("warn"), Level::kWarn);
  EXPECT_EQ(ParseLevel("warning"), Level::kWarn);
  EXPECT_EQ(ParseLevel("error"), Level::kError);
  EXPECT_EQ(ParseLevel("off"), Level::kOff);
  for (Level l : {Level::kTrace, Level::kDebug, Level::kInfo, Level::kWarn, Level::kError}) {
    EXPECT_EQ(ParseLevel(LevelName(l)), l);
  }
  try {
    ParseLevel("verbose");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'verbose'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("trace, debug, info, warn, error or off"),
              std::string::npos)
        << e.what();
  }
}

TEST(Log, PrintsOnlyMessagesAtOrAboveTheLevel) {
  Captured c;
  Logger logger = c.Make();  // default: info
  logger.Write(Level::kTrace, "t");
  logger.Write(Level::kDebug, "d");
  logger.Write(Level::kInfo, "i");
  logger.Write(Level::kWarn, "w");
  logger.Write(Level::kError, "e");
  ASSERT_EQ(c.lines.size(), 3u);
  EXPECT_EQ(c.lines[0], std::make_pair(Level::kInfo, std::string("i")));
  EXPECT_EQ(c.lines[1], std::make_pair(Level::kWarn, std::string("w")));
  EXPECT_EQ(c.lines[2], std::make_pair(Level::kError, std::string("e")));

  c.lines.clear();
  logger.SetLevel(Level::kDebug);
  EXPECT_TRUE(logger.Enabled(Level::kDebug));
  EXPECT_FALSE(logger.Enabled(Level::kTrace));
  logger.Write(Level::kTrace, "t");
  logger.Write(Level::kDebug, "d");
  ASSERT_EQ(c.lines.size(), 1u);
  EXPECT_EQ(c.lines[0].second, "d");

  c.lines.clear();
  logger.SetLevel(Level::kOff);
  logger.Write(Level::kError, "e");
  EXPECT_TRUE(c.lines.empty());
}

TEST(Log, RepeatsFromOnePlaceAreCountedAndSummarisedOncePerWindow) {
  Captured c;
  Logger logger = c.Make({.level = Level::kInfo, .max_per_window = 3, .window_s = 1.0});
  // A flood: 1000 messages within 0.5 s from one place.
  for (int i = 0; i < 1000; ++i) {
    LogFromOnePlace(logger, Level::kWarn, "garbage frame " + std::to_string(i));
    c.now_s += 0.0005;
  }
  ASSERT_EQ(c.lines.size(), 3u);
  EXPECT_EQ(c.lines[2].second, "garbage frame 2");

  // The window ends; the next message (from anywhere) first prints the summary.
  c.now_s = 101.2;
  logger.Write(Level::kInfo, "something else");
  ASSERT_EQ(c.lines.size(), 5u);
  EXPECT_EQ(c.lines[3].first, Level::kWarn);
  const std::string& summary = c.lines[3].second;
  EXPECT_EQ(summary.rfind("997 more like this from log_test.cpp:", 0), 0u) << summary;
  EXPECT_NE(summary.find("in 1.0 s"), std::string::npos) << summary;
  EXPECT_NE(summary.find("last: garbage frame 999"), std::string::npos) << summary;
  EXPECT_EQ(c.lines[4].second, "something else");

  // A new window: the place prints again, up to the limit.
  for (int i = 0; i < 5; ++i) LogFromOnePlace(logger, Level::kWarn, "again");
  EXPECT_EQ(c.lines.size(), 8u);
  logger.Flush();
  ASSERT_EQ(c.lines.size(), 9u);
  EXPECT_EQ(c.lines[8].second.rfind("2 more like this", 0), 0u) << c.lines[8].second;
  logger.Flush();  // nothing pending any more
  EXPECT_EQ(c.lines.size(), 9u);
}

TEST(Log, PlacesAndKeysAreLimitedSeparately) {
  Captured c;
  Logger logger = c.Make({.level = Level::kInfo, .max_per_window = 2, .window_s = 1.0});
  for (int i = 0; i < 10; ++i) {
    LogFromOnePlace(logger, Level::kError, "a", "alpha");
    LogFromOnePlace(logger, Level::kError, "b", "bravo");
    logger.Write(Level::kInfo, "other line");  // another source line
  }
  int a = 0, b = 0, other = 0;
  for (const auto& [level, m] : c.lines) {
    a += m == "a";
    b += m == "b";
    other += m == "other line";
  }
  EXPECT_EQ(a, 2);
  EXPECT_EQ(b, 2);
  EXPECT_EQ(other, 2);
  logger.Flush();
  int summaries = 0;
  for (const auto& [level, m] : c.lines) {
    if (m.rfind("8 more like this", 0) == 0) ++summaries;
  }
  EXPECT_EQ(summaries, 3);
  bool named_key = false;
  for (const auto& [level, m] : c.lines) {
    named_key = named_key || m.find("(bravo) in") != std::string::npos;
  }
  EXPECT_TRUE(named_key);
}

TEST(Log, SlowRepeatsAreNeverSuppressed) {
  Captured c;
  Logger logger = c.Make({.level = Level::kInfo, .max_per_window = 2, .window_s = 1.0});
  for (int i = 0; i < 20; ++i) {
    LogFromOnePlace(logger, Level::kInfo, "tick");
    c.now_s += 0.6;  // under 2 per second
  }
  logger.Flush();
  EXPECT_EQ(c.lines.size(), 20u);
}

TEST(Log, DestructorPrintsPendingSummaries) {
  Captured c;
  {
    Logger logger = c.Make({.level = Level::kInfo, .max_per_window = 1, .window_s = 10.0});
    for (int i = 0; i < 4; ++i) LogFromOnePlace(logger, Level::kWarn, "x");
  }
  ASSERT_EQ(c.lines.size(), 2u);
  EXPECT_EQ(c.lines[1].second.rfind("3 more like this", 0), 0u) << c.lines[1].second;
}

}  // namespace
}  // namespace draco::log
