#include "draco/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace draco::sim {

namespace {

constexpr double kSpacingM = 0.25;

void AppendSegment(std::vector<Vec2>* path, Vec2 to) {
  if (path->empty()) {
    path->push_back(to);
    return;
  }
  const Vec2 from = path->back();
  const double len = Norm(to - from);
  const int n = static_cast<int>(std::ceil(len / kSpacingM));
  for (int i = 1; i <= n; ++i) path->push_back(from + (static_cast<double>(i) / n) * (to - from));
}

std::vector<Vec2> PatternWaypoints(const PatternSpec& p) {
  std::vector<Vec2> pts;
  switch (p.type) {
    case PatternSpec::Type::kWaypoints:
      pts = p.waypoints_m;
      break;
    case PatternSpec::Type::kLoop:
      for (int lap = 0; lap < p.laps; ++lap) {
        for (const auto& w : p.waypoints_m) pts.push_back(w);
      }
      pts.push_back(p.waypoints_m.front());
      break;
    case PatternSpec::Type::kLawnmower: {
      const Vec2 u{std::cos(p.heading_rad), std::sin(p.heading_rad)};
      const Vec2 left{-u.y, u.x};
      for (int lane = 0; lane < p.lanes; ++lane) {
        const Vec2 a = p.origin_m + (lane * p.lane_spacing_m) * left;
        const Vec2 b = a + p.lane_length_m * u;
        if (lane % 2 == 0) {
          pts.push_back(a);
          pts.push_back(b);
        } else {
          pts.push_back(b);
          pts.push_back(a);
        }
      }
      break;
    }
    case PatternSpec::Type::kFigureEight: {
      // Lemniscate of Gerono scaled so each lobe is about radius_m across half its length.
      const Vec2 u{std::cos(p.heading_rad), std::sin(p.heading_rad)};
      const Vec2 v{-u.y, u.x};
      const int n = 96;
      for (int lap = 0; lap < p.laps; ++lap) {
        for (int i = 0; i < n; ++i) {
          const double t = 2.0 * M_PI * i / n;
          const double a = 2.0 * p.radius_m * std::sin(t);
          const double b = 1.2 * p.radius_m * std::sin(t) * std::cos(t) * 2.0;
          pts.push_back(p.center_m + a * u + b * v);
        }
      }
      pts.push_back(p.center_m);
      break;
    }
    case PatternSpec::Type::kOrbit: {
      const int n = std::max(24, static_cast<int>(2.0 * M_PI * p.radius_m / 1.0));
      const double dir = p.clockwise ? -1.0 : 1.0;
      for (int lap = 0; lap < p.laps; ++lap) {
        for (int i = 0; i < n; ++i) {
          const double t = p.heading_rad + dir * 2.0 * M_PI * i / n;
          pts.push_back(p.center_m + p.radius_m * Vec2{std::cos(t), std::sin(t)});
        }
      }
      pts.push_back(p.center_m +
                    p.radius_m * Vec2{std::cos(p.heading_rad), std::sin(p.heading_rad)});
      break;
    }
  }
  return pts;
}

}  // namespace

TrajectorySample Trajectory::At(double time_s) const {
  if (samples_.empty()) return {};
  if (time_s <= samples_.front().time_s) return samples_.front();
  if (time_s >= samples_.back().time_s) return samples_.back();
  const double dt = samples_[1].time_s - samples_[0].time_s;
  std::size_t i = static_cast<std::size_t>((time_s - samples_.front().time_s) / dt);
  i = std::min(i, samples_.size() - 2);
  while (i > 0 && samples_[i].time_s > time_s) --i;
  while (i + 2 < samples_.size() && samples_[i + 1].time_s < time_s) ++i;
  const TrajectorySample& a = samples_[i];
  const TrajectorySample& b = samples_[i + 1];
  const double w = (time_s - a.time_s) / (b.time_s - a.time_s);
  auto lerp = [w](double p, double q) { return p + w * (q - p); };
  TrajectorySample s;
  s.time_s = time_s;
  s.x_m = lerp(a.x_m, b.x_m);
  s.y_m = lerp(a.y_m, b.y_m);
  s.z_m = lerp(a.z_m, b.z_m);
  s.roll_rad = lerp(a.roll_rad, b.roll_rad);
  s.pitch_rad = lerp(a.pitch_rad, b.pitch_rad);
  s.yaw_rad = WrapAngle(a.yaw_rad + w * WrapAngle(b.yaw_rad - a.yaw_rad));
  s.yaw_rate_radps = lerp(a.yaw_rate_radps, b.yaw_rate_radps);
  s.vx_body_mps = lerp(a.vx_body_mps, b.vx_body_mps);
  s.vy_body_mps = lerp(a.vy_body_mps, b.vy_body_mps);
  s.vz_body_mps = lerp(a.vz_body_mps, b.vz_body_mps);
  s.distance_m = lerp(a.distance_m, b.distance_m);
  return s;
}

std::vector<Vec2> PatternPath(const RobotSpec& robot) {
  std::vector<Vec2> path;
  AppendSegment(&path, robot.start_m);
  for (const auto& pattern : robot.patterns) {
    for (const auto& w : PatternWaypoints(pattern)) AppendSegment(&path, w);
  }
  return path;
}

Trajectory GenerateTrajectory(const RobotSpec& robot, const VehicleOptions& vehicle,
                              double duration_cap_s) {
  const std::vector<Vec2> path = PatternPath(robot);
  std::vector<double> arc(path.size(), 0.0);
  for (std::size_t i = 1; i < path.size(); ++i) arc[i] = arc[i - 1] + Norm(path[i] - path[i - 1]);

  const double dt = vehicle.sample_dt_s;
  const double max_time = duration_cap_s > 0.0 ? duration_cap_s : 1e7;
  std::vector<TrajectorySample> out;
  out.reserve(
      static_cast<std::size_t>(std::min(max_time, arc.back() / robot.speed_mps * 1.5) / dt) + 16);

  Vec2 pos = robot.start_m;
  double yaw = robot.start_yaw_rad;
  double yaw_rate = 0.0;
  double speed = 0.0;
  double distance = 0.0;
  std::size_t progress = 0;
  const double window_m = 3.0 * vehicle.lookahead_m + 2.0;
  // Phases of the small attitude and heave oscillations differ per robot name.
  double phase = 0.0;
  for (char ch : robot.name) phase += 0.37 * static_cast<unsigned char>(ch);

  for (std::int64_t tick = 0;; ++tick) {
    const double t = static_cast<double>(tick) * dt;
    // Progress: nearest path point in a window ahead (never jumps across a crossing).
    std::size_t best = progress;
    double best_d = Norm(path[progress] - pos);
    for (std::size_t i = progress + 1; i < path.size() && arc[i] - arc[progress] < window_m; ++i) {
      const double d = Norm(path[i] - pos);
      if (d < best_d) {
        best_d = d;
        best = i;
      }
    }
    progress = best;
    const bool at_end = progress + 1 >= path.size() && best_d < 0.5;

    const double z =
        -robot.depth_m + vehicle.heave_amplitude_m * std::sin(2 * M_PI * t / 23.0 + phase);
    const double vz =
        vehicle.heave_amplitude_m * 2 * M_PI / 23.0 * std::cos(2 * M_PI * t / 23.0 + phase);
    const double roll = vehicle.roll_amplitude_rad * std::sin(2 * M_PI * t / 7.0 + 2.0 * phase);
    const double pitch = vehicle.pitch_amplitude_rad * std::sin(2 * M_PI * t / 11.0 + phase);
    const Vec2 ground{speed * std::cos(yaw) + vehicle.current_mps.x,
                      speed * std::sin(yaw) + vehicle.current_mps.y};
    TrajectorySample s;
    s.time_s = robot.start_time_s + t;
    s.x_m = pos.x;
    s.y_m = pos.y;
    s.z_m = z;
    s.roll_rad = roll;
    s.pitch_rad = pitch;
    s.yaw_rad = WrapAngle(yaw);
    s.yaw_rate_radps = yaw_rate;
    s.vx_body_mps = std::cos(yaw) * ground.x + std::sin(yaw) * ground.y;
    s.vy_body_mps = -std::sin(yaw) * ground.x + std::cos(yaw) * ground.y;
    s.vz_body_mps = vz;
    s.distance_m = distance;
    out.push_back(s);
    if (at_end || t >= max_time - 1e-9) break;

    // Pure pursuit: aim at the path point lookahead_m of arc ahead of the progress point.
    std::size_t target = progress;
    while (target + 1 < path.size() && arc[target] - arc[progress] < vehicle.lookahead_m) {
      ++target;
    }
    const Vec2 to = path[target] - pos;
    const double heading_error = WrapAngle(std::atan2(to.y, to.x) - yaw);
    const double cmd = std::clamp(vehicle.heading_gain_per_s * heading_error,
                                  -vehicle.max_yaw_rate_radps, vehicle.max_yaw_rate_radps);
    yaw_rate += (cmd - yaw_rate) * std::min(1.0, dt / vehicle.yaw_rate_lag_s);
    const double remaining = arc.back() - arc[progress] + best_d;
    double target_speed = robot.speed_mps * (1.0 - 0.5 * std::min(1.0, std::abs(heading_error)));
    target_speed = std::min(target_speed, std::max(0.05, 0.5 * remaining));
    speed += std::clamp(target_speed - speed, -vehicle.accel_mps2 * dt, vehicle.accel_mps2 * dt);

    yaw += yaw_rate * dt;
    const Vec2 step = dt * ground;
    pos = pos + step;
    distance += Norm(step);
  }
  return Trajectory(std::move(out));
}

}  // namespace draco::sim
