#include "draco/report/sonar_frame.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "canvas.hpp"

namespace draco::report {

double PingStructureScore(const msgs::SonarPing& ping, int threshold) {
  if (ping.intensity.empty()) return 0.0;
  std::size_t n = 0;
  for (const std::uint8_t v : ping.intensity) n += v >= threshold ? 1 : 0;
  return static_cast<double>(n) / static_cast<double>(ping.intensity.size());
}

void RenderSonarFrame(const msgs::SonarPing& ping, const std::vector<msgs::Point2>& detections,
                      const std::string& png_path, const SonarFrameOptions& o) {
  if (ping.num_beams < 2 || ping.num_ranges < 1 || ping.range_resolution_m <= 0 ||
      ping.bearings_rad.size() != static_cast<std::size_t>(ping.num_beams) ||
      ping.intensity.size() !=
          static_cast<std::size_t>(ping.num_beams) * static_cast<std::size_t>(ping.num_ranges)) {
    throw std::invalid_argument(png_path + ": inconsistent sonar ping");
  }
  const double max_range = ping.MaxRangeM();
  const double b_lo = ping.bearings_rad.front(), b_hi = ping.bearings_rad.back();
  const double half = std::max(std::abs(b_lo), std::abs(b_hi));
  // Extent in the sensor frame: forward 0..max_range, lateral +-max_range sin(half).
  const double lateral = max_range * std::sin(std::min(half, M_PI / 2.0));
  const double forward_min = half > M_PI / 2.0 ? max_range * std::cos(half) : 0.0;
  const int top = 36, pad = 14;
  const double scale = (o.width_px - 2.0 * pad) / (2.0 * lateral);
  const int height =
      top + pad + static_cast<int>(std::ceil((max_range - forward_min) * scale)) + pad;
  cv::Mat img(height, o.width_px, CV_8UC3, cv::Scalar(35, 30, 30));
  const double cx = o.width_px / 2.0;
  const double cy = top + pad + max_range * scale;  // sensor position (row)

  // Display gamma: faint returns become visible; detection is not affected.
  std::uint8_t gamma[256];
  for (int i = 0; i < 256; ++i) {
    gamma[i] = static_cast<std::uint8_t>(std::lround(255.0 * std::pow(i / 255.0, 0.6)));
  }
  // Fan: nearest beam and range bin for each pixel.
  for (int v = 0; v < height; ++v) {
    auto* row = img.ptr<cv::Vec3b>(v);
    for (int u = 0; u < o.width_px; ++u) {
      const double x = (cy - v) / scale, y = (cx - u) / scale;
      const double r = std::hypot(x, y);
      if (r > max_range || r < ping.range_resolution_m * 0.5) continue;
      const double b = std::atan2(y, x);
      if (b < b_lo || b > b_hi) continue;
      const auto it = std::lower_bound(ping.bearings_rad.begin(), ping.bearings_rad.end(),
                                       static_cast<float>(b));
      int beam = static_cast<int>(it - ping.bearings_rad.begin());
      if (beam >= ping.num_beams) beam = ping.num_beams - 1;
      if (beam > 0 && std::abs(ping.bearings_rad[static_cast<std::size_t>(beam - 1)] - b) <
                          std::abs(ping.bearings_rad[static_cast<std::size_t>(beam)] - b)) {
        --beam;
      }
      const int bin = std::clamp(static_cast<int>(std::lround(r / ping.range_resolution_m)) - 1, 0,
                                 ping.num_ranges - 1);
      const std::uint8_t g = gamma[ping.At(bin, beam)];
      row[u] = cv::Vec3b(g, g, g);
    }
  }
  // Range rings and the fan edges.
  const cv::Scalar ring(110, 160, 110);
  if (o.grid_spacing_m > 0) {
    for (double rr = o.grid_spacing_m; rr <= max_range + 1e-9; rr += o.grid_spacing_m) {
      const double a0 = -b_hi * 180.0 / M_PI - 90.0, a1 = -b_lo * 180.0 / M_PI - 90.0;
      cv::ellipse(img, cv::Point(static_cast<int>(cx), static_cast<int>(cy)),
                  cv::Size(static_cast<int>(rr * scale), static_cast<int>(rr * scale)), 0.0, a0, a1,
                  ring, 1, cv::LINE_AA);
      char label[32];
      std::snprintf(label, sizeof(label), "%g m", rr);
      // Inside the fan, just right of its left edge.
      const double lx = cx - rr * scale * std::sin(b_hi) + 6.0;
      const double ly = cy - rr * scale * std::cos(b_hi) - 4.0;
      detail::Text(img, label, {lx, ly}, 0.4, ring, detail::Align::kLeft);
    }
  }
  for (const double b : {b_lo, b_hi}) {
    detail::Line(img, {cx, cy},
                 {cx - max_range * scale * std::sin(b), cy - max_range * scale * std::cos(b)}, ring,
                 1);
  }
  // Detections.
  const cv::Scalar mark(0, 215, 255);  // amber
  for (const auto& p : detections) {
    const cv::Point c(static_cast<int>(std::lround(cx - p.y_m * scale)),
                      static_cast<int>(std::lround(cy - p.x_m * scale)));
    cv::circle(img, c, 3, mark, 1, cv::LINE_AA);
  }
  std::string caption = o.caption;
  if (caption.empty()) caption = std::to_string(detections.size()) + " detections";
  detail::Text(img, caption, {12.0, 24.0}, 0.6, detail::kWhite, detail::Align::kLeft, 1);
  detail::WritePng(img, png_path);
}

}  // namespace draco::report
