#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "draco/report/figures.hpp"
#include "draco/report/files.hpp"
#include "draco/report/sonar_frame.hpp"

namespace fs = std::filesystem;
using namespace draco::report;

namespace {

fs::path TempDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("draco_report_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::vector<std::string> Listing(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

bool Near(const cv::Vec3b& bgr, const Rgb& rgb, int tol = 12) {
  return std::abs(bgr[2] - rgb.r) <= tol && std::abs(bgr[1] - rgb.g) <= tol &&
         std::abs(bgr[0] - rgb.b) <= tol;
}

}  // namespace

TEST(Report, RobotColoursDifferAndAvoidPurple) {
  for (int i = 0; i < 8; ++i) {
    for (int j = i + 1; j < 8; ++j) EXPECT_FALSE(RobotColour(i) == RobotColour(j));
    EXPECT_FALSE(RobotColour(i) == kLoopColour);
  }
  EXPECT_EQ(RobotColour(0), RobotColour(8));
}

TEST(Report, NiceTicks) {
  const auto t = NiceTicks(0.0, 10.0, 5);
  ASSERT_EQ(t.size(), 6u);
  EXPECT_DOUBLE_EQ(t.front(), 0.0);
  EXPECT_DOUBLE_EQ(t.back(), 10.0);
  const auto u = NiceTicks(-0.13, 0.41, 6);
  ASSERT_FALSE(u.empty());
  EXPECT_NEAR(u[1] - u[0], 0.1, 1e-12);
  EXPECT_GE(u.front(), -0.13);
  EXPECT_LE(u.back(), 0.41);
  EXPECT_TRUE(NiceTicks(1.0, 1.0).empty());
}

TEST(Report, TeamMapHasRobotColoursAtTrajectoryPoints) {
  const fs::path dir = TempDir("map");
  TeamMap map;
  map.title = "test map";
  RobotLayer a{"alpha", {}, {{0, 0}, {20, 0}, {20, 20}}, {{0, 1}, {20, 1}}, {{5, 10}, {6, 10}}};
  RobotLayer b{"bravo", {}, {{0, 40}, {30, 40}}, {}, {}};
  map.robots = {a, b};
  map.objects.push_back({{10, 30}, 4.0, 2.0, 0.3, 1});
  map.inter_robot_loops.push_back({{20, 20}, {30, 40}, true});
  MapOptions opt;
  opt.width_px = 800;
  opt.height_px = 600;
  const std::string png = (dir / "map.png").string();
  RenderTeamMap(map, png, opt);
  const cv::Mat img = cv::imread(png, cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 800);
  EXPECT_EQ(img.rows, 600);
  const MapProjection proj = ProjectTeamMap(map, opt);
  EXPECT_GT(proj.px_per_m, 1.0);
  // Mid-points of straight segments (no markers, loops or other robots there).
  auto pixel = [&](Xy p) {
    const Xy q = proj.ToPixel(p);
    return img.at<cv::Vec3b>(static_cast<int>(std::lround(q.y)),
                             static_cast<int>(std::lround(q.x)));
  };
  EXPECT_TRUE(Near(pixel({10, 0}), RobotColour(0)));
  EXPECT_TRUE(Near(pixel({20, 8}), RobotColour(0)));
  EXPECT_TRUE(Near(pixel({15, 40}), RobotColour(1)));
  EXPECT_TRUE(Near(pixel({25, 30}), kLoopColour));
  // Every data point lies inside the map area (left of the legend, below the title).
  for (const Xy p : {Xy{0, 0}, Xy{30, 40}, Xy{20, 20}}) {
    const Xy q = proj.ToPixel(p);
    EXPECT_GT(q.x, 0);
    EXPECT_LT(q.x, opt.width_px - opt.legend_width_px);
    EXPECT_GT(q.y, opt.title_height_px);
    EXPECT_LT(q.y, opt.height_px);
  }
  EXPECT_EQ(Listing(dir), std::vector<std::string>{"map.png"});
  fs::remove_all(dir);
}

TEST(Report, EmptyTeamMapStillRenders) {
  const fs::path dir = TempDir("empty");
  RenderTeamMap(TeamMap{}, (dir / "e.png").string());
  const cv::Mat img = cv::imread((dir / "e.png").string());
  EXPECT_EQ(img.cols, MapOptions{}.width_px);
  fs::remove_all(dir);
}

TEST(Report, LineAndBarCharts) {
  const fs::path dir = TempDir("chart");
  Series s{"precision", {0.1, 0.2, 0.3, 0.4}, {0.5, 0.7, 0.9, 1.0}, Rgb{0, 0, 255}, false, true};
  ChartOptions o;
  o.title = "precision vs overlap";
  o.x_label = "overlap threshold";
  o.y_label = "precision";
  o.references.push_back({"budget", 0.8});
  RenderLineChart({s}, o, (dir / "line.png").string());
  cv::Mat img = cv::imread((dir / "line.png").string());
  EXPECT_EQ(img.cols, o.width_px);
  EXPECT_EQ(img.rows, o.height_px);
  RenderBarChart({"alpha", "bravo"}, {{"DR", {2.0, 3.0}, {}}, {"SLAM", {0.5, NAN}, {}}}, o,
                 (dir / "bar.png").string());
  img = cv::imread((dir / "bar.png").string());
  EXPECT_EQ(img.rows, o.height_px);
  EXPECT_THROW(
      RenderLineChart({Series{"bad", {1, 2}, {1}, {}, false, false}}, o, (dir / "x.png").string()),
      std::invalid_argument);
  EXPECT_EQ(Listing(dir), (std::vector<std::string>{"bar.png", "line.png"}));
  fs::remove_all(dir);
}

TEST(Report, LineChartPanelsSideBySide) {
  const fs::path dir = TempDir("panels");
  ChartPanel left, right;
  left.series.push_back(Series{"w=0", {0.5, 0.6, 0.7}, {0.8, 0.9, 1.0}, {}, false, true});
  left.options.title = "precision";
  right.series.push_back(Series{"w=0", {0.5, 0.6, 0.7}, {40, 20, 5}, {}, false, true});
  right.options.title = "true positives";
  right.options.width_px = 600;
  right.options.height_px = 400;  // shorter: padded to the left panel's height
  RenderLineChartPanels({left, right}, (dir / "fig3.png").string());
  const cv::Mat img = cv::imread((dir / "fig3.png").string());
  EXPECT_EQ(img.cols, left.options.width_px + 600);
  EXPECT_EQ(img.rows, left.options.height_px);
  EXPECT_THROW(RenderLineChartPanels({}, (dir / "x.png").string()), std::invalid_argument);
  EXPECT_EQ(Listing(dir), std::vector<std::string>{"fig3.png"});
  fs::remove_all(dir);
}

TEST(Report, SonarFrameDrawsDetections) {
  const fs::path dir = TempDir("sonar");
  draco::msgs::SonarPing ping;
  ping.num_beams = 64;
  ping.num_ranges = 100;
  ping.range_resolution_m = 0.1;
  for (int i = 0; i < 64; ++i) ping.bearings_rad.push_back(static_cast<float>(-1.0 + 2.0 * i / 63));
  ping.intensity.assign(64 * 100, 20);
  for (int b = 30; b < 34; ++b) ping.intensity[static_cast<std::size_t>(50 * 64 + b)] = 250;
  EXPECT_NEAR(PingStructureScore(ping, 85), 4.0 / 6400.0, 1e-12);
  SonarFrameOptions o;
  o.width_px = 400;
  o.caption = "test";
  RenderSonarFrame(ping, {{5.0, 0.0}}, (dir / "f.png").string(), o);
  const cv::Mat img = cv::imread((dir / "f.png").string());
  EXPECT_EQ(img.cols, 400);
  EXPECT_GT(img.rows, 100);
  fs::remove_all(dir);
}

TEST(Report, AtomicWriteLeavesNoTemporaryFile) {
  const fs::path dir = TempDir("atomic");
  const std::string path = (dir / "a.txt").string();
  WriteFileAtomically(path, "one");
  WriteFileAtomically(path, "two");
  std::ifstream f(path);
  std::string text;
  f >> text;
  EXPECT_EQ(text, "two");
  EXPECT_EQ(Listing(dir), std::vector<std::string>{"a.txt"});
  EXPECT_THROW(WriteFileAtomically((dir / "missing" / "b.txt").string(), "x"), std::runtime_error);
  EXPECT_EQ(Listing(dir), std::vector<std::string>{"a.txt"});
  fs::remove_all(dir);
}

TEST(Report, ReadsMapsAsPclReadsThem) {
  const fs::path dir = TempDir("ply");
  const std::string path = (dir / "m.ply").string();
  WriteFileAtomically(path,
                      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float "
                      "y\nproperty float z\nend_header\n1.5 -2 0\n3 4 0\n");
  const auto pts = ReadMapXy(path);
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_DOUBLE_EQ(pts[0].x, 1.5);
  EXPECT_DOUBLE_EQ(pts[1].y, 4.0);
  WriteFileAtomically(path,
                      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty "
                      "float y\nend_header\n1 2\n");
  EXPECT_THROW(ReadMapXy(path), std::runtime_error);
  // The robot's map: the PCD first, else the PLY.
  EXPECT_EQ(MapCloudPath(dir.string(), "m"), "");
  fs::rename(path, dir / "r.map.ply");
  EXPECT_EQ(MapCloudPath(dir.string(), "r"), (dir / "r.map.ply").string());
  WriteFileAtomically((dir / "r.map.pcd").string(),
                      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\n"
                      "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n-7.25 8.5 0\n");
  EXPECT_EQ(MapCloudPath(dir.string(), "r"), (dir / "r.map.pcd").string());
  const auto pcd = ReadMapXy(MapCloudPath(dir.string(), "r"));
  ASSERT_EQ(pcd.size(), 1u);
  EXPECT_DOUBLE_EQ(pcd[0].x, -7.25);
  EXPECT_DOUBLE_EQ(pcd[0].y, 8.5);
  fs::remove_all(dir);
}
