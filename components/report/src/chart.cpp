#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "canvas.hpp"
#include "draco/report/figures.hpp"

namespace draco::report {
namespace {

using detail::Bgr;

struct Frame {
  cv::Rect plot;
  double x0, x1, y0, y1;
  double X(double x) const { return plot.x + (x - x0) / (x1 - x0) * plot.width; }
  double Y(double y) const { return plot.y + plot.height - (y - y0) / (y1 - y0) * plot.height; }
};

void Range(double* lo, double* hi) {
  if (!std::isfinite(*lo) || !std::isfinite(*hi)) {
    *lo = 0.0;
    *hi = 1.0;
  }
  if (*hi - *lo < 1e-12) {
    const double pad = std::max(std::abs(*lo) * 0.1, 0.5);
    *lo -= pad;
    *hi += pad;
  }
}

// Axes, grid, ticks, labels and title; x ticks are numeric unless `categories` is given.
Frame DrawAxes(cv::Mat& img, const ChartOptions& o, double x0, double x1, double y0, double y1,
               bool numeric_x) {
  Frame f;
  f.plot = cv::Rect(86, 46, o.width_px - 86 - 24, o.height_px - 46 - 64);
  f.x0 = x0;
  f.x1 = x1;
  f.y0 = y0;
  f.y1 = y1;
  const auto yt = NiceTicks(y0, y1, 6);
  const double ystep = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  for (const double y : yt) {
    const double py = f.Y(y);
    detail::Line(img, {static_cast<double>(f.plot.x), py},
                 {static_cast<double>(f.plot.x + f.plot.width), py}, detail::kGrid, 1);
    detail::Line(img, {f.plot.x - 5.0, py}, {static_cast<double>(f.plot.x), py}, detail::kAxis, 1);
    detail::Text(img, detail::FormatTick(y, ystep), {f.plot.x - 9.0, py + 5}, 0.45, detail::kAxis,
                 detail::Align::kRight);
  }
  if (numeric_x) {
    const auto xt = NiceTicks(x0, x1, 7);
    const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1.0;
    for (const double x : xt) {
      const double px = f.X(x);
      detail::Line(img, {px, static_cast<double>(f.plot.y)},
                   {px, static_cast<double>(f.plot.y + f.plot.height)}, detail::kGrid, 1);
      detail::Line(img, {px, static_cast<double>(f.plot.y + f.plot.height)},
                   {px, f.plot.y + f.plot.height + 5.0}, detail::kAxis, 1);
      detail::Text(img, detail::FormatTick(x, xstep), {px, f.plot.y + f.plot.height + 22.0}, 0.45,
                   detail::kAxis, detail::Align::kCentre);
    }
  }
  cv::rectangle(img, f.plot, detail::kAxis, 1);
  if (!o.title.empty()) {
    detail::Text(img, o.title, {o.width_px / 2.0, 30.0}, 0.65, detail::kBlack,
                 detail::Align::kCentre, 2);
  }
  if (!o.x_label.empty()) {
    detail::Text(img, o.x_label, {f.plot.x + f.plot.width / 2.0, o.height_px - 14.0}, 0.55,
                 detail::kBlack, detail::Align::kCentre);
  }
  if (!o.y_label.empty()) {
    detail::VerticalText(img, o.y_label, {20.0, f.plot.y + f.plot.height / 2.0}, 0.55,
                         detail::kBlack);
  }
  return f;
}

struct LegendEntry {
  std::string label;
  cv::Scalar colour;
  bool dashed = false;
  bool box = false;
};

void DrawLegend(cv::Mat& img, const Frame& f, const std::vector<LegendEntry>& entries) {
  if (entries.empty()) return;
  int text_w = 0;
  for (const auto& e : entries) text_w = std::max(text_w, detail::TextSize(e.label, 0.45).width);
  const int w = text_w + 58, h = static_cast<int>(entries.size()) * 20 + 10;
  const cv::Rect box(f.plot.x + f.plot.width - w - 8, f.plot.y + 8, w, h);
  cv::rectangle(img, box, detail::kWhite, cv::FILLED);
  cv::rectangle(img, box, cv::Scalar(180, 180, 180), 1);
  double y = box.y + 20.0;
  for (const auto& e : entries) {
    const double x = box.x + 8.0;
    if (e.box) {
      cv::rectangle(img, cv::Rect(static_cast<int>(x) + 6, static_cast<int>(y) - 12, 20, 12),
                    e.colour, cv::FILLED);
    } else if (e.dashed) {
      detail::DashedPolyline(img, {{x, y - 5}, {x + 32, y - 5}}, e.colour, 2, 7.0, 4.0);
    } else {
      detail::Line(img, {x, y - 5}, {x + 32, y - 5}, e.colour, 2);
    }
    detail::Text(img, e.label, {x + 42, y}, 0.45, detail::kBlack);
    y += 20.0;
  }
}

// The line chart as an image (RenderLineChart, RenderLineChartPanels).
cv::Mat DrawLineChart(const std::vector<Series>& series, const ChartOptions& o) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0;
  double y0 = x0, y1 = -x0;
  for (const auto& s : series) {
    if (s.x.size() != s.y.size()) {
      throw std::invalid_argument("series '" + s.label + "': x and y differ in size");
    }
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  }
  for (const auto& r : o.references) {
    y0 = std::min(y0, r.y);
    y1 = std::max(y1, r.y);
  }
  Range(&x0, &x1);
  Range(&y0, &y1);
  if (o.y_from_zero) {
    y0 = std::min(y0, 0.0);
    y1 = std::max(y1, 0.0);
  }
  const double pad = (y1 - y0) * 0.06;
  if (!(o.y_from_zero && y0 == 0.0)) y0 -= pad;
  y1 += pad;
  x0 = o.x_min.value_or(x0);
  x1 = o.x_max.value_or(x1);
  y0 = o.y_min.value_or(y0);
  y1 = o.y_max.value_or(y1);
  Range(&x0, &x1);
  Range(&y0, &y1);

  cv::Mat img(o.height_px, o.width_px, CV_8UC3, detail::kWhite);
  const Frame f = DrawAxes(img, o, x0, x1, y0, y1, true);
  std::vector<LegendEntry> legend;
  cv::Mat plot = img(f.plot);  // clip data to the plot area
  auto local = [&](double x, double y) {
    return cv::Point2d(f.X(x) - f.plot.x, f.Y(y) - f.plot.y);
  };
  for (const auto& r : o.references) {
    detail::DashedPolyline(plot, {local(x0, r.y), local(x1, r.y)}, Bgr(r.colour), 2, 10.0, 6.0);
    legend.push_back({r.label, Bgr(r.colour), true});
  }
  for (std::size_t k = 0; k < series.size(); ++k) {
    const auto& s = series[k];
    const cv::Scalar c = Bgr(s.colour.value_or(RobotColour(static_cast<int>(k))));
    std::vector<cv::Point2d> pts;
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) pts.push_back(local(s.x[i], s.y[i]));
    }
    if (s.dashed) {
      detail::DashedPolyline(plot, pts, c, 2);
    } else {
      detail::Polyline(plot, pts, c, 2);
    }
    if (s.markers) {
      for (const auto& p : pts) {
        cv::circle(
            plot, cv::Point(static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y))),
            4, c, cv::FILLED, cv::LINE_AA);
      }
    }
    if (!s.label.empty()) legend.push_back({s.label, c, s.dashed});
  }
  cv::rectangle(img, f.plot, detail::kAxis, 1);
  DrawLegend(img, f, legend);
  return img;
}

}  // namespace

void RenderLineChart(const std::vector<Series>& series, const ChartOptions& o,
                     const std::string& png_path) {
  detail::WritePng(DrawLineChart(series, o), png_path);
}

void RenderLineChartPanels(const std::vector<ChartPanel>& panels, const std::string& png_path) {
  if (panels.empty()) throw std::invalid_argument("RenderLineChartPanels: no panel");
  int height = 0;
  for (const auto& p : panels) height = std::max(height, p.options.height_px);
  std::vector<cv::Mat> images;
  for (const auto& p : panels) {
    cv::Mat img = DrawLineChart(p.series, p.options);
    if (img.rows < height) {
      cv::copyMakeBorder(img, img, 0, height - img.rows, 0, 0, cv::BORDER_CONSTANT, detail::kWhite);
    }
    images.push_back(img);
  }
  cv::Mat out;
  cv::hconcat(images, out);
  detail::WritePng(out, png_path);
}

void RenderBarChart(const std::vector<std::string>& categories,
                    const std::vector<BarSeries>& series, const ChartOptions& o,
                    const std::string& png_path) {
  double y1 = 0.0, y0 = 0.0;
  for (const auto& s : series) {
    if (s.values.size() != categories.size()) {
      throw std::invalid_argument("bar series '" + s.label + "': one value per category needed");
    }
    for (const double v : s.values) {
      if (std::isfinite(v)) {
        y1 = std::max(y1, v);
        y0 = std::min(y0, v);
      }
    }
  }
  // Headroom for the value labels and the legend box in the top right corner.
  y1 = o.y_max.value_or(y1 > y0 ? y1 + (y1 - y0) * 0.35 : 1.0);
  y0 = o.y_min.value_or(y0);
  Range(&y0, &y1);
  const double n = std::max<std::size_t>(categories.size(), 1);
  cv::Mat img(o.height_px, o.width_px, CV_8UC3, detail::kWhite);
  const Frame f = DrawAxes(img, o, 0.0, n, y0, y1, false);
  const double group_w = f.plot.width / n;
  const double bar_w = group_w * 0.75 / std::max<std::size_t>(series.size(), 1);
  std::vector<LegendEntry> legend;
  for (std::size_t k = 0; k < series.size(); ++k) {
    const cv::Scalar c = Bgr(series[k].colour.value_or(RobotColour(static_cast<int>(k))));
    legend.push_back({series[k].label, c, false, true});
    for (std::size_t i = 0; i < categories.size(); ++i) {
      const double v = series[k].values[i];
      if (!std::isfinite(v)) continue;
      const double left = f.plot.x + group_w * i + group_w * 0.125 + bar_w * k;
      const double top = f.Y(std::max(v, 0.0)), bottom = f.Y(std::min(v, 0.0));
      cv::rectangle(
          img,
          cv::Rect(cv::Point(static_cast<int>(left) + 1, static_cast<int>(top)),
                   cv::Point(static_cast<int>(left + bar_w) - 1, static_cast<int>(bottom))),
          c, cv::FILLED);
      char label[32];
      std::snprintf(label, sizeof(label), std::abs(v) < 100 ? "%.2f" : "%.0f", v);
      detail::Text(img, label, {left + bar_w / 2.0, top - 5.0}, 0.4, detail::kAxis,
                   detail::Align::kCentre);
    }
  }
  for (std::size_t i = 0; i < categories.size(); ++i) {
    detail::Text(img, categories[i],
                 {f.plot.x + group_w * (i + 0.5), f.plot.y + f.plot.height + 22.0}, 0.5,
                 detail::kBlack, detail::Align::kCentre);
  }
  cv::rectangle(img, f.plot, detail::kAxis, 1);
  DrawLegend(img, f, legend);
  detail::WritePng(img, png_path);
}

}  // namespace draco::report
