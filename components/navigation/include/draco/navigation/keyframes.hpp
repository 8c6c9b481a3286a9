// Keyframe selection (Bruce-SLAM defaults: at least 1 s apart and more than 3 m or 30 deg
// of motion) and the pairing of sonar features with dead reckoning at the ping time.
// No runtime dependency.
#pragma once

#include <deque>
#include <optional>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::navigation {

struct KeyframeOptions {
  double min_interval_s = 1.0;
  double min_translation_m = 3.0;
  double min_rotation_rad = 30.0 * 3.14159265358979323846 / 180.0;
};

// True when a frame at (time_s, T_odom_body) should become a keyframe after the last one
// (always true when there is no last keyframe).
bool IsKeyframe(const KeyframeOptions& options, std::optional<double> last_time_s,
                const msgs::Pose2& last_T_odom_body, double time_s, const msgs::Pose2& T_odom_body);

// Dead-reckoning history: pose at any time between samples (linear interpolation) and the
// covariance of the increment between two times (composition of the per-sample increments).
class PoseHistory {
 public:
  void Add(const msgs::DeadReckoning& dr);
  bool empty() const { return samples_.empty(); }
  double latest_time_s() const { return samples_.back().time_s; }
  double earliest_time_s() const { return samples_.front().time_s; }
  // nullopt outside [earliest, latest].
  std::optional<msgs::Pose2> PoseAt(double time_s) const;
  double DepthAt(double time_s) const;
  // Covariance of T_a_b between times a < b: the increments of the samples in (a, b] are
  // composed, the one containing a scaled by the fraction of it after a.
  msgs::Covariance3 IncrementCovariance(double a_s, double b_s) const;
  // Forgets samples older than the one at or before time_s.
  void DropBefore(double time_s);

 private:
  std::deque<msgs::DeadReckoning> samples_;
};

// Which frames (pings) become keyframes, decided before anything is computed from them: the
// rule of KeyframeSelector on the same dead reckoning, so fed the same streams it keeps
// exactly the frames the selector would turn into keyframes. The local-SLAM graph runs CFAR
// on those pings only (3 % of the marina's). Frames are decided in time order.
class KeyframeGate {
 public:
  enum class Verdict { kUndecided, kKeyframe, kSkip };
  explicit KeyframeGate(const KeyframeOptions& options = {}) : options_(options) {}
  void AddDeadReckoning(const msgs::DeadReckoning& dr) { history_.Add(dr); }
  // kUndecided until dead reckoning reaches time_s (ask again when more has arrived); kSkip
  // for a frame before the first dead-reckoning sample, as the selector drops those.
  Verdict Decide(double time_s);

 private:
  KeyframeOptions options_;
  PoseHistory history_;
  std::optional<double> last_time_s_;
  msgs::Pose2 last_T_odom_body_;
};

// Pairs feature clouds with dead reckoning and selects keyframes. Feed dead reckoning and
// features in any interleaving; a feature cloud is decided once dead reckoning reaches
// its time (features older than the first dead-reckoning sample are dropped).
class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeOptions& options = {},
                            const msgs::Pose2& T_body_sensor = {})
      : options_(options), T_body_sensor_(T_body_sensor) {}

  void AddDeadReckoning(const msgs::DeadReckoning& dr) {
    odom_heading_rad_ = dr.odom_heading_rad;
    history_.Add(dr);
  }
  void AddFeatures(const msgs::SonarFeatures& features) { pending_.push_back(features); }
  // Decides every pending cloud that dead reckoning has reached; returns new keyframes.
  std::vector<msgs::Keyframe> Poll();
  int dropped() const { return dropped_; }

 private:
  KeyframeOptions options_;
  msgs::Pose2 T_body_sensor_;
  PoseHistory history_;
  std::deque<msgs::SonarFeatures> pending_;
  std::optional<msgs::Keyframe> last_;
  int dropped_ = 0;
  double odom_heading_rad_ = msgs::kUnknownHeading;
};

}  // namespace draco::navigation
