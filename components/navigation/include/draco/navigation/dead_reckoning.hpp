// Dead reckoning from DVL body velocity and AHRS yaw, as the reference (Bruce-SLAM) does it:
// at each DVL sample k,
//   p <- p + R(yaw_k) * (v_k + v_{k-1}) / 2 * dt,   yaw_k from the AHRS (not integrated),
// relative to the AHRS's first reading by default. A velocity whose horizontal speed is
// above max_speed_mps (a spike) or that is flagged invalid (a bottom-lock dropout) is
// replaced by the last good velocity, held for hold_time_s and then decayed to zero with
// time constant decay_time_s; its standard deviation grows with the time since the last
// good sample. No runtime dependency.
#pragma once

#include <optional>

#include "draco/msgs/sensors.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::navigation {

struct DeadReckoningOptions {
  bool yaw_relative_to_first = true;  // odom frame yaw 0 = the AHRS's first reading
  // The AHRS yaw is referenced to the same direction on every robot (a magnetometer or a
  // gyrocompass: the simulator's and the VN-100's): the odom frame's heading is reported
  // (msgs::DeadReckoning::odom_heading_rad) so teammates can bound the rotation between maps.
  // false for a gyro-only AHRS whose yaw starts anywhere.
  bool absolute_heading = true;
  double max_speed_mps = 0.9;                 // horizontal speeds above this are spikes
  double hold_time_s = 2.0;                   // hold the last good velocity this long...
  double decay_time_s = 5.0;                  // ...then decay it with this time constant
  double velocity_sigma_mps = 0.02;           // per-axis sigma of a good DVL velocity
  double held_sigma_growth_mps_per_s = 0.05;  // added sigma per second without a good sample
  double max_gap_s = 1.0;  // DVL samples further apart count as a dropout for the covariance
  // Relative yaw uncertainty between samples as a random walk (AHRS heading error is
  // Gauss-Markov, sigma ~1.5 deg over ~120 s: sqrt(2 * 0.026^2 / 120) ~ 0.0034).
  double yaw_random_walk_rad_per_sqrt_s = 0.0035;
};

// Covariance of a dead-reckoning increment `inc` over dt_s, in the new body frame: isotropic
// velocity noise (velocity_sigma_mps * dt_s per axis), the yaw random walk, and the
// translation error that a yaw error causes (g = S R_inc^T t_inc).
msgs::Covariance3 IncrementCovariance(const msgs::Pose2& inc, double dt_s,
                                      double velocity_sigma_mps,
                                      double yaw_random_walk_rad_per_sqrt_s);

class DeadReckoner {
 public:
  explicit DeadReckoner(const DeadReckoningOptions& options = {}) : options_(options) {}

  void AddAhrs(const msgs::Ahrs& ahrs);
  void AddDepth(const msgs::Depth& depth) { depth_m_ = depth.depth_m; }
  // Integrates one DVL sample. nullopt until the first AHRS reading has arrived, and for
  // samples not newer than the previous one.
  std::optional<msgs::DeadReckoning> AddDvl(const msgs::DvlVelocity& dvl);

  bool initialized() const { return initialized_; }
  const msgs::Pose2& pose() const { return pose_; }

 private:
  DeadReckoningOptions options_;
  bool have_ahrs_ = false;
  double yaw_offset_rad_ = 0.0;
  double yaw_rad_ = 0.0;  // latest AHRS yaw in the odom frame
  double depth_m_ = 0.0;
  bool initialized_ = false;
  double last_time_s_ = 0.0;
  double last_good_time_s_ = 0.0;
  double last_good_v_[2] = {0.0, 0.0};
  double prev_v_[2] = {0.0, 0.0};
  msgs::Pose2 pose_;
};

}  // namespace draco::navigation
