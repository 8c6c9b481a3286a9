// The simulated world: a flat (optionally sloped) seabed and vertical-prism primitives
// (piles, boxes, convex polygons, walls), each with a height range and a material.
//
// Frame "world": x east, y north, z up, water surface at z = 0, metres.
// Worlds are YAML files (config/worlds/*.yaml, format in docs/simulator.md); convenience
// objects (piers, docks, boats, aircraft) are expanded into primitives when loaded.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "draco/sim/geometry.hpp"

namespace draco::sim {

// A malformed world or mission file; what() is "file:line:column: message".
class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(const std::string& message) : std::runtime_error(message) {}
};

struct Material {
  std::string name;
  double reflectivity = 0.1;  // energy reflection coefficient R^2 at normal incidence
};

enum class ShapeKind { kCircle, kConvexPolygon, kSegment };

struct Primitive {
  ShapeKind kind = ShapeKind::kCircle;
  Vec2 center_m;                 // circle centre; for other kinds the bounding-circle centre
  double radius_m = 0;           // circle radius; for other kinds the bounding-circle radius
  std::vector<Vec2> vertices_m;  // polygon (counter-clockwise, convex) or segment (2 points)
  double z_min_m = 0.0;
  double z_max_m = 0.0;
  int material = 0;  // index into World::materials
  int group = 0;     // index into World::groups (the YAML object it came from)
};

struct Seabed {
  double depth_m = 5.0;           // depth below the surface at the world origin
  double slope_x = 0.0;           // dz/dx (z up): positive rises to the east
  double slope_y = 0.0;           // dz/dy
  double backscatter = 0.004;     // diffuse backscatter coefficient mu
  double texture_contrast = 0.5;  // 0 = uniform seabed; patches vary by +-this fraction
  double texture_scale_m = 3.0;   // size of seabed patches

  double ZAt(double x_m, double y_m) const { return -depth_m + slope_x * x_m + slope_y * y_m; }
};

struct World {
  std::string name;
  std::string source;  // file it was loaded from
  Seabed seabed;
  std::vector<Material> materials;
  std::vector<std::string> groups;  // names of YAML objects, for pictures
  std::vector<Primitive> primitives;
  Vec2 bounds_min_m{-50.0, -50.0};
  Vec2 bounds_max_m{50.0, 50.0};

  int FindMaterial(const std::string& name) const;  // -1 when unknown
};

// Reads a world file. Throws ConfigError naming the file, line and what was expected.
World LoadWorld(const std::filesystem::path& path);
// Same from text; source_name is used in error messages and relative paths.
World ParseWorld(const std::string& yaml_text, const std::string& source_name);

// Materials every world knows (a world may override or add): timber, concrete, steel,
// aluminium, fibreglass, rock, rubber.
std::vector<Material> DefaultMaterials();

}  // namespace draco::sim
