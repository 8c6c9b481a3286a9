// The views the stages share: the own keyframes (OwnKeyframes) and the teammates' keyframe
// poses (TeammatePoses), the own sonar for negative evidence (OwnSonar), stages.hpp.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "draco/agent/stages.hpp"
#include "stage_util.hpp"

namespace draco::agent {

using namespace stage_util;  // NOLINT(google-build-using-namespace): private helpers

void OwnKeyframes::OnKeyframe(const msgs::Keyframe& keyframe) {
  if (keyframe.index < 0) return;
  auto& kf = own_[keyframe.index];
  if (kf.has_points) return;  // a keyframe's points never change
  kf.time_s = keyframe.time_s;
  kf.has_points = true;
  kf.points_kf = keyframe.points_body;
  ++version_;
  if (kf.has_pose) ++poses_version_;
}

void OwnKeyframes::OnTrajectory(const msgs::KeyframeTrajectory& trajectory) {
  if (landmarks_ != trajectory.landmarks) {
    landmarks_ = trajectory.landmarks;
    ++landmarks_version_;
    ++version_;
  }
  for (const auto& p : trajectory.keyframes) {
    if (p.index < 0 || !Finite(p.T_map_kf)) continue;
    auto& kf = own_[p.index];
    if (kf.has_pose && kf.T_map_kf.x_m == p.T_map_kf.x_m && kf.T_map_kf.y_m == p.T_map_kf.y_m &&
        kf.T_map_kf.yaw_rad == p.T_map_kf.yaw_rad) {
      continue;
    }
    kf.has_pose = true;
    kf.T_map_kf = p.T_map_kf;
    if (!kf.has_points) kf.time_s = p.time_s;
    ++version_;
    ++poses_version_;
  }
}

const OwnSonar& OwnSonar::Update(const OwnKeyframes& own, const objects::CoverageOptions& options) {
  if (version == own.version()) return *this;
  std::vector<msgs::Pose2> poses;
  std::vector<msgs::Point2> returns;
  for (const auto& [k, e] : own.entries()) {
    if (!e.has_pose) continue;
    poses.push_back(e.T_map_kf);
    if (!e.has_points) continue;
    for (const auto& p : e.points_kf) returns.push_back(reg::Apply(e.T_map_kf, p));
  }
  version = own.version();
  coverage = objects::Coverage(poses, returns, options);
  points = objects::PointCounts(returns);
  return *this;
}

bool OwnKeyframes::Known(int index) const {
  const auto it = own_.find(index);
  return it != own_.end() && it->second.has_pose;
}

void OwnKeyframes::Chain(std::vector<Pose2>* poses, std::vector<bool>* real,
                         std::vector<double>* times) const {
  poses->clear();
  real->clear();
  if (times) times->clear();
  int last = -1;
  for (const auto& [index, kf] : own_) {
    if (kf.has_pose) last = index;
  }
  if (last < 0) return;
  poses->resize(static_cast<std::size_t>(last) + 1);
  real->assign(poses->size(), false);
  if (times) times->assign(poses->size(), 0.0);
  std::optional<Pose2> first;
  for (const auto& [index, kf] : own_) {
    if (kf.has_pose && index >= 0 && index <= last) {
      (*poses)[static_cast<std::size_t>(index)] = kf.T_map_kf;
      (*real)[static_cast<std::size_t>(index)] = true;
      if (times) (*times)[static_cast<std::size_t>(index)] = kf.time_s;
      if (!first) first = kf.T_map_kf;
    }
  }
  Pose2 prev = first.value_or(Pose2{});
  for (std::size_t i = 0; i < poses->size(); ++i) {
    if ((*real)[i]) {
      prev = (*poses)[i];
    } else {
      (*poses)[i] = prev;
    }
  }
}

void TeammatePoses::OnKeyframePoses(const msgs::KeyframePoses& poses) {
  Held& held = held_[poses.header.robot_id];
  const int max_kf = std::max(0, max_keyframes_);
  if (poses.full) {
    held.keyframes.clear();
    held.known.clear();
  }
  for (const auto& e : poses.poses) {
    if (e.index < 0 || e.index >= max_kf || !Finite(e.T_map_kf)) {
      ++held.ignored;
      continue;
    }
    const auto i = static_cast<std::size_t>(e.index);
    if (i >= held.keyframes.size()) {
      // Gaps (keyframes not heard of yet) hold the previous pose and are not "known".
      const Pose2 fill = held.keyframes.empty() ? e.T_map_kf : held.keyframes.back().T_map_kf;
      while (held.keyframes.size() < i) {
        msgs::KeyframePoseEntry g;
        g.index = static_cast<int>(held.keyframes.size());
        g.T_map_kf = fill;
        held.keyframes.push_back(g);
        held.known.push_back(false);
      }
      held.keyframes.push_back(e);
      held.known.push_back(true);
    } else {
      held.keyframes[i] = e;
      held.known[i] = true;
    }
  }
}

bool TeammatePoses::Known(int robot, int index) const {
  const auto it = held_.find(robot);
  if (it == held_.end() || index < 0) return false;
  const auto& known = it->second.known;
  return static_cast<std::size_t>(index) < known.size() && known[static_cast<std::size_t>(index)];
}

const TeammatePoses::Held* TeammatePoses::Find(int robot) const {
  const auto it = held_.find(robot);
  return it == held_.end() ? nullptr : &it->second;
}

}  // namespace draco::agent
