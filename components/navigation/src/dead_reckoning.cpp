// Dead reckoning from DVL and AHRS (see dead_reckoning.hpp).
#include "draco/navigation/dead_reckoning.hpp"

#include <cmath>

#include "draco/navigation/se2.hpp"

namespace draco::navigation {

msgs::Covariance3 IncrementCovariance(const msgs::Pose2& inc, double dt_s,
                                      double velocity_sigma_mps,
                                      double yaw_random_walk_rad_per_sqrt_s) {
  const double var_t = (velocity_sigma_mps * dt_s) * (velocity_sigma_mps * dt_s);
  const double var_y = yaw_random_walk_rad_per_sqrt_s * yaw_random_walk_rad_per_sqrt_s * dt_s;
  const double ci = std::cos(inc.yaw_rad), si = std::sin(inc.yaw_rad);
  const double lx = ci * inc.x_m + si * inc.y_m, ly = -si * inc.x_m + ci * inc.y_m;
  const double g[2] = {-ly, lx};
  return {var_t + var_y * g[0] * g[0],
          var_y * g[0] * g[1],
          var_y * g[0],
          var_y * g[1] * g[0],
          var_t + var_y * g[1] * g[1],
          var_y * g[1],
          var_y * g[0],
          var_y * g[1],
          var_y};
}

void DeadReckoner::AddAhrs(const msgs::Ahrs& ahrs) {
  if (!have_ahrs_) {
    yaw_offset_rad_ = options_.yaw_relative_to_first ? ahrs.yaw_rad : 0.0;
    have_ahrs_ = true;
  }
  yaw_rad_ = se2::WrapAngle(ahrs.yaw_rad - yaw_offset_rad_);
}

std::optional<msgs::DeadReckoning> DeadReckoner::AddDvl(const msgs::DvlVelocity& dvl) {
  if (!have_ahrs_) return std::nullopt;
  const double t = dvl.time_s;
  const double vx = dvl.velocity_body_mps[0], vy = dvl.velocity_body_mps[1];
  const bool good = dvl.valid && std::isfinite(vx) && std::isfinite(vy) &&
                    std::hypot(vx, vy) <= options_.max_speed_mps;
  msgs::DeadReckoning out;
  out.time_s = t;
  out.depth_m = depth_m_;
  out.dvl_ok = good;
  if (options_.absolute_heading) out.odom_heading_rad = yaw_offset_rad_;
  if (!initialized_) {
    initialized_ = true;
    pose_ = msgs::Pose2{0.0, 0.0, yaw_rad_};
    prev_v_[0] = good ? vx : 0.0;
    prev_v_[1] = good ? vy : 0.0;
    last_good_v_[0] = prev_v_[0];
    last_good_v_[1] = prev_v_[1];
    last_good_time_s_ = t;
    last_time_s_ = t;
    out.T_odom_body = pose_;
    out.velocity_body_mps = {prev_v_[0], prev_v_[1]};
    return out;
  }
  const double dt = t - last_time_s_;
  if (!(dt > 0.0)) return std::nullopt;

  double v[2];
  double sigma = options_.velocity_sigma_mps;
  if (good) {
    v[0] = vx;
    v[1] = vy;
    last_good_v_[0] = vx;
    last_good_v_[1] = vy;
    last_good_time_s_ = t;
  } else {
    const double age = t - last_good_time_s_;
    const double f =
        age <= options_.hold_time_s
            ? 1.0
            : std::exp(-(age - options_.hold_time_s) / std::max(options_.decay_time_s, 1e-9));
    v[0] = f * last_good_v_[0];
    v[1] = f * last_good_v_[1];
    sigma += options_.held_sigma_growth_mps_per_s * age;
  }
  if (dt > options_.max_gap_s) sigma += options_.held_sigma_growth_mps_per_s * dt;

  // Trapezoid on the body velocity, rotated by the current AHRS yaw (as the reference).
  const double ax = 0.5 * (v[0] + prev_v_[0]) * dt, ay = 0.5 * (v[1] + prev_v_[1]) * dt;
  const double c = std::cos(yaw_rad_), s = std::sin(yaw_rad_);
  const msgs::Pose2 previous = pose_;
  pose_ = msgs::Pose2{pose_.x_m + c * ax - s * ay, pose_.y_m + s * ax + c * ay, yaw_rad_};
  const msgs::Pose2 inc = se2::Between(previous, pose_);

  out.covariance_prev_body =
      IncrementCovariance(inc, dt, sigma, options_.yaw_random_walk_rad_per_sqrt_s);
  out.T_odom_body = pose_;
  out.T_prev_body = inc;
  out.velocity_body_mps = {v[0], v[1]};
  prev_v_[0] = v[0];
  prev_v_[1] = v[1];
  last_time_s_ = t;
  return out;
}

}  // namespace draco::navigation
