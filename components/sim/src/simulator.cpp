#include "draco/sim/simulator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "draco/sim/random.hpp"

namespace draco::sim {

namespace {

enum Stream { kAhrs = 0, kDvl, kDepth, kSonar, kGroundTruth, kStreamCount };

msgs::GroundTruthPose TruthPose(const TrajectorySample& s) {
  msgs::GroundTruthPose p;
  p.time_s = s.time_s;
  p.position_m = {s.x_m, s.y_m, s.z_m};
  p.roll_rad = s.roll_rad;
  p.pitch_rad = s.pitch_rad;
  p.yaw_rad = s.yaw_rad;
  return p;
}

}  // namespace

SonarPose SonarPoseAt(const TrajectorySample& body, double tilt_rad) {
  SonarPose p;
  p.x_m = body.x_m;
  p.y_m = body.y_m;
  p.z_m = body.z_m;
  p.yaw_rad = body.yaw_rad;
  p.tilt_rad = tilt_rad + body.pitch_rad;
  return p;
}

NavigationSensors::NavigationSensors(const NavigationOptions& options, const World& world,
                                     std::uint64_t seed)
    : options_(options), world_(world), rng_(seed) {
  dvl_scale_ = 1.0 + options_.dvl.scale_sigma * rng_.Normal();
  dvl_misalignment_rad_ = options_.dvl.misalignment_sigma_rad * rng_.Normal();
  yaw_drift_rad_ = options_.ahrs.yaw_drift_sigma_rad * rng_.Normal();
  const int steel = world_.FindMaterial("steel");
  if (steel >= 0 && options_.ahrs.steel_anomaly_rad > 0.0) {
    for (const auto& p : world_.primitives) {
      if (p.material != steel) continue;
      // Sign and strength fixed per object by its position (the same for every robot).
      const std::uint64_t h =
          Mix64(static_cast<std::uint64_t>(std::llround(p.center_m.x * 100)) * 0x9E3779B1ULL ^
                static_cast<std::uint64_t>(std::llround(p.center_m.y * 100)));
      const double u = static_cast<double>(h >> 11) * 0x1.0p-53;
      const double amplitude =
          options_.ahrs.steel_anomaly_rad * (u < 0.5 ? -1.0 : 1.0) * (0.5 + std::abs(u - 0.5));
      anomalies_.push_back({p.center_m.x, p.center_m.y, amplitude});
    }
  }
}

double NavigationSensors::HeadingAnomaly(double x_m, double y_m) const {
  const double length = options_.ahrs.steel_anomaly_length_m;
  const double reach2 = 9.0 * length * length;
  double sum = 0.0;
  for (const auto& a : anomalies_) {
    const double d2 = (a.x_m - x_m) * (a.x_m - x_m) + (a.y_m - y_m) * (a.y_m - y_m);
    if (d2 < reach2) sum += a.amplitude_rad * std::exp(-d2 / (length * length));
  }
  const double cap = options_.ahrs.steel_anomaly_rad * 1.5;
  return std::clamp(sum, -cap, cap);
}

msgs::DvlVelocity NavigationSensors::Dvl(const TrajectorySample& truth) {
  const DvlOptions& o = options_.dvl;
  msgs::DvlVelocity d;
  d.time_s = truth.time_s;
  const double c = std::cos(dvl_misalignment_rad_);
  const double s = std::sin(dvl_misalignment_rad_);
  const double vx = c * truth.vx_body_mps - s * truth.vy_body_mps;
  const double vy = s * truth.vx_body_mps + c * truth.vy_body_mps;
  d.velocity_body_mps = {dvl_scale_ * vx + o.noise_sigma_mps * rng_.Normal(),
                         dvl_scale_ * vy + o.noise_sigma_mps * rng_.Normal(),
                         dvl_scale_ * truth.vz_body_mps + o.noise_sigma_mps * rng_.Normal()};
  const double altitude = truth.z_m - world_.seabed.ZAt(truth.x_m, truth.y_m);
  d.altitude_m = altitude + o.altitude_noise_sigma_m * rng_.Normal();
  const bool dropout = rng_.Bernoulli(o.dropout_probability);
  if (dropout || altitude > o.max_altitude_m) {
    d.valid = false;
    d.velocity_body_mps = {0.0, 0.0, 0.0};
    d.altitude_m = -1.0;
  }
  return d;
}

msgs::Ahrs NavigationSensors::Ahrs(const TrajectorySample& truth) {
  const AhrsOptions& o = options_.ahrs;
  if (drift_time_s_ >= 0.0) {
    // First-order Gauss-Markov: exact discretisation keeps the stationary sigma.
    const double dt = std::max(0.0, truth.time_s - drift_time_s_);
    const double phi = std::exp(-dt / o.yaw_drift_tau_s);
    yaw_drift_rad_ =
        phi * yaw_drift_rad_ + o.yaw_drift_sigma_rad * std::sqrt(1.0 - phi * phi) * rng_.Normal();
  }
  drift_time_s_ = truth.time_s;
  msgs::Ahrs a;
  a.time_s = truth.time_s;
  a.roll_rad = truth.roll_rad + o.roll_pitch_noise_sigma_rad * rng_.Normal();
  a.pitch_rad = truth.pitch_rad + o.roll_pitch_noise_sigma_rad * rng_.Normal();
  a.yaw_rad = WrapAngle(truth.yaw_rad + yaw_drift_rad_ + HeadingAnomaly(truth.x_m, truth.y_m) +
                        o.yaw_noise_sigma_rad * rng_.Normal());
  a.yaw_rate_radps = truth.yaw_rate_radps + o.yaw_rate_noise_sigma_radps * rng_.Normal();
  return a;
}

msgs::Depth NavigationSensors::Depth(const TrajectorySample& truth) {
  msgs::Depth d;
  d.time_s = truth.time_s;
  d.depth_m = -truth.z_m + options_.depth.noise_sigma_m * rng_.Normal();
  return d;
}

RobotRunStats SimulateRobot(const World& world, const Mission& mission, int robot_index,
                            const SonarModel* sonar, RobotSink& sink, RobotProgress* progress) {
  const RobotSpec& robot = mission.robots.at(static_cast<std::size_t>(robot_index));
  const Trajectory traj = GenerateTrajectory(robot, mission.vehicle, mission.duration_s);
  const auto robot_key = static_cast<std::uint64_t>(robot_index) + 1;
  NavigationSensors nav(mission.navigation, world, DeriveSeed(mission.seed, robot_key, 0));

  const double t0 = traj.StartTime();
  const double t_end = traj.EndTime();
  const std::array<double, kStreamCount> rates = {
      mission.navigation.ahrs.rate_hz, mission.navigation.dvl.rate_hz,
      mission.navigation.depth.rate_hz, mission.sonar.rate_hz,
      mission.navigation.ground_truth_rate_hz};
  std::array<std::uint64_t, kStreamCount> next{};
  auto time_of = [&](int s) { return t0 + static_cast<double>(next[s]) / rates[s]; };

  RobotRunStats stats;
  const auto total_pings = static_cast<std::uint64_t>(std::floor((t_end - t0) * rates[kSonar])) + 1;
  if (progress != nullptr) progress->pings_total = total_pings;

  for (;;) {
    int stream = -1;
    double t = std::numeric_limits<double>::infinity();
    for (int s = 0; s < kStreamCount; ++s) {
      const double ts = time_of(s);
      if (ts <= t_end + 1e-9 && ts < t) {
        t = ts;
        stream = s;
      }
    }
    if (stream < 0) break;
    const TrajectorySample truth = traj.At(t);
    switch (stream) {
      case kAhrs:
        sink.OnAhrs(nav.Ahrs(truth));
        break;
      case kDvl:
        sink.OnDvl(nav.Dvl(truth));
        break;
      case kDepth:
        sink.OnDepth(nav.Depth(truth));
        break;
      case kSonar: {
        // Without sonar the ground truth at the ping times is still emitted: the navigation
        // and ground truth do not depend on whether pings are rendered.
        if (sonar != nullptr) {
          const auto id = static_cast<std::uint32_t>(next[kSonar]);
          const msgs::SonarPing ping =
              sonar->Render(SonarPoseAt(truth, mission.sonar_tilt_rad), t, id,
                            DeriveSeed(mission.seed, robot_key, std::uint64_t{id} + 1));
          sink.OnPing(ping, truth);
          ++stats.pings;
          if (progress != nullptr) {
            progress->pings_done = stats.pings;
            progress->mission_time_s = t - t0;
          }
        }
        if (time_of(kGroundTruth) != t) sink.OnGroundTruth(TruthPose(truth));
        break;
      }
      case kGroundTruth:
        sink.OnGroundTruth(TruthPose(truth));
        break;
      default:
        break;
    }
    ++next[stream];
  }
  stats.distance_m = traj.Length();
  stats.duration_s = t_end - t0;
  return stats;
}

double LastAhrsTimeS(const Mission& mission, int robot_index) {
  const RobotSpec& robot = mission.robots.at(static_cast<std::size_t>(robot_index));
  const Trajectory traj = GenerateTrajectory(robot, mission.vehicle, mission.duration_s);
  const double t0 = traj.StartTime();
  const double t_end = traj.EndTime();
  const double rate = mission.navigation.ahrs.rate_hz;
  if (!(rate > 0.0)) return 0.0;
  // The sample times as SimulateRobot computes them: t0 + n / rate while <= t_end + 1e-9.
  auto time_of = [&](std::uint64_t n) { return t0 + static_cast<double>(n) / rate; };
  auto n = static_cast<std::uint64_t>(std::max(0.0, std::floor((t_end - t0) * rate)));
  while (time_of(n + 1) <= t_end + 1e-9) ++n;
  while (n > 0 && time_of(n) > t_end + 1e-9) --n;
  return time_of(n);
}

void DeadReckoning::AddAhrs(const msgs::Ahrs& ahrs) {
  if (!have_yaw0_) {
    yaw0_ = ahrs.yaw_rad;
    have_yaw0_ = true;
  }
  yaw_ = WrapAngle(ahrs.yaw_rad - yaw0_);
}

void DeadReckoning::AddDvl(const msgs::DvlVelocity& dvl) {
  double vx = dvl.velocity_body_mps[0];
  double vy = dvl.velocity_body_mps[1];
  if (!dvl.valid || std::hypot(vx, vy) > max_speed_mps) {
    vx = prev_vx_;
    vy = prev_vy_;
  }
  if (have_prev_ && have_yaw0_) {
    const double dt = dvl.time_s - prev_t_;
    const double mx = 0.5 * (vx + prev_vx_) * dt;
    const double my = 0.5 * (vy + prev_vy_) * dt;
    x_ += std::cos(yaw_) * mx - std::sin(yaw_) * my;
    y_ += std::sin(yaw_) * mx + std::cos(yaw_) * my;
  }
  have_prev_ = true;
  prev_t_ = dvl.time_s;
  prev_vx_ = vx;
  prev_vy_ = vy;
}

}  // namespace draco::sim
