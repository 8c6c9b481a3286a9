// Keyframe selection and dead-reckoning history (see keyframes.hpp).
#include "draco/navigation/keyframes.hpp"

#include <algorithm>
#include <cmath>

#include "draco/navigation/se2.hpp"

namespace draco::navigation {

bool IsKeyframe(const KeyframeOptions& options, std::optional<double> last_time_s,
                const msgs::Pose2& last_T_odom_body, double time_s,
                const msgs::Pose2& T_odom_body) {
  if (!last_time_s) return true;
  if (time_s - *last_time_s < options.min_interval_s) return false;
  const msgs::Pose2 d = se2::Between(last_T_odom_body, T_odom_body);
  return se2::Translation(d) > options.min_translation_m ||
         std::abs(d.yaw_rad) > options.min_rotation_rad;
}

void PoseHistory::Add(const msgs::DeadReckoning& dr) {
  if (!samples_.empty() && dr.time_s <= samples_.back().time_s) return;
  samples_.push_back(dr);
}

std::optional<msgs::Pose2> PoseHistory::PoseAt(double time_s) const {
  if (samples_.empty() || time_s < samples_.front().time_s || time_s > samples_.back().time_s) {
    return std::nullopt;
  }
  auto it = std::lower_bound(samples_.begin(), samples_.end(), time_s,
                             [](const msgs::DeadReckoning& s, double t) { return s.time_s < t; });
  if (it->time_s == time_s) return it->T_odom_body;
  const auto& b = *it;
  const auto& a = *(it - 1);
  const double f = (time_s - a.time_s) / (b.time_s - a.time_s);
  return se2::Interpolate(a.T_odom_body, b.T_odom_body, f);
}

double PoseHistory::DepthAt(double time_s) const {
  if (samples_.empty()) return 0.0;
  auto it = std::lower_bound(samples_.begin(), samples_.end(), time_s,
                             [](const msgs::DeadReckoning& s, double t) { return s.time_s < t; });
  return it == samples_.end() ? samples_.back().depth_m : it->depth_m;
}

msgs::Covariance3 PoseHistory::IncrementCovariance(double a_s, double b_s) const {
  msgs::Covariance3 cov{};
  for (std::size_t i = 1; i < samples_.size(); ++i) {
    const double t0 = samples_[i - 1].time_s, t1 = samples_[i].time_s;
    if (t1 <= a_s || t0 >= b_s) continue;
    const double f = (std::min(t1, b_s) - std::max(t0, a_s)) / (t1 - t0);
    msgs::Covariance3 q = samples_[i].covariance_prev_body;
    for (double& v : q) v *= f;
    cov = se2::ComposeCovariance(cov, samples_[i].T_prev_body, q);
  }
  return cov;
}

void PoseHistory::DropBefore(double time_s) {
  while (samples_.size() >= 2 && samples_[1].time_s <= time_s) samples_.pop_front();
}

KeyframeGate::Verdict KeyframeGate::Decide(double time_s) {
  if (history_.empty()) return Verdict::kUndecided;
  if (time_s < history_.earliest_time_s()) return Verdict::kSkip;
  if (time_s > history_.latest_time_s()) return Verdict::kUndecided;
  const msgs::Pose2 pose = *history_.PoseAt(time_s);
  if (!IsKeyframe(options_, last_time_s_, last_T_odom_body_, time_s, pose)) return Verdict::kSkip;
  last_time_s_ = time_s;
  last_T_odom_body_ = pose;
  history_.DropBefore(time_s);
  return Verdict::kKeyframe;
}

std::vector<msgs::Keyframe> KeyframeSelector::Poll() {
  std::vector<msgs::Keyframe> out;
  while (!pending_.empty() && !history_.empty()) {
    const msgs::SonarFeatures& f = pending_.front();
    if (f.time_s < history_.earliest_time_s()) {
      ++dropped_;
      pending_.pop_front();
      continue;
    }
    if (f.time_s > history_.latest_time_s()) break;
    const msgs::Pose2 pose = *history_.PoseAt(f.time_s);
    const std::optional<double> last_time =
        last_ ? std::optional<double>(last_->time_s) : std::nullopt;
    if (IsKeyframe(options_, last_time, last_ ? last_->T_odom_body : msgs::Pose2{}, f.time_s,
                   pose)) {
      msgs::Keyframe kf;
      kf.index = last_ ? last_->index + 1 : 0;
      kf.time_s = f.time_s;
      kf.T_odom_body = pose;
      kf.depth_m = history_.DepthAt(f.time_s);
      kf.odom_heading_rad = odom_heading_rad_;
      kf.points_body.reserve(f.points_sensor.size());
      for (const msgs::Point2& p : f.points_sensor) {
        kf.points_body.push_back(se2::Apply(T_body_sensor_, p));
      }
      if (last_) {
        kf.T_prevkf_kf = se2::Between(last_->T_odom_body, pose);
        kf.covariance_prevkf_kf = history_.IncrementCovariance(last_->time_s, f.time_s);
      }
      last_ = msgs::Keyframe{kf.index, kf.time_s, kf.T_odom_body, kf.depth_m, {}, {}, {}};
      history_.DropBefore(f.time_s);
      out.push_back(std::move(kf));
    }
    pending_.pop_front();
  }
  return out;
}

}  // namespace draco::navigation
