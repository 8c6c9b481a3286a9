// PNG pictures for people: the world with the robots' true paths, and sonar frames.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "draco/msgs/sensors.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim_app {

struct PathDrawing {
  std::string name;
  std::vector<sim::Vec2> points_m;
};

// Top view of the world (seabed shaded by depth, structures by material) with each path in
// its own colour, a start marker and a label.
void WriteWorldPicture(const sim::World& world, const std::vector<PathDrawing>& paths,
                       const std::filesystem::path& png, double pixels_per_m = 5.0);

// The polar image as stored (range up, beams left to right).
void WritePolarPicture(const msgs::SonarPing& ping, const std::filesystem::path& png);

// Cartesian fan (sonar at the bottom centre, forward up), resolution in metres per pixel.
void WriteFanPicture(const msgs::SonarPing& ping, const std::filesystem::path& png,
                     double metres_per_pixel = 0.05);

}  // namespace draco::sim_app
