#include "draco/report/grids.hpp"

#include <cstdio>

namespace draco::report {

std::optional<ReportFigure> WriteGridFigure(const std::vector<GridLayer>& layers,
                                            const occupancy::GridOptions& options,
                                            const std::filesystem::path& dir,
                                            const std::string& stem, const std::string& caption) {
  std::vector<occupancy::Scan> scans;
  std::size_t points = 0;
  for (const auto& layer : layers) {
    std::vector<msgs::Pose2> poses;
    poses.reserve(layer.keyframes.size());
    for (const auto& k : layer.keyframes) poses.push_back({k.x_m, k.y_m, k.yaw_rad});
    std::vector<msgs::Point2> cloud;
    cloud.reserve(layer.cloud.size());
    for (const auto& p : layer.cloud) cloud.push_back({p.x, p.y});
    for (auto& s : occupancy::ScansFromMap(cloud, poses, options)) {
      points += s.points_map.size();
      scans.push_back(std::move(s));
    }
  }
  if (points == 0) return std::nullopt;
  const occupancy::Grid grid = occupancy::BuildGrid(scans, options);
  const std::string png = stem + ".png";
  occupancy::WriteGridPng(grid, (dir / png).string());
  occupancy::WriteGridFile(grid, (dir / (stem + ".gridmap.gz")).string());
  char size[160];
  std::snprintf(size, sizeof size,
                " %d x %d cells of %.2f m; %d free, %d occupied (white free, black occupied, "
                "grey unknown; MRPT grid file %s.gridmap.gz).",
                grid.width, grid.height, grid.cell_size_m, grid.Count(occupancy::CellState::kFree),
                grid.Count(occupancy::CellState::kOccupied), stem.c_str());
  return ReportFigure{png, caption + size};
}

bool IsGridFigure(const std::string& path) {
  const std::string suffix = ".grid.png";
  return path == "team_grid.png" ||
         (path.size() > suffix.size() &&
          path.compare(path.size() - suffix.size(), suffix.size(), suffix) == 0);
}

}  // namespace draco::report
