#include "pictures.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace draco::sim_app {

namespace {

const cv::Scalar kPathColours[] = {{40, 40, 230},  {40, 170, 40},  {220, 120, 20},
                                   {180, 40, 180}, {20, 180, 220}, {120, 120, 120}};

cv::Scalar MaterialColour(const std::string& name) {
  if (name == "timber") return {40, 90, 150};
  if (name == "concrete") return {150, 150, 150};
  if (name == "steel") return {90, 60, 60};
  if (name == "aluminium") return {200, 190, 180};
  if (name == "fibreglass") return {235, 235, 245};
  if (name == "rock") return {80, 100, 110};
  if (name == "rubber") return {30, 30, 30};
  return {60, 60, 200};
}

void Write(const std::filesystem::path& png, const cv::Mat& image) {
  if (!png.parent_path().empty()) std::filesystem::create_directories(png.parent_path());
  if (!cv::imwrite(png.string(), image)) {
    throw std::runtime_error(png.string() + ": cannot write PNG");
  }
}

}  // namespace

void WriteWorldPicture(const sim::World& world, const std::vector<PathDrawing>& paths,
                       const std::filesystem::path& png, double pixels_per_m) {
  const sim::Vec2 lo = world.bounds_min_m;
  const sim::Vec2 hi = world.bounds_max_m;
  const double extent = std::max(hi.x - lo.x, hi.y - lo.y);
  pixels_per_m = std::min(pixels_per_m, 2000.0 / extent);  // keep pictures a sane size
  const int w = static_cast<int>((hi.x - lo.x) * pixels_per_m) + 1;
  const int h = static_cast<int>((hi.y - lo.y) * pixels_per_m) + 1;
  auto px = [&](sim::Vec2 p) {
    return cv::Point(static_cast<int>(std::lround((p.x - lo.x) * pixels_per_m)),
                     static_cast<int>(std::lround((hi.y - p.y) * pixels_per_m)));
  };
  cv::Mat image(h, w, CV_8UC3);
  // Seabed: deeper is darker blue.
  const double d0 = world.seabed.depth_m;
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      const double x = lo.x + c / pixels_per_m;
      const double y = hi.y - r / pixels_per_m;
      const double depth = -world.seabed.ZAt(x, y);
      const double shade = std::clamp(1.0 - 0.15 * (depth - d0), 0.6, 1.2);
      image.at<cv::Vec3b>(r, c) = cv::Vec3b(static_cast<uchar>(std::min(255.0, 225 * shade)),
                                            static_cast<uchar>(std::min(255.0, 200 * shade)),
                                            static_cast<uchar>(std::min(255.0, 170 * shade)));
    }
  }
  // Grid every 10 m.
  for (double x = std::ceil(lo.x / 10.0) * 10.0; x <= hi.x; x += 10.0) {
    cv::line(image, px({x, lo.y}), px({x, hi.y}), {205, 185, 160}, 1);
  }
  for (double y = std::ceil(lo.y / 10.0) * 10.0; y <= hi.y; y += 10.0) {
    cv::line(image, px({lo.x, y}), px({hi.x, y}), {205, 185, 160}, 1);
  }
  // Structures: floating and low objects lighter, full-height ones solid.
  for (const auto& p : world.primitives) {
    const cv::Scalar colour = MaterialColour(world.materials[p.material].name);
    switch (p.kind) {
      case sim::ShapeKind::kCircle:
        cv::circle(image, px(p.center_m),
                   std::max(1, static_cast<int>(std::lround(p.radius_m * pixels_per_m))), colour,
                   cv::FILLED, cv::LINE_AA);
        break;
      case sim::ShapeKind::kConvexPolygon: {
        std::vector<cv::Point> pts;
        for (const auto& v : p.vertices_m) pts.push_back(px(v));
        cv::fillConvexPoly(image, pts, colour, cv::LINE_AA);
        cv::polylines(image, pts, true, colour * 0.6, 1, cv::LINE_AA);
        break;
      }
      case sim::ShapeKind::kSegment:
        cv::line(image, px(p.vertices_m[0]), px(p.vertices_m[1]), colour, 2, cv::LINE_AA);
        break;
    }
  }
  for (std::size_t i = 0; i < paths.size(); ++i) {
    const cv::Scalar colour = kPathColours[i % std::size(kPathColours)];
    std::vector<cv::Point> pts;
    for (const auto& p : paths[i].points_m) pts.push_back(px(p));
    if (pts.empty()) continue;
    cv::polylines(image, pts, false, colour, 2, cv::LINE_AA);
    cv::circle(image, pts.front(), 6, colour, cv::FILLED, cv::LINE_AA);
    cv::rectangle(image, pts.back() - cv::Point(5, 5), pts.back() + cv::Point(5, 5), colour, 2);
    cv::putText(image, paths[i].name, pts.front() + cv::Point(8, -8), cv::FONT_HERSHEY_SIMPLEX, 0.6,
                colour, 2, cv::LINE_AA);
  }
  // Scale bar: 10 m.
  const cv::Point bar0(15, h - 15);
  cv::line(image, bar0, bar0 + cv::Point(static_cast<int>(10 * pixels_per_m), 0), {0, 0, 0}, 3);
  cv::putText(image, "10 m", bar0 + cv::Point(0, -8), cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 1,
              cv::LINE_AA);
  cv::putText(image, world.name + " (x east, y north)", {15, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.6,
              {0, 0, 0}, 1, cv::LINE_AA);
  Write(png, image);
}

void WritePolarPicture(const msgs::SonarPing& ping, const std::filesystem::path& png) {
  cv::Mat image(ping.num_ranges, ping.num_beams, CV_8UC1);
  for (int r = 0; r < ping.num_ranges; ++r) {
    for (int b = 0; b < ping.num_beams; ++b) {
      // Port (positive bearing, left) on the left of the picture, far range at the top.
      image.at<uchar>(ping.num_ranges - 1 - r, ping.num_beams - 1 - b) = ping.At(r, b);
    }
  }
  Write(png, image);
}

void WriteFanPicture(const msgs::SonarPing& ping, const std::filesystem::path& png,
                     double metres_per_pixel) {
  const double rmax = ping.MaxRangeM();
  const double half =
      std::max(std::abs(ping.bearings_rad.front()), std::abs(ping.bearings_rad.back()));
  const int w =
      static_cast<int>(2.0 * rmax * std::sin(std::min(half, M_PI / 2)) / metres_per_pixel) + 1;
  const int h = static_cast<int>(rmax / metres_per_pixel) + 1;
  cv::Mat grey(h, w, CV_8UC1, cv::Scalar(0));
  const double cx = 0.5 * (w - 1);
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      const double fwd = (h - 1 - r) * metres_per_pixel;
      const double left = (cx - c) * metres_per_pixel;
      const double range = std::hypot(fwd, left);
      const double bearing = std::atan2(left, fwd);
      if (range >= rmax || bearing < ping.bearings_rad.front() ||
          bearing > ping.bearings_rad.back()) {
        continue;
      }
      const auto it = std::lower_bound(ping.bearings_rad.begin(), ping.bearings_rad.end(),
                                       static_cast<float>(bearing));
      int b = static_cast<int>(it - ping.bearings_rad.begin());
      if (b > 0 && (b >= ping.num_beams ||
                    bearing - ping.bearings_rad[b - 1] < ping.bearings_rad[b] - bearing)) {
        --b;
      }
      const int bin =
          std::clamp(static_cast<int>(range / ping.range_resolution_m) - 1, 0, ping.num_ranges - 1);
      grey.at<uchar>(r, c) = ping.At(bin, b);
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_BONE);
  // Range rings every 5 m.
  for (double ring = 5.0; ring < rmax; ring += 5.0) {
    const int radius = static_cast<int>(ring / metres_per_pixel);
    cv::ellipse(colour, cv::Point(static_cast<int>(cx), h - 1), cv::Size(radius, radius), 0.0,
                -90.0 - half * 180.0 / M_PI, -90.0 + half * 180.0 / M_PI, {60, 90, 60}, 1,
                cv::LINE_AA);
  }
  Write(png, colour);
}

}  // namespace draco::sim_app
