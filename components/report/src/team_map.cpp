#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "canvas.hpp"
#include "draco/report/figures.hpp"

namespace draco::report {
namespace {

using detail::Bgr;
using detail::Lighten;

struct Bounds {
  double x0 = std::numeric_limits<double>::infinity();
  double y0 = std::numeric_limits<double>::infinity();
  double x1 = -std::numeric_limits<double>::infinity();
  double y1 = -std::numeric_limits<double>::infinity();
  void Add(const Xy& p) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return;
    x0 = std::min(x0, p.x);
    y0 = std::min(y0, p.y);
    x1 = std::max(x1, p.x);
    y1 = std::max(y1, p.y);
  }
  bool Empty() const { return !(x1 >= x0 && y1 >= y0); }
};

std::array<Xy, 4> Corners(const ObjectRect& o) {
  const double c = std::cos(o.yaw_rad), s = std::sin(o.yaw_rad);
  const double l = o.length_m / 2.0, b = o.breadth_m / 2.0;
  std::array<Xy, 4> out;
  const double sx[4] = {l, -l, -l, l}, sy[4] = {b, b, -b, -b};
  for (int i = 0; i < 4; ++i) {
    out[static_cast<std::size_t>(i)] = {o.centre.x + c * sx[i] - s * sy[i],
                                        o.centre.y + s * sx[i] + c * sy[i]};
  }
  return out;
}

Rgb LayerColour(const TeamMap& map, std::size_t i) {
  return map.robots[i].colour.value_or(RobotColour(static_cast<int>(i)));
}

cv::Point2d Px(const MapProjection& proj, const Xy& p) {
  const Xy q = proj.ToPixel(p);
  return {q.x, q.y};
}

std::vector<cv::Point2d> Px(const MapProjection& proj, const std::vector<Xy>& pts) {
  std::vector<cv::Point2d> out;
  out.reserve(pts.size());
  for (const auto& p : pts) out.push_back(Px(proj, p));
  return out;
}

// 1, 2 or 5 times a power of ten, close to `target` metres.
double NiceLength(double target) {
  if (!(target > 0)) return 1.0;
  const double mag = std::pow(10.0, std::floor(std::log10(target)));
  double best = mag;
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * mag <= target) best = m * mag;
  }
  return best;
}

}  // namespace

MapProjection ProjectTeamMap(const TeamMap& map, const MapOptions& o) {
  Bounds b;
  for (const auto& r : map.robots) {
    for (const auto* v : {&r.estimate, &r.truth, &r.cloud}) {
      for (const auto& p : *v) b.Add(p);
    }
  }
  for (const auto& obj : map.objects) {
    for (const auto& c : Corners(obj)) b.Add(c);
  }
  for (const auto& l : map.inter_robot_loops) {
    b.Add(l.a);
    b.Add(l.b);
  }
  if (b.Empty()) b = Bounds{-10, -10, 10, 10};
  // At least 2 m across so a single point still gets a sensible scale.
  const double cx = (b.x0 + b.x1) / 2.0, cy = (b.y0 + b.y1) / 2.0;
  const double wx = std::max(b.x1 - b.x0, 2.0) * (1.0 + 2.0 * o.margin_fraction);
  const double wy = std::max(b.y1 - b.y0, 2.0) * (1.0 + 2.0 * o.margin_fraction);
  const double area_w = std::max(1, o.width_px - o.legend_width_px);
  const double area_h = std::max(1, o.height_px - o.title_height_px);
  MapProjection p;
  p.px_per_m = std::min(area_w / wx, area_h / wy);
  const double centre_px_x = area_w / 2.0;
  const double centre_px_y = o.title_height_px + area_h / 2.0;
  p.origin_x_px = centre_px_x - cx * p.px_per_m;
  p.origin_y_px = centre_px_y + cy * p.px_per_m;
  return p;
}

void RenderTeamMap(const TeamMap& map, const std::string& png_path, const MapOptions& o) {
  cv::Mat img(o.height_px, o.width_px, CV_8UC3, detail::kWhite);
  const MapProjection proj = ProjectTeamMap(map, o);
  const int map_w = o.width_px - o.legend_width_px;

  // Light metre grid.
  {
    const double x_lo = (0 - proj.origin_x_px) / proj.px_per_m;
    const double x_hi = (map_w - proj.origin_x_px) / proj.px_per_m;
    const double y_hi = (proj.origin_y_px - o.title_height_px) / proj.px_per_m;
    const double y_lo = (proj.origin_y_px - o.height_px) / proj.px_per_m;
    const auto xt = NiceTicks(x_lo, x_hi, 8);
    const double step = xt.size() > 1 ? xt[1] - xt[0] : 10.0;
    for (const double x : xt) {
      const double px = proj.origin_x_px + x * proj.px_per_m;
      cv::line(img, cv::Point(static_cast<int>(px), o.title_height_px),
               cv::Point(static_cast<int>(px), o.height_px - 1), detail::kGrid, 1);
    }
    for (double y = std::ceil(y_lo / step) * step; y <= y_hi; y += step) {
      const double py = proj.origin_y_px - y * proj.px_per_m;
      cv::line(img, cv::Point(0, static_cast<int>(py)), cv::Point(map_w - 1, static_cast<int>(py)),
               detail::kGrid, 1);
    }
  }

  // Point clouds first (underneath), as small dots in a lighter robot colour.
  for (std::size_t i = 0; i < map.robots.size(); ++i) {
    const cv::Vec3b c = [&] {
      const Rgb l = Lighten(LayerColour(map, i), 0.45);
      return cv::Vec3b(l.b, l.g, l.r);
    }();
    for (const auto& p : map.robots[i].cloud) {
      const Xy q = proj.ToPixel(p);
      const int u = static_cast<int>(std::lround(q.x)), v = static_cast<int>(std::lround(q.y));
      for (int dv = 0; dv <= 1; ++dv) {
        for (int du = 0; du <= 1; ++du) {
          const int uu = u + du, vv = v + dv;
          if (uu >= 0 && uu < map_w && vv >= o.title_height_px && vv < o.height_px) {
            img.at<cv::Vec3b>(vv, uu) = c;
          }
        }
      }
    }
  }
  // Ground truth: dashed, lighter.
  for (std::size_t i = 0; i < map.robots.size(); ++i) {
    detail::DashedPolyline(img, Px(proj, map.robots[i].truth),
                           Bgr(Lighten(LayerColour(map, i), 0.55)), 2, 9.0, 6.0);
  }
  // Objects.
  for (const auto& obj : map.objects) {
    const auto corners = Corners(obj);
    std::vector<cv::Point2d> pts;
    for (const auto& c : corners) pts.push_back(Px(proj, c));
    pts.push_back(pts.front());
    const cv::Scalar colour =
        obj.robot >= 0 && static_cast<std::size_t>(obj.robot) < map.robots.size()
            ? Bgr(LayerColour(map, static_cast<std::size_t>(obj.robot)))
            : detail::kBlack;
    detail::Polyline(img, pts, colour, 2);
  }
  // Estimates: solid, with a start marker.
  for (std::size_t i = 0; i < map.robots.size(); ++i) {
    const auto pts = Px(proj, map.robots[i].estimate);
    const cv::Scalar colour = Bgr(LayerColour(map, i));
    detail::Polyline(img, pts, colour, 3);
    if (!pts.empty()) {
      cv::circle(img,
                 cv::Point(static_cast<int>(std::lround(pts.front().x)),
                           static_cast<int>(std::lround(pts.front().y))),
                 6, colour, cv::FILLED, cv::LINE_AA);
      cv::circle(img,
                 cv::Point(static_cast<int>(std::lround(pts.front().x)),
                           static_cast<int>(std::lround(pts.front().y))),
                 6, detail::kBlack, 1, cv::LINE_AA);
    }
  }
  // Inter-robot loop closures on top.
  for (const auto& l : map.inter_robot_loops) {
    const std::vector<cv::Point2d> pts{Px(proj, l.a), Px(proj, l.b)};
    if (l.correct) {
      detail::Polyline(img, pts, Bgr(kLoopColour), 2);
    } else {
      detail::DashedPolyline(img, pts, Bgr(kLoopColour), 1, 5.0, 4.0);
    }
  }

  // Title strip and legend panel (drawn over anything that spilled).
  cv::rectangle(img, cv::Rect(0, 0, o.width_px, o.title_height_px), detail::kWhite, cv::FILLED);
  cv::rectangle(img, cv::Rect(map_w, 0, o.legend_width_px, o.height_px), detail::kWhite,
                cv::FILLED);
  cv::line(img, cv::Point(0, o.title_height_px), cv::Point(map_w, o.title_height_px), detail::kAxis,
           1);
  cv::line(img, cv::Point(map_w, o.title_height_px), cv::Point(map_w, o.height_px), detail::kAxis,
           1);
  if (!map.title.empty()) {
    detail::Text(img, map.title, {12.0, o.title_height_px - 12.0}, 0.7, detail::kBlack,
                 detail::Align::kLeft, 2);
  }

  // Legend.
  const double lx = map_w + 14.0;
  double ly = o.title_height_px + 24.0;
  const double row = 24.0;
  detail::Text(img, "Robots", {lx, ly}, 0.55, detail::kBlack, detail::Align::kLeft, 2);
  ly += row;
  for (std::size_t i = 0; i < map.robots.size(); ++i) {
    const cv::Scalar c = Bgr(LayerColour(map, i));
    detail::Line(img, {lx, ly - 5}, {lx + 34, ly - 5}, c, 3);
    detail::Text(img, map.robots[i].name, {lx + 44, ly}, 0.5, detail::kBlack);
    ly += row;
  }
  ly += 8;
  bool any_truth = false, any_cloud = false;
  for (const auto& r : map.robots) {
    any_truth |= !r.truth.empty();
    any_cloud |= !r.cloud.empty();
  }
  const cv::Scalar grey(120, 120, 120);
  detail::Line(img, {lx, ly - 5}, {lx + 34, ly - 5}, grey, 3);
  detail::Text(img, "estimate", {lx + 44, ly}, 0.5, detail::kBlack);
  ly += row;
  if (any_truth) {
    detail::DashedPolyline(img, {{lx, ly - 5}, {lx + 34, ly - 5}}, Bgr(Rgb{170, 170, 170}), 2, 9.0,
                           6.0);
    detail::Text(img, "ground truth", {lx + 44, ly}, 0.5, detail::kBlack);
    ly += row;
  }
  if (any_cloud) {
    for (int k = 0; k < 6; ++k) {
      cv::rectangle(img, cv::Rect(static_cast<int>(lx) + k * 6, static_cast<int>(ly) - 6, 2, 2),
                    cv::Scalar(150, 150, 150), cv::FILLED);
    }
    detail::Text(img, "map points", {lx + 44, ly}, 0.5, detail::kBlack);
    ly += row;
  }
  if (!map.objects.empty()) {
    cv::rectangle(img, cv::Rect(static_cast<int>(lx) + 4, static_cast<int>(ly) - 12, 26, 12),
                  detail::kBlack, 2);
    detail::Text(img, "objects (" + std::to_string(map.objects.size()) + ")", {lx + 44, ly}, 0.5,
                 detail::kBlack);
    ly += row;
  }
  if (!map.inter_robot_loops.empty()) {
    detail::Line(img, {lx, ly - 5}, {lx + 34, ly - 5}, Bgr(kLoopColour), 2);
    detail::Text(img, "inter-robot loops (" + std::to_string(map.inter_robot_loops.size()) + ")",
                 {lx + 44, ly}, 0.45, detail::kBlack);
    ly += row;
  }

  // Scale bar, bottom left of the map area, on a white box.
  {
    const double target_m = (map_w * 0.2) / proj.px_per_m;
    const double len_m = NiceLength(target_m);
    const double len_px = len_m * proj.px_per_m;
    const int x0 = 20, y0 = o.height_px - 22;
    char label[32];
    std::snprintf(label, sizeof(label), len_m >= 1 ? "%.0f m" : "%.2g m", len_m);
    const cv::Size ts = detail::TextSize(label, 0.5);
    cv::rectangle(img, cv::Rect(x0 - 8, y0 - 28, static_cast<int>(len_px) + 16 + ts.width + 12, 40),
                  detail::kWhite, cv::FILLED);
    cv::rectangle(img, cv::Rect(x0 - 8, y0 - 28, static_cast<int>(len_px) + 16 + ts.width + 12, 40),
                  cv::Scalar(180, 180, 180), 1);
    cv::rectangle(img, cv::Rect(x0, y0 - 4, static_cast<int>(std::lround(len_px)), 6),
                  detail::kBlack, cv::FILLED);
    cv::line(img, cv::Point(x0, y0 - 12), cv::Point(x0, y0 + 4), detail::kBlack, 2);
    cv::line(img, cv::Point(x0 + static_cast<int>(std::lround(len_px)), y0 - 12),
             cv::Point(x0 + static_cast<int>(std::lround(len_px)), y0 + 4), detail::kBlack, 2);
    detail::Text(img, label, {x0 + len_px + 10, y0 + 4.0}, 0.5, detail::kBlack);
  }
  // North arrow (world y up), top right of the map area.
  {
    const int ax = map_w - 30, ay = o.title_height_px + 50;
    cv::arrowedLine(img, cv::Point(ax, ay), cv::Point(ax, ay - 30), detail::kAxis, 2, cv::LINE_AA,
                    0, 0.3);
    detail::Text(img, "y", {ax + 8.0, ay - 18.0}, 0.45, detail::kAxis);
  }

  detail::WritePng(img, png_path);
}

}  // namespace draco::report
