// Confirmation of object-graph matches over time (graph_matcher.hpp MatchTracker).
#include <algorithm>
#include <cmath>

#include "draco/objects/geometry.hpp"
#include "draco/objects/graph_matcher.hpp"

namespace draco::objects {
namespace {

using msgs::MatchStatus;

}  // namespace

// Tracks are compared by T_a_b itself (where b's origin lands, and the yaw).
msgs::ObjectMatch MatchTracker::Update(const msgs::ObjectMatch& match) {
  if (match.status != MatchStatus::kMatched) return match;
  Track* track = nullptr;
  for (auto& t : tracks_) {
    const double dx = t.T.x_m - match.T_a_b.x_m, dy = t.T.y_m - match.T_a_b.y_m;
    if (std::sqrt(dx * dx + dy * dy) <= options_.same_m &&
        std::abs(NormalizeAngle(t.T.yaw_rad - match.T_a_b.yaw_rad)) <= options_.same_rad) {
      track = &t;
      break;
    }
  }
  if (!track) {
    tracks_.push_back({match.T_a_b, 0});
    track = &tracks_.back();
  }
  track->T = match.T_a_b;  // follow the newest answer as the maps grow
  ++track->votes;
  int others = 0;
  for (const auto& t : tracks_) {
    if (&t != track) others = std::max(others, t.votes);
  }
  msgs::ObjectMatch out = match;
  if (track->votes < options_.min_votes || track->votes < options_.dominance * others) {
    out.status = MatchStatus::kUnconfirmed;
  }
  return out;
}

}  // namespace draco::objects
