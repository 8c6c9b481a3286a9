// Occupancy-grid figures of a run (components/occupancy): a robot's point map and the keyframe
// poses it was seen from, in one frame, fused into a grid written as <stem>.png and
// <stem>.gridmap.gz (MRPT's grid file) in the run folder. docs/results.md.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "draco/eval/trajectory.hpp"
#include "draco/occupancy/grid.hpp"
#include "draco/report/figures.hpp"
#include "draco/report/run_report.hpp"

namespace draco::report {

// One robot's share: its keyframe poses and its map points, in the grid's frame.
struct GridLayer {
  eval::Trajectory keyframes;
  std::vector<Xy> cloud;
};

// Builds the grid of the layers together and writes it; returns the PNG as a report figure
// (caption given), or nothing when no map point is seen from a keyframe. Throws
// std::runtime_error naming the file when it cannot be written.
std::optional<ReportFigure> WriteGridFigure(const std::vector<GridLayer>& layers,
                                            const occupancy::GridOptions& options,
                                            const std::filesystem::path& dir,
                                            const std::string& stem, const std::string& caption);

// True for the grid PNGs WriteGridFigure names (<robot>.grid.png, team_grid.png).
bool IsGridFigure(const std::string& path);

}  // namespace draco::report
