// Deterministic executor: ordering, determinism, timers, pacing, errors, stop and flush.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "draco/graph/executor.hpp"
#include "draco/graph/progress.hpp"
#include "test_components.hpp"

namespace draco::graph {
namespace {

std::string ReadFile(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The directories made by TempDir, removed when the test process exits.
struct TempDirs {
  std::vector<std::filesystem::path> made;
  TempDirs() = default;
  TempDirs(const TempDirs&) = delete;
  TempDirs& operator=(const TempDirs&) = delete;
  ~TempDirs() {
    std::error_code ec;
    for (const auto& dir : made) std::filesystem::remove_all(dir, ec);
  }
};

std::string TempDir(const std::string& name) {
  static TempDirs dirs;
  const auto dir = std::filesystem::temp_directory_path() /
                   ("draco_graph_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  dirs.made.push_back(dir);
  return dir.string();
}

// Two sources with interleaving and coinciding stamps, a join and a sink.
const char* kJoin = R"(schema: 1
components:
  - id: b_fast
    type: example.Ticker
    params: { count: 20, period_s: 0.1, first: 1000 }
  - id: a_slow
    type: example.Ticker
    params: { count: 5, period_s: 0.5, first: 0, step: 10 }
  - id: join
    type: example.Sum
    inputs: { a: b_fast/value, b: a_slow/value }
  - id: sink
    type: example.CsvSink
    inputs: { in: join/out }
  - id: raw
    type: example.CsvSink
    inputs: { in: b_fast/value }
    params: { file: raw.csv }
  - id: meter
    type: example.RateMeter
    inputs: { in: b_fast/value }
  - id: meter_sink
    type: example.CsvSink
    inputs: { in: meter/count }
    params: { file: meter.csv }
)";

RunResult RunInto(const std::string& yaml, const std::string& dir) {
  auto g = LoadGraphString(yaml, "join.yaml");
  RunOptions o;
  o.output_dir = dir;
  return RunDeterministic(*g, o);
}

TEST(Deterministic, MergesByStampThenProducerId) {
  const std::string dir = TempDir("order");
  const auto r = RunInto(kJoin, dir);
  ASSERT_TRUE(r.ok) << r.error;
  std::istringstream csv(ReadFile(dir + "/values.csv"));
  std::string line;
  std::getline(csv, line);
  std::vector<std::string> rows;
  while (std::getline(csv, line)) rows.push_back(line);
  ASSERT_EQ(rows.size(), 20u);
  // At t = 0 both sources publish; "a_slow" < "b_fast", so b (=0) is already known when a
  // arrives: 1000 + 0. At t = 0.5, a_slow publishes 10 before b_fast's 1005 is joined.
  EXPECT_EQ(rows[0], "0.000000000,join,1000");
  EXPECT_EQ(rows[4], "0.400000000,join,1004");
  EXPECT_EQ(rows[5], "0.500000000,join,1015");
  EXPECT_EQ(rows[19], "1.900000000,join,1049");  // a_slow at 1.5 s was 30
}

TEST(Deterministic, IdenticalInputsGiveIdenticalOutputs) {
  const std::string d1 = TempDir("det1");
  const std::string d2 = TempDir("det2");
  ASSERT_TRUE(RunInto(kJoin, d1).ok);
  ASSERT_TRUE(RunInto(kJoin, d2).ok);
  for (const char* f : {"values.csv", "raw.csv", "meter.csv"}) {
    const std::string a = ReadFile(d1 + "/" + f);
    EXPECT_FALSE(a.empty()) << f;
    EXPECT_EQ(a, ReadFile(d2 + "/" + f)) << f;
  }
}

TEST(Deterministic, TimersFireInMissionTime) {
  const std::string dir = TempDir("timer");
  ASSERT_TRUE(RunInto(kJoin, dir).ok);
  // 20 values at 0.0 .. 1.9 s; the 1 s timer fires at t = 1 and t = 2 (the last event is
  // a_slow's at 2.0 s). A timer fires before messages with the same stamp.
  EXPECT_EQ(ReadFile(dir + "/meter.csv"),
            "stamp_s,producer,value\n1.000000000,meter,10\n2.000000000,meter,10\n");
}

TEST(Deterministic, StatsCountCallsAndInputs) {
  const std::string dir = TempDir("stats");
  const auto r = RunInto(kJoin, dir);
  ASSERT_TRUE(r.ok);
  const ComponentStats* join = nullptr;
  for (const auto& c : r.stats.components) {
    if (c.id == "join") join = &c;
  }
  ASSERT_NE(join, nullptr);
  EXPECT_EQ(join->calls, 20u);
  ASSERT_EQ(join->inputs.size(), 2u);
  EXPECT_EQ(join->inputs[0].received, 20u);
  EXPECT_EQ(join->inputs[1].received, 5u);
  EXPECT_EQ(join->dropped(), 0u);
  EXPECT_NEAR(r.stats.mission_s, 2.0, 1e-9);
  const std::string json = r.stats.ToJson();
  EXPECT_NE(json.find("\"id\": \"join\", \"type\": \"example.Sum\", \"calls\": 20"),
            std::string::npos)
      << json;
  EXPECT_NE(r.stats.ToTable().find("join"), std::string::npos);
}

TEST(Deterministic, PacedRunFollowsMissionTime) {
  // 2 s of mission time at 20 x real time takes at least 0.1 s of wall time.
  auto g = LoadGraphString(kJoin, "join.yaml");
  RunOptions o;
  o.use_graph_rate = false;
  o.rate = 20.0;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(RunDeterministic(*g, o).ok);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(wall, 1.9 / 20.0 * 0.99);
}

TEST(Deterministic, RecoverableErrorsAreCountedAndTheRunGoesOn) {
  auto g = LoadGraphString(R"(schema: 1
components:
  - id: t
    type: example.Ticker
    params: { count: 10 }
  - id: s
    type: example.Scale
    inputs: { in: t/value }
    params: { fail_above: 6.5 }
)",
                           "g.yaml");
  RunOptions o;
  o.log_errors = false;
  const auto r = RunDeterministic(*g, o);
  EXPECT_TRUE(r.ok);
  EXPECT_EQ(r.stats.components[0].id, "s");
  EXPECT_EQ(r.stats.components[0].errors, 3u);  // 7, 8, 9
}

TEST(Deterministic, FatalErrorStopsTheRunAndNamesTheComponent) {
  auto g = LoadGraphString(R"(schema: 1
components:
  - id: t
    type: example.Ticker
    params: { count: 10 }
  - id: f
    type: test.Fatal
    inputs: { in: t/value }
    params: { fail_at: 4 }
)",
                           "g.yaml");
  const auto r = RunDeterministic(*g);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.error, "f: message 4 is bad");
  EXPECT_EQ(r.stats.components[0].calls, 4u);
}

TEST(Deterministic, StopRequestEndsTheRunAndFlushesOutputs) {
  const std::string dir = TempDir("stop");
  auto g = LoadGraphString(R"(schema: 1
components:
  - id: t
    type: example.Ticker
    params: { count: 1000 }
  - id: slow
    type: test.Slow
    inputs: { oldest: t/value }
    params: { stop_after: 10 }
  - id: sink
    type: example.CsvSink
    inputs: { in: slow/out }
)",
                           "g.yaml");
  test::GetProbe().stop_flag = false;
  test::GetProbe().processed = 0;
  RunOptions o;
  o.output_dir = dir;
  o.stop_requested = &test::GetProbe().stop_flag;
  const auto r = RunDeterministic(*g, o);
  EXPECT_TRUE(r.ok);
  EXPECT_TRUE(r.interrupted);
  std::istringstream csv(ReadFile(dir + "/values.csv"));  // written by Stop()
  std::string line;
  int rows = -1;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 10);
}

TEST(Deterministic, UntilStopsAtMissionTime) {
  const std::string dir = TempDir("until");
  auto g = LoadGraphString(kJoin, "join.yaml");
  RunOptions o;
  o.output_dir = dir;
  o.until = Time::FromSeconds(0.95);
  ASSERT_TRUE(RunDeterministic(*g, o).ok);
  std::istringstream csv(ReadFile(dir + "/raw.csv"));
  std::string line;
  int rows = -1;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 10);
}

TEST(Deterministic, FeedbackEdgeIsDeliveredAfterNormalOnes) {
  // a -> b -> c -> b(feedback, delayed): the graph is valid and runs to completion.
  auto g = LoadGraphString(R"(schema: 1
components:
  - id: t
    type: example.Ticker
    params: { count: 5 }
  - id: b
    type: test.Relay
    inputs: { in: t/value, feedback: c/out }
  - id: c
    type: test.Relay
    inputs: { in: b/out }
)",
                           "g.yaml");
  const auto r = RunDeterministic(*g);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.stats.components[0].inputs[1].received, 5u);  // b/feedback
}

TEST(Deterministic, ProgressIsReportedInMissionTimeAndChangesNothing) {
  const std::string yaml = R"(schema: 1
components:
  - id: t
    type: example.Ticker
    params: { count: 3000, period_s: 0.1 }
  - id: sink
    type: example.CsvSink
    inputs: { in: t/value }
)";
  const std::string d1 = TempDir("progress1");
  const std::string d2 = TempDir("progress2");
  std::vector<double> seen;
  {
    auto g = LoadGraphString(yaml, "g.yaml");
    RunOptions o;
    o.output_dir = d1;
    o.progress_period_s = 0.0;
    o.progress = [&](const RunProgress& p) {
      seen.push_back(p.mission_time.Seconds());
      EXPECT_EQ(p.end, Time::Max());  // a ticker does not know its end
    };
    ASSERT_TRUE(RunDeterministic(*g, o).ok);
  }
  {
    auto g = LoadGraphString(yaml, "g.yaml");
    RunOptions o;
    o.output_dir = d2;
    ASSERT_TRUE(RunDeterministic(*g, o).ok);
  }
  ASSERT_GE(seen.size(), 10u);  // every 256 events: 6000 events
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_LE(seen.back(), 299.9 + 1e-9);
  EXPECT_EQ(ReadFile(d1 + "/values.csv"), ReadFile(d2 + "/values.csv"));
}

// The expected end comes from the sources (IntSource knows its last stamp) or from `until`,
// whichever is earlier; one source that does not know its end leaves only `until`.
TEST(Progress, ExpectedEndFromTheSourcesOrUntil) {
  const std::string known = R"(schema: 1
components:
  - id: s
    type: test.IntSource
    params: { count: 5001 }
)";
  auto g = LoadGraphString(known, "g.yaml");
  std::vector<RunProgress> seen;
  RunOptions o;
  o.progress_period_s = 0.0;
  o.progress = [&](const RunProgress& p) { seen.push_back(p); };
  ASSERT_TRUE(RunDeterministic(*g, o).ok);
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.back().end, Time::FromSeconds(50.0));
  EXPECT_EQ(ExpectedEnd(*g, RunOptions{}), Time::FromSeconds(50.0));
  RunOptions until;
  until.until = Time::FromSeconds(20.0);
  EXPECT_EQ(ExpectedEnd(*g, until), Time::FromSeconds(20.0));
  until.until = Time::FromSeconds(90.0);
  EXPECT_EQ(ExpectedEnd(*g, until), Time::FromSeconds(50.0));

  auto mixed = LoadGraphString(known + R"(  - id: t
    type: example.Ticker
    params: { count: 3, period_s: 0.1 }
)",
                               "g.yaml");
  EXPECT_EQ(ExpectedEnd(*mixed, RunOptions{}), Time::Max());
  EXPECT_EQ(ExpectedEnd(*mixed, until), Time::FromSeconds(90.0));
}

// The threaded executor reports progress too: a paced replay of 2 s of mission at 4x real
// time, told every 50 ms, sees the mission clock advance towards the sources' end.
TEST(Progress, ThreadedExecutorReportsMissionTimeAndEnd) {
  auto g = LoadGraphString(R"(schema: 1
executor: threaded
components:
  - id: s
    type: test.IntSource
    params: { count: 201 }
)",
                           "g.yaml");
  std::vector<RunProgress> seen;
  RunOptions o;
  o.rate = 4.0;
  o.use_graph_rate = false;
  o.progress_period_s = 0.05;
  o.progress = [&](const RunProgress& p) { seen.push_back(p); };
  const auto r = RunThreaded(*g, o);
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_GE(seen.size(), 3u);  // about 0.5 s of wall time
  for (std::size_t i = 0; i < seen.size(); ++i) {
    EXPECT_EQ(seen[i].end, Time::FromSeconds(2.0));
    if (i > 0) {
      EXPECT_GE(seen[i].mission_time, seen[i - 1].mission_time);
    }
  }
  EXPECT_GT(seen.back().mission_time, seen.front().mission_time);
  EXPECT_LE(seen.back().mission_time, Time::FromSeconds(2.0));
}

// The printer: a line every period of wall time (not every update), with the share of the
// mission, the rate and the time left; mission time and rate only when the end is unknown.
TEST(Progress, PrinterWritesAtItsPeriodWithShareRateAndEta) {
  std::vector<std::string> lines;
  double wall = 1000.0;
  ProgressPrinter p("robot alpha",
                    ProgressOptions{.total_s = 0.0,
                                    .period_s = 5.0,
                                    .emit = [&](const std::string& l) { lines.push_back(l); },
                                    .wall_clock = [&] { return wall; }});
  // 10x real time for 12 s of wall time, updates every 0.5 s, the executor knows the end.
  for (int i = 1; i <= 24; ++i) {
    wall = 1000.0 + 0.5 * i;
    p.Update(Time::FromSeconds(5.0 * i), Time::FromSeconds(200.0));
  }
  ASSERT_EQ(lines.size(), 2u);  // at 5 s and 10 s of wall time
  EXPECT_EQ(lines[0], "robot alpha: mission 50.0 / 200.0 s (25 %), 10.0x real time, ETA 0m15s");
  EXPECT_EQ(lines[1], "robot alpha: mission 100.0 / 200.0 s (50 %), 10.0x real time, ETA 0m10s");
  p.Finish(Time::FromSeconds(120.0));
  EXPECT_EQ(lines.back(), "robot alpha: done: 120.0 s of mission in 12.0 s, 10.0x real time");

  lines.clear();
  wall = 0.0;
  ProgressPrinter unknown("draco: g",
                          ProgressOptions{.emit = [&](const std::string& l) { lines.push_back(l); },
                                          .wall_clock = [&] { return wall; }});
  wall = 6.0;
  unknown.Update(Time::FromSeconds(30.0));
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "draco: g: mission 30.0 s, 5.0x real time");
}

}  // namespace
}  // namespace draco::graph

namespace draco::graph {
namespace {

// Three robots of a pretend team (islands: no edge joins them) that talk through a mailbox
// outside the graph with a 0.25 s least delay (test.MailRobot), and a fourth island that
// talks to nobody. `first_b` changes what robot b hears, so it shows in a's and c's outputs.
std::string MailTeam(const std::string& bus, int first_b = 100, int fail_at = 0) {
  std::string y = "schema: 1\ncomponents:\n";
  const char* names[] = {"a", "b", "c"};
  for (int i = 0; i < 3; ++i) {
    const std::string n = names[i];
    const int first = i == 1 ? first_b : 10 * i;
    y += "  - { id: " + n + "_src, type: example.Ticker, params: { count: 300, period_s: 0.07, " +
         "first: " + std::to_string(first) + ", step: " + std::to_string(i + 1) + " } }\n";
    y += "  - { id: " + n + "_robot, type: test.MailRobot, inputs: { in: " + n +
         "_src/value }, params: { bus: " + bus + ", me: " + std::to_string(i) +
         ", members: 3, delay_s: 0.25, work: " + std::to_string(20000 * (i + 1)) + " } }\n";
    y += "  - { id: " + n + "_sink, type: example.CsvSink, inputs: { in: " + n +
         "_robot/state }, params: { file: " + n + ".csv } }\n";
  }
  y += "  - { id: d_src, type: example.Ticker, params: { count: 50, period_s: 0.3 } }\n";
  y += "  - { id: d_sink, type: example.CsvSink, inputs: { in: d_src/value }, params: { file: "
       "d.csv } }\n";
  if (fail_at > 0) {
    y += "  - { id: c_fatal, type: test.Fatal, inputs: { in: c_src/value }, params: { fail_at: " +
         std::to_string(fail_at) + " } }\n";
  }
  return y;
}

struct TeamRun {
  RunResult result;
  std::map<std::string, std::string> files;
};

TeamRun RunMailTeam(const std::string& name, int threads, int first_b = 100, int fail_at = 0) {
  const std::string dir = TempDir(name);
  auto g = LoadGraphString(MailTeam(name, first_b, fail_at), name + ".yaml");
  RunOptions o;
  o.output_dir = dir;
  o.until = Time::FromSeconds(20.0);
  o.island_threads = threads;
  TeamRun run;
  run.result = RunDeterministic(*g, o);
  for (const char* f : {"a.csv", "b.csv", "c.csv", "d.csv"}) run.files[f] = ReadFile(dir + "/" + f);
  std::filesystem::remove_all(dir);
  return run;
}

TEST(Islands, RunInParallelWithTheOutputsOfOneThread) {
  // island_threads 0: one engine for the whole graph; 1-4: the parts (tickers upstream,
  // robots and sinks downstream, the idle island alone) on that many threads.
  const TeamRun one = RunMailTeam("islands_one", 0);
  ASSERT_TRUE(one.result.ok) << one.result.error;
  for (const auto& [file, text] : one.files) {
    EXPECT_GT(std::count(text.begin(), text.end(), '\n'), 40) << file;
  }
  for (int threads : {1, 2, 3, 2, 4, 2}) {
    const TeamRun many = RunMailTeam("islands_" + std::to_string(threads), threads);
    ASSERT_TRUE(many.result.ok) << many.result.error;
    for (const auto& [file, text] : one.files) {
      EXPECT_EQ(many.files.at(file), text) << file << " with " << threads << " threads";
    }
    ASSERT_EQ(many.result.stats.components.size(), one.result.stats.components.size());
    for (std::size_t i = 0; i < one.result.stats.components.size(); ++i) {
      EXPECT_EQ(many.result.stats.components[i].calls, one.result.stats.components[i].calls)
          << one.result.stats.components[i].id;
    }
    EXPECT_DOUBLE_EQ(many.result.stats.mission_s, one.result.stats.mission_s);
  }
}

TEST(Islands, WhatOneIslandHearsOfAnotherShowsInItsOutputs) {
  // The check above would pass for islands that never hear each other: b's inputs must
  // reach a and c through the mailbox (and not d, which hears nobody), on either executor.
  for (int threads : {0, 3}) {
    const TeamRun base = RunMailTeam("islands_base" + std::to_string(threads), threads);
    const TeamRun other = RunMailTeam("islands_other" + std::to_string(threads), threads, 7);
    ASSERT_TRUE(base.result.ok && other.result.ok);
    EXPECT_NE(base.files.at("a.csv"), other.files.at("a.csv"));
    EXPECT_NE(base.files.at("c.csv"), other.files.at("c.csv"));
    EXPECT_EQ(base.files.at("d.csv"), other.files.at("d.csv"));
  }
}

// A timer's output must reach its consumers before any message stamped later, also when that
// message came from another part early (an upstream part runs ahead and its messages wait in
// the queue): the robot's state (its 0.5 s timer) joined with the latest source value (from
// the upstream part) gives the single engine's sums on any number of threads. Before, the
// engine popped the early message, fired the timers up to its stamp and dispatched it before
// what those timers had just published.
TEST(Islands, ATimersOutputComesBeforeLaterMessagesFromAnotherPart) {
  const auto run = [](const std::string& name, int threads) {
    const std::string dir = TempDir(name);
    const std::string y =
        "schema: 1\ncomponents:\n"
        "  - { id: src, type: example.Ticker, params: { count: 300, period_s: "
        "0.07, first: 1, step: 1 } }\n"
        "  - { id: robot, type: test.MailRobot, inputs: { in: src/value }, "
        "params: { bus: " +
        name +
        ", me: 0, members: 1, delay_s: 0.25 } }\n"
        "  - { id: join, type: example.Sum, inputs: { a: robot/state, b: "
        "src/value } }\n"
        "  - { id: sink, type: example.CsvSink, inputs: { in: join/out } }\n";
    auto g = LoadGraphString(y, name + ".yaml");
    RunOptions o;
    o.output_dir = dir;
    o.until = Time::FromSeconds(20.0);
    o.island_threads = threads;
    const RunResult r = RunDeterministic(*g, o);
    EXPECT_TRUE(r.ok) << r.error;
    std::string out = ReadFile(dir + "/values.csv");
    std::filesystem::remove_all(dir);
    return out;
  };
  const std::string one = run("timer_order_one", 0);
  EXPECT_GT(std::count(one.begin(), one.end(), '\n'), 30);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(run("timer_order_" + std::to_string(i), 1 + i % 2), one) << i;
  }
}

TEST(Islands, AMessageStampedBeforeItsEventToAnotherPartIsAnError) {
  // lagger (upstream part) feeds the robot (downstream part) stamps 0.5 s in the past: the
  // robot's part may already have run beyond them, so the run stops naming the component.
  const std::string yaml = R"(schema: 1
components:
  - { id: src, type: example.Ticker, params: { count: 40, period_s: 0.1 } }
  - { id: lagger, type: test.Lagger, inputs: { in: src/value } }
  - { id: robot, type: test.MailRobot, inputs: { in: lagger/out }, params: { bus: lag } }
  - { id: other, type: test.MailRobot, params: { bus: lag, me: 1, members: 2 } }
)";
  for (int threads : {0, 2}) {
    auto g = LoadGraphString(yaml, "lag.yaml");
    RunOptions o;
    o.until = Time::FromSeconds(5.0);
    o.island_threads = threads;
    const RunResult r = RunDeterministic(*g, o);
    if (threads == 0) {
      EXPECT_TRUE(r.ok) << r.error;  // one engine: a late message is simply next
    } else {
      EXPECT_FALSE(r.ok);
      EXPECT_NE(r.error.find("lagger: published a message stamped"), std::string::npos) << r.error;
      EXPECT_NE(r.error.find("island_threads"), std::string::npos) << r.error;
    }
  }
}

TEST(Islands, AFatalErrorInOneIslandStopsEveryIsland) {
  const TeamRun r = RunMailTeam("islands_fatal", 3, 100, 40);
  EXPECT_FALSE(r.result.ok);
  EXPECT_EQ(r.result.error, "c_fatal: message 40 is bad");
  // The others stopped early too: far fewer than the 285 states 20 s of mission give.
  const auto& a = r.files.at("a.csv");
  EXPECT_LT(std::count(a.begin(), a.end(), '\n'), 200);
}

}  // namespace
}  // namespace draco::graph
