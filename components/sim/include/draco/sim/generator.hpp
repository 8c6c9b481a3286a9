// Generator of harbour-like worlds and multi-robot missions nobody tuned parameters on
// (docs/simulator.md, "Generated worlds").
//
// GenerateScenario(style, seed) is a pure function: the same style and seed give the same
// world and mission text, byte for byte. Randomness comes from draco::sim::Rng
// (std::mt19937_64 with the distributions written out) and every number is written rounded
// to centimetres (millimetres for pile positions), so the output does not depend on the
// standard library.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "draco/sim/geometry.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim {

// A value drawn uniformly from [min, max].
struct UniformRange {
  double min = 0.0;
  double max = 0.0;
};

// An integer drawn uniformly from {min, ..., max}.
struct IntRange {
  int min = 0;
  int max = 0;
};

// Relative frequency of each survey pattern type.
struct PatternWeights {
  double loop = 3.0;  // around a structure (a U-shaped pass for structures on a quay)
  double lawnmower = 2.0;
  double figure_eight = 1.5;
  double orbit = 1.5;
  double waypoints = 1.0;  // a leg along a quay wall
};

// A style: what kinds of worlds and missions to draw. The defaults are the harbour style
// (config/generator/harbour.yaml documents every key).
struct GeneratorOptions {
  std::string name = "harbour";

  // World: a water rectangle, seabed plane.
  UniformRange world_size_m{80.0, 160.0};  // each side of the water rectangle
  UniformRange seabed_depth_m{4.0, 15.0};  // everywhere in the rectangle
  double seabed_slope_max = 0.01;          // |dz/dx|, |dz/dy|
  UniformRange backscatter{0.0035, 0.0045};
  UniformRange texture_contrast{0.4, 0.5};
  UniformRange texture_scale_m{3.0, 4.0};
  double structure_gap_m = 8.0;       // free-standing structures at least this far apart
  double edge_margin_m = 2.0;         // structures at least this far inside the rectangle
  double area_per_robot_m2 = 3000.0;  // the rectangle grows (within size_m) to this per robot

  // Shore: quay walls along 0-3 contiguous sides of the rectangle.
  std::vector<double> quay_sides_weights{0.15, 0.35, 0.3, 0.2};  // 0, 1, 2, 3 sides
  double basin_corner_probability = 0.5;  // L-shaped basin: a land block at a quay corner
  UniformRange basin_corner_size_m{12.0, 30.0};

  // Periodic structures (pile grids or pier bents): all or nothing per world.
  double periodic_probability = 0.6;
  IntRange periodic_count{1, 3};
  double pile_grid_probability = 0.5;  // a periodic structure is a pile grid (else a pier)

  // Pile grids: identical piles on a square or rectangular lattice.
  UniformRange grid_spacing_m{2.0, 8.0};
  double grid_square_probability = 0.5;
  IntRange grid_piles_per_side{3, 9};
  double grid_max_extent_m = 40.0;
  UniformRange grid_pile_diameter_m{0.3, 0.8};
  double grid_jitter_m = 0.035;            // per axis: every pile within 5 cm of its lattice point
  double grid_attached_probability = 0.4;  // on a quay wall (a wharf)
  double grid_missing_probability = 0.35;  // some piles missing
  UniformRange grid_missing_fraction{0.05, 0.2};
  double grid_short_probability = 0.25;  // a few piles broken off near the seabed

  // Piers: the `pier` object (bents of piles across the deck).
  UniformRange pier_length_m{20.0, 50.0};
  UniformRange pier_width_m{4.0, 8.0};
  UniformRange pier_bent_spacing_m{2.0, 5.0};
  IntRange pier_piles_per_bent{3, 6};
  UniformRange pier_pile_diameter_m{0.3, 0.6};
  double pier_jitter_m = 0.035;  // per axis
  double pier_attached_probability = 0.75;
  double pier_l_shape_probability = 0.25;
  double pier_wave_screen_probability = 0.4;

  // Floating docks: a walkway with finger docks on one side.
  IntRange dock_count{0, 2};
  UniformRange dock_length_m{20.0, 45.0};
  UniformRange dock_width_m{2.0, 3.5};
  UniformRange dock_section_length_m{8.0, 14.0};
  IntRange dock_fingers{0, 4};
  UniformRange dock_finger_length_m{6.0, 12.0};
  double dock_attached_probability = 0.5;

  // Boats: moored alongside docks, piers, pile grids and quays, or at anchor.
  IntRange boat_count{2, 8};
  UniformRange boat_length_m{5.0, 14.0};
  double boat_moored_probability = 0.7;

  // Wrecks: a broken steel hull in pieces, often with a debris field.
  double wreck_probability = 0.35;
  UniformRange wreck_length_m{10.0, 25.0};
  IntRange wreck_pieces{1, 3};
  double wreck_debris_probability = 0.7;

  // Debris fields: small low boxes of mixed materials scattered in a disc.
  double debris_probability = 0.3;  // a field on its own (besides the wreck's)
  IntRange debris_pieces{8, 20};
  UniformRange debris_radius_m{5.0, 12.0};

  // Boulders: convex rock polygons, alone or in small clusters.
  IntRange boulder_count{0, 8};
  UniformRange boulder_diameter_m{1.0, 3.5};
  UniformRange boulder_height_m{0.4, 1.5};

  // Mission.
  IntRange robots{3, 5};
  UniformRange path_length_m{200.0, 350.0};  // planned path per robot, start leg included
  UniformRange speed_mps{0.3, 0.4};
  UniformRange depth_m{1.0, 3.0};
  double min_altitude_m = 2.0;  // depth_m at most the shallowest seabed minus this
  // ...and at least the deepest seabed minus this (the DVL loses bottom lock above 10 m, and
  // dead reckoning without it drifts tens of metres).
  double max_altitude_m = 8.0;
  UniformRange sonar_tilt_deg{5.0, 10.0};  // 5 deg at 3 m altitude or less, 10 at 10 m or more
  UniformRange start_time_s{0.0, 120.0};
  double path_clearance_m = 3.0;    // planned path to any object footprint
  double driven_clearance_m = 2.0;  // simulated (pure-pursuit) path to any object footprint
  double overlap_radius_m = 10.0;
  UniformRange overlap{0.2, 0.8};  // fraction of each path within overlap_radius_m of another's
  double near_structure_m = 20.0;
  double min_near_structure = 0.6;  // fraction of each path within near_structure_m of structure
  double open_water_probability = 0.5;  // a robot crosses open water on its way
  // In worlds with a pile grid or pier, at least this fraction of the robots (rounded up)
  // spends at least periodic_exposure of its path within near_structure_m of one.
  double periodic_robots = 0.5;
  double periodic_exposure = 0.25;
  PatternWeights pattern_weights;
};

// Reads a style file. Unknown keys, wrong types and bad values throw ConfigError naming the
// file, line and column.
GeneratorOptions LoadGeneratorOptions(const std::filesystem::path& path);
GeneratorOptions ParseGeneratorOptions(const std::string& yaml_text,
                                       const std::string& source_name);

// A generated world and mission with what scenario.txt reports.
struct Scenario {
  std::string world_yaml;
  std::string mission_yaml;  // its `world:` is "world.yaml" (same folder)
  std::string summary;       // scenario.txt: one "key: value" per line

  std::uint64_t seed = 0;
  std::string style;
  bool periodic = false;                    // a pile grid or pier bents are present
  std::vector<std::string> structures;      // kinds present: quay, pile_grid, pier, dock, ...
  std::vector<std::string> grid_spacing_m;  // per pile grid, "4.2 x 3.1"
  std::vector<double> pier_bent_spacing_m;  // per pier
  int objects = 0;                          // YAML objects in the world
  std::vector<std::string> robot_names;
  std::vector<double> path_length_m;
  std::vector<double> overlap;  // per robot: fraction within overlap_radius_m of any other
  std::vector<std::vector<double>> pair_overlap;  // [i][j]: fraction of i's path near j's
  std::vector<double> near_structure;             // per robot
  std::vector<double> near_periodic;  // per robot: fraction within near_structure_m of one
  double min_path_clearance_m = 0.0;
  double min_driven_clearance_m = 0.0;
};

// Draws a world and a mission. Deterministic in (options, seed).
Scenario GenerateScenario(const GeneratorOptions& options, std::uint64_t seed);

// Footprint geometry (also used by tests on loaded worlds).
// Distance from a point to a primitive's footprint, 0 inside a circle or polygon.
double FootprintDistance(const Primitive& primitive, Vec2 point);
// Clearance between two footprints, 0 when they touch or overlap.
double FootprintGap(const Primitive& a, const Primitive& b);

}  // namespace draco::sim
