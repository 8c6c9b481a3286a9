// A sonar ping as a Cartesian fan image (PNG) with feature detections drawn on it.
#pragma once

#include <string>
#include <vector>

#include "draco/msgs/sensors.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::report {

struct SonarFrameOptions {
  int width_px = 900;           // the fan is scaled to this width (height follows)
  std::string caption;          // drawn at the top-left, e.g. "alpha ping 450, t = 90.0 s"
  double grid_spacing_m = 5.0;  // range rings; 0 = none
};

// Fan image of `ping` (range up, bearing counter-clockwise = to the left, sensor at the bottom
// centre), grey scale, with range rings, and `detections` (points in the sensor frame: x
// along the zero bearing, y left) as circles. Written atomically; throws on failure.
void RenderSonarFrame(const msgs::SonarPing& ping, const std::vector<msgs::Point2>& detections,
                      const std::string& png_path, const SonarFrameOptions& options = {});

// Fraction of the ping's cells at or above `threshold`: a cheap "how much structure" score
// for picking frames worth looking at.
double PingStructureScore(const msgs::SonarPing& ping, int threshold = 85);

}  // namespace draco::report
