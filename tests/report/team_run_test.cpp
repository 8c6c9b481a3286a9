// A tiny hand-made team run folder (two robots, as draco-fleet writes it) against hand-computed
// numbers: loop verdicts, precision before and after the filter, Table II, Table IV sums,
// traffic binning, team ATE, and the figures written.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include "draco/report/files.hpp"
#include "draco/report/team_run.hpp"

namespace fs = std::filesystem;
using namespace draco::report;

namespace {

constexpr double kPi = std::numbers::pi;

// TUM lines "t x y 0 qx qy qz qw" from (t, x, y, yaw).
std::string Tum(const std::vector<std::array<double, 4>>& rows) {
  std::ostringstream os;
  os.precision(12);
  os << "# t x y z qx qy qz qw\n";
  for (const auto& r : rows) {
    os << r[0] << " " << r[1] << " " << r[2] << " 0 0 0 " << std::sin(r[3] / 2) << " "
       << std::cos(r[3] / 2) << "\n";
  }
  return os.str();
}

std::string LinkStats(int id, const std::string& kinds) {
  return R"({"robot_id": )" + std::to_string(id) + R"(, "kinds": {)" + kinds +
         R"(}, "teammates": [{"robot_id": )" + std::to_string(1 - id) +
         R"(, "frames_received": 7, "restarts": 1}]})";
}

std::string Kind(const std::string& name, double frames, double bits, double max_bits,
                 double dropped_queue, double lost, double rejected) {
  std::ostringstream os;
  os << '"' << name << R"(": {"frames_sent": )" << frames << R"(, "bits_sent": )" << bits
     << R"(, "mean_bits": 0, "max_bits": )" << max_bits << R"(, "dropped_queue": )" << dropped_queue
     << R"(, "dropped_expired": 0, "lost": )" << lost
     << R"(, "frames_received": 0, "bits_received": 0, "rejected": )" << rejected << "}";
  return os.str();
}

// Robots "zed" (id 0) and "amy" (id 1): the ids, not the names, give the team order.
// Ground truth: zed along x at 1 m/s, yaw 0: (t, 0, 0); amy north along x = 10, yaw 90 deg:
// (10, t, pi/2). Keyframes: zed at t = 0, 2, 4; amy at t = 1, 3.
class TeamRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("draco_team_run_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::vector<std::array<double, 4>> zed_truth, amy_truth;
    for (int t = 0; t <= 10; ++t) {
      zed_truth.push_back({double(t), double(t), 0, 0});
      amy_truth.push_back({double(t), 10, double(t), kPi / 2});
    }
    Write("zed.ground_truth.tum", Tum(zed_truth));
    Write("amy.ground_truth.tum", Tum(amy_truth));
    // Local frames start at the origin (poses irrelevant to the loops: only the times).
    Write("zed.trajectory.tum", Tum({{0, 0, 0, 0}, {2, 2, 0, 0}, {4, 4, 0, 0}}));
    Write("zed.dead_reckoning.tum", Tum({{0, 0, 0, 0}, {2, 2, 0, 0}, {4, 4, 0, 0}}));
    Write("amy.trajectory.tum", Tum({{1, 0, 0, 0}, {3, 2, 0, 0}}));
    // zed's team estimate: both robots exact, in a frame rotated by 30 deg and shifted.
    const double a = kPi / 6, c = std::cos(a), s = std::sin(a);
    auto in_zed_frame = [&](double t, double x, double y, double yaw) {
      return std::array<double, 4>{t, c * x - s * y + 5, s * x + c * y - 2, yaw + a};
    };
    Write("zed.team.zed.tum",
          Tum({in_zed_frame(0, 0, 0, 0), in_zed_frame(2, 2, 0, 0), in_zed_frame(4, 4, 0, 0)}));
    Write("zed.team.amy.tum",
          Tum({in_zed_frame(1, 10, 1, kPi / 2), in_zed_frame(3, 10, 3, kPi / 2)}));
    Write("amy.team.amy.tum", Tum({{1, 0, 0, 0}, {3, 2, 0, 0}}));
    // Loops of zed (own robot 0):
    //  1: kf 2 (t 4, truth (4, 0, 0)) -> amy kf 1 (t 3, (10, 3, 90 deg)): truth relative pose
    //     (6, 3, 90 deg); the loop says exactly that: TP, accepted.
    //  2: kf 1 (t 2, (2, 0, 0)) -> amy kf 0 (t 1, (10, 1, 90 deg)): truth (8, 1, 90 deg); the
    //     loop is 3 m off in x: not a TP, accepted.
    //  3: kf 0 -> amy kf 0: truth (10, 1, 90 deg); the loop is 20 deg off: not a TP, rejected.
    //  4: kf 7 does not exist: not judged, rejected.
    const std::string header =
        "id,own_robot,own_keyframe,teammate_robot,teammate_keyframe,x_m,y_m,yaw_rad,overlap,"
        "accepted\n";
    std::ostringstream z;
    z.precision(10);
    z << header << "1,0,2,1,1,6,3," << kPi / 2 << ",0.6,1\n"
      << "2,0,1,1,0,11,1," << kPi / 2 << ",0.5,1\n"
      << "3,0,0,1,0,10,1," << kPi / 2 + 20 * kPi / 180 << ",0.4,0\n"
      << "4,0,7,1,0,0,0,0,0.3,0\n";
    Write("zed.inter_loops.csv", z.str());
    // amy holds loop 1 as zed accepted it, seen from amy: inv(6, 3, 90 deg) = (-3, 6, -90 deg).
    std::ostringstream m;
    m.precision(10);
    m << header << "1,1,1,0,2,-3,6," << -kPi / 2 << ",0.6,1\n";
    Write("amy.inter_loops.csv", m.str());
    // Agent steps of zed: matches 1 and 3, wall 1 and 3 ms, one PGO step.
    Write("zed.agent_steps.csv",
          "time_s,matches_tried,matches_found,requests_sent,scans_registered,candidates_added,"
          "loops_accepted,optimized,wall_ms\n"
          "1.000,1,0,2,4,1,0,0,1.0\n2.000,3,1,0,0,3,2,1,3.0\n");
    // Link: object_map from both, heartbeat from zed.
    Write("zed.link_stats.json", LinkStats(0, Kind("object_map", 2, 800, 500, 1, 1, 0) + ", " +
                                                  Kind("heartbeat", 4, 800, 200, 0, 0, 0)));
    Write("amy.link_stats.json", LinkStats(1, Kind("object_map", 3, 900, 400, 0, 0, 2)));
    Write("zed.runtime_stats.json", R"({"wall_s": 1, "mission_s": 20, "components": []})");
    Write("zed.link_traffic.csv",
          "start_s,end_s,kind,bits,lost\n0.5,0.6,object_map,400,0\n9.9,10.0,heartbeat,200,0\n"
          "10.0,10.1,object_map,400,0\n25,25.1,heartbeat,200,1\n");
    Write("amy.link_traffic.csv", "start_s,end_s,kind,bits,lost\n12,12.1,object_map,300,0\n");
    Write("zed.objects.csv",
          "id,center_x_m,center_y_m,length_m,breadth_m,yaw_rad,num_points\n0,3,1,2,1,0.5,10\n");
  }
  void TearDown() override { fs::remove_all(dir_); }
  void Write(const std::string& name, const std::string& text) {
    WriteFileAtomically((dir_ / name).string(), text);
  }
  fs::path dir_;
};

}  // namespace

TEST_F(TeamRunTest, TeamOrderFollowsLinkIds) {
  EXPECT_TRUE(IsTeamRun(dir_.string()));
  EXPECT_EQ(TeamOf(dir_.string()), (std::vector<std::string>{"zed", "amy"}));
}

TEST_F(TeamRunTest, JudgesLoopsAgainstTruth) {
  const TeamResult t = EvaluateTeamRun(dir_.string());
  EXPECT_TRUE(t.problems.empty()) << t.problems.front();
  ASSERT_EQ(t.robots.size(), 2u);
  ASSERT_EQ(t.loops[0].size(), 4u);
  const auto& l = t.loops[0];
  EXPECT_TRUE(l[0].judged);
  EXPECT_TRUE(l[0].true_positive);
  EXPECT_NEAR(l[0].err_m, 0.0, 1e-6);
  EXPECT_NEAR(l[0].err_deg, 0.0, 1e-6);
  EXPECT_TRUE(l[1].judged);
  EXPECT_FALSE(l[1].true_positive);
  EXPECT_NEAR(l[1].err_m, 3.0, 1e-6);
  EXPECT_TRUE(l[2].judged);
  EXPECT_FALSE(l[2].true_positive);
  EXPECT_NEAR(l[2].err_m, 0.0, 1e-6);
  EXPECT_NEAR(l[2].err_deg, 20.0, 1e-6);
  EXPECT_FALSE(l[3].judged);
  // The mirrored loop as amy holds it is the same true positive.
  ASSERT_EQ(t.loops[1].size(), 1u);
  EXPECT_TRUE(t.loops[1][0].true_positive);
  EXPECT_NEAR(t.loops[1][0].err_m, 0.0, 1e-6);

  const LoopCounts& z = t.robots[0].loops;
  EXPECT_EQ(z.candidates, 4);
  EXPECT_EQ(z.accepted, 2);
  EXPECT_EQ(z.judged, 3);
  EXPECT_EQ(z.tp_candidates, 1);
  EXPECT_EQ(z.tp_accepted, 1);
  EXPECT_NEAR(z.PrecisionBefore(), 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(z.PrecisionAfter(), 0.5, 1e-12);
  EXPECT_NEAR(z.RecallProxy(), 1.0, 1e-12);
  EXPECT_EQ(t.robots[0].candidates, 4);
  EXPECT_EQ(t.robots[0].accepted, 2);
  // Each loop once over the team: loop 1 is in both files.
  EXPECT_EQ(t.distinct_loops.candidates, 4);
  EXPECT_EQ(t.distinct_loops.accepted, 2);
  EXPECT_EQ(t.distinct_loops.tp_accepted, 1);

  // The verdict CSV: the loops CSV plus true_positive (empty when not judged).
  const auto written = WriteLoopVerdicts(t);
  ASSERT_EQ(written.size(), 2u);
  std::ifstream f(dir_ / "zed.inter_loops_verdict.csv");
  std::string header, line;
  std::getline(f, header);
  EXPECT_NE(header.find(",accepted,true_positive,err_m,err_deg"), std::string::npos);
  std::vector<std::string> tp;
  while (std::getline(f, line)) {
    const auto cells = line.substr(0, line.size());
    std::vector<std::string> parts;
    std::stringstream ss(cells);
    std::string c;
    while (std::getline(ss, c, ',')) parts.push_back(c);
    tp.push_back(parts.size() > 10 ? parts[10] : "");
  }
  EXPECT_EQ(tp, (std::vector<std::string>{"1", "0", "0", ""}));
}

TEST_F(TeamRunTest, TeamAteWorkAndLink) {
  const TeamResult t = EvaluateTeamRun(dir_.string());
  const auto& z = t.robots[0];
  const auto& a = t.robots[1];
  EXPECT_EQ(z.name, "zed");
  EXPECT_EQ(z.placed, 2);
  EXPECT_EQ(a.placed, 1);
  EXPECT_NEAR(z.team_ate_m, 0.0, 1e-6);  // exact, in a rotated frame
  EXPECT_NEAR(z.local_ate_m, 0.0, 1e-6);
  EXPECT_NEAR(z.dr_ate_m, 0.0, 1e-6);
  EXPECT_LT(a.dr_ate_m, 0.0);  // no dead reckoning file

  ASSERT_EQ(t.steps.size(), 1u);
  const StepWork& w = t.steps[0];
  EXPECT_EQ(w.robot, "zed");
  EXPECT_EQ(w.steps, 2);
  EXPECT_EQ(w.optimized, 1);
  EXPECT_DOUBLE_EQ(w.matches_tried.mean, 2.0);
  EXPECT_DOUBLE_EQ(w.matches_tried.max, 3.0);
  EXPECT_DOUBLE_EQ(w.requests_sent.mean, 1.0);
  EXPECT_DOUBLE_EQ(w.scans_registered.max, 4.0);
  EXPECT_DOUBLE_EQ(w.wall_ms.mean, 2.0);
  EXPECT_DOUBLE_EQ(w.wall_ms.max, 3.0);

  // Kinds summed over robots, in the docs/fleet.md order.
  ASSERT_EQ(t.kinds.size(), 2u);
  EXPECT_EQ(t.kinds[0].kind, "object_map");
  EXPECT_DOUBLE_EQ(t.kinds[0].frames, 5);
  EXPECT_DOUBLE_EQ(t.kinds[0].bits, 1700);
  EXPECT_DOUBLE_EQ(t.kinds[0].max_bits, 500);
  EXPECT_DOUBLE_EQ(t.kinds[0].dropped, 2);  // queue 1 + lost 1
  EXPECT_DOUBLE_EQ(t.kinds[0].rejected, 2);
  EXPECT_EQ(t.kinds[1].kind, "heartbeat");
  // zed: 1600 bits over the runtime's 20 s mission.
  EXPECT_DOUBLE_EQ(z.bits_sent, 1600);
  EXPECT_DOUBLE_EQ(z.mission_s, 20);
  EXPECT_DOUBLE_EQ(z.mean_bps, 80);
  EXPECT_EQ(z.restarts_seen, 1);
  EXPECT_DOUBLE_EQ(z.teammate_frames.at("amy"), 7);

  ASSERT_EQ(t.traffic.size(), 5u);
  // 10 s windows to 30 s: [0,10) object_map 400 + heartbeat 200; [10,20) object_map 400 + 300;
  // [20,30) heartbeat 200 (lost, still on the channel).
  const TrafficSeries ts = BinTraffic(t.traffic, 10.0, 30.0);
  ASSERT_EQ(ts.window_start_s, (std::vector<double>{0, 10, 20}));
  ASSERT_EQ(ts.kinds, (std::vector<std::string>{"object_map", "heartbeat"}));
  EXPECT_EQ(ts.bps[0], (std::vector<double>{40, 70, 0}));
  EXPECT_EQ(ts.bps[1], (std::vector<double>{20, 0, 20}));
  EXPECT_EQ(ts.total_bps, (std::vector<double>{60, 70, 20}));
  // The mission ends at 25 s: the last window is 5 s long.
  EXPECT_EQ(BinTraffic(t.traffic, 10.0, 25.0).total_bps, (std::vector<double>{60, 70, 40}));
}

TEST_F(TeamRunTest, FiguresAndReport) {
  const TeamResult t = EvaluateTeamRun(dir_.string());
  const auto figures = RenderTeamFigures(t);
  std::vector<std::string> paths;
  for (const auto& f : figures) paths.push_back(f.path);
  EXPECT_EQ(paths, (std::vector<std::string>{"team_map.png", "link_traffic.png",
                                             "link_traffic_detail.png"}));
  for (const auto& p : paths) {
    ASSERT_TRUE(fs::exists(dir_ / p)) << p;
    EXPECT_GT(fs::file_size(dir_ / p), 1000u) << p;
  }
  EXPECT_NE(figures[0].caption.find("2 accepted inter-robot loop"), std::string::npos)
      << figures[0].caption;
  const std::string md = TeamReportMarkdown(t, figures);
  for (const char* s :
       {"## Team ATE (Table III layout)", "| robots placed | 2 of 2 | 1 of 2 |",
        "| zed | 4 | 1 | 33.3 % | 2 | 1 | 50.0 % | 100.0 % |",
        "## Loop-closure work per time step (Table II layout)", "| zed | 2 | 2.00 / 3.00 |",
        "| object_map | 5 | 340 | 500 | 2 | 2 |", "| zed | 1.6 | 20.0 | 80 | 4.0 % |",
        "![link_traffic.png](link_traffic.png)"}) {
    EXPECT_NE(md.find(s), std::string::npos) << s << "\n" << md;
  }
}

TEST(TeamRun, NotATeamRunWithoutTeamFiles) {
  const fs::path dir = fs::temp_directory_path() / ("draco_not_team_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  WriteFileAtomically((dir / "r1.trajectory.tum").string(), "# t\n0 0 0 0 0 0 0 1\n");
  EXPECT_FALSE(IsTeamRun(dir.string()));
  fs::remove_all(dir);
}

TEST(TeamRun, MalformedLoopsNameTheLine) {
  const fs::path dir =
      fs::temp_directory_path() / ("draco_bad_loops_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string p = (dir / "x.inter_loops.csv").string();
  WriteFileAtomically(p,
                      "id,own_robot,own_keyframe,teammate_robot,teammate_keyframe,x_m,y_m,yaw_rad,"
                      "overlap,accepted\n1,0,2,1,1,six,3,0,0.6,1\n");
  try {
    ReadInterLoops(p);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(":2:"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// Fig. 3 from logged registrations: per window and threshold, the converged, judged ones with
// overlap >= threshold; hand-counted.
TEST(TeamRun, OverlapSweepCountsByWindowAndThreshold) {
  const fs::path dir = fs::temp_directory_path() / ("draco_sweep_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string p = (dir / "a.registrations.csv").string();
  WriteFileAtomically(
      p,
      "time_s,window,configured,own_robot,own_keyframe,teammate_robot,teammate_keyframe,x_m,y_m,"
      "yaw_rad,overlap,status\n"
      "1,3,1,0,1,1,1,0,0,0,0.95,accepted\n"
      "1,3,1,0,2,1,2,0,0,0,0.70,low overlap\n"
      "1,3,1,0,3,1,3,0,0,0,0.99,ICP failed\n"
      "1,0,0,0,1,1,1,0,0,0,0.60,low overlap\n");
  auto rows = ReadRegistrations(p);
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(rows[0].window, 3);
  EXPECT_TRUE(rows[0].configured);
  EXPECT_TRUE(rows[1].loop.accepted);   // ICP converged, overlap below the threshold
  EXPECT_FALSE(rows[2].loop.accepted);  // ICP failed: never counted
  // Verdicts as JudgeInterLoops would give them: the first is true, the second false.
  for (auto& r : rows) r.loop.judged = true;
  rows[0].loop.true_positive = true;
  rows[3].loop.true_positive = true;
  const auto sweep = OverlapSweep(rows, {0.5, 0.8, 0.96});
  ASSERT_EQ(sweep.size(), 6u);  // windows 0 and 3, three thresholds each
  auto at = [&](int w, double t) {
    for (const auto& s : sweep) {
      if (s.window == w && std::abs(s.threshold - t) < 1e-9) return s;
    }
    ADD_FAILURE() << "no point " << w << " " << t;
    return SweepPoint{};
  };
  EXPECT_EQ(at(3, 0.5).registrations, 2);
  EXPECT_EQ(at(3, 0.5).true_positives, 1);
  EXPECT_DOUBLE_EQ(at(3, 0.5).precision, 0.5);
  EXPECT_EQ(at(3, 0.8).registrations, 1);
  EXPECT_DOUBLE_EQ(at(3, 0.8).precision, 1.0);
  EXPECT_EQ(at(3, 0.96).registrations, 0);
  EXPECT_TRUE(std::isnan(at(3, 0.96).precision));
  EXPECT_EQ(at(0, 0.5).true_positives, 1);
  EXPECT_EQ(at(0, 0.8).registrations, 0);
  fs::remove_all(dir);
}
