// Random object worlds and two robots' views of them, for the matcher tests and benchmark.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "draco/msgs/objects.hpp"
#include "draco/objects/geometry.hpp"

namespace draco::objects::world {

struct WorldOptions {
  int num_objects = 30;
  double size_m = 150.0;          // square world side
  double min_separation_m = 4.0;  // between centres
  double center_noise_m = 0.3;    // per axis, per view
  double size_noise_m = 0.2;      // per side, per view
};

inline std::vector<msgs::Object> RandomWorld(std::mt19937_64* rng, const WorldOptions& o) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<msgs::Object> world;
  for (int attempt = 0; static_cast<int>(world.size()) < o.num_objects && attempt < 100000;
       ++attempt) {
    msgs::Object obj;
    obj.center = {o.size_m * u(*rng), o.size_m * u(*rng)};
    bool ok = true;
    for (const auto& w : world) {
      ok = ok && std::hypot(w.center.x_m - obj.center.x_m, w.center.y_m - obj.center.y_m) >=
                     o.min_separation_m;
    }
    if (!ok) continue;
    obj.length_m = 3.0 + 9.0 * u(*rng);
    obj.breadth_m = 0.5 + (obj.length_m - 0.5) * 0.6 * u(*rng);
    obj.id = static_cast<std::uint32_t>(world.size());
    world.push_back(obj);
  }
  return world;
}

inline msgs::Pose2 Inverse(const msgs::Pose2& T) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {-c * T.x_m - s * T.y_m, s * T.x_m - c * T.y_m, -T.yaw_rad};
}

// The objects `visible` of the world seen in frame `frame` (T_world_frame), with noise,
// plus `clutter` random objects inside the world's square. Ids: the world id for true
// objects, 100000 + n for clutter. Shuffled.
inline msgs::ObjectMap View(const std::vector<msgs::Object>& world, const std::vector<int>& visible,
                            const msgs::Pose2& T_world_frame, int clutter, const WorldOptions& o,
                            std::mt19937_64* rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const msgs::Pose2 inv = Inverse(T_world_frame);
  msgs::ObjectMap map;
  for (const int v : visible) {
    msgs::Object obj = world[v];
    obj.center = Transform(inv, obj.center);
    obj.center.x_m += o.center_noise_m * g(*rng);
    obj.center.y_m += o.center_noise_m * g(*rng);
    obj.length_m = std::max(0.1, obj.length_m + o.size_noise_m * g(*rng));
    obj.breadth_m = std::max(0.1, obj.breadth_m + o.size_noise_m * g(*rng));
    map.objects.push_back(obj);
  }
  for (int c = 0; c < clutter; ++c) {
    msgs::Object obj;
    obj.center = Transform(inv, {o.size_m * u(*rng), o.size_m * u(*rng)});
    obj.length_m = 3.0 + 9.0 * u(*rng);
    obj.breadth_m = 0.5 + (obj.length_m - 0.5) * 0.6 * u(*rng);
    obj.id = 100000u + static_cast<std::uint32_t>(c);
    map.objects.push_back(obj);
  }
  std::shuffle(map.objects.begin(), map.objects.end(), *rng);
  return map;
}

inline msgs::Pose2 Compose(const msgs::Pose2& A, const msgs::Pose2& B) {
  const Point2 t = Transform(A, {B.x_m, B.y_m});
  return {t.x_m, t.y_m, NormalizeAngle(A.yaw_rad + B.yaw_rad)};
}

}  // namespace draco::objects::world
