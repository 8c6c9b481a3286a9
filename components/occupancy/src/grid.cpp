// Occupancy grids through MRPT's COccupancyGridMap2D (grid.hpp). MRPT's cells hold the
// probability of being free (1 white, 0 black in its pictures); Grid holds the probability of
// being occupied, so values cross as 1 - p.
#include "draco/occupancy/grid.hpp"

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>
#include <stdexcept>

namespace draco::occupancy {
namespace {

constexpr double kMaxCells = 1e8;

double WrapPi(double a) { return std::remainder(a, 2.0 * std::numbers::pi); }

void Require(bool ok, const char* field, const char* what) {
  if (!ok) {
    throw std::invalid_argument(std::string("occupancy grid option ") + field + ": " + what);
  }
}

mrpt::maps::COccupancyGridMap2D ToMrpt(const Grid& g) {
  mrpt::maps::COccupancyGridMap2D m;
  const auto res = static_cast<float>(g.cell_size_m);
  m.setSize(static_cast<float>(g.x_min_m), static_cast<float>(g.x_min_m + g.width * g.cell_size_m),
            static_cast<float>(g.y_min_m), static_cast<float>(g.y_min_m + g.height * g.cell_size_m),
            res, 0.5f);
  const int w = std::min<int>(g.width, static_cast<int>(m.getSizeX()));
  const int h = std::min<int>(g.height, static_cast<int>(m.getSizeY()));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) m.setCell(x, y, 1.0f - g.P(x, y));
  }
  return m;
}

Grid FromMrpt(const mrpt::maps::COccupancyGridMap2D& m) {
  Grid g;
  g.x_min_m = m.getXMin();
  g.y_min_m = m.getYMin();
  g.cell_size_m = m.getResolution();
  g.width = static_cast<int>(m.getSizeX());
  g.height = static_cast<int>(m.getSizeY());
  g.p_occupied.resize(static_cast<std::size_t>(g.width) * static_cast<std::size_t>(g.height));
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      g.p_occupied[static_cast<std::size_t>(y) * g.width + x] = 1.0f - m.getCell(x, y);
    }
  }
  return g;
}

}  // namespace

void Validate(const GridOptions& o) {
  Require(std::isfinite(o.cell_size_m) && o.cell_size_m >= 0.01, "cell_size_m", "below 0.01 m");
  Require(std::isfinite(o.max_range_m) && o.max_range_m > 0.0, "max_range_m", "not positive");
  Require(std::isfinite(o.fov_rad) && o.fov_rad > 0.0 && o.fov_rad <= 2.0 * std::numbers::pi,
          "fov_rad", "not in (0, 2 pi]");
  Require(std::isfinite(o.bearing_bin_rad) && o.bearing_bin_rad > 0.0, "bearing_bin_rad",
          "not positive");
  Require(o.p_free > 0.0 && o.p_free < 0.5, "p_free", "not in (0, 0.5)");
  Require(o.p_occupied > 0.5 && o.p_occupied < 1.0, "p_occupied", "not in (0.5, 1)");
  Require(std::isfinite(o.margin_m) && o.margin_m >= 0.0, "margin_m", "negative");
}

bool Grid::CellOf(double x_m, double y_m, int* ix, int* iy) const {
  if (cell_size_m <= 0.0) return false;
  const double fx = std::floor((x_m - x_min_m) / cell_size_m);
  const double fy = std::floor((y_m - y_min_m) / cell_size_m);
  if (!(fx >= 0.0 && fy >= 0.0 && fx < width && fy < height)) return false;
  *ix = static_cast<int>(fx);
  *iy = static_cast<int>(fy);
  return true;
}

CellState Grid::StateAt(double x_m, double y_m) const {
  int ix = 0, iy = 0;
  if (!CellOf(x_m, y_m, &ix, &iy)) return CellState::kUnknown;
  const float p = P(ix, iy);
  if (p < 0.45f) return CellState::kFree;
  if (p > 0.55f) return CellState::kOccupied;
  return CellState::kUnknown;
}

int Grid::Count(CellState state) const {
  int n = 0;
  for (const float p : p_occupied) {
    const CellState s = p < 0.45f   ? CellState::kFree
                        : p > 0.55f ? CellState::kOccupied
                                    : CellState::kUnknown;
    n += s == state ? 1 : 0;
  }
  return n;
}

Grid BuildGrid(const std::vector<Scan>& scans, const GridOptions& o) {
  Validate(o);
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  auto extend = [&](double x, double y) {
    if (!std::isfinite(x) || !std::isfinite(y)) return;
    x0 = std::min(x0, x);
    y0 = std::min(y0, y);
    x1 = std::max(x1, x);
    y1 = std::max(y1, y);
  };
  for (const auto& s : scans) {
    extend(s.T_map_sensor.x_m, s.T_map_sensor.y_m);
    for (const auto& p : s.points_map) extend(p.x_m, p.y_m);
  }
  Grid empty;
  empty.cell_size_m = o.cell_size_m;
  if (!(x0 <= x1)) return empty;
  x0 -= o.margin_m;
  y0 -= o.margin_m;
  x1 += o.margin_m;
  y1 += o.margin_m;
  const double cells =
      std::ceil((x1 - x0) / o.cell_size_m + 1.0) * std::ceil((y1 - y0) / o.cell_size_m + 1.0);
  if (cells > kMaxCells) {
    throw std::runtime_error("occupancy grid of " + std::to_string(x1 - x0) + " x " +
                             std::to_string(y1 - y0) + " m at " + std::to_string(o.cell_size_m) +
                             " m cells exceeds 100 million cells (raise cell_size_m)");
  }

  mrpt::maps::COccupancyGridMap2D m;
  m.setSize(static_cast<float>(x0), static_cast<float>(x1), static_cast<float>(y0),
            static_cast<float>(y1), static_cast<float>(o.cell_size_m), 0.5f);
  Grid frame;  // the grid's geometry, for cell indices
  frame.x_min_m = m.getXMin();
  frame.y_min_m = m.getYMin();
  frame.cell_size_m = m.getResolution();
  frame.width = static_cast<int>(m.getSizeX());
  frame.height = static_cast<int>(m.getSizeY());
  const std::size_t n_cells = static_cast<std::size_t>(frame.width) * frame.height;

  // Per scan: 1 = crossed by a beam, 2 = holds a return; each touched cell updated once.
  std::vector<unsigned char> mark(n_cells, 0);
  std::vector<std::size_t> touched;
  // As MRPT's probabilities of being free.
  const float free_if_crossed = static_cast<float>(1.0 - o.p_free);
  const float free_if_return = static_cast<float>(1.0 - o.p_occupied);
  for (const auto& s : scans) {
    const double ox = s.T_map_sensor.x_m, oy = s.T_map_sensor.y_m;
    if (!std::isfinite(ox) || !std::isfinite(oy)) continue;
    // Nearest return per bearing bin.
    std::map<long, std::pair<double, msgs::Point2>> first;
    for (const auto& p : s.points_map) {
      int ix = 0, iy = 0;
      if (!frame.CellOf(p.x_m, p.y_m, &ix, &iy)) continue;
      const double dx = p.x_m - ox, dy = p.y_m - oy;
      const double r = std::hypot(dx, dy);
      const long bin = std::lround(std::floor(std::atan2(dy, dx) / o.bearing_bin_rad));
      auto [it, added] = first.try_emplace(bin, r, p);
      if (!added && r < it->second.first) it->second = {r, p};
      const std::size_t c = static_cast<std::size_t>(iy) * frame.width + ix;
      if (mark[c] == 0) touched.push_back(c);
      mark[c] = 2;
    }
    // Free cells from the sensor up to (not into) the cell of each beam's first return,
    // sampled every quarter cell.
    for (const auto& [bin, hit] : first) {
      const auto& [r, p] = hit;
      int ex = 0, ey = 0;
      frame.CellOf(p.x_m, p.y_m, &ex, &ey);
      const int steps = static_cast<int>(std::ceil(4.0 * r / frame.cell_size_m));
      for (int i = 0; i < steps; ++i) {
        const double t = static_cast<double>(i) / steps;
        int ix = 0, iy = 0;
        if (!frame.CellOf(ox + t * (p.x_m - ox), oy + t * (p.y_m - oy), &ix, &iy)) continue;
        if (ix == ex && iy == ey) break;
        const std::size_t c = static_cast<std::size_t>(iy) * frame.width + ix;
        if (mark[c] == 0) {
          mark[c] = 1;
          touched.push_back(c);
        }
      }
    }
    for (const std::size_t c : touched) {
      const int ix = static_cast<int>(c % static_cast<std::size_t>(frame.width));
      const int iy = static_cast<int>(c / static_cast<std::size_t>(frame.width));
      m.updateCell(ix, iy, mark[c] == 2 ? free_if_return : free_if_crossed);
      mark[c] = 0;
    }
    touched.clear();
  }
  return FromMrpt(m);
}

std::vector<Scan> ScansFromMap(const std::vector<msgs::Point2>& points,
                               const std::vector<msgs::Pose2>& kfs, const GridOptions& o) {
  Validate(o);
  std::vector<Scan> scans(kfs.size());
  for (std::size_t k = 0; k < kfs.size(); ++k) scans[k].T_map_sensor = kfs[k];
  const double r2_max = o.max_range_m * o.max_range_m;
  for (const auto& p : points) {
    double best = std::numeric_limits<double>::infinity();
    std::size_t best_k = kfs.size();
    for (std::size_t k = 0; k < kfs.size(); ++k) {
      const double dx = p.x_m - kfs[k].x_m, dy = p.y_m - kfs[k].y_m;
      const double r2 = dx * dx + dy * dy;
      if (r2 >= best || r2 > r2_max) continue;
      if (std::abs(WrapPi(std::atan2(dy, dx) - kfs[k].yaw_rad)) > 0.5 * o.fov_rad) continue;
      best = r2;
      best_k = k;
    }
    if (best_k < kfs.size()) scans[best_k].points_map.push_back(p);
  }
  return scans;
}

void WriteGridPng(const Grid& grid, const std::string& path) {
  if (grid.width <= 0 || grid.height <= 0) {
    throw std::runtime_error(path + ": empty occupancy grid, nothing to draw");
  }
  if (!ToMrpt(grid).saveAsBitmapFile(path)) throw std::runtime_error("cannot write " + path);
}

void WriteGridFile(const Grid& grid, const std::string& path) {
  const auto m = ToMrpt(grid);
  try {
    mrpt::io::CFileGZOutputStream f;
    if (!f.open(path)) throw std::runtime_error("cannot open");
    auto archive = mrpt::serialization::archiveFrom(f);
    archive << m;
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write " + path + ": " + e.what());
  }
}

Grid ReadGridFile(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) {
    throw std::runtime_error(path + ": no such grid file");
  }
  mrpt::maps::COccupancyGridMap2D m;
  try {
    mrpt::io::CFileGZInputStream f;
    if (!f.open(path)) throw std::runtime_error("cannot open");
    auto archive = mrpt::serialization::archiveFrom(f);
    archive >> m;
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": not an MRPT occupancy grid (COccupancyGridMap2D): " +
                             std::string(e.what()).substr(0, 300));
  }
  return FromMrpt(m);
}

}  // namespace draco::occupancy
