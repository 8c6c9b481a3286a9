// Occupancy grids (grid.hpp) on a hand-made scene: a sonar at the origin looking along +x at a
// wall x = 10.1 m (the middle of a 0.2 m cell), |y| <= 2.95 m. Cells along the beams are free, the
// wall's cells occupied, cells behind the wall, behind the sonar and beside the wall (no return)
// unknown; the grid file MRPT writes reads back through MRPT unchanged; the map is split between
// the keyframes that see its points.
#include <gtest/gtest.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <stdexcept>

#include "draco/occupancy/grid.hpp"

namespace draco::occupancy {
namespace {

namespace fs = std::filesystem;

std::vector<msgs::Point2> Wall(double x_m, double y0_m, double y1_m) {
  std::vector<msgs::Point2> out;
  for (double y = y0_m; y <= y1_m + 1e-9; y += 0.05) out.push_back({x_m, y});
  return out;
}

std::string TempPath(const std::string& name) {
  return (fs::temp_directory_path() / ("draco_occupancy_" + name)).string();
}

TEST(OccupancyGrid, FreeAlongBeamsOccupiedAtTheWallUnknownElsewhere) {
  GridOptions o;
  o.cell_size_m = 0.2;
  const Scan scan{{0.0, 0.0, 0.0}, Wall(10.1, -2.95, 2.95)};
  const Grid g = BuildGrid({scan}, o);
  // Extent: sensor and returns plus the 2 m margin, x in [-2, 12.1], y in [-4.95, 4.95],
  // bounds snapped by MRPT to multiples of the 0.2 m cell.
  EXPECT_NEAR(g.x_min_m, -2.0, 1e-6);
  EXPECT_NEAR(g.y_min_m, -5.0, 1e-6);
  EXPECT_EQ(g.width, 70);
  EXPECT_EQ(g.height, 50);
  for (const double x : {0.5, 3.1, 5.1, 9.5}) {
    EXPECT_EQ(g.StateAt(x, 0.1), CellState::kFree) << x;
    EXPECT_EQ(g.StateAt(x, 0.25 * x), CellState::kFree) << x;  // the beam towards y = 2.5
  }
  for (const double y : {-2.9, -1.0, 0.1, 2.9}) {
    EXPECT_EQ(g.StateAt(10.1, y), CellState::kOccupied) << y;
  }
  EXPECT_EQ(g.StateAt(11.1, 0.1), CellState::kUnknown);  // behind the wall
  EXPECT_EQ(g.StateAt(-1.5, 0.1), CellState::kUnknown);  // behind the sonar
  EXPECT_EQ(g.StateAt(5.1, 4.5), CellState::kUnknown);   // bearing 41 deg: no return there
  EXPECT_EQ(g.StateAt(50.0, 0.0), CellState::kUnknown);  // outside the grid
  // One update each: MRPT's Bayesian fusion of 0.5 with p is p (to its log-odds step).
  int ix = 0, iy = 0;
  ASSERT_TRUE(g.CellOf(5.1, 0.1, &ix, &iy));
  EXPECT_NEAR(g.P(ix, iy), o.p_free, 0.01);
  ASSERT_TRUE(g.CellOf(10.1, 0.1, &ix, &iy));
  EXPECT_NEAR(g.P(ix, iy), o.p_occupied, 0.01);
  // The wall: y in [-2.95, 2.95] covers cells [-3.0, 3.0): 30 cells, nothing else occupied.
  EXPECT_EQ(g.Count(CellState::kOccupied), 30);
}

TEST(OccupancyGrid, RepeatedScansSharpenAndARemovedObstacleClears) {
  GridOptions o;
  const Scan wall{{0.0, 0.0, 0.0}, Wall(10.1, -2.95, 2.95)};
  const Grid once = BuildGrid({wall}, o);
  const Grid thrice = BuildGrid({wall, wall, wall}, o);
  int ix = 0, iy = 0;
  ASSERT_TRUE(once.CellOf(5.1, 0.1, &ix, &iy));
  EXPECT_LT(thrice.P(ix, iy), once.P(ix, iy) - 0.1);
  ASSERT_TRUE(once.CellOf(10.1, 0.1, &ix, &iy));
  EXPECT_GT(thrice.P(ix, iy), once.P(ix, iy) + 0.1);
  // A post at x = 5.1 seen once (log-odds +1.39), then the wall behind it seen five times
  // through where it stood (5 x -0.41): free.
  const Scan post{{0.0, 0.0, 0.0}, Wall(5.1, -0.15, 0.15)};
  const Grid g = BuildGrid({post, wall, wall, wall, wall, wall}, o);
  EXPECT_EQ(BuildGrid({post}, o).StateAt(5.1, 0.05), CellState::kOccupied);
  EXPECT_EQ(g.StateAt(5.1, 0.05), CellState::kFree);
}

TEST(OccupancyGrid, GridFileReadsBackThroughMrpt) {
  // The wall scene turned by 0.3 rad about the sensor.
  std::vector<msgs::Point2> wall;
  for (const auto& p : Wall(10.1, -2.95, 2.95)) {
    wall.push_back({p.x_m * std::cos(0.3) - p.y_m * std::sin(0.3),
                    p.x_m * std::sin(0.3) + p.y_m * std::cos(0.3)});
  }
  const Grid g = BuildGrid({{{0.0, 0.0, 0.3}, wall}}, {});
  const std::string path = TempPath("wall.gridmap.gz");
  WriteGridFile(g, path);
  const Grid back = ReadGridFile(path);
  EXPECT_NEAR(back.x_min_m, g.x_min_m, 1e-5);
  EXPECT_NEAR(back.y_min_m, g.y_min_m, 1e-5);
  EXPECT_NEAR(back.cell_size_m, g.cell_size_m, 1e-6);
  ASSERT_EQ(back.width, g.width);
  ASSERT_EQ(back.height, g.height);
  for (std::size_t i = 0; i < g.p_occupied.size(); ++i) {
    ASSERT_NEAR(back.p_occupied[i], g.p_occupied[i], 0.005) << i;
  }
  EXPECT_EQ(back.Count(CellState::kOccupied), g.Count(CellState::kOccupied));
  EXPECT_EQ(back.Count(CellState::kFree), g.Count(CellState::kFree));

  // Read by MRPT as MRPT's apps do: its cells hold the probability of being free.
  mrpt::maps::COccupancyGridMap2D m;
  {
    mrpt::io::CFileGZInputStream f(path);
    auto archive = mrpt::serialization::archiveFrom(f);
    archive >> m;
  }
  EXPECT_NEAR(m.getResolution(), 0.2, 1e-6);
  EXPECT_NEAR(m.getPos(5.1f, static_cast<float>(0.1 + 5.1 * std::tan(0.3))),
              1.0 - GridOptions{}.p_free, 0.01);  // crossed by the beams: free
  const double wall_y = 1.0;  // a wall point in the world: sensor at yaw 0.3 rad
  const double wx = 10.1 * std::cos(0.3) - wall_y * std::sin(0.3);
  const double wy = 10.1 * std::sin(0.3) + wall_y * std::cos(0.3);
  EXPECT_LT(m.getPos(static_cast<float>(wx), static_cast<float>(wy)), 0.45);  // occupied
  EXPECT_NEAR(m.getPos(static_cast<float>(wx + 1.0), static_cast<float>(wy)), 0.5,
              1e-3);  // behind it: unknown
  fs::remove(path);

  const std::string png = TempPath("wall.png");
  WriteGridPng(g, png);
  std::ifstream f(png, std::ios::binary);
  char magic[4] = {};
  f.read(magic, 4);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  fs::remove(png);
}

TEST(OccupancyGrid, BadFilesAndOptionsAreClearErrors) {
  try {
    ReadGridFile(TempPath("missing.gridmap.gz"));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.gridmap.gz"), std::string::npos) << e.what();
  }
  const std::string junk = TempPath("junk.gridmap");
  std::ofstream(junk) << "not a grid at all, just some text of some length\n";
  try {
    ReadGridFile(junk);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("junk.gridmap"), std::string::npos) << e.what();
  }
  fs::remove(junk);
  GridOptions o;
  o.cell_size_m = 0.0;
  try {
    BuildGrid({}, o);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cell_size_m"), std::string::npos) << e.what();
  }
  o = {};
  o.cell_size_m = 0.01;  // 1 km x 1 km at 1 cm: 10^10 cells
  EXPECT_THROW(BuildGrid({{{0, 0, 0}, {{1000.0, 1000.0}}}}, o), std::runtime_error);
  EXPECT_EQ(BuildGrid({}, {}).width, 0);
}

TEST(OccupancyGrid, MapPointsGoToTheNearestKeyframeThatSeesThem) {
  // Keyframe 0 at the origin looking +x, keyframe 1 at (20, 0) looking -x (back at the
  // origin), keyframe 2 at (4, 0) looking +y.
  const std::vector<msgs::Pose2> kfs{
      {0.0, 0.0, 0.0}, {20.0, 0.0, std::numbers::pi}, {4.0, 0.0, 0.5 * std::numbers::pi}};
  const std::vector<msgs::Point2> points{
      {8.0, 0.0},    // 8 m from kf 0, 12 m from kf 1, beside kf 2's view (bearing -pi/2)
      {13.0, 1.0},   // nearer kf 1, which sees it
      {4.0, 3.0},    // in kf 2's view (3 m), kf 0 sees it too at 5 m
      {-10.0, 0.0},  // behind kf 0, 30 m from kf 1: beyond range
  };
  GridOptions o;
  o.max_range_m = 25.0;
  const auto scans = ScansFromMap(points, kfs, o);
  ASSERT_EQ(scans.size(), 3u);
  ASSERT_EQ(scans[0].points_map.size(), 1u);
  EXPECT_EQ(scans[0].points_map[0].x_m, 8.0);
  ASSERT_EQ(scans[1].points_map.size(), 1u);
  EXPECT_EQ(scans[1].points_map[0].x_m, 13.0);
  ASSERT_EQ(scans[2].points_map.size(), 1u);
  EXPECT_EQ(scans[2].points_map[0].y_m, 3.0);
  EXPECT_EQ(scans[1].T_map_sensor.yaw_rad, std::numbers::pi);
}

}  // namespace
}  // namespace draco::occupancy
