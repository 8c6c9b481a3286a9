// Occupancy grids from a sonar point map and the poses it was seen from: every cell a beam
// crosses before its first return is evidence of free space, the cell of a return is
// evidence of an obstacle, cells no beam reached stay unknown. The grid is MRPT's
// mrpt::maps::COccupancyGridMap2D (Bayesian log-odds fusion of the evidence), written as PNG
// and as MRPT's own grid file (a gzip-compressed serialized COccupancyGridMap2D, what MRPT's
// apps open as .gridmap.gz). MRPT is used in src/grid.cpp only; this header is plain C++.
#pragma once

#include <string>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::occupancy {

struct GridOptions {
  double cell_size_m = 0.2;
  // The sonar (the recorded mission's mission.yaml: range_bins x range_resolution_m and
  // horizontal_aperture_rad); ScansFromMap gives a point to a keyframe that could see it.
  double max_range_m = 30.0;
  double fov_rad = 2.2689280275926285;  // 130 deg
  // Returns of one scan whose bearings from the sensor fall in the same bin of this width are
  // one beam: free space along it up to its nearest return.
  double bearing_bin_rad = 0.00872664625997165;  // 0.5 deg
  // Evidence per scan: a cell crossed by beams takes one update p_free, a cell holding a
  // return one update p_occupied (a return wins over a crossing within the same scan).
  double p_free = 0.4;
  double p_occupied = 0.8;
  double margin_m = 2.0;  // around every sensor position and return
};

// Throws std::invalid_argument naming the field when an option is out of range.
void Validate(const GridOptions& options);

// One scan: the sensor pose and its returns, both in the map frame.
struct Scan {
  msgs::Pose2 T_map_sensor;
  std::vector<msgs::Point2> points_map;
};

enum class CellState { kUnknown, kFree, kOccupied };

// A copy of the grid: occupancy probability per cell, 0.5 where nothing was seen.
struct Grid {
  double x_min_m = 0.0;
  double y_min_m = 0.0;
  double cell_size_m = 0.0;
  int width = 0;                  // cells along x
  int height = 0;                 // cells along y
  std::vector<float> p_occupied;  // row-major, row 0 at y_min_m

  // Cell of a map point; false outside the grid.
  bool CellOf(double x_m, double y_m, int* ix, int* iy) const;
  float P(int ix, int iy) const { return p_occupied[static_cast<std::size_t>(iy) * width + ix]; }
  // kFree below 0.45, kOccupied above 0.55, kUnknown between and outside the grid.
  CellState StateAt(double x_m, double y_m) const;
  int Count(CellState state) const;
};

// Fuses the scans into a grid spanning every sensor position and return (plus margin_m).
// Throws std::invalid_argument on bad options, std::runtime_error when the grid would exceed
// 100 million cells.
Grid BuildGrid(const std::vector<Scan>& scans, const GridOptions& options = {});

// A point map without per-point origins (a <robot>.map.pcd) as scans from its keyframes:
// each point goes to the nearest keyframe that sees it (within max_range_m, inside fov_rad
// around the keyframe's heading; the sonar is taken at the keyframe's origin), points no
// keyframe sees are dropped. The sensor of a real return is one of the keyframes that see
// it; the nearest is the likeliest, not always the right one.
std::vector<Scan> ScansFromMap(const std::vector<msgs::Point2>& points_map,
                               const std::vector<msgs::Pose2>& T_map_keyframe,
                               const GridOptions& options = {});

// PNG (MRPT's saveAsBitmapFile: one pixel per cell, white free, black occupied, grey
// unknown). Throws std::runtime_error naming the file when it cannot be written.
void WriteGridPng(const Grid& grid, const std::string& path);
// MRPT's grid file (gzip-compressed serialized mrpt::maps::COccupancyGridMap2D).
// Throws std::runtime_error naming the file.
void WriteGridFile(const Grid& grid, const std::string& path);
// Reads a grid file through MRPT (any COccupancyGridMap2D MRPT wrote, gzip or not).
// Throws std::runtime_error naming the file when it is missing or not such a grid.
Grid ReadGridFile(const std::string& path);

}  // namespace draco::occupancy
