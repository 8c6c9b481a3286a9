// Stage 2, object-graph matching (stages.hpp): MatchObjectMaps against each teammate's object
// map, and the scan requests for the matched objects.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "draco/agent/stages.hpp"
#include "stage_util.hpp"

namespace draco::agent {

using namespace stage_util;  // NOLINT(google-build-using-namespace): private helpers

GraphMatcherStage::GraphMatcherStage(const GraphMatcherStageOptions& options) : options_(options) {}

void GraphMatcherStage::Forget(int robot) {
  roster_.Erase(robot);
  mates_.erase(robot);
  matches_.guesses.erase(robot);
  shared_.erase(robot);
  // A restarted robot has a new map frame: what others said of the old one is stale.
  for (auto& [sender, held] : shared_) held.erase(robot);
}

void GraphMatcherStage::OnTeammateTransforms(const msgs::TeammateTransforms& t) {
  const int sender = t.header.robot_id;
  if (sender == options_.robot_id) return;
  if (!roster_.Note(options_.robot_id, t.header, [this](int r) { Forget(r); })) return;
  auto& held = shared_[sender];
  std::map<int, Shared> next;
  for (const auto& e : t.transforms) {
    if (e.robot_id == sender || e.robot_id == options_.robot_id || !Finite(e.T_sender_robot))
      continue;
    Shared s{e.T_sender_robot, 1};
    const auto it = held.find(e.robot_id);
    if (it != held.end() && Agree(it->second.T, s.T)) s.agreeing = it->second.agreeing + 1;
    next[e.robot_id] = s;
  }
  held = std::move(next);
}

bool GraphMatcherStage::Agree(const Pose2& a, const Pose2& b) const {
  const Pose2 d = reg::Between(a, b);
  return std::hypot(d.x_m, d.y_m) <= options_.chain_agree_m &&
         std::abs(d.yaw_rad) <= options_.chain_agree_rad;
}

void GraphMatcherStage::OnTeammateObjectMap(const msgs::FleetHeader& header,
                                            const msgs::ObjectMap& map) {
  if (!roster_.Note(options_.robot_id, header, [this](int r) { Forget(r); })) return;
  auto [it, added] = mates_.try_emplace(header.robot_id);
  if (added) it->second.last_try_s = it->second.last_chain_try_s = kNever;
  it->second.objects = map;
  it->second.objects.robot_id = header.robot_id;
  it->second.map_changed = true;
  it->second.map_seq = header.seq;
  matches_.guesses[header.robot_id].robot_id = header.robot_id;
  matches_.guesses[header.robot_id].teammate_map_heading_rad = map.map_heading_rad;
}

void GraphMatcherStage::OnScanRequest(const msgs::ScanRequest& request) {
  if (request.target_robot != options_.robot_id) return;
  if (!roster_.Note(options_.robot_id, request.header, [this](int r) { Forget(r); })) return;
  auto [it, added] = mates_.try_emplace(request.header.robot_id);
  if (added) it->second.last_try_s = it->second.last_chain_try_s = kNever;
  auto& g = matches_.guesses[request.header.robot_id];
  g.robot_id = request.header.robot_id;
  if (Finite(request.T_requester_target)) {
    g.has_reverse = true;
    g.T_own_teammate_reverse = reg::Inverse(request.T_requester_target);
  }
}

std::vector<msgs::ScanRequest> GraphMatcherStage::Step(double now_s, const msgs::ObjectMap& own,
                                                       std::uint64_t own_version,
                                                       msgs::TeamStepStats* st) {
  WallTimer wall(st);
  std::vector<msgs::ScanRequest> out;
  for (auto& [robot, mate] : mates_) {
    const bool changed = mate.map_changed || mate.own_version_at_try != own_version;
    if (!changed || mate.objects.objects.empty() || own.objects.empty()) continue;
    if (now_s - mate.last_try_s < options_.match_period_s) continue;
    mate.last_try_s = now_s;
    mate.map_changed = false;
    mate.own_version_at_try = own_version;
    ++st->matches_tried;
    const bool evidence = options_.matcher.vote_miss_weight > 0.0;
    const OwnSonar* view = evidence ? &own_sonar_.Update(own_, options_.coverage) : nullptr;
    auto match = objects::MatchObjectMaps(own, mate.objects, options_.matcher,
                                          view ? &view->coverage : nullptr, nullptr,
                                          view ? &view->points : nullptr);
    match.robot_a = options_.robot_id;
    match.robot_b = robot;
    attempts_.push_back({now_s, static_cast<int>(own.objects.size()),
                         static_cast<int>(mate.objects.objects.size()), match});
    if (match.status != msgs::MatchStatus::kMatched) continue;
    ++st->matches_found;
    auto& g = matches_.guesses[robot];
    g.robot_id = robot;
    mate.agreeing_matches =
        g.matched && Agree(g.match.T_a_b, match.T_a_b) ? mate.agreeing_matches + 1 : 1;
    g.matched = true;
    g.match = match;
    ++g.match_count;
    // Request the scans of the matched objects, best fitting first.
    std::vector<msgs::ObjectPair> pairs = match.pairs;
    std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) {
      return std::tie(a.residual_m, a.id_b) < std::tie(b.residual_m, b.id_b);
    });
    Request(now_s, robot, mate, match.T_a_b, pairs, &out, st);
  }
  if (options_.chain_shared_transforms) ChainUnmatched(now_s, own, &out, st);
  return out;
}

void GraphMatcherStage::ChainUnmatched(double now_s, const msgs::ObjectMap& own,
                                       std::vector<msgs::ScanRequest>* out,
                                       msgs::TeamStepStats* st) {
  for (auto& [robot, mate] : mates_) {
    auto& g = matches_.guesses[robot];
    g.robot_id = robot;
    if (g.matched) {
      g.chained = false;
      continue;
    }
    // Through the lowest-id matched teammate that shared a verified estimate of `robot`.
    std::optional<Pose2> T;
    int via = -1;
    for (const auto& [sender, entries] : shared_) {
      const auto c = matches_.guesses.find(sender);
      const auto cm = mates_.find(sender);
      if (c == matches_.guesses.end() || !c->second.matched || cm == mates_.end() ||
          cm->second.agreeing_matches < options_.chain_min_agreeing) {
        continue;
      }
      const auto e = entries.find(robot);
      if (e == entries.end() || e->second.agreeing < options_.chain_min_agreeing) continue;
      T = reg::Compose(c->second.match.T_a_b, e->second.T);
      via = sender;
      break;
    }
    if (!T || !objects::HeadingAllows(objects::HeadingYawPrior(own, mate.objects), T->yaw_rad,
                                      options_.matcher.max_heading_gap_rad)) {
      g.chained = false;
      continue;
    }
    g.chained = true;
    g.chained_via = via;
    g.T_own_teammate_chained = *T;
    if (mate.objects.objects.empty() || own.objects.empty()) continue;
    if (now_s - mate.last_chain_try_s < options_.match_period_s) continue;
    mate.last_chain_try_s = now_s;
    Request(now_s, robot, mate, *T,
            objects::PairsUnderTransform(own, mate.objects, *T, options_.chain_pair_margin_m), out,
            st);
  }
}

void GraphMatcherStage::Request(double now_s, int robot, const Teammate& mate,
                                const Pose2& T_own_teammate,
                                const std::vector<msgs::ObjectPair>& pairs,
                                std::vector<msgs::ScanRequest>* out,
                                msgs::TeamStepStats* st) const {
  msgs::ScanRequest req;
  req.header.robot_id = options_.robot_id;
  req.header.time_s = now_s;
  req.target_robot = robot;
  req.object_map_version = mate.map_seq;
  req.T_requester_target = T_own_teammate;
  for (const auto& p : pairs) {
    if (std::find(req.object_ids.begin(), req.object_ids.end(), p.id_b) == req.object_ids.end()) {
      req.object_ids.push_back(p.id_b);
    }
  }
  req.max_scans = options_.max_scans_per_request;
  if (req.object_ids.empty() || req.max_scans <= 0) return;
  out->push_back(std::move(req));
  ++st->requests_sent;
}

}  // namespace draco::agent
