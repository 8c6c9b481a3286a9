#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "draco/occupancy/grid.hpp"
#include "draco/pointcloud_io/pointcloud_io.hpp"
#include "draco/report/files.hpp"
#include "draco/report/run_report.hpp"

namespace fs = std::filesystem;
using namespace draco::report;

namespace {

// TUM lines "t x y 0 0 0 0 1" (yaw 0).
std::string Tum(const std::vector<std::array<double, 3>>& rows) {
  std::ostringstream os;
  os << "# t x y z qx qy qz qw\n";
  for (const auto& r : rows) os << r[0] << " " << r[1] << " " << r[2] << " 0 0 0 0 1\n";
  return os.str();
}

std::string Stats(long calls_a, double mean_a, double max_a) {
  std::ostringstream os;
  os << R"({"executor": "deterministic", "wall_s": 2.0, "mission_s": 10.0, "components": [)"
     << R"({"id": "cfar", "type": "sonar.Cfar", "calls": )" << calls_a
     << R"(, "errors": 0, "mean_ms": )" << mean_a << R"(, "p99_ms": 1, "max_ms": )" << max_a
     << R"(, "total_ms": )" << calls_a * mean_a << R"(, "inputs": []}]})";
  return os.str();
}

class RunReportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("draco_run_report_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const auto d = [&](const std::string& name) { return (dir_ / name).string(); };
    // Ground truth: straight along x. The estimate is off by +-0.1 m in y, symmetric in
    // time so the alignment is the identity: every error is 0.1 m, ATE = 0.100. Dead
    // reckoning is off by +-0.3 m: ATE = 0.300. RPE of the estimate: steps (1, -0.2),
    // (1, 0), (1, 0.2) against (1, 0): sqrt((0.04 + 0 + 0.04) / 3) = 0.163.
    WriteFileAtomically(d("r1.ground_truth.tum"),
                        Tum({{0, 0, 0}, {1, 1, 0}, {2, 2, 0}, {3, 3, 0}}));
    WriteFileAtomically(d("r1.trajectory.tum"),
                        Tum({{0, 0, 0.1}, {1, 1, -0.1}, {2, 2, -0.1}, {3, 3, 0.1}}));
    WriteFileAtomically(d("r1.dead_reckoning.tum"),
                        Tum({{0, 0, 0.3}, {1, 1, -0.3}, {2, 2, -0.3}, {3, 3, 0.3}}));
    WriteFileAtomically(d("r1.trajectory.full-pcm.tum"),
                        Tum({{0, 0, 0}, {1, 1, 0}, {2, 2, 0}, {3, 3, 0}}));
    WriteFileAtomically(d("r1.intra_loops.csv"),
                        "from_index,to_index,x_m,y_m,yaw_rad,overlap_ratio,accepted\n"
                        "0,3,1,0,0,0.5,1\n0,2,1,0,0,0.4,0\n");
    WriteFileAtomically(d("r1.runtime_stats.json"), Stats(10, 2.0, 5.0));
    // Second robot: a ground truth in the shared file, estimate exact.
    WriteFileAtomically(d("ground_truth.tum"), Tum({{0, 0, 0}, {1, 0, 1}, {2, 0, 2}}));
    WriteFileAtomically(d("r2.trajectory.tum"), Tum({{0, 0, 0}, {1, 0, 1}, {2, 0, 2}}));
    WriteFileAtomically(d("r2.runtime_stats.json"), Stats(30, 1.0, 9.0));
    draco::pointcloud_io::WritePcd(d("r1.map.pcd"), {{0.5, 1.0}, {2.0, -1.0}, {3.0, 0.25}});
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

}  // namespace

TEST_F(RunReportTest, EvaluatesHandMadeRun) {
  const RunEvaluation ev = EvaluateRun(dir_.string());
  ASSERT_EQ(ev.robots.size(), 2u);
  const auto& r1 = ev.robots[0];
  EXPECT_EQ(r1.robot, "r1");
  EXPECT_EQ(r1.keyframes, 4u);
  EXPECT_NEAR(r1.slam_ate_m, 0.1, 1e-9);
  EXPECT_NEAR(r1.dr_ate_m, 0.3, 1e-9);
  EXPECT_NEAR(r1.slam_rpe_m, std::sqrt(0.08 / 3.0), 1e-9);
  EXPECT_EQ(r1.intra_loops, 2);
  EXPECT_EQ(r1.intra_loops_accepted, 1);
  EXPECT_TRUE(std::isnan(ev.robots[1].dr_ate_m));
  EXPECT_NEAR(ev.robots[1].slam_ate_m, 0.0, 1e-9);
  // Dead reckoning, local SLAM and the one team variant present.
  ASSERT_EQ(ev.methods.size(), 3u);
  EXPECT_EQ(ev.methods[2].method, "Full PCM");
  ASSERT_EQ(ev.runtime_total.size(), 1u);
  EXPECT_EQ(ev.runtime_total[0].calls, 40);
  EXPECT_NEAR(ev.runtime_total[0].mean_ms, (10 * 2.0 + 30 * 1.0) / 40.0, 1e-9);
  EXPECT_NEAR(ev.runtime_total[0].max_ms, 9.0, 1e-9);
}

TEST_F(RunReportTest, WritesReportWithTablesAndFigures) {
  const RunEvaluation ev = EvaluateRun(dir_.string());
  ReportContent content;
  content.command = "draco-eval " + dir_.string();
  content.figures = RenderRunFigures(ev);
  const std::string path = WriteReport(ev, content);
  EXPECT_EQ(path, (dir_ / "report.md").string());
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string md = ss.str();
  EXPECT_NE(md.find("| r1 | 4 | 3.0 | 2 (1) | 0.300 | 0.100 | 0.33 | "), std::string::npos) << md;
  EXPECT_NE(md.find("| Dead reckoning | 0.300 | – | 0.300 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| Local SLAM | 0.100 | 0.000 | 0.050 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| Full PCM | 0.000 | – | 0.000 |"), std::string::npos) << md;
  EXPECT_EQ(md.find("Two-step PCM |"), std::string::npos);
  EXPECT_NE(md.find("| cfar | sonar.Cfar | 40 | 1.250 | 9.000 |"), std::string::npos) << md;
  EXPECT_NE(md.find("![team map](team_map.png)"), std::string::npos);
  EXPECT_NE(md.find("![ATE per robot](ate.png)"), std::string::npos);
  EXPECT_NE(md.find("`draco-eval "), std::string::npos);
  EXPECT_TRUE(fs::exists(dir_ / "team_map.png"));
  EXPECT_TRUE(fs::exists(dir_ / "ate.png"));
  // The drawn point clouds as one PCD beside the picture (r1's map, aligned as drawn).
  EXPECT_EQ(draco::pointcloud_io::ReadMapPcd((dir_ / "team_map.pcd").string()).size(), 3u);
  // r1's occupancy grid beside the map (r2 has no map, so no grid): PNG and MRPT's grid file,
  // in the map's frame (the alignment is the identity): r1's three map points occupied, the
  // beam from the keyframe (2, -0.1) to (3, 0.25) free, behind the first keyframe unknown.
  EXPECT_NE(md.find("![r1.grid.png](r1.grid.png)"), std::string::npos) << md;
  EXPECT_EQ(md.find("r2.grid.png"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir_ / "r1.grid.png"));
  EXPECT_FALSE(fs::exists(dir_ / "r2.grid.png"));
  const auto grid = draco::occupancy::ReadGridFile((dir_ / "r1.grid.gridmap.gz").string());
  using draco::occupancy::CellState;
  for (const auto& [x, y] : {std::pair{0.5, 1.0}, {2.0, -1.0}, {3.0, 0.25}}) {
    EXPECT_EQ(grid.StateAt(x, y), CellState::kOccupied) << x << " " << y;
  }
  EXPECT_EQ(grid.StateAt(2.5, 0.15), CellState::kFree);
  EXPECT_EQ(grid.StateAt(-1.0, 0.1), CellState::kUnknown);
  // Atomic writes: nothing temporary is left behind.
  for (const auto& e : fs::directory_iterator(dir_)) {
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
  }
}

TEST_F(RunReportTest, SplitsATeamRuntimeFileByRobot) {
  // An in-process team run: no per-robot files, one runtime_stats.json whose component ids
  // carry the robot's name.
  fs::remove(dir_ / "r1.runtime_stats.json");
  fs::remove(dir_ / "r2.runtime_stats.json");
  WriteFileAtomically(
      (dir_ / "runtime_stats.json").string(),
      R"({"executor": "deterministic", "wall_s": 4.0, "mission_s": 20.0, "components": [)"
      R"({"id": "r1_cfar", "type": "sonar.Cfar", "calls": 10, "errors": 0, "mean_ms": 2, )"
      R"("p99_ms": 1, "max_ms": 5, "total_ms": 20, "inputs": []},)"
      R"({"id": "r2_cfar", "type": "sonar.Cfar", "calls": 30, "errors": 0, "mean_ms": 1, )"
      R"("p99_ms": 1, "max_ms": 9, "total_ms": 30, "inputs": []},)"
      R"({"id": "link", "type": "fleet.Link", "calls": 5, "errors": 0, "mean_ms": 1, )"
      R"("p99_ms": 1, "max_ms": 1, "total_ms": 5, "inputs": []}]})");
  const RunEvaluation ev = EvaluateRun(dir_.string());
  ASSERT_EQ(ev.runtimes.size(), 2u);
  EXPECT_EQ(ev.runtimes[0].robot, "r1");
  EXPECT_NEAR(ev.runtimes[1].mission_s, 20.0, 1e-12);
  ASSERT_EQ(ev.runtime_total.size(),
            1u);  // "cfar" of both robots; the shared link is not a robot's
  EXPECT_EQ(ev.runtime_total[0].id, "cfar");
  EXPECT_EQ(ev.runtime_total[0].calls, 40);
  EXPECT_NEAR(ev.runtime_total[0].mean_ms, 50.0 / 40.0, 1e-9);
  EXPECT_NEAR(ev.runtime_total[0].max_ms, 9.0, 1e-9);
}
