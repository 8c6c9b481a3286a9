#include "canvas.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "draco/report/files.hpp"

namespace draco::report {

Rgb RobotColour(int index) {
  // Blue, orange, green, red, brown, teal, olive, pink-red: no purple (loop closures).
  static constexpr std::array<Rgb, 8> kPalette{{{31, 119, 180},
                                                {255, 127, 14},
                                                {44, 160, 44},
                                                {214, 39, 40},
                                                {140, 86, 75},
                                                {23, 190, 207},
                                                {188, 189, 34},
                                                {227, 119, 194}}};
  const int n = static_cast<int>(kPalette.size());
  return kPalette[static_cast<std::size_t>(((index % n) + n) % n)];
}

std::vector<double> NiceTicks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!std::isfinite(lo) || !std::isfinite(hi) || hi <= lo || target < 1) return ticks;
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (const double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * mag;
    if (step >= raw) break;
  }
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (int i = 0;; ++i) {
    const double v = first + i * step;
    if (v > hi + step * 1e-9) break;
    ticks.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
    if (i > 1000) break;
  }
  return ticks;
}

namespace detail {

Rgb Lighten(const Rgb& c, double f) {
  auto mix = [f](std::uint8_t v) {
    return static_cast<std::uint8_t>(std::lround(v + (255.0 - v) * std::clamp(f, 0.0, 1.0)));
  };
  return {mix(c.r), mix(c.g), mix(c.b)};
}

namespace {
constexpr int kShift = 4;
constexpr double kOne = 1 << kShift;
cv::Point Fixed(cv::Point2d p) {
  return {static_cast<int>(std::lround(p.x * kOne)), static_cast<int>(std::lround(p.y * kOne))};
}
}  // namespace

void Line(cv::Mat& img, cv::Point2d a, cv::Point2d b, const cv::Scalar& colour, int thickness) {
  cv::line(img, Fixed(a), Fixed(b), colour, thickness, cv::LINE_AA, kShift);
}

void Polyline(cv::Mat& img, const std::vector<cv::Point2d>& pts, const cv::Scalar& colour,
              int thickness) {
  if (pts.size() == 1) {
    cv::circle(img, Fixed(pts[0]), static_cast<int>(thickness * kOne / 2), colour, cv::FILLED,
               cv::LINE_AA, kShift);
    return;
  }
  std::vector<cv::Point> fixed;
  fixed.reserve(pts.size());
  for (const auto& p : pts) fixed.push_back(Fixed(p));
  cv::polylines(img, fixed, false, colour, thickness, cv::LINE_AA, kShift);
}

void DashedPolyline(cv::Mat& img, const std::vector<cv::Point2d>& pts, const cv::Scalar& colour,
                    int thickness, double dash_px, double gap_px) {
  const double period = dash_px + gap_px;
  double phase = 0.0;  // distance travelled within the current period
  for (std::size_t i = 1; i < pts.size(); ++i) {
    const cv::Point2d a = pts[i - 1], b = pts[i];
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    if (len <= 0) continue;
    const cv::Point2d dir = (b - a) / len;
    double s = 0.0;
    while (s < len) {
      const bool on = phase < dash_px;
      const double left = on ? dash_px - phase : period - phase;
      const double step = std::min(left, len - s);
      if (on) Line(img, a + dir * s, a + dir * (s + step), colour, thickness);
      s += step;
      phase += step;
      if (phase >= period - 1e-9) phase = 0.0;
    }
  }
}

cv::Size TextSize(const std::string& text, double scale, int thickness) {
  int baseline = 0;
  return cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, thickness, &baseline);
}

void Text(cv::Mat& img, const std::string& text, cv::Point2d at, double scale,
          const cv::Scalar& colour, Align align, int thickness) {
  const cv::Size size = TextSize(text, scale, thickness);
  double x = at.x;
  if (align == Align::kCentre) x -= size.width / 2.0;
  if (align == Align::kRight) x -= size.width;
  cv::putText(img, text, cv::Point(static_cast<int>(std::lround(x)), static_cast<int>(at.y)),
              cv::FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv::LINE_AA);
}

void VerticalText(cv::Mat& img, const std::string& text, cv::Point2d centre, double scale,
                  const cv::Scalar& colour) {
  const cv::Size size = TextSize(text, scale);
  cv::Mat strip(size.height + 8, size.width + 4, img.type(), kWhite);
  Text(strip, text, {2.0, size.height + 2.0}, scale, colour);
  cv::Mat rotated;
  cv::rotate(strip, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int x0 = static_cast<int>(centre.x - rotated.cols / 2.0);
  const int y0 = static_cast<int>(centre.y - rotated.rows / 2.0);
  const cv::Rect dst =
      cv::Rect(x0, y0, rotated.cols, rotated.rows) & cv::Rect(0, 0, img.cols, img.rows);
  if (dst.area() <= 0) return;
  const cv::Rect src(dst.x - x0, dst.y - y0, dst.width, dst.height);
  // Copy only the ink so the background of the strip does not hide anything.
  cv::Mat mask;
  cv::Mat grey;
  cv::cvtColor(rotated(src), grey, cv::COLOR_BGR2GRAY);
  cv::compare(grey, 250, mask, cv::CMP_LT);
  rotated(src).copyTo(img(dst), mask);
}

std::string FormatTick(double value, double step) {
  int decimals = 0;
  if (step > 0 && step < 1.0) {
    decimals = std::min(6, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
  }
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, value);
  return buf;
}

void WritePng(const cv::Mat& img, const std::string& path) {
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", img, bytes)) throw std::runtime_error(path + ": PNG encoding failed");
  WriteFileAtomically(path, std::string(bytes.begin(), bytes.end()));
}

}  // namespace detail
}  // namespace draco::report
