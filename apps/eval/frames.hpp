// Sonar frames with CFAR detections for the report: picks the most structure-rich pings of a
// robot and draws the feature extractor's detections on the fan image.
#pragma once

#include <string>
#include <vector>

#include "draco/report/run_report.hpp"

namespace draco::eval_app {

struct FramesOptions {
  std::string mission_dir;
  std::string robot;  // empty: every robot of the mission
  int per_robot = 3;
};

// Writes <run_dir>/frames/<robot>_ping<id>.png; returns them relative to run_dir.
std::vector<report::ReportFigure> RenderFrames(const std::string& run_dir,
                                               const FramesOptions& options);

}  // namespace draco::eval_app
