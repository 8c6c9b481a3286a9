// Internal drawing helpers shared by the figure renderers (OpenCV stays inside src/).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "draco/report/figures.hpp"

namespace draco::report::detail {

inline cv::Scalar Bgr(const Rgb& c) { return cv::Scalar(c.b, c.g, c.r); }
// Mixes `c` with white: f = 0 keeps c, f = 1 gives white.
Rgb Lighten(const Rgb& c, double f);

inline const cv::Scalar kBlack(0, 0, 0);
inline const cv::Scalar kWhite(255, 255, 255);
inline const cv::Scalar kGrid(225, 225, 225);
inline const cv::Scalar kAxis(60, 60, 60);

// Sub-pixel anti-aliased line.
void Line(cv::Mat& img, cv::Point2d a, cv::Point2d b, const cv::Scalar& colour, int thickness);
void Polyline(cv::Mat& img, const std::vector<cv::Point2d>& pts, const cv::Scalar& colour,
              int thickness);
// Dashes of dash_px separated by gap_px, continuing across vertices.
void DashedPolyline(cv::Mat& img, const std::vector<cv::Point2d>& pts, const cv::Scalar& colour,
                    int thickness, double dash_px = 10.0, double gap_px = 7.0);

enum class Align { kLeft, kCentre, kRight };
// Text with its baseline at y; scale 0.5 is about 11 px tall.
void Text(cv::Mat& img, const std::string& text, cv::Point2d at, double scale,
          const cv::Scalar& colour, Align align = Align::kLeft, int thickness = 1);
// Text rotated 90 degrees counter-clockwise, centred on `centre` (y-axis labels).
void VerticalText(cv::Mat& img, const std::string& text, cv::Point2d centre, double scale,
                  const cv::Scalar& colour);
cv::Size TextSize(const std::string& text, double scale, int thickness = 1);

// Tick label: as few decimals as the step needs.
std::string FormatTick(double value, double step);

// PNG encoding + atomic write.
void WritePng(const cv::Mat& img, const std::string& path);

}  // namespace draco::report::detail
