#include "draco/sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "draco/sim/random.hpp"
#include "yaml_util.hpp"

namespace draco::sim {

namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Primitives a world may hold. The sonar model tests every primitive for every beam (the
// marina world has 439); a pier or dock whose lengths and spacings would expand past this is
// an error naming it, not an out-of-memory.
constexpr std::size_t kMaxPrimitives = 100000;

// Deterministic small offset for a pile (real piles are never on a perfect grid).
double HashJitter(std::uint64_t a, std::uint64_t b) {
  return static_cast<double>(Mix64(a * 1000003ULL + b) >> 11) * 0x1.0p-53 * 2.0 - 1.0;
}

Vec2 BoundingCenter(const std::vector<Vec2>& pts, double* radius) {
  Vec2 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  Vec2 hi{-lo.x, -lo.y};
  for (const auto& p : pts) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y)};
  }
  const Vec2 c = 0.5 * (lo + hi);
  double r = 0.0;
  for (const auto& p : pts) r = std::max(r, Norm(p - c));
  *radius = r;
  return c;
}

class WorldBuilder {
 public:
  WorldBuilder(World* world, std::string file) : world_(world), file_(std::move(file)) {}

  void Parse(const YAML::Node& root) {
    yaml::Map top(file_, root, "world",
                  {"name", "description", "bounds_m", "seabed", "materials", "objects"});
    world_->name = top.String("name", "world");
    world_->materials = DefaultMaterials();
    if (top.Has("materials")) ParseMaterials(top.Get("materials"));
    if (top.Has("seabed")) ParseSeabed(top.Get("seabed"));
    if (top.Has("objects")) {
      const YAML::Node objects = top.Get("objects");
      if (!objects.IsSequence()) yaml::Fail(file_, objects, "expected a list of objects");
      for (const auto& obj : objects) ParseObject(obj);
    }
    if (top.Has("bounds_m")) {
      const auto pts = yaml::ToVec2List(file_, top.Get("bounds_m"),
                                        "bounds_m [[xmin, ymin], "
                                        "[xmax, ymax]]",
                                        2);
      world_->bounds_min_m = pts[0];
      world_->bounds_max_m = pts[1];
    } else {
      ComputeBounds();
    }
  }

 private:
  void ParseMaterials(const YAML::Node& node) {
    if (!node.IsMap()) yaml::Fail(file_, node, "expected 'name: reflectivity' pairs");
    for (const auto& kv : node) {
      const std::string name = yaml::ToString(file_, kv.first, "material name");
      const double r = yaml::ToDouble(file_, kv.second, "material reflectivity");
      if (r < 0.0 || r > 1.0) yaml::Fail(file_, kv.second, "reflectivity must be in [0, 1]");
      const int idx = world_->FindMaterial(name);
      if (idx >= 0) {
        world_->materials[idx].reflectivity = r;
      } else {
        world_->materials.push_back({name, r});
      }
    }
  }

  void ParseSeabed(const YAML::Node& node) {
    yaml::Map m(file_, node, "seabed",
                {"depth_m", "slope", "backscatter", "texture_contrast", "texture_scale_m"});
    Seabed& s = world_->seabed;
    s.depth_m = m.Double("depth_m", s.depth_m);
    if (s.depth_m <= 0.0) m.FailAt("depth_m", "seabed depth_m must be positive");
    const Vec2 slope = m.Vec("slope", {s.slope_x, s.slope_y});
    s.slope_x = slope.x;
    s.slope_y = slope.y;
    s.backscatter = m.Double("backscatter", s.backscatter);
    s.texture_contrast = m.Double("texture_contrast", s.texture_contrast);
    if (s.texture_contrast < 0.0 || s.texture_contrast >= 1.0) {
      m.FailAt("texture_contrast", "texture_contrast must be in [0, 1)");
    }
    s.texture_scale_m = m.Double("texture_scale_m", s.texture_scale_m);
    if (s.texture_scale_m <= 0.0) m.FailAt("texture_scale_m", "must be positive");
  }

  int Material(const yaml::Map& m, const std::string& fallback) {
    const std::string name = m.String("material", fallback);
    const int idx = world_->FindMaterial(name);
    if (idx < 0) {
      std::string known;
      for (const auto& mat : world_->materials) known += (known.empty() ? "" : ", ") + mat.name;
      m.FailAt("material", "unknown material '" + name + "' (known: " + known + ")");
    }
    return idx;
  }

  // z range: 'z_m' absolute (z up, surface 0) or 'height_m' above the seabed at `at`.
  std::pair<double, double> ZRange(const yaml::Map& m, Vec2 at, std::pair<double, double> dflt) {
    if (m.Has("z_m") && m.Has("height_m")) m.FailAt("height_m", "give z_m or height_m, not both");
    if (m.Has("z_m")) return m.Range("z_m");
    if (m.Has("height_m")) {
      const auto h = m.Range("height_m");
      const double bed = world_->seabed.ZAt(at.x, at.y);
      return {bed + h.first, bed + h.second};
    }
    return dflt;
  }

  int Group(const yaml::Map& m, const std::string& type) {
    std::string name = m.String("name", type + "_" + std::to_string(world_->groups.size()));
    world_->groups.push_back(name);
    return static_cast<int>(world_->groups.size()) - 1;
  }

  std::pair<double, double> FullHeight(Vec2 at) const {
    return {world_->seabed.ZAt(at.x, at.y) - 0.5, 1.0};
  }

  void AddCircle(Vec2 c, double radius, std::pair<double, double> z, int material, int group) {
    Primitive p;
    p.kind = ShapeKind::kCircle;
    p.center_m = c;
    p.radius_m = radius;
    p.z_min_m = z.first;
    p.z_max_m = z.second;
    p.material = material;
    p.group = group;
    world_->primitives.push_back(p);
  }

  void AddPolygon(std::vector<Vec2> pts, std::pair<double, double> z, int material, int group) {
    if (SignedArea(pts) < 0.0) std::reverse(pts.begin(), pts.end());
    Primitive p;
    p.kind = ShapeKind::kConvexPolygon;
    p.center_m = BoundingCenter(pts, &p.radius_m);
    p.vertices_m = std::move(pts);
    p.z_min_m = z.first;
    p.z_max_m = z.second;
    p.material = material;
    p.group = group;
    world_->primitives.push_back(p);
  }

  // Fails unless `count` more primitives fit in the world (a double: counts computed from
  // lengths may be huge, or not finite, before any cast to an integer).
  void Reserve(const YAML::Node& node, double count, const std::string& what) const {
    const double room = static_cast<double>(kMaxPrimitives - world_->primitives.size());
    if (!(count <= room)) {
      std::ostringstream text;
      text << what << " would expand to " << count << " primitives; a world holds at most "
           << kMaxPrimitives << " (" << world_->primitives.size() << " so far)";
      yaml::Fail(file_, node, text.str());
    }
  }

  // Length of each polyline segment; fails on two equal consecutive points (no direction).
  std::vector<double> SegmentLengths(const yaml::Map& m, const std::vector<Vec2>& line) const {
    std::vector<double> lengths;
    for (std::size_t i = 0; i + 1 < line.size(); ++i) {
      lengths.push_back(Norm(line[i + 1] - line[i]));
      if (!(lengths.back() > 0.0) || !std::isfinite(lengths.back())) {
        m.FailAt("polyline_m", "polyline_m point " + std::to_string(i + 1) +
                                   " equals the one before it (or the segment is not finite)");
      }
    }
    return lengths;
  }

  void AddWall(const std::vector<Vec2>& pts, std::pair<double, double> z, int material, int group) {
    for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
      Primitive p;
      p.kind = ShapeKind::kSegment;
      p.vertices_m = {pts[i], pts[i + 1]};
      p.center_m = BoundingCenter(p.vertices_m, &p.radius_m);
      p.z_min_m = z.first;
      p.z_max_m = z.second;
      p.material = material;
      p.group = group;
      world_->primitives.push_back(p);
    }
  }

  void ParseObject(const YAML::Node& node) {
    if (!node.IsMap() || !node["type"]) {
      yaml::Fail(file_, node,
                 "expected an object with a 'type' (pile, box, polygon, wall, "
                 "pier, dock, boat)");
    }
    const std::string type = yaml::ToString(file_, node["type"], "object type");
    if (type == "pile") {
      yaml::Map m(file_, node, "pile object",
                  {"type", "name", "center_m", "diameter_m", "z_m", "height_m", "material"});
      const Vec2 c = m.Vec("center_m");
      const double d = m.Double("diameter_m");
      if (d <= 0.0) m.FailAt("diameter_m", "diameter_m must be positive");
      AddCircle(c, 0.5 * d, ZRange(m, c, FullHeight(c)), Material(m, "timber"), Group(m, type));
    } else if (type == "box") {
      yaml::Map m(file_, node, "box object",
                  {"type", "name", "center_m", "size_m", "yaw_deg", "z_m", "height_m", "material"});
      const Vec2 c = m.Vec("center_m");
      const Vec2 size = m.Vec("size_m");
      if (size.x <= 0.0 || size.y <= 0.0) m.FailAt("size_m", "size_m must be positive");
      const auto z = ZRange(m, c, FullHeight(c));
      AddPolygon(BoxVertices(c, size.x, size.y, m.Double("yaw_deg", 0.0) * kDegToRad), z,
                 Material(m, "concrete"), Group(m, type));
    } else if (type == "polygon") {
      yaml::Map m(file_, node, "polygon object",
                  {"type", "name", "points_m", "z_m", "height_m", "material"});
      auto pts = yaml::ToVec2List(file_, m.Get("points_m"), "points_m", 3);
      if (!IsConvex(pts)) m.FailAt("points_m", "polygon must be convex (split it into parts)");
      double r = 0.0;
      const Vec2 c = BoundingCenter(pts, &r);
      AddPolygon(std::move(pts), ZRange(m, c, FullHeight(c)), Material(m, "concrete"),
                 Group(m, type));
    } else if (type == "wall") {
      yaml::Map m(file_, node, "wall object",
                  {"type", "name", "points_m", "z_m", "height_m", "material"});
      const auto pts = yaml::ToVec2List(file_, m.Get("points_m"), "points_m", 2);
      Reserve(node, static_cast<double>(pts.size()), "wall");
      AddWall(pts, ZRange(m, pts[0], FullHeight(pts[0])), Material(m, "concrete"), Group(m, type));
    } else if (type == "pier") {
      ParsePier(node);
    } else if (type == "dock") {
      ParseDock(node);
    } else if (type == "boat") {
      ParseBoat(node);
    } else {
      yaml::Fail(file_, node["type"],
                 "unknown object type '" + type +
                     "' (expected pile, box, polygon, wall, pier, dock or boat)");
    }
  }

  // Fixed pier: bents of piles across its width every bent_spacing_m along the polyline,
  // optionally a wave screen (timber wall) along one side.
  void ParsePier(const YAML::Node& node) {
    yaml::Map m(file_, node, "pier object",
                {"type", "name", "polyline_m", "width_m", "bent_spacing_m", "piles_per_bent",
                 "pile_diameter_m", "jitter_m", "z_m", "material", "wave_screen"});
    const auto line = yaml::ToVec2List(file_, m.Get("polyline_m"), "polyline_m", 2);
    const double width = m.Double("width_m");
    const double spacing = m.Double("bent_spacing_m", 2.4);
    const int across = m.Int("piles_per_bent", 4);
    const double diameter = m.Double("pile_diameter_m", 0.3);
    const double jitter = m.Double("jitter_m", 0.08);
    if (width <= 0.0 || spacing <= 0.1 || across < 1 || diameter <= 0.0) {
      yaml::Fail(file_, node,
                 "pier needs width_m > 0, bent_spacing_m > 0.1, piles_per_bent >= 1 "
                 "and pile_diameter_m > 0");
    }
    const std::vector<double> lengths = SegmentLengths(m, line);
    double piles = 0.0;
    for (const double len : lengths)
      piles += (std::max(1.0, std::floor(len / spacing)) + 1) * across;
    Reserve(node, piles + static_cast<double>(line.size()), "pier");
    const int material = Material(m, "timber");
    const int group = Group(m, "pier");
    const std::size_t first_pile = world_->primitives.size();
    std::uint64_t counter = 0;
    for (std::size_t seg = 0; seg + 1 < line.size(); ++seg) {
      const Vec2 a = line[seg];
      const Vec2 b = line[seg + 1];
      const double len = lengths[seg];
      const Vec2 along = (1.0 / len) * (b - a);
      const Vec2 left{-along.y, along.x};
      const int bents = std::max(1, static_cast<int>(std::floor(len / spacing)));
      const double step = len / bents;
      for (int i = (seg == 0 ? 0 : 1); i <= bents; ++i) {
        for (int k = 0; k < across; ++k) {
          const double off = across == 1 ? 0.0 : -0.5 * width + width * k / (across - 1);
          Vec2 c = a + (step * i) * along + off * left;
          c = c +
              Vec2{jitter * HashJitter(group, counter), jitter * HashJitter(group, counter + 7)};
          ++counter;
          const auto z = m.Has("z_m") ? m.Range("z_m") : FullHeight(c);
          AddCircle(c, 0.5 * diameter, z, material, group);
        }
      }
    }
    if (world_->primitives.size() == first_pile) yaml::Fail(file_, node, "pier has no piles");
    if (m.Has("wave_screen")) {
      yaml::Map w(file_, m.Get("wave_screen"), "wave_screen", {"side", "z_m", "material"});
      const std::string side = w.String("side", "left");
      if (side != "left" && side != "right") w.FailAt("side", "side must be left or right");
      const double sign = side == "left" ? 1.0 : -1.0;
      std::vector<Vec2> screen;
      for (std::size_t i = 0; i < line.size(); ++i) {
        const Vec2 dir = i + 1 < line.size() ? line[i + 1] - line[i] : line[i] - line[i - 1];
        const Vec2 u = (1.0 / Norm(dir)) * dir;
        screen.push_back(line[i] + (sign * (0.5 * width + 0.3)) * Vec2{-u.y, u.x});
      }
      const auto z = w.Has("z_m") ? w.Range("z_m") : std::pair<double, double>{-1.5, 1.0};
      AddWall(screen, z, Material(w, "timber"), group);
    }
  }

  // Floating dock: boxes in sections along the polyline with narrow gaps, plus guide piles.
  void ParseDock(const YAML::Node& node) {
    yaml::Map m(file_, node, "dock object",
                {"type", "name", "polyline_m", "width_m", "section_length_m", "z_m", "material",
                 "guide_pile_spacing_m", "guide_pile_diameter_m", "guide_pile_material"});
    const auto line = yaml::ToVec2List(file_, m.Get("polyline_m"), "polyline_m", 2);
    const double width = m.Double("width_m");
    const double section = m.Double("section_length_m", 13.0);
    const auto z = m.Has("z_m") ? m.Range("z_m") : std::pair<double, double>{-0.6, 0.4};
    const double guide_spacing = m.Double("guide_pile_spacing_m", 13.0);
    const double guide_d = m.Double("guide_pile_diameter_m", 0.35);
    if (width <= 0.0 || section <= 0.5) {
      yaml::Fail(file_, node, "dock needs width_m > 0 and section_length_m > 0.5");
    }
    const int material = Material(m, "concrete");
    int guide_material = material;
    if (m.Has("guide_pile_material")) {
      const std::string name = m.String("guide_pile_material");
      guide_material = world_->FindMaterial(name);
      if (guide_material < 0) m.FailAt("guide_pile_material", "unknown material '" + name + "'");
    }
    const std::vector<double> lengths = SegmentLengths(m, line);
    double parts = 0.0;
    for (const double len : lengths) {
      parts += std::max(1.0, std::round(len / section));
      if (guide_spacing > 0.0) parts += std::max(1.0, std::round(len / guide_spacing)) + 1;
    }
    Reserve(node, parts, "dock");
    const int group = Group(m, "dock");
    for (std::size_t seg = 0; seg + 1 < line.size(); ++seg) {
      const Vec2 a = line[seg];
      const Vec2 b = line[seg + 1];
      const double len = lengths[seg];
      const Vec2 along = (1.0 / len) * (b - a);
      const double yaw = std::atan2(along.y, along.x);
      const int sections = std::max(1, static_cast<int>(std::round(len / section)));
      const double step = len / sections;
      const double gap = 0.25;
      for (int i = 0; i < sections; ++i) {
        const Vec2 c = a + (step * (i + 0.5)) * along;
        AddPolygon(BoxVertices(c, step - gap, width, yaw), z, material, group);
      }
      if (guide_spacing > 0.0) {
        const Vec2 left{-along.y, along.x};
        const int n = std::max(1, static_cast<int>(std::round(len / guide_spacing)));
        for (int i = (seg == 0 ? 0 : 1); i <= n; ++i) {
          const Vec2 c = a + (len * i / n) * along + (0.5 * width + 0.5 * guide_d + 0.05) * left;
          AddCircle(c, 0.5 * guide_d, FullHeight(c), guide_material, group);
        }
      }
    }
  }

  // Moored boat: a convex hull outline (square stern, pointed bow) down to its draft.
  void ParseBoat(const YAML::Node& node) {
    yaml::Map m(
        file_, node, "boat object",
        {"type", "name", "center_m", "length_m", "beam_m", "yaw_deg", "draft_m", "material"});
    const Vec2 c = m.Vec("center_m");
    const double length = m.Double("length_m");
    const double beam = m.Double("beam_m", 0.35 * length);
    const double draft = m.Double("draft_m", 0.1 * length);
    if (length <= 0.0 || beam <= 0.0 || draft <= 0.0) {
      yaml::Fail(file_, node, "boat needs positive length_m, beam_m and draft_m");
    }
    const double yaw = m.Double("yaw_deg", 0.0) * kDegToRad;
    const double hl = 0.5 * length;
    const double hb = 0.5 * beam;
    const std::vector<Vec2> local = {
        {-hl, -0.85 * hb},     {0.1 * hl, -hb}, {0.6 * hl, -0.75 * hb}, {hl, 0.0},
        {0.6 * hl, 0.75 * hb}, {0.1 * hl, hb},  {-hl, 0.85 * hb}};
    std::vector<Vec2> pts;
    for (const auto& p : local) {
      pts.push_back(c + Vec2{std::cos(yaw) * p.x - std::sin(yaw) * p.y,
                             std::sin(yaw) * p.x + std::cos(yaw) * p.y});
    }
    AddPolygon(std::move(pts), {-draft, 0.5}, Material(m, "fibreglass"), Group(m, "boat"));
  }

  void ComputeBounds() {
    if (world_->primitives.empty()) return;
    Vec2 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    Vec2 hi{-lo.x, -lo.y};
    for (const auto& p : world_->primitives) {
      lo = {std::min(lo.x, p.center_m.x - p.radius_m), std::min(lo.y, p.center_m.y - p.radius_m)};
      hi = {std::max(hi.x, p.center_m.x + p.radius_m), std::max(hi.y, p.center_m.y + p.radius_m)};
    }
    world_->bounds_min_m = lo - Vec2{15.0, 15.0};
    world_->bounds_max_m = hi + Vec2{15.0, 15.0};
  }

  World* world_;
  std::string file_;
};

}  // namespace

int World::FindMaterial(const std::string& material_name) const {
  for (std::size_t i = 0; i < materials.size(); ++i) {
    if (materials[i].name == material_name) return static_cast<int>(i);
  }
  return -1;
}

std::vector<Material> DefaultMaterials() {
  // R^2 with R = (Z - Zw) / (Z + Zw), Z = density * sound speed (simulator notes); timber and
  // fibreglass are raised a little for surface roughness.
  return {{"timber", 0.10},     {"concrete", 0.47}, {"steel", 0.88}, {"aluminium", 0.70},
          {"fibreglass", 0.30}, {"rock", 0.35},     {"rubber", 0.05}};
}

World ParseWorld(const std::string& yaml_text, const std::string& source_name) {
  World world;
  world.source = source_name;
  WorldBuilder(&world, source_name).Parse(yaml::LoadText(yaml_text, source_name));
  return world;
}

World LoadWorld(const std::filesystem::path& path) {
  World world;
  world.source = path.string();
  WorldBuilder(&world, path.string()).Parse(yaml::LoadFile(path.string()));
  return world;
}

}  // namespace draco::sim
