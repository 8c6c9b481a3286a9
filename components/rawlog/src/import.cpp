#include "draco/rawlog/import.hpp"

#include <cmath>

#include "draco/navigation/dead_reckoning.hpp"
#include "draco/navigation/se2.hpp"

namespace draco::rawlog {

double MessageTime(const Message& message) {
  return std::visit([](const auto& m) { return m.time_s; }, message);
}

std::vector<Message> ToMessages(const std::vector<Entry>& entries, const ImportOptions& o) {
  std::vector<Message> out;
  bool have_previous = false;
  Odometry previous;
  std::uint32_t ping_id = 0;
  for (const auto& e : entries) {
    if (const auto* odo = std::get_if<Odometry>(&e)) {
      msgs::DeadReckoning d;
      d.time_s = odo->time_s;
      d.T_odom_body = odo->T_odom_body;
      if (have_previous) {
        const double dt = std::max(odo->time_s - previous.time_s, 0.0);
        const msgs::Pose2 inc = se2::Between(previous.T_odom_body, odo->T_odom_body);
        d.T_prev_body = inc;
        d.covariance_prev_body = navigation::IncrementCovariance(inc, dt, o.velocity_sigma_mps,
                                                                 o.yaw_random_walk_rad_per_sqrt_s);
        if (dt > 0.0) {
          d.velocity_body_mps = {inc.x_m / dt, inc.y_m / dt};
        }
      }
      previous = *odo;
      have_previous = true;
      out.push_back(std::move(d));
    } else if (const auto* scan = std::get_if<RangeScan>(&e)) {
      msgs::SonarFeatures f;
      f.time_s = scan->time_s;
      f.ping_id = ping_id++;
      f.points_sensor = ScanPoints(*scan);
      f.num_detections = static_cast<int>(f.points_sensor.size());
      out.push_back(std::move(f));
    }
  }
  return out;
}

}  // namespace draco::rawlog
