#include "draco/sim/generator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "draco/sim/mission.hpp"
#include "draco/sim/random.hpp"
#include "draco/sim/trajectory.hpp"
#include "yaml_util.hpp"

namespace draco::sim {

// ---------------------------------------------------------------------------------------------
// Footprint geometry.

namespace {

// Length by sqrt (correctly rounded everywhere, unlike hypot, and much faster).
double Len(Vec2 v) { return std::sqrt(v.x * v.x + v.y * v.y); }

double PointSegmentDistance(Vec2 p, Vec2 a, Vec2 b) {
  const Vec2 ab = b - a;
  const double len2 = Dot(ab, ab);
  const double t = len2 > 0.0 ? std::clamp(Dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
  return Len(p - (a + t * ab));
}

bool SegmentsCross(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  const double d1 = Cross(b - a, c - a);
  const double d2 = Cross(b - a, d - a);
  const double d3 = Cross(d - c, a - c);
  const double d4 = Cross(d - c, b - c);
  return ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) &&
         ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0));
}

double SegmentSegmentDistance(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  if (SegmentsCross(a, b, c, d)) return 0.0;
  return std::min({PointSegmentDistance(a, c, d), PointSegmentDistance(b, c, d),
                   PointSegmentDistance(c, a, b), PointSegmentDistance(d, a, b)});
}

bool InsideConvex(Vec2 p, const std::vector<Vec2>& ccw) {
  const std::size_t n = ccw.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (Cross(ccw[(i + 1) % n] - ccw[i], p - ccw[i]) < 0.0) return false;
  }
  return true;
}

// Edges of a polygon (closed) or a segment.
std::size_t EdgeCount(const Primitive& p) {
  return p.kind == ShapeKind::kConvexPolygon ? p.vertices_m.size() : 1;
}

}  // namespace

double FootprintDistance(const Primitive& primitive, Vec2 point) {
  switch (primitive.kind) {
    case ShapeKind::kCircle:
      return std::max(0.0, Len(point - primitive.center_m) - primitive.radius_m);
    case ShapeKind::kSegment:
      return PointSegmentDistance(point, primitive.vertices_m[0], primitive.vertices_m[1]);
    case ShapeKind::kConvexPolygon: {
      const auto& v = primitive.vertices_m;
      if (InsideConvex(point, v)) return 0.0;
      double d = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < v.size(); ++i) {
        d = std::min(d, PointSegmentDistance(point, v[i], v[(i + 1) % v.size()]));
      }
      return d;
    }
  }
  return 0.0;
}

double FootprintGap(const Primitive& a, const Primitive& b) {
  if (a.kind == ShapeKind::kCircle) {
    return std::max(0.0, FootprintDistance(b, a.center_m) - a.radius_m);
  }
  if (b.kind == ShapeKind::kCircle) {
    return std::max(0.0, FootprintDistance(a, b.center_m) - b.radius_m);
  }
  if (a.kind == ShapeKind::kConvexPolygon) {
    for (const auto& v : b.vertices_m) {
      if (InsideConvex(v, a.vertices_m)) return 0.0;
    }
  }
  if (b.kind == ShapeKind::kConvexPolygon) {
    for (const auto& v : a.vertices_m) {
      if (InsideConvex(v, b.vertices_m)) return 0.0;
    }
  }
  double d = std::numeric_limits<double>::infinity();
  const std::size_t na = EdgeCount(a);
  const std::size_t nb = EdgeCount(b);
  for (std::size_t i = 0; i < na; ++i) {
    const Vec2 a0 = a.vertices_m[i];
    const Vec2 a1 = a.vertices_m[(i + 1) % a.vertices_m.size()];
    for (std::size_t j = 0; j < nb; ++j) {
      d = std::min(d, SegmentSegmentDistance(a0, a1, b.vertices_m[j],
                                             b.vertices_m[(j + 1) % b.vertices_m.size()]));
    }
  }
  return d;
}

// ---------------------------------------------------------------------------------------------
// Style files.

namespace {

class StyleParser {
 public:
  StyleParser(GeneratorOptions* o, std::string file) : o_(o), file_(std::move(file)) {}

  void Parse(const YAML::Node& root) {
    if (!root || root.IsNull()) return;  // an empty file: the defaults
    yaml::Map top(file_, root, "style",
                  {"name", "description", "world", "shore", "periodic", "pile_grid", "pier", "dock",
                   "boat", "wreck", "debris", "boulder", "mission"});
    o_->name = top.String("name", o_->name);
    if (top.Has("world")) {
      yaml::Map m(
          file_, top.Get("world"), "style section 'world'",
          {"size_m", "seabed_depth_m", "seabed_slope_max", "backscatter", "texture_contrast",
           "texture_scale_m", "structure_gap_m", "edge_margin_m", "area_per_robot_m2"});
      Range(m, "size_m", &o_->world_size_m, 40.0, 1000.0);
      Range(m, "seabed_depth_m", &o_->seabed_depth_m, 1.0, 200.0);
      Number(m, "seabed_slope_max", &o_->seabed_slope_max, 0.0, 0.2);
      Range(m, "backscatter", &o_->backscatter, 0.0, 1.0);
      Range(m, "texture_contrast", &o_->texture_contrast, 0.0, 0.99);
      Range(m, "texture_scale_m", &o_->texture_scale_m, 0.1, 100.0);
      Number(m, "structure_gap_m", &o_->structure_gap_m, 0.5, 100.0);
      Number(m, "edge_margin_m", &o_->edge_margin_m, 0.0, 100.0);
      Number(m, "area_per_robot_m2", &o_->area_per_robot_m2, 0.0, 1e6);
    }
    if (top.Has("shore")) {
      yaml::Map m(file_, top.Get("shore"), "style section 'shore'",
                  {"quay_sides_weights", "basin_corner_probability", "basin_corner_size_m"});
      if (m.Has("quay_sides_weights")) {
        const YAML::Node n = m.Get("quay_sides_weights");
        auto w = yaml::ToDoubleList(file_, n, "quay_sides_weights");
        double sum = 0.0;
        for (double v : w) {
          if (v < 0.0) yaml::Fail(file_, n, "quay_sides_weights must not be negative");
          sum += v;
        }
        if (w.size() != 4 || !(sum > 0.0)) {
          yaml::Fail(file_, n,
                     "quay_sides_weights needs 4 weights (0, 1, 2, 3 quay sides) with a "
                     "positive sum");
        }
        o_->quay_sides_weights = w;
      }
      Probability(m, "basin_corner_probability", &o_->basin_corner_probability);
      Range(m, "basin_corner_size_m", &o_->basin_corner_size_m, 1.0, 200.0);
    }
    if (top.Has("periodic")) {
      yaml::Map m(file_, top.Get("periodic"), "style section 'periodic'",
                  {"probability", "count", "pile_grid_probability"});
      Probability(m, "probability", &o_->periodic_probability);
      Ints(m, "count", &o_->periodic_count, 1, 10);
      Probability(m, "pile_grid_probability", &o_->pile_grid_probability);
    }
    if (top.Has("pile_grid")) {
      yaml::Map m(file_, top.Get("pile_grid"), "style section 'pile_grid'",
                  {"spacing_m", "square_probability", "piles_per_side", "max_extent_m",
                   "pile_diameter_m", "jitter_m", "attached_probability", "missing_probability",
                   "missing_fraction", "short_probability"});
      Range(m, "spacing_m", &o_->grid_spacing_m, 1.0, 30.0);
      Probability(m, "square_probability", &o_->grid_square_probability);
      Ints(m, "piles_per_side", &o_->grid_piles_per_side, 2, 30);
      Number(m, "max_extent_m", &o_->grid_max_extent_m, 2.0, 200.0);
      Range(m, "pile_diameter_m", &o_->grid_pile_diameter_m, 0.05, 3.0);
      Number(m, "jitter_m", &o_->grid_jitter_m, 0.0, 0.5);
      Probability(m, "attached_probability", &o_->grid_attached_probability);
      Probability(m, "missing_probability", &o_->grid_missing_probability);
      Range(m, "missing_fraction", &o_->grid_missing_fraction, 0.0, 0.5);
      Probability(m, "short_probability", &o_->grid_short_probability);
    }
    if (top.Has("pier")) {
      yaml::Map m(
          file_, top.Get("pier"), "style section 'pier'",
          {"length_m", "width_m", "bent_spacing_m", "piles_per_bent", "pile_diameter_m", "jitter_m",
           "attached_probability", "l_shape_probability", "wave_screen_probability"});
      Range(m, "length_m", &o_->pier_length_m, 5.0, 300.0);
      Range(m, "width_m", &o_->pier_width_m, 1.0, 30.0);
      Range(m, "bent_spacing_m", &o_->pier_bent_spacing_m, 1.0, 30.0);
      Ints(m, "piles_per_bent", &o_->pier_piles_per_bent, 1, 20);
      Range(m, "pile_diameter_m", &o_->pier_pile_diameter_m, 0.05, 3.0);
      Number(m, "jitter_m", &o_->pier_jitter_m, 0.0, 0.5);
      Probability(m, "attached_probability", &o_->pier_attached_probability);
      Probability(m, "l_shape_probability", &o_->pier_l_shape_probability);
      Probability(m, "wave_screen_probability", &o_->pier_wave_screen_probability);
    }
    if (top.Has("dock")) {
      yaml::Map m(file_, top.Get("dock"), "style section 'dock'",
                  {"count", "length_m", "width_m", "section_length_m", "fingers", "finger_length_m",
                   "attached_probability"});
      Ints(m, "count", &o_->dock_count, 0, 20);
      Range(m, "length_m", &o_->dock_length_m, 5.0, 300.0);
      Range(m, "width_m", &o_->dock_width_m, 0.5, 20.0);
      Range(m, "section_length_m", &o_->dock_section_length_m, 1.0, 50.0);
      Ints(m, "fingers", &o_->dock_fingers, 0, 20);
      Range(m, "finger_length_m", &o_->dock_finger_length_m, 2.0, 50.0);
      Probability(m, "attached_probability", &o_->dock_attached_probability);
    }
    if (top.Has("boat")) {
      yaml::Map m(file_, top.Get("boat"), "style section 'boat'",
                  {"count", "length_m", "moored_probability"});
      Ints(m, "count", &o_->boat_count, 0, 50);
      Range(m, "length_m", &o_->boat_length_m, 2.0, 60.0);
      Probability(m, "moored_probability", &o_->boat_moored_probability);
    }
    if (top.Has("wreck")) {
      yaml::Map m(file_, top.Get("wreck"), "style section 'wreck'",
                  {"probability", "length_m", "pieces", "debris_probability"});
      Probability(m, "probability", &o_->wreck_probability);
      Range(m, "length_m", &o_->wreck_length_m, 3.0, 100.0);
      Ints(m, "pieces", &o_->wreck_pieces, 1, 6);
      Probability(m, "debris_probability", &o_->wreck_debris_probability);
    }
    if (top.Has("debris")) {
      yaml::Map m(file_, top.Get("debris"), "style section 'debris'",
                  {"probability", "pieces", "radius_m"});
      Probability(m, "probability", &o_->debris_probability);
      Ints(m, "pieces", &o_->debris_pieces, 1, 100);
      Range(m, "radius_m", &o_->debris_radius_m, 1.0, 50.0);
    }
    if (top.Has("boulder")) {
      yaml::Map m(file_, top.Get("boulder"), "style section 'boulder'",
                  {"count", "diameter_m", "height_m"});
      Ints(m, "count", &o_->boulder_count, 0, 100);
      Range(m, "diameter_m", &o_->boulder_diameter_m, 0.2, 10.0);
      Range(m, "height_m", &o_->boulder_height_m, 0.1, 10.0);
    }
    if (top.Has("mission")) ParseMission(top.Get("mission"));
  }

 private:
  void ParseMission(const YAML::Node& node) {
    yaml::Map m(
        file_, node, "style section 'mission'",
        {"robots", "path_length_m", "speed_mps", "depth_m", "min_altitude_m", "max_altitude_m",
         "sonar_tilt_deg", "start_time_s", "path_clearance_m", "driven_clearance_m",
         "overlap_radius_m", "overlap", "near_structure_m", "min_near_structure",
         "open_water_probability", "periodic_robots", "periodic_exposure", "pattern_weights"});
    Ints(m, "robots", &o_->robots, 1, 8);
    Range(m, "path_length_m", &o_->path_length_m, 20.0, 100000.0);
    if (o_->path_length_m.max - o_->path_length_m.min < 20.0) {
      m.FailAt("path_length_m", "path_length_m must span at least 20 m");
    }
    Range(m, "speed_mps", &o_->speed_mps, 0.05, 5.0);
    Range(m, "depth_m", &o_->depth_m, 0.1, 100.0);
    Number(m, "min_altitude_m", &o_->min_altitude_m, 0.0, 100.0);
    Number(m, "max_altitude_m", &o_->max_altitude_m, 0.5, 100.0);
    Range(m, "sonar_tilt_deg", &o_->sonar_tilt_deg, -30.0, 60.0);
    Range(m, "start_time_s", &o_->start_time_s, 0.0, 1e6);
    Number(m, "path_clearance_m", &o_->path_clearance_m, 0.5, 50.0);
    Number(m, "driven_clearance_m", &o_->driven_clearance_m, 0.0, 50.0);
    if (o_->driven_clearance_m > o_->path_clearance_m) {
      m.FailAt("driven_clearance_m", "driven_clearance_m must not exceed path_clearance_m");
    }
    Number(m, "overlap_radius_m", &o_->overlap_radius_m, 0.5, 200.0);
    Range(m, "overlap", &o_->overlap, 0.0, 1.0);
    Number(m, "near_structure_m", &o_->near_structure_m, 1.0, 200.0);
    Number(m, "min_near_structure", &o_->min_near_structure, 0.0, 1.0);
    Probability(m, "open_water_probability", &o_->open_water_probability);
    Number(m, "periodic_robots", &o_->periodic_robots, 0.0, 1.0);
    Number(m, "periodic_exposure", &o_->periodic_exposure, 0.0, 1.0);
    if (m.Has("pattern_weights")) {
      yaml::Map w(file_, m.Get("pattern_weights"), "pattern_weights",
                  {"loop", "lawnmower", "figure_eight", "orbit", "waypoints"});
      PatternWeights& p = o_->pattern_weights;
      Number(w, "loop", &p.loop, 0.0, 1000.0);
      Number(w, "lawnmower", &p.lawnmower, 0.0, 1000.0);
      Number(w, "figure_eight", &p.figure_eight, 0.0, 1000.0);
      Number(w, "orbit", &p.orbit, 0.0, 1000.0);
      Number(w, "waypoints", &p.waypoints, 0.0, 1000.0);
      if (!(p.loop + p.lawnmower + p.figure_eight + p.orbit + p.waypoints > 0.0)) {
        yaml::Fail(file_, m.Get("pattern_weights"), "pattern_weights need a positive sum");
      }
    }
  }

  static std::string Bounds(double lo, double hi) {
    std::ostringstream s;
    s << "[" << lo << ", " << hi << "]";
    return s.str();
  }

  void Number(const yaml::Map& m, const std::string& key, double* out, double lo, double hi) {
    if (!m.Has(key)) return;
    const double v = m.Double(key);
    if (!(v >= lo && v <= hi)) m.FailAt(key, key + " must be in " + Bounds(lo, hi));
    *out = v;
  }

  void Probability(const yaml::Map& m, const std::string& key, double* out) {
    Number(m, key, out, 0.0, 1.0);
  }

  void Range(const yaml::Map& m, const std::string& key, UniformRange* out, double lo, double hi) {
    if (!m.Has(key)) return;
    const Vec2 v = yaml::ToVec2(file_, m.Get(key), key + " [min, max]");
    if (!(v.x <= v.y)) m.FailAt(key, "expected [min, max] with min <= max for " + key);
    if (!(v.x >= lo && v.y <= hi)) m.FailAt(key, key + " must lie in " + Bounds(lo, hi));
    *out = {v.x, v.y};
  }

  void Ints(const yaml::Map& m, const std::string& key, IntRange* out, int lo, int hi) {
    if (!m.Has(key)) return;
    const YAML::Node n = m.Get(key);
    if (!n.IsSequence() || n.size() != 2) {
      yaml::Fail(file_, n, "expected [min, max] (two integers) for " + key);
    }
    const int a = yaml::ToInt(file_, n[0], key);
    const int b = yaml::ToInt(file_, n[1], key);
    if (a > b) m.FailAt(key, "expected [min, max] with min <= max for " + key);
    if (a < lo || b > hi) {
      m.FailAt(key, key + " must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
    *out = {a, b};
  }

  GeneratorOptions* o_;
  std::string file_;
};

}  // namespace

GeneratorOptions ParseGeneratorOptions(const std::string& yaml_text,
                                       const std::string& source_name) {
  GeneratorOptions o;
  StyleParser(&o, source_name).Parse(yaml::LoadText(yaml_text, source_name));
  return o;
}

GeneratorOptions LoadGeneratorOptions(const std::filesystem::path& path) {
  GeneratorOptions o;
  StyleParser(&o, path.string()).Parse(yaml::LoadFile(path.string()));
  return o;
}

// ---------------------------------------------------------------------------------------------
// Generation.

namespace {

constexpr double kDeg = M_PI / 180.0;
// Footprints used for placement and path checks are this much larger than what the world
// loader makes of the objects (rounding, jitter).
constexpr double kMargin = 0.05;
const char* const kRobotNames[] = {"alpha", "bravo",   "charlie", "delta",
                                   "echo",  "foxtrot", "golf",    "hotel"};

double Round(double v, int decimals) {
  static const double kScale[] = {1.0, 10.0, 100.0, 1000.0};
  const double scale = kScale[std::clamp(decimals, 0, 3)];
  const double r = std::round(v * scale) / scale;
  return r == 0.0 ? 0.0 : r;
}
Vec2 Round(Vec2 p, int decimals) { return {Round(p.x, decimals), Round(p.y, decimals)}; }

// Shortest decimal text of an already rounded value (no trailing zeros, no "-0").
std::string Num(double v, int decimals = 2) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  std::string s = buf;
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  if (s == "-0") s = "0";
  return s;
}
std::string Pt(Vec2 p, int decimals = 2) {
  return "[" + Num(p.x, decimals) + ", " + Num(p.y, decimals) + "]";
}
std::string Pts(const std::vector<Vec2>& pts) {
  std::string s = "[";
  for (std::size_t i = 0; i < pts.size(); ++i) s += (i ? ", " : "") + Pt(pts[i]);
  return s + "]";
}

Vec2 Unit(double angle_rad) { return {std::cos(angle_rad), std::sin(angle_rad)}; }
Vec2 Left(Vec2 u) { return {-u.y, u.x}; }
double Angle(Vec2 v) { return std::atan2(v.y, v.x); }
// Degrees in [0, 360), rounded to 0.1.
double Degrees(double angle_rad) {
  double d = Round(std::fmod(angle_rad / kDeg, 360.0), 1);
  if (d < 0.0) d += 360.0;
  if (d >= 360.0) d -= 360.0;
  return Round(d, 1);
}

double Draw(Rng& rng, const UniformRange& r) { return rng.Uniform(r.min, r.max); }
int Draw(Rng& rng, const IntRange& r) {
  const int n = r.max - r.min + 1;
  return r.min + std::min(n - 1, static_cast<int>(rng.Uniform() * n));
}
int Pick(Rng& rng, std::size_t n) {
  return std::min(static_cast<int>(n) - 1,
                  static_cast<int>(rng.Uniform() * static_cast<double>(n)));
}
int PickWeighted(Rng& rng, const std::vector<double>& w) {
  double sum = 0.0;
  for (double v : w) sum += v;
  if (!(sum > 0.0)) return -1;
  double x = rng.Uniform() * sum;
  for (std::size_t i = 0; i < w.size(); ++i) {
    if (w[i] <= 0.0) continue;
    if (x < w[i]) return static_cast<int>(i);
    x -= w[i];
  }
  for (std::size_t i = w.size(); i-- > 0;) {
    if (w[i] > 0.0) return static_cast<int>(i);
  }
  return -1;
}

// Oriented box: centre, unit axis u, half-length along u, half-width along v = left of u.
struct Obb {
  Vec2 c;
  Vec2 u{1.0, 0.0};
  double hl = 0.0;
  double hw = 0.0;
  Vec2 v() const { return Left(u); }
  Vec2 At(double s, double t) const { return c + s * u + t * v(); }
  std::vector<Vec2> Corners(double grow = 0.0) const {
    return {At(-hl - grow, -hw - grow), At(hl + grow, -hw - grow), At(hl + grow, hw + grow),
            At(-hl - grow, hw + grow)};
  }
};

// Smallest box with frame's axes holding the points.
Obb FitBox(const Obb& frame, const std::vector<Vec2>& pts) {
  double s0 = std::numeric_limits<double>::infinity();
  double s1 = -s0;
  double t0 = s0;
  double t1 = -s0;
  for (const auto& p : pts) {
    const double s = Dot(p - frame.c, frame.u);
    const double t = Dot(p - frame.c, frame.v());
    s0 = std::min(s0, s);
    s1 = std::max(s1, s);
    t0 = std::min(t0, t);
    t1 = std::max(t1, t);
  }
  Obb b;
  b.u = frame.u;
  b.c = frame.At(0.5 * (s0 + s1), 0.5 * (t0 + t1));
  b.hl = 0.5 * (s1 - s0);
  b.hw = 0.5 * (t1 - t0);
  return b;
}

std::vector<Vec2> Vertices(const Primitive& p) {
  if (p.kind != ShapeKind::kCircle) return p.vertices_m;
  return {p.center_m + Vec2{p.radius_m, 0.0}, p.center_m + Vec2{-p.radius_m, 0.0},
          p.center_m + Vec2{0.0, p.radius_m}, p.center_m + Vec2{0.0, -p.radius_m}};
}

void SetBound(Primitive* p) {
  Vec2 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  Vec2 hi{-lo.x, -lo.y};
  for (const auto& v : p->vertices_m) {
    lo = {std::min(lo.x, v.x), std::min(lo.y, v.y)};
    hi = {std::max(hi.x, v.x), std::max(hi.y, v.y)};
  }
  p->center_m = 0.5 * (lo + hi);
  p->radius_m = 0.0;
  for (const auto& v : p->vertices_m) p->radius_m = std::max(p->radius_m, Len(v - p->center_m));
}

Primitive PolygonShape(std::vector<Vec2> pts) {
  if (SignedArea(pts) < 0.0) std::reverse(pts.begin(), pts.end());
  Primitive p;
  p.kind = ShapeKind::kConvexPolygon;
  p.vertices_m = std::move(pts);
  SetBound(&p);
  return p;
}
Primitive BoxShape(const Obb& b, double grow) { return PolygonShape(b.Corners(grow)); }
Primitive SegmentShape(Vec2 a, Vec2 b) {
  Primitive p;
  p.kind = ShapeKind::kSegment;
  p.vertices_m = {a, b};
  SetBound(&p);
  return p;
}

// Convex hull, counter-clockwise, collinear points dropped (Andrew's monotone chain).
std::vector<Vec2> ConvexHull(std::vector<Vec2> pts) {
  std::sort(pts.begin(), pts.end(),
            [](Vec2 a, Vec2 b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  if (pts.size() < 3) return pts;
  std::vector<Vec2> hull(2 * pts.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    while (k >= 2 && Cross(hull[k - 1] - hull[k - 2], pts[i] - hull[k - 2]) <= 0.0) --k;
    hull[k++] = pts[i];
  }
  for (std::size_t i = pts.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && Cross(hull[k - 1] - hull[k - 2], pts[i - 1] - hull[k - 2]) <= 0.0) --k;
    hull[k++] = pts[i - 1];
  }
  hull.resize(k - 1);
  return hull;
}

bool PointInPolygon(Vec2 p, const std::vector<Vec2>& poly) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Vec2 a = poly[i];
    const Vec2 b = poly[j];
    if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) {
      inside = !inside;
    }
  }
  return inside;
}

// Footprints on a uniform grid: the smallest distance from a point, up to `reach`.
class ShapeIndex {
 public:
  void Build(const std::vector<Primitive>& shapes, Vec2 lo, Vec2 hi, double cell_m,
             double reach_m) {
    shapes_ = &shapes;
    lo_ = lo;
    cell_ = cell_m;
    reach_ = reach_m;
    nx_ = static_cast<int>(std::ceil((hi.x - lo.x) / cell_m)) + 1;
    ny_ = static_cast<int>(std::ceil((hi.y - lo.y) / cell_m)) + 1;
    cells_.assign(static_cast<std::size_t>(nx_ * ny_), {});
    for (std::size_t i = 0; i < shapes.size(); ++i) {
      const Primitive& s = shapes[i];
      const double r = s.radius_m + reach_m;
      const int x0 = CellX(s.center_m.x - r);
      const int x1 = CellX(s.center_m.x + r);
      const int y0 = CellY(s.center_m.y - r);
      const int y1 = CellY(s.center_m.y + r);
      for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) cells_[static_cast<std::size_t>(y * nx_ + x)].push_back(i);
      }
    }
  }

  double Distance(Vec2 p) const {
    double d = reach_;
    for (std::size_t i : cells_[static_cast<std::size_t>(CellY(p.y) * nx_ + CellX(p.x))]) {
      const Primitive& s = (*shapes_)[i];
      if (Len(p - s.center_m) - s.radius_m >= d) continue;
      d = std::min(d, FootprintDistance(s, p));
    }
    return d;
  }
  double reach() const { return reach_; }

 private:
  int CellX(double x) const {
    return std::clamp(static_cast<int>(std::floor((x - lo_.x) / cell_)), 0, nx_ - 1);
  }
  int CellY(double y) const {
    return std::clamp(static_cast<int>(std::floor((y - lo_.y) / cell_)), 0, ny_ - 1);
  }

  const std::vector<Primitive>* shapes_ = nullptr;
  Vec2 lo_;
  double cell_ = 1.0;
  double reach_ = 0.0;
  int nx_ = 1;
  int ny_ = 1;
  std::vector<std::vector<std::size_t>> cells_;
};

// Points on a grid: is any within r of a query point?
class PointGrid {
 public:
  PointGrid(const std::vector<Vec2>& pts, double cell_m) : cell_(cell_m) {
    Vec2 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    Vec2 hi{-lo.x, -lo.y};
    for (const auto& p : pts) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y)};
    }
    if (pts.empty()) lo = hi = Vec2{};
    lo_ = lo;
    nx_ = static_cast<int>((hi.x - lo.x) / cell_m) + 1;
    ny_ = static_cast<int>((hi.y - lo.y) / cell_m) + 1;
    cells_.assign(static_cast<std::size_t>(nx_ * ny_), {});
    for (const auto& p : pts) {
      const int x = static_cast<int>((p.x - lo.x) / cell_m);
      const int y = static_cast<int>((p.y - lo.y) / cell_m);
      cells_[static_cast<std::size_t>(y * nx_ + x)].push_back(p);
    }
  }

  bool AnyWithin(Vec2 p, double r) const {
    const int x0 = std::max(0, static_cast<int>(std::floor((p.x - r - lo_.x) / cell_)));
    const int x1 = std::min(nx_ - 1, static_cast<int>(std::floor((p.x + r - lo_.x) / cell_)));
    const int y0 = std::max(0, static_cast<int>(std::floor((p.y - r - lo_.y) / cell_)));
    const int y1 = std::min(ny_ - 1, static_cast<int>(std::floor((p.y + r - lo_.y) / cell_)));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        for (const auto& q : cells_[static_cast<std::size_t>(y * nx_ + x)]) {
          if (Len(q - p) < r) return true;
        }
      }
    }
    return false;
  }

 private:
  double cell_;
  Vec2 lo_;
  int nx_ = 1;
  int ny_ = 1;
  std::vector<std::vector<Vec2>> cells_;
};

double PathLength(const std::vector<Vec2>& path) {
  double len = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) len += Len(path[i] - path[i - 1]);
  return len;
}

// Points every step_m of arc length along a polyline (its start included).
std::vector<Vec2> Resample(const std::vector<Vec2>& path, double step_m) {
  std::vector<Vec2> out;
  if (path.empty()) return out;
  out.push_back(path.front());
  double carry = 0.0;  // arc length since the last sample
  for (std::size_t i = 1; i < path.size(); ++i) {
    const Vec2 a = path[i - 1];
    const double len = Len(path[i] - a);
    double s = step_m - carry;
    while (s <= len) {
      out.push_back(a + (s / len) * (path[i] - a));
      s += step_m;
    }
    carry = len - (s - step_m);
  }
  return out;
}

// --- World ------------------------------------------------------------------------------------

enum class Kind { kQuay, kPileGrid, kPier, kDock, kBoat, kWreck, kDebris, kBoulder };

struct QuayEdge {
  Vec2 a;
  Vec2 b;
  Vec2 in;  // unit normal into the water
  double length_m = 0.0;
};

struct Structure {
  Kind kind = Kind::kQuay;
  std::vector<std::string> yaml;     // world objects, one per line
  std::vector<Primitive> footprint;  // holds every primitive the loader makes of them
  Obb box;                           // overall, for survey patterns
  bool attached = false;             // root end (-u of box) on a quay wall
  bool moored = false;               // a boat alongside another structure
  int parent = -1;
};

// Where a boat can lie alongside: edge a-b of a structure, boat on the `out` side.
struct Berth {
  Vec2 a;
  Vec2 b;
  Vec2 out;
  int structure = -1;
};

// What a robot can plan a pattern around.
struct Anchor {
  Obb box;
  bool attached = false;
  bool wall = false;  // a quay edge: water on its +v side
  bool periodic = false;
  double weight = 1.0;
};

struct GenWorld {
  double width_m = 0.0;
  double height_m = 0.0;
  Seabed seabed;
  std::vector<Vec2> water;                       // counter-clockwise
  bool open_side[4] = {true, true, true, true};  // S, E, N, W
  std::vector<QuayEdge> quay;
  std::string shore = "open";
  bool l_basin = false;
  std::vector<Structure> structures;
  std::vector<Berth> berths;
  std::vector<Anchor> anchors;
  bool periodic = false;
  std::vector<std::string> grid_spacings;
  std::vector<double> pier_spacings;
  int counts[8] = {0, 0, 0, 0, 0, 0, 0, 0};  // per Kind
  std::vector<Primitive> shapes;             // every footprint
  std::vector<Primitive> periodic_shapes;    // footprints of pile grids and piers

  double MinBedDepth() const {
    double d = std::numeric_limits<double>::infinity();
    for (double sx : {-0.5, 0.5}) {
      for (double sy : {-0.5, 0.5}) d = std::min(d, -seabed.ZAt(sx * width_m, sy * height_m));
    }
    return d;
  }
  double MaxBedDepth() const {
    double d = 0.0;
    for (double sx : {-0.5, 0.5}) {
      for (double sy : {-0.5, 0.5}) d = std::max(d, -seabed.ZAt(sx * width_m, sy * height_m));
    }
    return d;
  }
};

const char* KindName(Kind k) {
  switch (k) {
    case Kind::kQuay:
      return "quay";
    case Kind::kPileGrid:
      return "pile_grid";
    case Kind::kPier:
      return "pier";
    case Kind::kDock:
      return "dock";
    case Kind::kBoat:
      return "boat";
    case Kind::kWreck:
      return "wreck";
    case Kind::kDebris:
      return "debris";
    case Kind::kBoulder:
      return "boulder";
  }
  return "";
}

class WorldMaker {
 public:
  WorldMaker(const GeneratorOptions& o, Rng* rng) : o_(o), rng_(*rng) {}

  // False when the drawn world cannot hold what it must (periodic structure, anchors).
  bool Make(int robots, bool periodic, GenWorld* w) {
    w_ = w;
    double width = Draw(rng_, o_.world_size_m);
    double height = Draw(rng_, o_.world_size_m);
    // Room for the team: grow both sides (within the range) to area_per_robot_m2 per robot.
    const double need = robots * o_.area_per_robot_m2;
    if (width * height < need) {
      const double f = std::sqrt(need / (width * height));
      width = std::min(o_.world_size_m.max, width * f);
      height = std::min(o_.world_size_m.max, std::max(height * f, need / width));
    }
    w_->width_m = Round(width, 1);
    w_->height_m = Round(height, 1);
    Seabed();
    Shore();
    if (periodic) {
      const int n = Draw(rng_, o_.periodic_count);
      for (int i = 0; i < n; ++i) {
        const bool grid = rng_.Bernoulli(o_.pile_grid_probability);
        for (int t = 0; t < 4; ++t) {
          if (grid ? PileGrid() : Pier()) break;
        }
      }
      w_->periodic = w_->counts[static_cast<int>(Kind::kPileGrid)] +
                         w_->counts[static_cast<int>(Kind::kPier)] >
                     0;
      if (!w_->periodic) return false;
    }
    const int docks = Draw(rng_, o_.dock_count);
    for (int i = 0; i < docks; ++i) Dock();
    if (rng_.Bernoulli(o_.wreck_probability)) Wreck();
    if (rng_.Bernoulli(o_.debris_probability)) DebrisField();
    const int boats = Draw(rng_, o_.boat_count);
    for (int i = 0; i < boats; ++i) Boat();
    int boulders = Draw(rng_, o_.boulder_count);
    while (boulders > 0) {
      const int n = std::min(boulders, 1 + Pick(rng_, 3));
      Boulders(n);
      boulders -= n;
    }
    MakeAnchors();
    int structure_anchors = 0;
    for (const auto& a : w_->anchors) structure_anchors += a.wall ? 0 : 1;
    return structure_anchors >= 2;
  }

 private:
  void Seabed() {
    ::draco::sim::Seabed& s = w_->seabed;
    s.slope_x = Round(rng_.Uniform(-o_.seabed_slope_max, o_.seabed_slope_max), 3);
    s.slope_y = Round(rng_.Uniform(-o_.seabed_slope_max, o_.seabed_slope_max), 3);
    // Depth at (x, y) is depth_m - slope . (x, y): keep it inside the range everywhere.
    const double half =
        std::abs(s.slope_x) * 0.5 * w_->width_m + std::abs(s.slope_y) * 0.5 * w_->height_m;
    const double lo = o_.seabed_depth_m.min + half;
    const double hi = o_.seabed_depth_m.max - half;
    s.depth_m = Round(lo <= hi ? rng_.Uniform(lo, hi) : 0.5 * (lo + hi), 2);
    s.backscatter = Round(Draw(rng_, o_.backscatter) * 1e4, 0) / 1e4;
    s.texture_contrast = Round(Draw(rng_, o_.texture_contrast), 2);
    s.texture_scale_m = Round(Draw(rng_, o_.texture_scale_m), 1);
  }

  // Quay walls along contiguous sides of the rectangle, an optional land block at a corner
  // between two quays (an L-shaped basin). The water polygon is counter-clockwise.
  void Shore() {
    const double hx = 0.5 * w_->width_m;
    const double hy = 0.5 * w_->height_m;
    const Vec2 corner[4] = {{-hx, -hy}, {hx, -hy}, {hx, hy}, {-hx, hy}};  // SW SE NE NW
    const int k = std::max(0, PickWeighted(rng_, o_.quay_sides_weights));
    const int s0 = Pick(rng_, 4);
    bool quay[4] = {false, false, false, false};  // side i runs corner i -> corner i+1
    for (int i = 0; i < k; ++i) quay[(s0 + i) % 4] = true;
    int cut = -1;
    if (k >= 2 && rng_.Bernoulli(o_.basin_corner_probability)) {
      cut = (s0 + 1 + Pick(rng_, static_cast<std::size_t>(k - 1))) % 4;  // between quay sides
    }
    std::vector<Vec2> v;
    std::vector<bool> edge_quay;  // edge v[i] -> v[i+1]
    for (int j = 0; j < 4; ++j) {
      if (j == cut) {
        const Vec2 din =
            (1.0 / Len(corner[j] - corner[(j + 3) % 4])) * (corner[j] - corner[(j + 3) % 4]);
        const Vec2 dout =
            (1.0 / Len(corner[(j + 1) % 4] - corner[j])) * (corner[(j + 1) % 4] - corner[j]);
        const double a = Round(Draw(rng_, o_.basin_corner_size_m), 1);
        const double b = Round(Draw(rng_, o_.basin_corner_size_m), 1);
        v.push_back(Round(corner[j] - a * din, 2));
        edge_quay.push_back(true);
        v.push_back(Round(corner[j] - a * din + b * dout, 2));
        edge_quay.push_back(true);
        v.push_back(Round(corner[j] + b * dout, 2));
        edge_quay.push_back(quay[j]);
        w_->l_basin = true;
      } else {
        v.push_back(corner[j]);
        edge_quay.push_back(quay[j]);
      }
    }
    w_->water = v;
    for (int i = 0; i < 4; ++i) w_->open_side[i] = !quay[i];
    w_->shore = k == 0 ? "open" : k == 1 ? "straight" : k == 2 ? "corner" : "u";
    if (k == 0) return;
    // One wall polyline: the run of quay edges (contiguous, at most 3 of 4 sides).
    const std::size_t n = v.size();
    std::size_t start = 0;
    while (!(edge_quay[start] && !edge_quay[(start + n - 1) % n])) ++start;
    std::vector<Vec2> line{v[start]};
    Structure s;
    s.kind = Kind::kQuay;
    for (std::size_t i = start; edge_quay[i % n]; ++i) {
      const Vec2 a = v[i % n];
      const Vec2 b = v[(i + 1) % n];
      line.push_back(b);
      QuayEdge e;
      e.a = a;
      e.b = b;
      e.length_m = Len(b - a);
      e.in = Left((1.0 / e.length_m) * (b - a));
      w_->quay.push_back(e);
      s.footprint.push_back(SegmentShape(a, b));
      w_->berths.push_back({a, b, e.in, -1});
    }
    s.yaml.push_back("{type: wall, name: quay, points_m: " + Pts(line) + ", material: concrete}");
    Add(std::move(s));
  }

  // Inside the water polygon and edge_margin_m from open sides of the rectangle.
  bool InWater(Vec2 p) const {
    const double hx = 0.5 * w_->width_m - o_.edge_margin_m;
    const double hy = 0.5 * w_->height_m - o_.edge_margin_m;
    if ((w_->open_side[0] && p.y < -hy) || (w_->open_side[1] && p.x > hx) ||
        (w_->open_side[2] && p.y > hy) || (w_->open_side[3] && p.x < -hx)) {
      return false;
    }
    return PointInPolygon(p, w_->water);
  }

  // The shapes are in the water and at least `gap` from every structure (quay_gap from quay
  // walls, parent_gap from structure `parent`).
  bool Fits(const std::vector<Primitive>& shapes, double gap, double quay_gap, int parent = -1,
            double parent_gap = 0.0) const {
    for (const auto& s : shapes) {
      for (const auto& p : Vertices(s)) {
        if (!InWater(p)) return false;
      }
    }
    for (std::size_t k = 0; k < w_->structures.size(); ++k) {
      const Structure& other = w_->structures[k];
      const double req = static_cast<int>(k) == parent ? parent_gap
                         : other.kind == Kind::kQuay   ? quay_gap
                                                       : gap;
      for (const auto& f : other.footprint) {
        for (const auto& s : shapes) {
          if (Len(s.center_m - f.center_m) - s.radius_m - f.radius_m >= req) continue;
          if (FootprintGap(s, f) < req) return false;
        }
      }
    }
    return true;
  }

  int Add(Structure s) {
    w_->counts[static_cast<int>(s.kind)] += 1;
    w_->structures.push_back(std::move(s));
    return static_cast<int>(w_->structures.size()) - 1;
  }

  std::string Name(Kind k) const {
    return std::string(KindName(k)) + "_" + std::to_string(w_->counts[static_cast<int>(k)] + 1);
  }

  // A random point of the rectangle at least `inset` inside it.
  Vec2 RandomPoint(double inset) {
    const double hx = std::max(0.0, 0.5 * w_->width_m - inset);
    const double hy = std::max(0.0, 0.5 * w_->height_m - inset);
    return {rng_.Uniform(-hx, hx), rng_.Uniform(-hy, hy)};
  }

  // Axis of a free structure: along the rectangle's axes (harbours are built square) or any.
  Vec2 RandomAxis() {
    if (rng_.Bernoulli(0.5)) return Unit(Pick(rng_, 4) * 90.0 * kDeg + rng_.Uniform(-4, 4) * kDeg);
    return Unit(rng_.Uniform(0.0, M_PI));
  }

  // A point on a quay edge at least half_width + 4 m from its ends; false when none fits.
  bool QuayPosition(double half_width, QuayEdge* edge, Vec2* point) {
    std::vector<double> w;
    for (const auto& e : w_->quay) {
      w.push_back(e.length_m >= 2.0 * (half_width + 4.0) ? e.length_m : 0.0);
    }
    const int i = PickWeighted(rng_, w);
    if (i < 0) return false;
    *edge = w_->quay[i];
    const double s = rng_.Uniform(half_width + 4.0, edge->length_m - half_width - 4.0);
    *point = edge->a + (s / edge->length_m) * (edge->b - edge->a);
    return true;
  }

  std::string PickMaterial(const std::vector<std::pair<const char*, double>>& table) {
    std::vector<double> w;
    for (const auto& t : table) w.push_back(t.second);
    return table[PickWeighted(rng_, w)].first;
  }

  void AddBerths(int structure, const Obb& b) {
    w_->berths.push_back({b.At(-b.hl, b.hw), b.At(b.hl, b.hw), b.v(), structure});
    w_->berths.push_back({b.At(-b.hl, -b.hw), b.At(b.hl, -b.hw), -1.0 * b.v(), structure});
  }

  // Identical piles on a square or rectangular lattice, a few missing or broken sometimes.
  bool PileGrid() {
    const double su = Round(Draw(rng_, o_.grid_spacing_m), 1);
    double sv = su;
    if (!rng_.Bernoulli(o_.grid_square_probability)) {
      for (int t = 0; t < 8 && std::abs(sv - su) < 0.5; ++t) {
        sv = Round(Draw(rng_, o_.grid_spacing_m), 1);
      }
    }
    int nu = Draw(rng_, o_.grid_piles_per_side);
    int nv = Draw(rng_, o_.grid_piles_per_side);
    while (nu > 2 && (nu - 1) * su > o_.grid_max_extent_m) --nu;
    while (nv > 2 && (nv - 1) * sv > o_.grid_max_extent_m) --nv;
    const double d = std::round(Draw(rng_, o_.grid_pile_diameter_m) * 20.0) / 20.0;
    const double j = o_.grid_jitter_m;
    const double pad = 0.5 * d + j * std::sqrt(2.0) + 0.001 + kMargin;
    const bool attach = !w_->quay.empty() && rng_.Bernoulli(o_.grid_attached_probability);
    for (int t = 0; t < 40; ++t) {
      Obb box;
      box.hl = 0.5 * (nu - 1) * su + pad;
      box.hw = 0.5 * (nv - 1) * sv + pad;
      if (attach) {
        QuayEdge e;
        Vec2 at;
        if (!QuayPosition(box.hw, &e, &at)) return false;
        box.u = e.in;
        box.c = at + (1.0 + box.hl) * e.in;
      } else {
        box.u = RandomAxis();
        box.c = RandomPoint(o_.edge_margin_m + box.hl);
      }
      const std::vector<Primitive> shape{BoxShape(box, 0.0)};
      if (!Fits(shape, o_.structure_gap_m, attach ? 0.5 : o_.structure_gap_m)) continue;

      Structure s;
      s.kind = Kind::kPileGrid;
      s.footprint = shape;
      s.box = box;
      s.attached = attach;
      const std::string name = Name(s.kind);
      const std::string material =
          PickMaterial({{"concrete", 0.5}, {"steel", 0.3}, {"timber", 0.2}});
      std::vector<Vec2> piles;
      for (int a = 0; a < nu; ++a) {
        for (int b = 0; b < nv; ++b) {
          const Vec2 ideal = box.At(-0.5 * (nu - 1) * su + a * su, -0.5 * (nv - 1) * sv + b * sv);
          piles.push_back(Round(ideal + Vec2{rng_.Uniform(-j, j), rng_.Uniform(-j, j)}, 3));
        }
      }
      std::vector<bool> missing(piles.size(), false);
      if (rng_.Bernoulli(o_.grid_missing_probability)) {
        const int m =
            std::max(1, static_cast<int>(Draw(rng_, o_.grid_missing_fraction) * piles.size()));
        for (int i = 0; i < m; ++i) missing[Pick(rng_, piles.size())] = true;
      }
      std::vector<double> short_height(piles.size(), 0.0);
      if (rng_.Bernoulli(o_.grid_short_probability)) {
        const int m = 1 + Pick(rng_, 3);
        for (int i = 0; i < m; ++i) {
          short_height[Pick(rng_, piles.size())] = Round(rng_.Uniform(0.5, 2.0), 1);
        }
      }
      for (std::size_t i = 0; i < piles.size(); ++i) {
        if (missing[i]) continue;
        std::string line = "{type: pile, name: " + name + ", center_m: " + Pt(piles[i], 3) +
                           ", diameter_m: " + Num(d) + ", material: " + material;
        if (short_height[i] > 0.0) line += ", height_m: [0, " + Num(short_height[i], 1) + "]";
        s.yaml.push_back(line + "}");
      }
      const int idx = Add(std::move(s));
      AddBerths(idx, box);
      char buf[64];
      std::snprintf(buf, sizeof(buf), "%s x %s", Num(su, 1).c_str(), Num(sv, 1).c_str());
      w_->grid_spacings.push_back(buf);
      return true;
    }
    return false;
  }

  // Fixed pier (bents of piles), on a quay or free-standing, straight or L-shaped.
  bool Pier() {
    const double width = Round(Draw(rng_, o_.pier_width_m), 1);
    const double spacing = Round(Draw(rng_, o_.pier_bent_spacing_m), 1);
    const int across = Draw(rng_, o_.pier_piles_per_bent);
    const double d = std::round(Draw(rng_, o_.pier_pile_diameter_m) * 20.0) / 20.0;
    const double j = Round(rng_.Uniform(0.0, o_.pier_jitter_m), 3);
    // Whole bents: length a multiple of the spacing (plus a little for rounding).
    const int bents =
        std::max(3, static_cast<int>(std::round(Draw(rng_, o_.pier_length_m) / spacing)));
    const double length = bents * spacing + 0.05;
    const bool l_shape = rng_.Bernoulli(o_.pier_l_shape_probability);
    const int bents2 = std::max(2, static_cast<int>(bents * rng_.Uniform(0.3, 0.6)));
    const double length2 = bents2 * spacing + 0.05;
    const double turn = rng_.Bernoulli(0.5) ? 1.0 : -1.0;
    const bool screen = !l_shape && rng_.Bernoulli(o_.pier_wave_screen_probability);
    const bool screen_left = rng_.Bernoulli(0.5);
    const std::string material = PickMaterial({{"timber", 0.6}, {"concrete", 0.4}});
    const bool attach = !w_->quay.empty() && rng_.Bernoulli(o_.pier_attached_probability);
    const double pad = 0.5 * d + j * std::sqrt(2.0) + kMargin;
    const double half_width =
        std::max(0.5 * width + pad, screen ? 0.5 * width + 0.3 + kMargin : 0.0);
    for (int t = 0; t < 40; ++t) {
      Vec2 root;
      Vec2 u;
      if (attach) {
        QuayEdge e;
        Vec2 at;
        if (!QuayPosition(half_width + (l_shape ? length2 : 0.0), &e, &at)) return false;
        u = e.in;
        root = at + (1.0 + pad) * e.in;
      } else {
        u = RandomAxis();
        root = RandomPoint(o_.edge_margin_m + 0.5 * length) - (0.5 * length) * u;
      }
      std::vector<Vec2> line{Round(root, 2), Round(root + length * u, 2)};
      if (l_shape) line.push_back(Round(line[1] + (turn * length2) * Left(u), 2));
      std::vector<Primitive> shapes;
      std::vector<Obb> boxes;
      for (std::size_t i = 0; i + 1 < line.size(); ++i) {
        const double len = Len(line[i + 1] - line[i]);
        Obb b;
        b.u = (1.0 / len) * (line[i + 1] - line[i]);
        b.c = 0.5 * (line[i] + line[i + 1]);
        b.hl = 0.5 * len + pad;
        b.hw = half_width;
        boxes.push_back(b);
        shapes.push_back(BoxShape(b, 0.0));
      }
      if (!Fits(shapes, o_.structure_gap_m, attach ? 0.5 : o_.structure_gap_m)) continue;
      Structure s;
      s.kind = Kind::kPier;
      s.footprint = shapes;
      s.attached = attach;
      std::vector<Vec2> corners;
      for (const auto& b : boxes) {
        for (const auto& c : b.Corners()) corners.push_back(c);
      }
      s.box = FitBox(boxes[0], corners);
      std::string yaml = "{type: pier, name: " + Name(s.kind) + ", polyline_m: " + Pts(line) +
                         ", width_m: " + Num(width, 1) + ", bent_spacing_m: " + Num(spacing, 1) +
                         ", piles_per_bent: " + std::to_string(across) +
                         ", pile_diameter_m: " + Num(d) + ", jitter_m: " + Num(j, 3) +
                         ", material: " + material;
      if (screen) {
        yaml += std::string(", wave_screen: {side: ") + (screen_left ? "left" : "right") +
                ", z_m: [-1.8, 1.0], material: timber}";
      }
      s.yaml.push_back(yaml + "}");
      const int idx = Add(std::move(s));
      for (std::size_t i = 0; i < boxes.size(); ++i) {
        const Obb& b = boxes[i];
        if (!(screen && screen_left)) {
          w_->berths.push_back({b.At(-b.hl, b.hw), b.At(b.hl, b.hw), b.v(), idx});
        }
        if (!(screen && !screen_left)) {
          w_->berths.push_back({b.At(-b.hl, -b.hw), b.At(b.hl, -b.hw), -1.0 * b.v(), idx});
        }
      }
      const double first = Len(line[1] - line[0]);
      w_->pier_spacings.push_back(Round(first / std::floor(first / spacing), 3));
      return true;
    }
    return false;
  }

  // Floating dock: a walkway of sections on steel guide piles, finger docks on its right.
  void Dock() {
    const double width = Round(Draw(rng_, o_.dock_width_m), 1);
    const double section = Round(Draw(rng_, o_.dock_section_length_m), 1);
    const int sections =
        std::max(2, static_cast<int>(std::round(Draw(rng_, o_.dock_length_m) / section)));
    const double length = sections * section;
    int fingers = Draw(rng_, o_.dock_fingers);
    while (fingers > 0 && length / (fingers + 1) < 6.0) --fingers;
    const double finger_length = Round(Draw(rng_, o_.dock_finger_length_m), 1);
    const double finger_width = Round(rng_.Uniform(1.2, 2.0), 1);
    const double guide_d = 0.35;
    const bool attach = !w_->quay.empty() && rng_.Bernoulli(o_.dock_attached_probability);
    const double half_width = 0.5 * width + guide_d + 0.05 + kMargin;
    for (int t = 0; t < 40; ++t) {
      Vec2 root;
      Vec2 u;
      if (attach) {
        QuayEdge e;
        Vec2 at;
        if (!QuayPosition(half_width + finger_length, &e, &at)) return;
        u = e.in;
        root = at + 1.5 * e.in;  // gangway gap
      } else {
        u = RandomAxis();
        root = RandomPoint(o_.edge_margin_m + 0.5 * length) - (0.5 * length) * u;
      }
      const Vec2 a = Round(root, 2);
      const Vec2 b = Round(root + length * u, 2);
      const double len = Len(b - a);
      Obb walk;
      walk.u = (1.0 / len) * (b - a);
      walk.c = 0.5 * (a + b);
      walk.hl = 0.5 * len + 0.5 * guide_d + kMargin;
      walk.hw = half_width;
      std::vector<Primitive> shapes{BoxShape(walk, 0.0)};
      std::vector<Obb> boxes{walk};
      std::vector<std::pair<Vec2, Vec2>> finger_lines;
      for (int f = 0; f < fingers; ++f) {
        const Vec2 p0 =
            Round(a + (len * (f + 1) / (fingers + 1)) * walk.u - (0.5 * width + 0.3) * walk.v(), 2);
        const Vec2 p1 = Round(p0 - finger_length * walk.v(), 2);
        finger_lines.push_back({p0, p1});
        Obb fb;
        fb.u = (1.0 / Len(p1 - p0)) * (p1 - p0);
        fb.c = 0.5 * (p0 + p1);
        fb.hl = 0.5 * Len(p1 - p0) + kMargin;
        fb.hw = 0.5 * finger_width + kMargin;
        boxes.push_back(fb);
        shapes.push_back(BoxShape(fb, 0.0));
      }
      if (!Fits(shapes, o_.structure_gap_m, attach ? 0.5 : o_.structure_gap_m)) continue;
      Structure s;
      s.kind = Kind::kDock;
      s.footprint = shapes;
      s.attached = attach;
      std::vector<Vec2> corners;
      for (const auto& bx : boxes) {
        for (const auto& c : bx.Corners()) corners.push_back(c);
      }
      s.box = FitBox(walk, corners);
      const std::string name = Name(s.kind);
      s.yaml.push_back("{type: dock, name: " + name + ", polyline_m: " + Pts({a, b}) +
                       ", width_m: " + Num(width, 1) + ", section_length_m: " + Num(section, 1) +
                       ", guide_pile_spacing_m: " + Num(section, 1) +
                       ", guide_pile_material: steel}");
      for (const auto& fl : finger_lines) {
        s.yaml.push_back(
            "{type: dock, name: " + name + ", polyline_m: " + Pts({fl.first, fl.second}) +
            ", width_m: " + Num(finger_width, 1) + ", section_length_m: " + Num(finger_length, 1) +
            ", guide_pile_spacing_m: 0}");
      }
      const int idx = Add(std::move(s));
      // Boats lie along the walkway's outer (left) side and along the fingers.
      w_->berths.push_back({walk.At(-walk.hl, walk.hw), walk.At(walk.hl, walk.hw), walk.v(), idx});
      for (std::size_t i = 1; i < boxes.size(); ++i) AddBerths(idx, boxes[i]);
      return;
    }
  }

  // Moored alongside a berth, or at anchor.
  void Boat() {
    const double length = Round(Draw(rng_, o_.boat_length_m), 1);
    const double beam = Round(length * rng_.Uniform(0.3, 0.38), 1);
    const double draft = Round(std::min(1.6, 0.08 * length + rng_.Uniform(0.1, 0.4)), 1);
    const std::string material = length > 11.0 && rng_.Bernoulli(0.5) ? "steel" : "fibreglass";
    const bool moored = !w_->berths.empty() && rng_.Bernoulli(o_.boat_moored_probability);
    for (int t = 0; t < 30; ++t) {
      Vec2 c;
      double yaw = 0.0;
      int parent = -1;
      if (moored) {
        const Berth& b = w_->berths[Pick(rng_, w_->berths.size())];
        const double len = Len(b.b - b.a);
        if (len < length + 1.0) continue;
        const Vec2 dir = (1.0 / len) * (b.b - b.a);
        const double s = rng_.Uniform(0.5 * length + 0.5, len - 0.5 * length - 0.5);
        c = b.a + s * dir + (rng_.Uniform(0.5, 1.2) + 0.5 * beam) * b.out;
        yaw = Angle(dir) + (rng_.Bernoulli(0.5) ? M_PI : 0.0);
        parent = b.structure;
      } else {
        c = RandomPoint(o_.edge_margin_m + 0.5 * length);
        yaw = rng_.Uniform(0.0, 2.0 * M_PI);
      }
      c = Round(c, 2);
      const double yaw_deg = Degrees(yaw);
      Obb box;
      box.c = c;
      box.u = Unit(yaw_deg * kDeg);
      box.hl = 0.5 * length + kMargin;
      box.hw = 0.5 * beam + kMargin;
      const std::vector<Primitive> shape{BoxShape(box, 0.0)};
      const double gap = moored ? 0.5 : o_.structure_gap_m;
      if (!Fits(shape, gap, gap, parent, 0.4)) continue;
      Structure s;
      s.kind = Kind::kBoat;
      s.footprint = shape;
      s.box = box;
      s.moored = moored;
      s.parent = parent;
      s.yaml.push_back("{type: boat, name: " + Name(s.kind) + ", center_m: " + Pt(c) +
                       ", length_m: " + Num(length, 1) + ", beam_m: " + Num(beam, 1) +
                       ", yaw_deg: " + Num(yaw_deg, 1) + ", draft_m: " + Num(draft, 1) +
                       ", material: " + material + "}");
      if (s.parent >= 0) {
        // Patterns around the parent keep clear of its boats.
        Structure& p = w_->structures[s.parent];
        std::vector<Vec2> corners = p.box.Corners();
        for (const auto& v : box.Corners()) corners.push_back(v);
        p.box = FitBox(p.box, corners);
      }
      Add(std::move(s));
      return;
    }
  }

  // Debris pieces in a disc, clear of `avoid` and of each other. Returns the footprints.
  std::vector<Primitive> DebrisPieces(Vec2 centre, const std::string& name,
                                      const std::vector<Primitive>& avoid,
                                      std::vector<std::string>* yaml) {
    const double radius = Draw(rng_, o_.debris_radius_m);
    const int n = Draw(rng_, o_.debris_pieces);
    std::vector<Primitive> pieces;
    for (int t = 0; t < 10 * n && static_cast<int>(pieces.size()) < n; ++t) {
      const Vec2 c = Round(
          centre + (radius * std::sqrt(rng_.Uniform())) * Unit(rng_.Uniform(0.0, 2.0 * M_PI)), 2);
      const double l = Round(rng_.Uniform(0.3, 1.5), 2);
      const double wd = Round(rng_.Uniform(0.2, 1.0), 2);
      const double yaw_deg = Degrees(rng_.Uniform(0.0, M_PI));
      const double h = Round(rng_.Uniform(0.1, 0.5), 2);
      Obb b;
      b.c = c;
      b.u = Unit(yaw_deg * kDeg);
      b.hl = 0.5 * l + kMargin;
      b.hw = 0.5 * wd + kMargin;
      const Primitive shape = BoxShape(b, 0.0);
      bool ok = true;
      for (const auto& o : pieces) ok = ok && FootprintGap(shape, o) >= 0.3;
      for (const auto& o : avoid) ok = ok && FootprintGap(shape, o) >= 0.8;
      if (!ok) continue;
      pieces.push_back(shape);
      const std::string material = PickMaterial({{"steel", 0.35},
                                                 {"aluminium", 0.2},
                                                 {"timber", 0.25},
                                                 {"fibreglass", 0.1},
                                                 {"rubber", 0.1}});
      yaml->push_back("{type: box, name: " + name + ", center_m: " + Pt(c) +
                      ", size_m: " + Pt({l, wd}) + ", yaw_deg: " + Num(yaw_deg, 1) +
                      ", height_m: [0, " + Num(h) + "], material: " + material + "}");
    }
    return pieces;
  }

  // A broken steel hull on the seabed (boxes, a pointed bow polygon, a deckhouse on the
  // stern piece), often with debris trailing behind.
  void Wreck() {
    const double length = Draw(rng_, o_.wreck_length_m);
    const double beam = length * rng_.Uniform(0.25, 0.35);
    const double height = rng_.Uniform(1.0, 2.5);
    const int n = Draw(rng_, o_.wreck_pieces);
    const bool debris = rng_.Bernoulli(o_.wreck_debris_probability);
    for (int t = 0; t < 40; ++t) {
      const Vec2 centre = RandomPoint(o_.edge_margin_m + 0.5 * length + 5.0);
      const double heading = rng_.Uniform(0.0, 2.0 * M_PI);
      const Vec2 u = Unit(heading);
      std::vector<double> parts;
      double sum = 0.0;
      for (int i = 0; i < n; ++i) {
        parts.push_back(rng_.Uniform(0.6, 1.4));
        sum += parts.back();
      }
      std::vector<Primitive> pieces;
      std::vector<std::string> yaml;
      const std::string name = Name(Kind::kWreck);
      double cursor = -0.5 * length;
      bool ok = true;
      for (int i = 0; i < n && ok; ++i) {
        const double len = length * parts[i] / sum;
        const double yaw = heading + (i > 0 ? rng_.Uniform(-15.0, 15.0) * kDeg : 0.0);
        const double h = Round(i > 0 ? height * rng_.Uniform(0.5, 1.0) : height, 2);
        const Vec2 c = Round(
            centre + (cursor + 0.5 * len) * u + (i > 0 ? rng_.Uniform(-0.8, 0.8) : 0.0) * Left(u),
            2);
        cursor += len + rng_.Uniform(0.8, 2.5);
        const double yaw_deg = Degrees(yaw);
        const Vec2 pu = Unit(yaw_deg * kDeg);
        if (i == n - 1 && len > 2.5) {
          // Bow: pointed, convex.
          const double hl = 0.5 * len;
          const double hb = 0.5 * beam;
          std::vector<Vec2> pts;
          for (const Vec2 q : {Vec2{-hl, -hb}, Vec2{0.3 * hl, -hb}, Vec2{hl, 0.0},
                               Vec2{0.3 * hl, hb}, Vec2{-hl, hb}}) {
            pts.push_back(Round(c + q.x * pu + q.y * Left(pu), 2));
          }
          if (!IsConvex(pts)) {
            ok = false;
            break;
          }
          Primitive p = PolygonShape(pts);
          Obb grow = FitBox(Obb{c, pu, 0.0, 0.0}, p.vertices_m);
          pieces.push_back(BoxShape(grow, kMargin));
          yaml.push_back("{type: polygon, name: " + name + ", points_m: " + Pts(p.vertices_m) +
                         ", height_m: [0, " + Num(h) + "], material: steel}");
        } else {
          Obb b{c, pu, 0.5 * len, 0.5 * beam};
          const double l = Round(len, 2);
          const double wb = Round(beam, 2);
          b.hl = 0.5 * l + kMargin;
          b.hw = 0.5 * wb + kMargin;
          pieces.push_back(BoxShape(b, 0.0));
          yaml.push_back("{type: box, name: " + name + ", center_m: " + Pt(c) +
                         ", size_m: " + Pt({l, wb}) + ", yaw_deg: " + Num(yaw_deg, 1) +
                         ", height_m: [0, " + Num(h) + "], material: steel}");
        }
        if (i == 0 && len > 4.0) {
          // Deckhouse on the stern piece, above the hull (inside its full-beam part).
          const double top = Round(h + rng_.Uniform(1.0, 2.5), 2);
          const bool bow = n == 1 && len > 2.5;
          const Vec2 dc = Round(c + ((bow ? -0.25 : -0.15) * len) * pu, 2);
          yaml.push_back("{type: box, name: " + name + ", center_m: " + Pt(dc) + ", size_m: " +
                         Pt({Round((bow ? 0.3 : 0.35) * len, 2), Round(0.6 * beam, 2)}) +
                         ", yaw_deg: " + Num(yaw_deg, 1) + ", height_m: [" + Num(h) + ", " +
                         Num(top) + "], material: steel}");
        }
        for (std::size_t k = 0; k + 1 < pieces.size() && ok; ++k) {
          ok = FootprintGap(pieces[k], pieces.back()) >= 0.3;
        }
      }
      if (!ok) continue;
      std::vector<Primitive> shapes = pieces;
      if (debris) {
        const Vec2 dc = centre - (0.5 * length + 6.0) * u + rng_.Uniform(-4.0, 4.0) * Left(u);
        const auto d = DebrisPieces(dc, Name(Kind::kDebris), pieces, &yaml);
        shapes.insert(shapes.end(), d.begin(), d.end());
      }
      if (!Fits(shapes, o_.structure_gap_m, o_.structure_gap_m)) continue;
      Structure s;
      s.kind = Kind::kWreck;
      s.footprint = shapes;
      s.yaml = yaml;
      std::vector<Vec2> corners;
      for (const auto& p : shapes) {
        for (const auto& v : Vertices(p)) corners.push_back(v);
      }
      s.box = FitBox(Obb{centre, u, 0.0, 0.0}, corners);
      Add(std::move(s));
      if (debris) w_->counts[static_cast<int>(Kind::kDebris)] += 1;
      return;
    }
  }

  void DebrisField() {
    for (int t = 0; t < 30; ++t) {
      const Vec2 centre = RandomPoint(o_.edge_margin_m + o_.debris_radius_m.max + 1.0);
      std::vector<std::string> yaml;
      const auto shapes = DebrisPieces(centre, Name(Kind::kDebris), {}, &yaml);
      if (shapes.empty() || !Fits(shapes, o_.structure_gap_m, o_.structure_gap_m)) continue;
      Structure s;
      s.kind = Kind::kDebris;
      s.footprint = shapes;
      s.yaml = yaml;
      std::vector<Vec2> corners;
      for (const auto& p : shapes) {
        for (const auto& v : p.vertices_m) corners.push_back(v);
      }
      s.box = FitBox(Obb{centre, {1.0, 0.0}, 0.0, 0.0}, corners);
      Add(std::move(s));
      return;
    }
  }

  // n boulders (convex rock polygons) within a few metres of each other.
  void Boulders(int n) {
    for (int t = 0; t < 30; ++t) {
      const Vec2 centre = RandomPoint(o_.edge_margin_m + 6.0);
      std::vector<Primitive> shapes;
      std::vector<std::string> yaml;
      for (int b = 0, tries = 0; b < n && tries < 40; ++tries) {
        const double r = 0.5 * Draw(rng_, o_.boulder_diameter_m);
        const Vec2 c =
            centre + (b == 0 ? 0.0 : rng_.Uniform(0.0, 5.0)) * Unit(rng_.Uniform(0.0, 2.0 * M_PI));
        const int k = 6 + Pick(rng_, 4);
        std::vector<Vec2> pts;
        for (int i = 0; i < k; ++i) {
          const double a = 2.0 * M_PI * (i + rng_.Uniform(-0.3, 0.3)) / k;
          pts.push_back(Round(c + (r * rng_.Uniform(0.7, 1.0)) * Unit(a), 2));
        }
        pts = ConvexHull(pts);
        if (pts.size() < 3 || !IsConvex(pts)) continue;
        Primitive p = PolygonShape(pts);
        bool ok = true;
        for (const auto& o : shapes) ok = ok && FootprintGap(p, o) >= 0.5;
        if (!ok) continue;
        const double h = Round(Draw(rng_, o_.boulder_height_m), 2);
        const int number = w_->counts[static_cast<int>(Kind::kBoulder)] + b + 1;
        yaml.push_back("{type: polygon, name: boulder_" + std::to_string(number) + ", points_m: " +
                       Pts(p.vertices_m) + ", height_m: [0, " + Num(h) + "], material: rock}");
        Obb grow = FitBox(Obb{c, {1.0, 0.0}, 0.0, 0.0}, p.vertices_m);
        shapes.push_back(BoxShape(grow, kMargin));
        ++b;
      }
      if (shapes.empty() || !Fits(shapes, o_.structure_gap_m, o_.structure_gap_m)) continue;
      Structure s;
      s.kind = Kind::kBoulder;
      s.footprint = shapes;
      s.yaml = yaml;
      std::vector<Vec2> corners;
      for (const auto& p : shapes) {
        for (const auto& v : p.vertices_m) corners.push_back(v);
      }
      s.box = FitBox(Obb{centre, {1.0, 0.0}, 0.0, 0.0}, corners);
      Add(std::move(s));
      w_->counts[static_cast<int>(Kind::kBoulder)] += static_cast<int>(shapes.size()) - 1;
      return;
    }
  }

  void MakeAnchors() {
    for (const auto& s : w_->structures) {
      const bool periodic = s.kind == Kind::kPileGrid || s.kind == Kind::kPier;
      for (const auto& f : s.footprint) {
        w_->shapes.push_back(f);
        if (periodic) w_->periodic_shapes.push_back(f);
      }
      if (s.kind == Kind::kQuay || s.moored) continue;
      Anchor a;
      a.box = s.box;
      a.attached = s.attached;
      a.periodic = periodic;
      a.weight = s.kind == Kind::kPileGrid || s.kind == Kind::kPier ? 3.0
                 : s.kind == Kind::kDock || s.kind == Kind::kWreck  ? 2.0
                                                                    : 1.0;
      w_->anchors.push_back(a);
    }
    for (const auto& e : w_->quay) {
      if (e.length_m < 25.0) continue;
      Anchor a;
      a.box.u = (1.0 / e.length_m) * (e.b - e.a);
      a.box.c = 0.5 * (e.a + e.b);
      a.box.hl = 0.5 * e.length_m;
      a.wall = true;
      a.weight = 1.0;
      w_->anchors.push_back(a);
    }
  }

  const GeneratorOptions& o_;
  Rng& rng_;
  GenWorld* w_ = nullptr;
};

// --- Missions ---------------------------------------------------------------------------------

struct Plan {
  RobotSpec spec;
  std::vector<Vec2> path;     // PatternPath(spec)
  std::vector<Vec2> samples;  // every 1 m
  std::vector<int> anchors;   // used
  double length_m = 0.0;
  double near = 0.0;
  double near_periodic = 0.0;
  double min_clearance_m = 0.0;
  double driven_clearance_m = -1.0;  // -1: not computed yet
};

Vec2 Entry(const PatternSpec& p) {
  switch (p.type) {
    case PatternSpec::Type::kWaypoints:
    case PatternSpec::Type::kLoop:
      return p.waypoints_m.front();
    case PatternSpec::Type::kLawnmower:
      return p.origin_m;
    case PatternSpec::Type::kFigureEight:
      return p.center_m;
    case PatternSpec::Type::kOrbit:
      return p.center_m + p.radius_m * Unit(p.heading_rad);
  }
  return {};
}

class MissionMaker {
 public:
  MissionMaker(const GeneratorOptions& o, const GenWorld& w, Rng* rng) : o_(o), w_(w), rng_(*rng) {
    const Vec2 half{0.5 * w.width_m + 40.0, 0.5 * w.height_m + 40.0};
    clear_index_.Build(w.shapes, -1.0 * half, half, 6.0, o.path_clearance_m + 5.0);
    near_index_.Build(w.shapes, -1.0 * half, half, 10.0, o.near_structure_m);
    periodic_index_.Build(w.periodic_shapes, -1.0 * half, half, 10.0, o.near_structure_m);
    for (std::size_t i = 0; i < w.anchors.size(); ++i) {
      if (w.anchors[i].periodic) periodic_anchors_.push_back(static_cast<int>(i));
    }
    clearance_ = o.path_clearance_m + 0.01;
  }

  // All robots. Returns 0 when every overlap is in range and every simulated path keeps
  // driven_clearance_m, else the best set's shortfall (infinity: none found).
  double Make(int robots, std::vector<Plan>* out) {
    std::vector<Plan> best;
    double best_violation = std::numeric_limits<double>::infinity();
    const int need_periodic =
        w_.periodic ? static_cast<int>(std::ceil(o_.periodic_robots * robots - 1e-9)) : 0;
    for (int attempt = 0; attempt < 3; ++attempt) {
      MakeHomes(robots);
      std::vector<Plan> plans;
      for (int k = 0; k < robots; ++k) {
        auto p = DrawRobot(k, plans, k == 0 ? 0.0 : 0.3, true, k < need_periodic);
        if (!p) return best_violation;
        plans.push_back(std::move(*p));
      }
      for (int round = 0; round < 30; ++round) {
        std::vector<std::vector<double>> pair;
        const auto ov = Overlaps(plans, &pair);
        std::vector<double> violation(robots, 0.0);
        double total = 0.0;
        for (int i = 0; i < robots && robots >= 2; ++i) {
          violation[i] = std::max({0.0, o_.overlap.min - ov[i], ov[i] - o_.overlap.max});
          total += violation[i];
        }
        std::vector<double> lacking(robots, 0.0);
        int periodic = 0;
        for (int i = 0; i < robots; ++i) {
          const bool exposed = plans[i].near_periodic >= o_.periodic_exposure;
          periodic += exposed;
          lacking[i] = exposed ? 0.0 : 1.0;
        }
        const int deficit = std::max(0, need_periodic - periodic);
        total += 0.1 * deficit;
        int redraw = PickWeighted(rng_, violation);
        bool want_periodic = false;
        if (deficit > 0 && (redraw < 0 || rng_.Bernoulli(0.5))) {
          redraw = PickWeighted(rng_, lacking);
          want_periodic = true;
        } else if (redraw >= 0 && ov[redraw] > o_.overlap.max && rng_.Bernoulli(0.3)) {
          // Too much overlap: move the robot it shares most with instead.
          int partner = redraw == 0 ? 1 : 0;
          for (int j = 0; j < robots; ++j) {
            if (j != redraw && pair[redraw][j] > pair[redraw][partner]) partner = j;
          }
          redraw = partner;
        }
        if (redraw < 0) {
          // Overlaps in range: the simulated paths must keep clear too.
          for (int i = 0; i < robots && redraw < 0; ++i) {
            if (plans[i].driven_clearance_m < 0.0) plans[i].driven_clearance_m = Driven(plans[i]);
            if (plans[i].driven_clearance_m < o_.driven_clearance_m) redraw = i;
          }
          if (redraw < 0) {
            *out = std::move(plans);
            return 0.0;
          }
          total += 1.0;
        }
        // A robot near periodic structure stays so when redrawn for another reason.
        want_periodic = want_periodic || (plans[redraw].near_periodic >= o_.periodic_exposure &&
                                          periodic <= need_periodic);
        if (total < best_violation) {
          best_violation = total;
          best = plans;
        }
        std::vector<Plan> others;
        for (int j = 0; j < robots; ++j) {
          if (j != redraw) others.push_back(plans[j]);
        }
        const double share = robots < 2                    ? 0.0
                             : ov[redraw] < o_.overlap.min ? 0.7
                             : ov[redraw] > o_.overlap.max ? 0.0
                                                           : 0.3;
        auto p = DrawRobot(redraw, others, share, ov[redraw] <= o_.overlap.max, want_periodic);
        if (p) plans[redraw] = std::move(*p);
      }
    }
    for (auto& p : best) {
      if (p.driven_clearance_m < 0.0) p.driven_clearance_m = Driven(p);
    }
    *out = std::move(best);
    return best_violation;
  }

  // Per robot: fraction of its samples within overlap_radius_m of any other robot's; pair[i][j]
  // the same against robot j alone.
  std::vector<double> Overlaps(const std::vector<Plan>& plans,
                               std::vector<std::vector<double>>* pair) const {
    const std::size_t n = plans.size();
    std::vector<PointGrid> grids;
    for (const auto& p : plans) grids.emplace_back(p.samples, o_.overlap_radius_m);
    std::vector<double> any(n, 0.0);
    if (pair) pair->assign(n, std::vector<double>(n, 0.0));
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t near_any = 0;
      std::vector<std::size_t> near_j(n, 0);
      for (const auto& q : plans[i].samples) {
        bool found = false;
        for (std::size_t j = 0; j < n; ++j) {
          if (j == i || (found && !pair)) continue;
          if (grids[j].AnyWithin(q, o_.overlap_radius_m)) {
            found = true;
            ++near_j[j];
          }
        }
        near_any += found;
      }
      const double m = static_cast<double>(std::max<std::size_t>(1, plans[i].samples.size()));
      any[i] = near_any / m;
      if (pair) {
        for (std::size_t j = 0; j < n; ++j) (*pair)[i][j] = j == i ? 0.0 : near_j[j] / m;
      }
    }
    return any;
  }

  double ClearanceOf(const std::vector<Vec2>& pts) const {
    double d = std::numeric_limits<double>::infinity();
    for (const auto& p : pts) d = std::min(d, clear_index_.Distance(p));
    return d;
  }

 private:
  bool InRectangle(Vec2 p, double inset) const {
    return std::abs(p.x) <= 0.5 * w_.width_m - inset && std::abs(p.y) <= 0.5 * w_.height_m - inset;
  }

  // Path points are at most 0.25 m apart (PatternPath) and distances change by at most the
  // step, so a point with room to spare lets the next few be skipped.
  bool Clear(const std::vector<Vec2>& path, std::size_t from) const {
    for (std::size_t i = from; i < path.size();) {
      const Vec2 p = path[i];
      const double room_rect =
          std::min(0.5 * w_.width_m - std::abs(p.x), 0.5 * w_.height_m - std::abs(p.y)) -
          clearance_;
      if (room_rect < 0.0) return false;
      const double room = std::min(room_rect, clear_index_.Distance(p) - clearance_);
      if (room < 0.0) return false;
      i += 1 + static_cast<std::size_t>(room / 0.25);
    }
    return true;
  }

  // Smallest distance from the simulated (pure-pursuit) path to any footprint.
  double Driven(const Plan& plan) const {
    // The vehicle model at 20 Hz instead of the simulator's 100 Hz: the same path to within
    // centimetres, five times cheaper.
    VehicleOptions vehicle;
    vehicle.sample_dt_s = 0.05;
    const Trajectory t = GenerateTrajectory(plan.spec, vehicle, 0.0);
    double d = std::numeric_limits<double>::infinity();
    const auto& s = t.samples();
    for (std::size_t i = 0; i < s.size(); i += 2) {
      d = std::min(d, clear_index_.Distance({s[i].x_m, s[i].y_m}));
    }
    return d;
  }

  static double NearFraction(const ShapeIndex& index, const std::vector<Vec2>& samples) {
    std::size_t near = 0;
    for (const auto& p : samples) near += index.Distance(p) < index.reach();
    return samples.empty() ? 0.0 : static_cast<double>(near) / samples.size();
  }

  // A pile grid or pier, nearer ones likelier.
  int PeriodicAnchor(Vec2 near) {
    std::vector<double> w;
    for (int a : periodic_anchors_)
      w.push_back(1.0 / (1.0 + Len(w_.anchors[a].box.c - near) / 30.0));
    return periodic_anchors_[PickWeighted(rng_, w)];
  }

  // Adds patterns when the path stays clear and within max_len.
  bool TryAdd(Plan* plan, const std::vector<PatternSpec>& add, double max_len) const {
    RobotSpec r = plan->spec;
    for (const auto& p : add) r.patterns.push_back(p);
    std::vector<Vec2> path = PatternPath(r);
    const double len = PathLength(path);
    if (len > max_len) return false;
    if (!Clear(path, plan->path.empty() ? 0 : plan->path.size() - 1)) return false;
    plan->spec = std::move(r);
    plan->path = std::move(path);
    plan->length_m = len;
    return true;
  }

  // Adds the pattern, with a detour waypoint before it when the straight transit is blocked.
  bool AddWithDetour(Plan* plan, const PatternSpec& p, double max_len) {
    if (TryAdd(plan, {p}, max_len)) return true;
    const Vec2 from = plan->path.empty() ? plan->spec.start_m : plan->path.back();
    const Vec2 to = Entry(p);
    const double dist = Len(to - from);
    for (int t = 0; t < 6; ++t) {
      const Vec2 q = Round(0.5 * (from + to) + rng_.Uniform(0.0, 0.5 * dist + 10.0) *
                                                   Unit(rng_.Uniform(0.0, 2.0 * M_PI)),
                           2);
      if (!InRectangle(q, clearance_ + 1.0) || clear_index_.Distance(q) < clearance_ + 1.0) {
        continue;
      }
      PatternSpec via;
      via.type = PatternSpec::Type::kWaypoints;
      via.waypoints_m = {q};
      if (TryAdd(plan, {via, p}, max_len)) return true;
    }
    return false;
  }

  double Offset() {
    return Round(rng_.Uniform(o_.path_clearance_m + 1.5, o_.path_clearance_m + 7.0), 1);
  }

  // Loop around a free structure; U-shaped pass around one on a quay.
  std::optional<PatternSpec> Loop(const Anchor& a, Vec2 p, double remaining) {
    if (a.wall) return std::nullopt;
    const double o = Offset();
    const Obb& b = a.box;
    PatternSpec s;
    if (a.attached) {
      const double root = std::min(-b.hl + o_.path_clearance_m + 2.5, b.hl);
      const double side = rng_.Bernoulli(0.5) ? 1.0 : -1.0;
      std::vector<Vec2> pts{b.At(root, side * (b.hw + o)), b.At(b.hl + o, side * (b.hw + o)),
                            b.At(b.hl + o, -side * (b.hw + o)), b.At(root, -side * (b.hw + o))};
      if (Len(pts[3] - p) < Len(pts[0] - p)) std::reverse(pts.begin(), pts.end());
      const double len = 2.0 * (b.hl + o - root) + 2.0 * (b.hw + o);
      if (len > remaining + 30.0) return std::nullopt;
      if (remaining > 2.0 * len + 20.0 && rng_.Bernoulli(0.5)) {
        for (int i = 2; i >= 0; --i) pts.push_back(pts[i]);
      }
      s.type = PatternSpec::Type::kWaypoints;
      for (auto& q : pts) s.waypoints_m.push_back(Round(q, 2));
      return s;
    }
    std::vector<Vec2> corners = b.Corners(o);
    const double perimeter = 4.0 * (b.hl + b.hw + 2.0 * o);
    if (perimeter > remaining + 30.0) return std::nullopt;
    std::size_t first = 0;
    for (std::size_t i = 1; i < corners.size(); ++i) {
      if (Len(corners[i] - p) < Len(corners[first] - p)) first = i;
    }
    std::rotate(corners.begin(), corners.begin() + first, corners.end());
    if (rng_.Bernoulli(0.5)) std::reverse(corners.begin() + 1, corners.end());
    s.type = PatternSpec::Type::kLoop;
    for (auto& q : corners) s.waypoints_m.push_back(Round(q, 2));
    s.laps = remaining > 2.0 * perimeter + 10.0 && rng_.Bernoulli(0.6) ? 2 : 1;
    return s;
  }

  std::optional<PatternSpec> Orbit(const Anchor& a, Vec2 p, double remaining) {
    if (a.wall || a.attached) return std::nullopt;
    const double rb = std::hypot(a.box.hl, a.box.hw);
    if (rb > 22.0) return std::nullopt;
    const double r = Round(rb + Offset(), 1);
    const double circumference = 2.0 * M_PI * r;
    if (circumference > remaining + 30.0) return std::nullopt;
    PatternSpec s;
    s.type = PatternSpec::Type::kOrbit;
    s.center_m = Round(a.box.c, 2);
    s.radius_m = r;
    s.heading_rad = Degrees(Angle(p - a.box.c)) * kDeg;
    s.laps = remaining > 2.0 * circumference + 10.0 && rng_.Bernoulli(0.5) ? 2 : 1;
    s.clockwise = rng_.Bernoulli(0.5);
    return s;
  }

  // Lanes parallel to the structure's long axis on one side, stepping away from it or
  // towards it.
  std::optional<PatternSpec> Lawnmower(const Anchor& a, Vec2 p, double remaining) {
    const Obb& b = a.box;
    const double side = a.wall || rng_.Bernoulli(0.5) ? 1.0 : -1.0;
    const double extra = rng_.Uniform(3.0, 12.0);
    const double spacing = Round(rng_.Uniform(6.0, 12.0), 1);
    const double o = Offset();
    double s0 = a.attached ? -b.hl + o_.path_clearance_m + 2.5
                : a.wall   ? -b.hl + o_.path_clearance_m + 3.0
                           : -b.hl - extra;
    double s1 = a.wall ? b.hl - o_.path_clearance_m - 3.0 : b.hl + extra;
    double lane = s1 - s0;
    int max_lanes = static_cast<int>((remaining + spacing) / (lane + spacing));
    if (max_lanes < 2) {
      const double shorter = 0.5 * (remaining - spacing) - 1.0;
      if (shorter < 15.0 || shorter > lane) return std::nullopt;
      const double mid = rng_.Uniform(s0 + 0.5 * shorter, s1 - 0.5 * shorter);
      s0 = mid - 0.5 * shorter;
      s1 = mid + 0.5 * shorter;
      lane = shorter;
      max_lanes = 2;
    }
    if (lane < 15.0) return std::nullopt;
    const int lanes = 2 + Pick(rng_, static_cast<std::size_t>(std::min(max_lanes, 5) - 1));
    const double t_near = side * (b.hw + o);
    const double t_far = side * (b.hw + o + (lanes - 1) * spacing);
    // Away: heading side*u from the near lane; towards: heading -side*u from the far lane.
    const Vec2 away_origin = b.At(side > 0 ? s0 : s1, t_near);
    const Vec2 towards_origin = b.At(side > 0 ? s1 : s0, t_far);
    const bool away = Len(away_origin - p) <= Len(towards_origin - p);
    PatternSpec s;
    s.type = PatternSpec::Type::kLawnmower;
    s.origin_m = Round(away ? away_origin : towards_origin, 2);
    s.heading_rad = Degrees(Angle((away ? side : -side) * b.u)) * kDeg;
    s.lane_length_m = Round(lane, 1);
    s.lane_spacing_m = spacing;
    s.lanes = lanes;
    return s;
  }

  std::optional<PatternSpec> FigureEight(const Anchor& a, double remaining) {
    const Obb& b = a.box;
    double r = rng_.Uniform(5.0, 9.0);
    if (10.5 * r > remaining + 20.0) r = std::max(5.0, (remaining + 10.0) / 10.5);
    if (10.5 * r > remaining + 30.0) return std::nullopt;
    r = Round(r, 1);
    const double side = a.wall || rng_.Bernoulli(0.5) ? 1.0 : -1.0;
    const double o = Offset();
    PatternSpec s;
    s.type = PatternSpec::Type::kFigureEight;
    s.radius_m = r;
    const double along = rng_.Uniform(-0.5, 0.5) * b.hl;
    if (rng_.Bernoulli(0.5)) {
      s.center_m = Round(b.At(along, side * (b.hw + o + 1.2 * r)), 2);
      s.heading_rad = Degrees(Angle((rng_.Bernoulli(0.5) ? 1.0 : -1.0) * b.u)) * kDeg;
    } else {
      s.center_m = Round(b.At(along, side * (b.hw + o + 2.0 * r)), 2);
      s.heading_rad = Degrees(Angle(side * b.v())) * kDeg;
    }
    s.laps = remaining > 21.0 * r + 10.0 && rng_.Bernoulli(0.4) ? 2 : 1;
    return s;
  }

  // A pass along one side of a structure or quay wall.
  std::optional<PatternSpec> Pass(const Anchor& a, Vec2 p, double remaining) {
    const Obb& b = a.box;
    if (b.hl < 10.0) return std::nullopt;  // long structures and walls only
    const double side = a.wall || rng_.Bernoulli(0.5) ? 1.0 : -1.0;
    const double o = Offset();
    const double extra = rng_.Uniform(3.0, 10.0);
    const double s0 = a.attached ? -b.hl + o_.path_clearance_m + 2.5
                      : a.wall   ? -b.hl + o_.path_clearance_m + 3.0
                                 : -b.hl - extra;
    double s1 = a.wall ? b.hl - o_.path_clearance_m - 3.0 : b.hl + extra;
    s1 = std::min(s1, s0 + remaining);
    if (s1 - s0 < 15.0) return std::nullopt;
    Vec2 q0 = b.At(s0, side * (b.hw + o));
    Vec2 q1 = b.At(s1, side * (b.hw + o));
    if (Len(q1 - p) < Len(q0 - p)) std::swap(q0, q1);
    PatternSpec s;
    s.type = PatternSpec::Type::kWaypoints;
    s.waypoints_m = {Round(q0, 2), Round(q1, 2)};
    return s;
  }

  // A leg to the open-water point farthest from structure among a few random ones.
  std::optional<PatternSpec> OpenWater(Vec2 p, double remaining) {
    Vec2 best;
    double best_d = -1.0;
    for (int t = 0; t < 16; ++t) {
      const Vec2 q{
          rng_.Uniform(-0.5 * w_.width_m + clearance_ + 3.0, 0.5 * w_.width_m - clearance_ - 3.0),
          rng_.Uniform(-0.5 * w_.height_m + clearance_ + 3.0,
                       0.5 * w_.height_m - clearance_ - 3.0)};
      const double dist = Len(q - p);
      if (dist < 20.0 || dist > std::min(70.0, remaining)) continue;
      if (!PointInPolygon(q, w_.water)) continue;
      const double d = near_index_.Distance(q);
      if (d > best_d) {
        best_d = d;
        best = q;
      }
    }
    if (best_d < 12.0) return std::nullopt;
    PatternSpec s;
    s.type = PatternSpec::Type::kWaypoints;
    s.waypoints_m = {Round(best, 2)};
    return s;
  }

  std::optional<PatternSpec> MakePattern(int anchor, Vec2 p, double remaining) {
    const Anchor& a = w_.anchors[anchor];
    const PatternWeights& pw = o_.pattern_weights;
    std::vector<double> w{a.wall ? 0.0 : pw.loop, pw.lawnmower, pw.figure_eight,
                          a.wall || a.attached ? 0.0 : pw.orbit, pw.waypoints};
    switch (PickWeighted(rng_, w)) {
      case 0:
        return Loop(a, p, remaining);
      case 1:
        return Lawnmower(a, p, remaining);
      case 2:
        return FigureEight(a, remaining);
      case 3:
        return Orbit(a, p, remaining);
      case 4:
        return Pass(a, p, remaining);
      default:
        return std::nullopt;
    }
  }

  // Home areas: one point per robot, spread out (farthest-point choice among random water
  // points); every anchor belongs to the nearest home.
  void MakeHomes(int robots) {
    std::vector<Vec2> candidates;
    for (int t = 0; t < 200 && candidates.size() < 96; ++t) {
      const Vec2 q{rng_.Uniform(-0.5 * w_.width_m + 10.0, 0.5 * w_.width_m - 10.0),
                   rng_.Uniform(-0.5 * w_.height_m + 10.0, 0.5 * w_.height_m - 10.0)};
      if (PointInPolygon(q, w_.water)) candidates.push_back(q);
    }
    if (candidates.empty()) candidates.push_back({0.0, 0.0});
    homes_ = {candidates[Pick(rng_, candidates.size())]};
    while (static_cast<int>(homes_.size()) < robots) {
      std::size_t best = 0;
      double best_d = -1.0;
      for (std::size_t i = 0; i < candidates.size(); ++i) {
        double d = std::numeric_limits<double>::infinity();
        for (const auto& h : homes_) d = std::min(d, Len(candidates[i] - h));
        if (d > best_d) {
          best_d = d;
          best = i;
        }
      }
      homes_.push_back(candidates[best]);
    }
    own_.assign(robots, {});
    for (std::size_t a = 0; a < w_.anchors.size(); ++a) {
      int k_best = 0;
      for (int k = 1; k < robots; ++k) {
        if (Len(w_.anchors[a].box.c - homes_[k]) < Len(w_.anchors[a].box.c - homes_[k_best])) {
          k_best = k;
        }
      }
      own_[k_best].push_back(static_cast<int>(a));
    }
    for (int k = 0; k < robots; ++k) {
      if (!own_[k].empty()) continue;
      // None of its own: take the nearest anchor of a robot that has two or more.
      int from = -1;
      std::size_t from_i = 0;
      double from_d = std::numeric_limits<double>::infinity();
      for (int j = 0; j < robots; ++j) {
        if (own_[j].size() < 2) continue;
        for (std::size_t i = 0; i < own_[j].size(); ++i) {
          const double d = Len(w_.anchors[own_[j][i]].box.c - homes_[k]);
          if (d < from_d) {
            from_d = d;
            from = j;
            from_i = i;
          }
        }
      }
      if (from >= 0) {
        own_[k].push_back(own_[from][from_i]);
        own_[from].erase(own_[from].begin() + static_cast<std::ptrdiff_t>(from_i));
        continue;
      }
      // Fewer anchors than robots: share the two nearest.
      std::vector<std::pair<double, int>> by_distance;
      for (std::size_t i = 0; i < w_.anchors.size(); ++i) {
        by_distance.push_back({Len(w_.anchors[i].box.c - homes_[k]), static_cast<int>(i)});
      }
      std::sort(by_distance.begin(), by_distance.end());
      for (std::size_t i = 0; i < std::min<std::size_t>(2, by_distance.size()); ++i) {
        own_[k].push_back(by_distance[i].second);
      }
    }
  }

  // Another robot's anchor with probability `share`, else one of the robot's own (near the
  // current position more often than not).
  int ChooseAnchor(int k, const std::vector<Plan>& others, double share, const Vec2* near) {
    std::vector<int> shared;
    for (const auto& o : others) shared.insert(shared.end(), o.anchors.begin(), o.anchors.end());
    if (!shared.empty() && rng_.Bernoulli(share)) return shared[Pick(rng_, shared.size())];
    const std::vector<int>& own = own_[k];
    if (near && rng_.Bernoulli(0.5)) {
      std::vector<std::pair<double, int>> by_distance;
      for (int a : own) by_distance.push_back({Len(w_.anchors[a].box.c - *near), a});
      std::sort(by_distance.begin(), by_distance.end());
      return by_distance[Pick(rng_, std::min<std::size_t>(2, by_distance.size()))].second;
    }
    std::vector<double> w;
    for (int a : own) w.push_back(w_.anchors[a].weight);
    return own[PickWeighted(rng_, w)];
  }

  // want_periodic: the path must spend periodic_exposure near pile grids or piers.
  std::optional<Plan> DrawRobot(int k, const std::vector<Plan>& others, double share,
                                bool open_allowed, bool want_periodic) {
    want_periodic = want_periodic && !periodic_anchors_.empty();
    const double bed_min = w_.MinBedDepth();
    double depth_hi =
        std::max(o_.depth_m.min, std::min(o_.depth_m.max, bed_min - o_.min_altitude_m));
    // Deep water: the vehicle goes down to keep the DVL in bottom lock over the deepest bed
    // (beyond the style's depth range if it must, never closer than min_altitude_m).
    const double depth_lo = std::min(std::max(o_.depth_m.min, w_.MaxBedDepth() - o_.max_altitude_m),
                                     std::max(o_.depth_m.min, bed_min - o_.min_altitude_m));
    depth_hi = std::max(depth_hi, depth_lo);
    for (int attempt = 0; attempt < 60; ++attempt) {
      Plan plan;
      RobotSpec& r = plan.spec;
      r.name = kRobotNames[k];
      r.speed_mps = Round(Draw(rng_, o_.speed_mps), 2);
      r.depth_m = Round(rng_.Uniform(depth_lo, depth_hi), 1);
      r.start_time_s = Round(Draw(rng_, o_.start_time_s), 1);
      const double target = Draw(rng_, o_.path_length_m);
      const double max_len = o_.path_length_m.max;

      // First pattern near an anchor, the start a little away from its entry.
      const int a0 =
          want_periodic ? PeriodicAnchor(homes_[k]) : ChooseAnchor(k, others, share, nullptr);
      const Obb& b0 = w_.anchors[a0].box;
      const Vec2 hint = b0.c + (std::hypot(b0.hl, b0.hw) + rng_.Uniform(8.0, 20.0)) *
                                   Unit(rng_.Uniform(0.0, 2.0 * M_PI));
      const auto first = MakePattern(a0, hint, target);
      if (!first) continue;
      const Vec2 entry = Entry(*first);
      bool placed = false;
      for (int t = 0; t < 20 && !placed; ++t) {
        const Vec2 q =
            Round(entry + rng_.Uniform(6.0, 18.0) * Unit(rng_.Uniform(0.0, 2.0 * M_PI)), 2);
        if (!InRectangle(q, clearance_ + 3.0) || !PointInPolygon(q, w_.water)) continue;
        if (clear_index_.Distance(q) < clearance_ + 3.0) continue;
        r.start_m = q;
        placed = true;
      }
      if (!placed) continue;
      r.start_yaw_rad = Degrees(Angle(entry - r.start_m) + rng_.Uniform(-90.0, 90.0) * kDeg) * kDeg;
      if (!AddWithDetour(&plan, *first, max_len)) continue;
      plan.anchors.push_back(a0);

      // No open-water leg when the overlap is to come down (it crosses the others' areas).
      bool open_leg = open_allowed && rng_.Bernoulli(o_.open_water_probability);
      for (int fails = 0; plan.length_m < target - 20.0 && fails < 12;) {
        const double remaining = target - plan.length_m;
        const Vec2 here = plan.path.back();
        std::optional<PatternSpec> cand;
        int anchor = -1;
        if (open_leg && rng_.Bernoulli(0.5)) {
          cand = OpenWater(here, remaining);
          open_leg = false;
          if (cand && !AddWithDetour(&plan, *cand, max_len)) cand.reset();
        } else {
          anchor = want_periodic && rng_.Bernoulli(0.5) ? PeriodicAnchor(here)
                                                        : ChooseAnchor(k, others, share, &here);
          // A few tries around the same anchor (offsets and sides differ).
          for (int t = 0; t < 3; ++t) {
            cand = MakePattern(anchor, here, remaining);
            if (cand && AddWithDetour(&plan, *cand, max_len)) break;
            cand.reset();
          }
        }
        if (cand) {
          if (anchor >= 0) plan.anchors.push_back(anchor);
        } else {
          ++fails;
        }
      }
      // Too short: a last leg in some clear direction.
      for (int t = 0; t < 24 && plan.length_m < o_.path_length_m.min; ++t) {
        const double need = std::min(70.0, target - plan.length_m + rng_.Uniform(0.0, 10.0));
        PatternSpec leg;
        leg.type = PatternSpec::Type::kWaypoints;
        leg.waypoints_m = {Round(plan.path.back() + need * Unit(rng_.Uniform(0.0, 2.0 * M_PI)), 2)};
        TryAdd(&plan, {leg}, max_len);
      }
      if (plan.length_m < o_.path_length_m.min || plan.length_m > max_len) continue;
      plan.samples = Resample(plan.path, 1.0);
      plan.near = NearFraction(near_index_, plan.samples);
      if (plan.near < o_.min_near_structure) continue;
      plan.near_periodic = NearFraction(periodic_index_, plan.samples);
      if (want_periodic && plan.near_periodic < o_.periodic_exposure) continue;
      plan.min_clearance_m = ClearanceOf(plan.path);
      return plan;
    }
    return std::nullopt;
  }

  const GeneratorOptions& o_;
  const GenWorld& w_;
  Rng& rng_;
  ShapeIndex clear_index_;
  ShapeIndex near_index_;
  ShapeIndex periodic_index_;
  std::vector<int> periodic_anchors_;
  std::vector<Vec2> homes_;
  std::vector<std::vector<int>> own_;  // anchors per robot
  double clearance_ = 3.0;
};

// --- Text -------------------------------------------------------------------------------------

std::string WorldYaml(const GenWorld& w, const std::string& style, std::uint64_t seed) {
  std::ostringstream y;
  y << "# Generated by `draco-sim generate --seed " << seed << "` (style " << style
    << "); docs/simulator.md, \"Generated worlds\".\n";
  y << "name: " << style << "-" << seed << "\n";
  y << "description: generated harbour-like world (style " << style << ", seed " << seed << ")\n";
  const double hx = 0.5 * w.width_m + 8.0;
  const double hy = 0.5 * w.height_m + 8.0;
  y << "bounds_m: [" << Pt({-hx, -hy}) << ", " << Pt({hx, hy}) << "]\n";
  y << "seabed: {depth_m: " << Num(w.seabed.depth_m) << ", slope: [" << Num(w.seabed.slope_x, 3)
    << ", " << Num(w.seabed.slope_y, 3) << "], backscatter: " << Num(w.seabed.backscatter, 4)
    << ", texture_contrast: " << Num(w.seabed.texture_contrast)
    << ", texture_scale_m: " << Num(w.seabed.texture_scale_m, 1) << "}\n";
  y << "objects:\n";
  for (const auto& s : w.structures) {
    for (const auto& line : s.yaml) y << "  - " << line << "\n";
  }
  return y.str();
}

std::string PatternYaml(const PatternSpec& p) {
  switch (p.type) {
    case PatternSpec::Type::kWaypoints:
      return "{type: waypoints, waypoints_m: " + Pts(p.waypoints_m) + "}";
    case PatternSpec::Type::kLoop:
      return "{type: loop, waypoints_m: " + Pts(p.waypoints_m) +
             ", laps: " + std::to_string(p.laps) + "}";
    case PatternSpec::Type::kLawnmower:
      return "{type: lawnmower, origin_m: " + Pt(p.origin_m) +
             ", heading_deg: " + Num(p.heading_rad / kDeg, 1) +
             ", lane_length_m: " + Num(p.lane_length_m, 1) +
             ", lane_spacing_m: " + Num(p.lane_spacing_m, 1) +
             ", lanes: " + std::to_string(p.lanes) + "}";
    case PatternSpec::Type::kFigureEight:
      return "{type: figure_eight, center_m: " + Pt(p.center_m) +
             ", radius_m: " + Num(p.radius_m, 1) +
             ", heading_deg: " + Num(p.heading_rad / kDeg, 1) +
             ", laps: " + std::to_string(p.laps) + "}";
    case PatternSpec::Type::kOrbit:
      return "{type: orbit, center_m: " + Pt(p.center_m) + ", radius_m: " + Num(p.radius_m, 1) +
             ", heading_deg: " + Num(p.heading_rad / kDeg, 1) +
             ", laps: " + std::to_string(p.laps) +
             ", clockwise: " + (p.clockwise ? "true" : "false") + "}";
  }
  return "";
}

std::string MissionYaml(const std::vector<Plan>& plans, double tilt_deg, const std::string& style,
                        std::uint64_t seed) {
  std::ostringstream y;
  y << "# Generated by `draco-sim generate --seed " << seed << "` (style " << style
    << "); docs/simulator.md, \"Generated worlds\".\n";
  y << "name: " << style << "-" << seed << "\n";
  y << "world: world.yaml\n";
  // The mission file's seed is a non-negative int.
  const std::uint64_t mission_seed = seed <= 0x7fffffffULL ? seed : (Mix64(seed) & 0x7fffffffULL);
  y << "seed: " << mission_seed << "\n";
  y << "sonar:\n  tilt_deg: " << Num(tilt_deg, 1) << "\n";
  y << "robots:\n";
  for (const auto& p : plans) {
    const RobotSpec& r = p.spec;
    y << "  - name: " << r.name << "\n";
    y << "    start_m: " << Pt(r.start_m) << "\n";
    y << "    start_yaw_deg: " << Num(r.start_yaw_rad / kDeg, 1) << "\n";
    y << "    depth_m: " << Num(r.depth_m, 1) << "\n";
    y << "    speed_mps: " << Num(r.speed_mps) << "\n";
    y << "    start_time_s: " << Num(r.start_time_s, 1) << "\n";
    y << "    patterns:\n";
    for (const auto& pattern : r.patterns) y << "      - " << PatternYaml(pattern) << "\n";
  }
  return y.str();
}

template <typename T, typename F>
std::string Join(const std::vector<T>& v, F format) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + format(v[i]);
  return s;
}

}  // namespace

Scenario GenerateScenario(const GeneratorOptions& options, std::uint64_t seed) {
  const GeneratorOptions& o = options;
  GenWorld world;
  std::vector<Plan> plans;
  Rng choose(DeriveSeed(seed, 0));
  const int n_robots = std::clamp(Draw(choose, o.robots), 1, 8);
  // Whether the world has a pile grid or pier depends on the seed alone, through the
  // golden-ratio sequence frac(seed * 0.618...): evenly spread, so every run of consecutive
  // seeds is periodic for close to periodic_probability of them (and redrawn worlds keep it).
  const double weyl =
      std::fmod(static_cast<double>(seed % 1000000007ULL) * 0.6180339887498949, 1.0);
  const bool periodic = weyl < o.periodic_probability;
  // Up to 4 worlds that take a mission; the first whose mission meets every target, else the
  // one that comes closest.
  double best = std::numeric_limits<double>::infinity();
  for (int attempt = 0, tried = 0; attempt < 40 && tried < 4 && best > 0.0; ++attempt) {
    GenWorld w;
    Rng world_rng(DeriveSeed(seed, 1, static_cast<std::uint64_t>(attempt)));
    if (!WorldMaker(o, &world_rng).Make(n_robots, periodic, &w)) continue;
    Rng mission_rng(DeriveSeed(seed, 2, static_cast<std::uint64_t>(attempt)));
    std::vector<Plan> p;
    const double v = MissionMaker(o, w, &mission_rng).Make(n_robots, &p);
    if (v == std::numeric_limits<double>::infinity()) continue;
    ++tried;
    if (v < best) {
      best = v;
      world = std::move(w);
      plans = std::move(p);
    }
  }
  if (plans.empty()) {
    throw std::runtime_error("generator: no world and mission found for seed " +
                             std::to_string(seed) + " with style " + o.name);
  }

  // Sonar tilt from the mean altitude: 5 deg at 3 m or less, 10 deg at 10 m or more.
  double altitude = 0.0;
  for (const auto& p : plans) {
    Vec2 mean;
    for (const auto& q : p.samples) mean = mean + q;
    mean = (1.0 / std::max<std::size_t>(1, p.samples.size())) * mean;
    altitude += -world.seabed.ZAt(mean.x, mean.y) - p.spec.depth_m;
  }
  altitude /= static_cast<double>(plans.size());
  const double f = std::clamp((altitude - 3.0) / 7.0, 0.0, 1.0);
  const double tilt_deg =
      std::round(2.0 * (o.sonar_tilt_deg.min + f * (o.sonar_tilt_deg.max - o.sonar_tilt_deg.min))) /
      2.0;

  Scenario sc;
  sc.seed = seed;
  sc.style = o.name;
  sc.world_yaml = WorldYaml(world, o.name, seed);
  sc.mission_yaml = MissionYaml(plans, tilt_deg, o.name, seed);
  sc.periodic = world.periodic;
  for (int k = 0; k < 8; ++k) {
    if (world.counts[k] > 0) sc.structures.push_back(KindName(static_cast<Kind>(k)));
  }
  sc.grid_spacing_m = world.grid_spacings;
  sc.pier_bent_spacing_m = world.pier_spacings;
  for (const auto& s : world.structures) sc.objects += static_cast<int>(s.yaml.size());
  MissionMaker measure(o, world, &choose);
  sc.overlap = measure.Overlaps(plans, &sc.pair_overlap);
  sc.min_path_clearance_m = std::numeric_limits<double>::infinity();
  sc.min_driven_clearance_m = std::numeric_limits<double>::infinity();
  for (const auto& p : plans) {
    sc.robot_names.push_back(p.spec.name);
    sc.path_length_m.push_back(p.length_m);
    sc.near_structure.push_back(p.near);
    sc.near_periodic.push_back(p.near_periodic);
    sc.min_path_clearance_m = std::min(sc.min_path_clearance_m, p.min_clearance_m);
    sc.min_driven_clearance_m = std::min(sc.min_driven_clearance_m, p.driven_clearance_m);
  }

  auto pct = [](double v) { return Num(std::round(100.0 * v), 0); };
  std::ostringstream t;
  t << "seed: " << seed << "\n";
  t << "style: " << o.name << "\n";
  t << "world_size_m: " << Num(world.width_m, 1) << " x " << Num(world.height_m, 1) << "\n";
  t << "seabed_depth_m: " << Num(world.MinBedDepth(), 1) << " - " << Num(world.MaxBedDepth(), 1)
    << "\n";
  t << "shore: " << world.shore << "\n";
  t << "l_basin: " << (world.l_basin ? "true" : "false") << "\n";
  double long_wall = 0.0;
  for (const auto& e : world.quay) long_wall = std::max(long_wall, e.length_m);
  t << "longest_wall_m: " << Num(long_wall, 1) << "\n";
  t << "structures: " << Join(sc.structures, [](const std::string& s) { return s; }) << "\n";
  t << "periodic: " << (sc.periodic ? "true" : "false") << "\n";
  t << "pile_grids: " << world.counts[static_cast<int>(Kind::kPileGrid)] << "\n";
  t << "grid_spacing_m: "
    << (sc.grid_spacing_m.empty() ? "none"
                                  : Join(sc.grid_spacing_m, [](const std::string& s) { return s; }))
    << "\n";
  t << "piers: " << world.counts[static_cast<int>(Kind::kPier)] << "\n";
  t << "pier_bent_spacing_m: "
    << (sc.pier_bent_spacing_m.empty()
            ? "none"
            : Join(sc.pier_bent_spacing_m, [](double v) { return Num(v, 2); }))
    << "\n";
  for (Kind k : {Kind::kDock, Kind::kBoat, Kind::kWreck, Kind::kBoulder}) {
    t << KindName(k) << "s: " << world.counts[static_cast<int>(k)] << "\n";
  }
  t << "debris_fields: " << world.counts[static_cast<int>(Kind::kDebris)] << "\n";
  t << "objects: " << sc.objects << "\n";
  t << "robots: " << plans.size() << "\n";
  t << "robot_names: " << Join(sc.robot_names, [](const std::string& s) { return s; }) << "\n";
  t << "path_length_m: " << Join(sc.path_length_m, [](double v) { return Num(v, 1); }) << "\n";
  t << "overlap_pct: " << Join(sc.overlap, pct) << "\n";
  for (std::size_t i = 0; i < plans.size(); ++i) {
    std::vector<std::string> row;
    for (std::size_t j = 0; j < plans.size(); ++j) {
      row.push_back(i == j ? "-" : pct(sc.pair_overlap[i][j]));
    }
    t << "pair_overlap_pct." << sc.robot_names[i] << ": "
      << Join(row, [](const std::string& s) { return s; }) << "\n";
  }
  t << "near_structure_pct: " << Join(sc.near_structure, pct) << "\n";
  t << "near_periodic_pct: " << Join(sc.near_periodic, pct) << "\n";
  t << "min_path_clearance_m: " << Num(std::floor(100.0 * sc.min_path_clearance_m) / 100.0) << "\n";
  t << "min_driven_clearance_m: " << Num(std::floor(100.0 * sc.min_driven_clearance_m) / 100.0)
    << "\n";
  t << "depth_m: " << Join(plans, [](const Plan& p) { return Num(p.spec.depth_m, 1); }) << "\n";
  t << "speed_mps: " << Join(plans, [](const Plan& p) { return Num(p.spec.speed_mps); }) << "\n";
  t << "start_time_s: " << Join(plans, [](const Plan& p) { return Num(p.spec.start_time_s, 1); })
    << "\n";
  t << "sonar_tilt_deg: " << Num(tilt_deg, 1) << "\n";
  sc.summary = t.str();
  return sc;
}

}  // namespace draco::sim
