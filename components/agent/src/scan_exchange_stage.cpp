// Stage 3, the scan exchange (stages.hpp): serving the own scans a teammate asked for, and
// registering the teammate's scans into inter-robot loop candidates.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "draco/agent/stages.hpp"
#include "stage_util.hpp"

namespace draco::agent {

using namespace stage_util;  // NOLINT(google-build-using-namespace): private helpers

ScanExchangeStage::ScanExchangeStage(const ScanExchangeStageOptions& options)
    : options_(options), poses_(options.max_teammate_keyframes) {}

void ScanExchangeStage::Forget(int robot) {
  roster_.Erase(robot);
  mates_.erase(robot);
  poses_.Forget(robot);
  for (auto it = keys_.begin(); it != keys_.end();) {
    it = std::get<0>(*it) == robot ? keys_.erase(it) : std::next(it);
  }
  loops_seen_until_ = 0;  // the next OnLoops takes every candidate again
}

ScanExchangeStage::Teammate* ScanExchangeStage::Mate(const msgs::FleetHeader& header) {
  if (!roster_.Note(options_.robot_id, header, [this](int r) { Forget(r); })) return nullptr;
  return &mates_[header.robot_id];
}

void ScanExchangeStage::OnKeyframePoses(const msgs::KeyframePoses& poses) {
  if (!Mate(poses.header)) return;
  poses_.OnKeyframePoses(poses);
}

void ScanExchangeStage::OnScanRequest(const msgs::ScanRequest& request) {
  if (request.target_robot != options_.robot_id) return;
  Teammate* mate = Mate(request.header);
  if (!mate) return;
  mate->requests_in.push_back(request);
  const std::size_t kMaxQueued = 16;  // a flooding teammate cannot grow the queue
  while (mate->requests_in.size() > kMaxQueued) mate->requests_in.pop_front();
}

void ScanExchangeStage::OnScanReply(const msgs::ScanReply& reply) {
  if (reply.requester_robot != options_.robot_id) return;
  Teammate* mate = Mate(reply.header);
  if (!mate) return;
  if (reply.keyframe < 0 || reply.keyframe >= options_.max_teammate_keyframes ||
      !Finite(reply.T_map_kf)) {
    ++mate->ignored;
    return;
  }
  ++mate->scans_received;
  for (std::size_t i = 0; i < mate->scans.size(); ++i) {
    if (mate->scans[i].keyframe == reply.keyframe) {  // a resend: the newer replaces it
      mate->scans.erase(mate->scans.begin() + static_cast<long>(i));
      mate->scan_registered.erase(mate->scan_registered.begin() + static_cast<long>(i));
      break;
    }
  }
  mate->scans.push_back(reply);
  mate->scan_registered.push_back(false);
  const auto max_scans = static_cast<std::size_t>(std::max(0, options_.max_teammate_scans));
  while (mate->scans.size() > max_scans) {
    mate->scans.pop_front();
    mate->scan_registered.pop_front();
  }
}

void ScanExchangeStage::OnLoops(const std::vector<msgs::InterRobotLoop>& loops) {
  // The filter numbers its candidates in the order it takes them and sends every one each
  // step: a candidate below the highest id seen is already in keys_.
  std::uint64_t until = loops_seen_until_;
  for (const auto& l : loops) {
    if (l.id < loops_seen_until_) continue;
    keys_.insert({l.teammate_robot, l.own_keyframe, l.teammate_keyframe});
    until = std::max(until, l.id + 1);
  }
  loops_seen_until_ = until;
}

void ScanExchangeStage::RebuildOwnScans() {
  if (scans_version_ == own_.version()) return;
  own_scans_.clear();
  own_info_.clear();
  own_scan_position_.clear();
  for (const auto& [index, kf] : own_.entries()) {
    if (!kf.has_pose || !kf.has_points) continue;
    own_scan_position_[index] = static_cast<int>(own_scans_.size());
    own_scans_.push_back({index, kf.time_s, kf.T_map_kf, kf.points_kf});
    own_info_.push_back({index, kf.T_map_kf, static_cast<int>(kf.points_kf.size())});
  }
  scans_version_ = own_.version();
}

namespace {

// Calls visit(entry, T_kf_j) for keyframe `index` (identity) and then its nearest neighbours
// (up to submap_keyframes each side, nearer first) while fewer than min_points were visited.
template <typename Entries, typename Visit>
void VisitSubmap(const Entries& entries, int index, int submap_keyframes, int min_points,
                 Visit&& visit) {
  const auto self = entries.find(index);
  int points = static_cast<int>(self->second.points_kf.size());
  visit(self->second, Pose2{});
  const Pose2 T_kf_map = reg::Inverse(self->second.T_map_kf);
  for (int d = 1; d <= submap_keyframes && points < min_points; ++d) {
    for (const int j : {index - d, index + d}) {
      const auto it = entries.find(j);
      if (it == entries.end() || !it->second.has_pose || !it->second.has_points) continue;
      points += static_cast<int>(it->second.points_kf.size());
      visit(it->second, reg::Compose(T_kf_map, it->second.T_map_kf));
    }
  }
}

}  // namespace

// The keyframe's points, with those of its nearest neighbours (up to serve_submap_keyframes
// each side, nearer first) moved into its frame until it holds selection.min_points.
std::vector<msgs::Point2> ScanExchangeStage::Submap(int index) const {
  std::vector<msgs::Point2> out;
  VisitSubmap(own_.entries(), index, options_.serve_submap_keyframes, options_.selection.min_points,
              [&](const auto& kf, const Pose2& T_kf_j) {
                for (const auto& q : kf.points_kf) out.push_back(reg::Apply(T_kf_j, q));
              });
  return out;
}

// own_info_ with each keyframe's point count as Submap would serve it (counted, not built).
const std::vector<reg::KeyframeInfo>& ScanExchangeStage::ServedInfo() {
  if (served_version_ == own_.version()) return served_info_;
  served_info_ = own_info_;
  for (auto& kf : served_info_) {
    kf.num_points = 0;
    VisitSubmap(own_.entries(), kf.index, options_.serve_submap_keyframes,
                options_.selection.min_points, [&](const auto& e, const Pose2&) {
                  kf.num_points += static_cast<int>(e.points_kf.size());
                });
  }
  served_version_ = own_.version();
  return served_info_;
}

// Serving: replies for the own keyframes that observed the named objects.
void ScanExchangeStage::Serve(double now_s, const msgs::ObjectMap& own_objects, Output* out) {
  for (auto& [robot, mate] : mates_) {
    while (!mate.requests_in.empty()) {
      const msgs::ScanRequest req = std::move(mate.requests_in.front());
      mate.requests_in.pop_front();
      const int max_scans = std::min(req.max_scans, options_.max_scans_per_request);
      if (max_scans <= 0 || own_info_.empty()) continue;
      // SelectScanRequests with the own map on both sides: named objects as the pairs,
      // identity transform (every keyframe is its own candidate). It orders by named objects
      // observed (most first), then newest first, skips min_points and `exclude`.
      msgs::ObjectMatch m;
      m.status = msgs::MatchStatus::kMatched;
      for (const auto id : req.object_ids) m.pairs.push_back({id, id, 0.0});
      reg::SelectionOptions s = options_.selection;
      s.max_requests = max_scans;
      s.max_candidates_per_request = 1;
      s.candidate_radius_m = 1.0;
      s.candidate_max_yaw_rad = 1.0;
      const std::vector<int> exclude(mate.sent_to.begin(), mate.sent_to.end());
      const auto& info = options_.serve_submap_keyframes > 0 ? ServedInfo() : own_info_;
      const auto picks =
          reg::SelectScanRequests(own_objects, own_objects, m, info, info, s, exclude);
      for (const auto& p : picks) {
        const auto it = own_.entries().find(p.teammate_keyframe);
        if (it == own_.entries().end() || !it->second.has_pose || !it->second.has_points) {
          continue;
        }
        mate.sent_to.insert(p.teammate_keyframe);
        msgs::ScanReply reply;
        reply.header.robot_id = options_.robot_id;
        reply.header.time_s = now_s;
        reply.requester_robot = robot;
        reply.keyframe = p.teammate_keyframe;
        reply.keyframe_time_s = it->second.time_s;
        reply.T_map_kf = it->second.T_map_kf;
        reply.points_kf = options_.serve_submap_keyframes > 0 ? Submap(p.teammate_keyframe)
                                                              : it->second.points_kf;
        out->replies.push_back(std::move(reply));
      }
    }
  }
}

// Own keyframes near the teammate keyframe placed by T_own_teammate (the selection's
// candidate rule: radius, heading, nearest first).
std::vector<int> ScanExchangeStage::Candidates(const msgs::ObjectMap& own_objects,
                                               const Pose2& T_own_teammate,
                                               const msgs::ScanReply& scan) const {
  msgs::ObjectMap fake;
  fake.objects.resize(1);
  fake.objects[0].keyframes = {scan.keyframe};
  msgs::ObjectMatch m;
  m.status = msgs::MatchStatus::kMatched;
  m.T_a_b = T_own_teammate;
  m.pairs = {{0, 0, 0.0}};
  reg::SelectionOptions s = options_.selection;
  s.max_requests = 1;
  s.min_points = 0;
  const std::vector<reg::KeyframeInfo> team{
      {scan.keyframe, scan.T_map_kf, static_cast<int>(scan.points_kf.size())}};
  const auto r = reg::SelectScanRequests(own_objects, fake, m, own_info_, team, s);
  return r.empty() ? std::vector<int>{} : r.front().candidates;
}

void ScanExchangeStage::Log(double now_s, int window, bool configured,
                            const reg::RegistrationResult& r) {
  if (attempts_.size() >= options_.max_logged) return;
  RegistrationAttempt a;
  a.time_s = now_s;
  a.window = window;
  a.configured = configured;
  a.status = r.status;
  a.loop = r.loop;
  attempts_.push_back(a);
}

ScanExchangeStage::Output ScanExchangeStage::Step(double now_s, const msgs::ObjectMap& own_objects,
                                                  const msgs::MapMatches& matches,
                                                  msgs::TeamStepStats* st) {
  WallTimer wall(st);
  Output out;
  RebuildOwnScans();
  Serve(now_s, own_objects, &out);
  // Registration of the scans received since the last step.
  for (auto& [robot, mate] : mates_) {
    const auto g = matches.guesses.find(robot);
    std::optional<Pose2> guess;  // the own match, else a chained one (not the reverse guess)
    if (g != matches.guesses.end()) {
      if (g->second.matched) {
        guess = g->second.match.T_a_b;
      } else if (g->second.chained) {
        guess = g->second.T_own_teammate_chained;
      }
    }
    // With both maps' absolute headings known, the compass already tells a registration from
    // its turned alternatives: the ambiguity test probes only the turns the headings allow,
    // and a registration whose map-to-map rotation the headings exclude is refused.
    msgs::ObjectMap mate_heading;
    if (g != matches.guesses.end())
      mate_heading.map_heading_rad = g->second.teammate_map_heading_rad;
    const std::optional<double> yaw_prior =
        options_.max_heading_gap_rad > 0.0 ? objects::HeadingYawPrior(own_objects, mate_heading)
                                           : std::nullopt;
    reg::RegistrationOptions registration = options_.registration;
    if (yaw_prior && guess && options_.headings_prune_turns) {
      std::vector<double> turns;
      for (const double t : registration.ambiguity_turns_deg) {
        if (objects::HeadingAllows(yaw_prior, guess->yaw_rad + t * M_PI / 180.0,
                                   options_.max_heading_gap_rad)) {
          turns.push_back(t);
        }
      }
      registration.ambiguity_turns_deg = turns;
    }
    for (std::size_t i = 0; i < mate.scans.size(); ++i) {
      if (mate.scan_registered[i]) continue;
      const msgs::ScanReply& scan = mate.scans[i];
      if (!poses_.Known(robot, scan.keyframe)) {
        // The teammate never shared this keyframe's pose: not usable in its graph.
        ++mate.ignored;
        mate.scan_registered[i] = true;
        continue;
      }
      if (!guess) continue;  // held until a match seeds it
      mate.scan_registered[i] = true;
      ++st->scans_registered;
      for (const int own_index : Candidates(own_objects, *guess, scan)) {
        const auto pos = own_scan_position_.find(own_index);
        if (pos == own_scan_position_.end()) continue;
        const int k = pos->second;
        if (keys_.count({robot, own_index, scan.keyframe})) continue;
        const Pose2 seed =
            reg::SeedPose(own_scans_[static_cast<std::size_t>(k)].T_map_kf, *guess, scan.T_map_kf);
        auto r = reg::RegisterScan(own_scans_, k, scan.points_kf, seed, registration,
                                   options_.robot_id, robot, scan.keyframe);
        if (r.accepted() && yaw_prior) {
          const double map_yaw = own_scans_[static_cast<std::size_t>(k)].T_map_kf.yaw_rad +
                                 r.loop.T_ownkf_teammatekf.yaw_rad - scan.T_map_kf.yaw_rad;
          if (!objects::HeadingAllows(yaw_prior, map_yaw, options_.max_heading_gap_rad)) {
            r.status = reg::RegistrationStatus::kHeadingMismatch;
          }
        }
        Log(now_s, options_.registration.window, true, r);
        for (const int w : options_.log_windows) {
          if (w == options_.registration.window || w < 0) continue;
          auto o = options_.registration;
          o.window = w;
          Log(now_s, w, false,
              reg::RegisterScan(own_scans_, k, scan.points_kf, seed, o, options_.robot_id, robot,
                                scan.keyframe));
        }
        if (!r.accepted() || !Finite(r.loop.T_ownkf_teammatekf) ||
            !PositiveDefinite(r.loop.covariance)) {
          continue;
        }
        msgs::InterRobotLoop loop = r.loop;
        loop.id = 0;
        loop.flags = 0;
        keys_.insert({robot, own_index, scan.keyframe});
        out.candidates.push_back(loop);
      }
    }
    // Registered scans stay held (bounded) so a request never asks for them again.
  }
  return out;
}

}  // namespace draco::agent
