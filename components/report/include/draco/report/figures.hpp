// PNG figures of a run: the team map (trajectories, ground truth, point clouds, objects,
// inter-robot loop closures), "value vs x" line charts, grouped bar charts. No OpenCV in this
// header; every Render* function writes its PNG atomically (temporary file + rename) and
// throws std::runtime_error when it cannot.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace draco::report {

struct Rgb {
  std::uint8_t r = 0;
  std::uint8_t g = 0;
  std::uint8_t b = 0;
  bool operator==(const Rgb&) const = default;
};

// Colour of robot `index` (0, 1, 2, ...): a fixed, distinguishable palette that cycles.
// Purple is kept for inter-robot loop closures and never used for a robot.
Rgb RobotColour(int index);
// Purple of inter-robot loop closures.
inline constexpr Rgb kLoopColour{150, 40, 190};

struct Xy {
  double x = 0.0;
  double y = 0.0;
};

// ---------------------------------------------------------------------------------------
// Team map (the paper's Fig. 1): everything in one world frame, x east, y north (up).

struct RobotLayer {
  std::string name;
  std::optional<Rgb> colour;  // default: RobotColour(position in TeamMap::robots)
  std::vector<Xy> estimate;   // optimised trajectory (solid)
  std::vector<Xy> truth;      // ground truth (dashed, lighter); may be empty
  std::vector<Xy> cloud;      // point-cloud map (small dots, lighter); may be empty
};

// Object rectangle (objects map): centre, long side, short side, direction of the long side.
struct ObjectRect {
  Xy centre;
  double length_m = 0.0;
  double breadth_m = 0.0;
  double yaw_rad = 0.0;
  int robot = -1;  // index into TeamMap::robots for the outline colour; -1 = black
};

// An inter-robot loop closure between two keyframe positions (purple line); a loop judged
// false against ground truth is drawn thinner and dashed.
struct LoopLine {
  Xy a;
  Xy b;
  bool correct = true;
};

struct TeamMap {
  std::string title;
  std::vector<RobotLayer> robots;
  std::vector<ObjectRect> objects;
  std::vector<LoopLine> inter_robot_loops;
};

struct MapOptions {
  int width_px = 1200;
  int height_px = 900;
  double margin_fraction = 0.05;  // of the data extent, on each side
  int legend_width_px = 220;      // legend panel on the right
  int title_height_px = 40;
};

// World (metres) to pixel mapping used by RenderTeamMap, exposed so tests and callers can
// locate data points in the image. Equal scale on both axes; y points up in the world and
// down in the image.
struct MapProjection {
  double px_per_m = 1.0;
  double origin_x_px = 0.0;  // pixel column of world x = 0
  double origin_y_px = 0.0;  // pixel row of world y = 0
  Xy ToPixel(const Xy& p) const {
    return {origin_x_px + p.x * px_per_m, origin_y_px - p.y * px_per_m};
  }
};
MapProjection ProjectTeamMap(const TeamMap& map, const MapOptions& options = {});

void RenderTeamMap(const TeamMap& map, const std::string& png_path, const MapOptions& options = {});

// ---------------------------------------------------------------------------------------
// Line chart: "value vs x" (precision vs overlap threshold, link traffic vs time, ATE vs
// time, ...).

struct Series {
  std::string label;
  std::vector<double> x;
  std::vector<double> y;      // same size as x
  std::optional<Rgb> colour;  // default: RobotColour(series index)
  bool dashed = false;
  bool markers = false;  // a dot at every sample
};

// A horizontal reference line (e.g. the modem budget).
struct ReferenceLine {
  std::string label;
  double y = 0.0;
  Rgb colour{200, 30, 30};
};

struct ChartOptions {
  std::string title;
  std::string x_label;
  std::string y_label;
  int width_px = 900;
  int height_px = 550;
  bool y_from_zero = true;                           // include 0 in the y range
  std::optional<double> x_min, x_max, y_min, y_max;  // override the automatic range
  std::vector<ReferenceLine> references;
};

void RenderLineChart(const std::vector<Series>& series, const ChartOptions& options,
                     const std::string& png_path);

// Several line charts side by side in one PNG (e.g. the paper's Fig. 3: precision and true
// positives against the overlap threshold); each panel has its own size, shorter panels are
// padded at the bottom.
struct ChartPanel {
  std::vector<Series> series;
  ChartOptions options;
};
void RenderLineChartPanels(const std::vector<ChartPanel>& panels, const std::string& png_path);

// Grouped bar chart: one group per category, one bar per series in the group
// (e.g. categories = robots, series = {dead reckoning, local SLAM}).
struct BarSeries {
  std::string label;
  std::vector<double> values;  // one per category; NaN = no bar
  std::optional<Rgb> colour;
};
void RenderBarChart(const std::vector<std::string>& categories,
                    const std::vector<BarSeries>& series, const ChartOptions& options,
                    const std::string& png_path);

// "Nice" axis ticks covering [lo, hi]: steps of 1, 2 or 5 times a power of ten, about
// `target` of them. Returns the tick values inside [lo, hi].
std::vector<double> NiceTicks(double lo, double hi, int target = 6);

}  // namespace draco::report
