// Stage 5, the two-step pose graph optimisation (stages.hpp): placing each teammate from the
// accepted loops (with the map check), then the team graph.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "draco/agent/stages.hpp"
#include "stage_util.hpp"

namespace draco::agent {

using namespace stage_util;  // NOLINT(google-build-using-namespace): private helpers

OptimizerStage::OptimizerStage(const OptimizerStageOptions& options)
    : options_(options), poses_(options.max_teammate_keyframes), last_optimize_s_(kNever) {
  options_.two_step.solver.num_threads = 1;  // bit-identical solves
  if (options_.mutual_placement_max_gap_m > 0.0 && options_.place_chained_teammates) {
    throw std::invalid_argument(
        "team.TwoStepOptimizer: mutual_placement_max_gap_m > 0 and place_chained_teammates "
        "cannot be combined (shared transforms then include placements not yet confirmed)");
  }
}

void OptimizerStage::OnKeyframePoses(const msgs::KeyframePoses& poses) {
  if (!roster_.Note(options_.robot_id, poses.header, [this](int r) { Forget(r); })) return;
  poses_.OnKeyframePoses(poses);
  graph_changed_[poses.header.robot_id] = true;
  ++poses_seq_[poses.header.robot_id];
}

void OptimizerStage::OnTeammateTransforms(const msgs::TeammateTransforms& t) {
  const int sender = t.header.robot_id;
  if (sender == options_.robot_id) return;
  if (!roster_.Note(options_.robot_id, t.header, [this](int r) { Forget(r); })) return;
  std::vector<msgs::Heartbeat::Transform> kept;
  for (const auto& e : t.transforms) {
    if (e.robot_id != sender && Finite(e.T_sender_robot)) kept.push_back(e);
  }
  auto& held = shared_[sender];
  if (held == kept) return;
  for (const auto& e : held) graph_changed_[e.robot_id] = true;
  for (const auto& e : kept) graph_changed_[e.robot_id] = true;
  held = std::move(kept);
}

void OptimizerStage::OnTeammateObjectMap(const msgs::FleetHeader& header,
                                         const msgs::ObjectMap& map) {
  if (header.robot_id == options_.robot_id) return;
  if (!roster_.Note(options_.robot_id, header, [this](int r) { Forget(r); })) return;
  teammate_objects_[header.robot_id] = {header.time_s, map};
}

std::vector<msgs::Heartbeat::Transform> OptimizerStage::SharedTransforms() const {
  std::vector<msgs::Heartbeat::Transform> out;
  for (const int robot : loop_verified_) {
    const auto it = estimate_.T_own_teammate.find(robot);
    if (it != estimate_.T_own_teammate.end()) {
      out.push_back({robot, it->second});
    } else if (const auto u = unconfirmed_.find(robot); u != unconfirmed_.end()) {
      out.push_back({robot, u->second});  // waiting for mutual placement
    } else if (const auto w = settling_.find(robot); w != settling_.end()) {
      out.push_back({robot, w->second.T_own_teammate});  // waiting for it to settle
    }
  }
  return out;
}

void OptimizerStage::Forget(int robot) {
  if (robot == options_.robot_id) return;
  shared_.erase(robot);
  roster_.Erase(robot);
  poses_.Forget(robot);
  graph_changed_.erase(robot);
  match_counts_.erase(robot);
  teammate_objects_.erase(robot);
  poses_seq_.erase(robot);
  mate_coverage_.erase(robot);
  estimate_.trajectories.erase(robot);
  estimate_.T_own_teammate.erase(robot);
  warm_.erase(robot);
  settling_.erase(robot);
  placements_.erase(robot);
  own_graph_changed_ = true;  // the estimate is recomputed without it
}

bool OptimizerStage::WarmStillHolds(
    const team::TeamProblem& problem,
    const std::set<std::pair<int, std::uint64_t>>& loop_keys) const {
  if (warm_.empty()) return false;
  if (!std::includes(loop_keys.begin(), loop_keys.end(), warm_loops_.begin(), warm_loops_.end()))
    return false;  // a loop the last solution stood on is gone
  for (const auto& [robot, before] : warm_guesses_) {
    if (!warm_.count(robot)) continue;
    const auto now = problem.maps.find({options_.robot_id, robot});
    const auto graph = problem.robots.find(robot);
    if (now == problem.maps.end() || graph == problem.robots.end()) return false;
    msgs::Point2 c{0.0, 0.0};  // the teammate's keyframe centroid: where a gap shows
    for (const auto& p : graph->second.poses) {
      c.x_m += p.x_m / static_cast<double>(graph->second.poses.size());
      c.y_m += p.y_m / static_cast<double>(graph->second.poses.size());
    }
    const auto [m, rad] = TransformGap(FromPg(now->second), before, c);
    if (m > options_.warm_reset_guess_m || rad > options_.warm_reset_guess_rad) return false;
  }
  return true;
}

bool OptimizerStage::Contested(int robot,
                               const std::vector<msgs::InterRobotLoop>& candidates) const {
  const OptimizerStageOptions& o = options_;
  if (o.competitor_ratio <= 0.0) return false;
  const auto* held = poses_.Find(robot);
  if (!held) return false;
  // The map-to-map transform each candidate with `robot` implies.
  struct Implied {
    const msgs::InterRobotLoop* loop;
    Pose2 T;
  };
  std::vector<Implied> accepted, others;
  for (const auto& l : candidates) {
    if (l.teammate_robot != robot) continue;
    const auto own = own_.entries().find(l.own_keyframe);
    if (own == own_.entries().end() || !own->second.has_pose) continue;
    if (l.teammate_keyframe < 0 ||
        l.teammate_keyframe >= static_cast<int>(held->keyframes.size()) ||
        !held->known[static_cast<std::size_t>(l.teammate_keyframe)])
      continue;
    const Pose2 T = reg::Compose(
        reg::Compose(own->second.T_map_kf, l.T_ownkf_teammatekf),
        reg::Inverse(held->keyframes[static_cast<std::size_t>(l.teammate_keyframe)].T_map_kf));
    (l.flags & msgs::kLoopAccepted ? accepted : others).push_back({&l, T});
  }
  if (accepted.empty()) return false;
  // The teammate's keyframe centroid: where a transform error shows.
  msgs::Point2 c{0.0, 0.0};
  int n = 0;
  for (std::size_t k = 0; k < held->keyframes.size(); ++k) {
    if (!held->known[k]) continue;
    c.x_m += held->keyframes[k].T_map_kf.x_m;
    c.y_m += held->keyframes[k].T_map_kf.y_m;
    ++n;
  }
  if (n > 0) {
    c.x_m /= n;
    c.y_m /= n;
  }
  const auto far_from_accepted = [&](const Pose2& T) {
    for (const auto& a : accepted) {
      const auto [m, rad] = TransformGap(T, a.T, c);
      if (m <= o.competitor_distinct_m && rad <= o.competitor_distinct_rad) return false;
    }
    return true;
  };
  std::vector<const Implied*> rivals;
  for (const auto& x : others) {
    if (far_from_accepted(x.T)) rivals.push_back(&x);
  }
  std::vector<const msgs::InterRobotLoop*> acc;
  for (const auto& a : accepted) acc.push_back(a.loop);
  const int support = DistinctKeyframes(acc);
  const double needed = std::max<double>(o.min_distinct_keyframes, o.competitor_ratio * support);
  // Each rival as the seed of a group of the rivals that agree with it.
  for (const auto* seed : rivals) {
    std::vector<const msgs::InterRobotLoop*> group;
    for (const auto* x : rivals) {
      const auto [m, rad] = TransformGap(x->T, seed->T, c);
      if (m <= o.competitor_agree_m && rad <= o.competitor_agree_rad) group.push_back(x->loop);
    }
    if (DistinctKeyframes(group) >= needed) return true;
  }
  return false;
}

namespace {

// The rigid fit of a teammate's known keyframe poses (its map frame) to `poses`, the estimate's;
// *moved (optional): those poses of `poses`.
std::optional<Pose2> RigidPlacement(const TeammatePoses::Held& held,
                                    const std::vector<Pose2>& poses,
                                    std::vector<Pose2>* moved = nullptr) {
  std::vector<Pose2> local, placed;
  for (std::size_t k = 0; k < poses.size() && k < held.keyframes.size(); ++k) {
    if (!held.known[k]) continue;
    local.push_back(held.keyframes[k].T_map_kf);
    placed.push_back(poses[k]);
  }
  const auto T = AlignSe2(local, placed);
  if (moved != nullptr) *moved = std::move(placed);
  return T;
}

}  // namespace

void OptimizerStage::TurnTowardHeadings(int robot, const team::TeamProblem& problem,
                                        std::vector<Pose2>* poses) const {
  const auto map = teammate_objects_.find(robot);
  const auto* held = poses_.Find(robot);
  if (map == teammate_objects_.end() || held == nullptr) return;
  const auto prior = objects::HeadingYawPrior(own_objects_, map->second.map);
  if (!prior) return;
  const double fraction = HeadingTurnFraction(robot, problem);
  if (!(fraction > 0.0)) return;
  const auto T = RigidPlacement(*held, *poses);
  if (!T) return;
  // The centroid of the teammate's keyframes that loops tie to own ones, where it is placed.
  double cx = 0.0, cy = 0.0;
  int n = 0;
  for (const auto& l : problem.loops) {
    if (l.teammate_robot != robot || l.teammate_keyframe < 0 ||
        l.teammate_keyframe >= static_cast<int>(poses->size()))
      continue;
    cx += (*poses)[static_cast<std::size_t>(l.teammate_keyframe)].x_m;
    cy += (*poses)[static_cast<std::size_t>(l.teammate_keyframe)].y_m;
    ++n;
  }
  if (n == 0) return;
  cx /= n;
  cy /= n;
  const double turn = fraction * std::remainder(*prior - T->yaw_rad, 2.0 * M_PI);
  const double c = std::cos(turn), sn = std::sin(turn);
  for (auto& p : *poses) {
    const double dx = p.x_m - cx, dy = p.y_m - cy;
    p = {cx + c * dx - sn * dy, cy + sn * dx + c * dy,
         std::remainder(p.yaw_rad + turn, 2.0 * M_PI)};
  }
}

void OptimizerStage::RefineOnObjects(int robot, std::vector<Pose2>* poses) const {
  if (options_.refine_min_pairs <= 0) return;
  const auto map = teammate_objects_.find(robot);
  const auto* held = poses_.Find(robot);
  if (map == teammate_objects_.end() || held == nullptr) return;
  std::vector<Pose2> moved;
  const auto T = RigidPlacement(*held, *poses, &moved);
  if (!T) return;
  objects::RefineOptions ro;
  ro.gate_m = options_.refine_gate_m;
  ro.max_length_m = options_.refine_max_length_m;
  ro.min_pairs = options_.refine_min_pairs;
  ro.rotate = options_.refine_rotation;
  int pairs = 0;
  const auto refined = objects::RefineUnderTransform(own_objects_, map->second.map, *T, ro, &pairs);
  if (!refined) return;
  // The move: refined * inv(T), applied to every pose the estimate holds for the teammate;
  // with refine_blend_pairs, the fraction pairs / (pairs + refine_blend_pairs) of it (turned
  // and shifted about the teammate's keyframe centroid).
  Pose2 delta = reg::Compose(*refined, reg::Inverse(*T));
  if (options_.refine_blend_pairs > 0.0) {
    const double a = pairs / (pairs + options_.refine_blend_pairs);
    double cx = 0.0, cy = 0.0;
    for (const auto& p : moved) {
      cx += p.x_m;
      cy += p.y_m;
    }
    cx /= static_cast<double>(moved.size());
    cy /= static_cast<double>(moved.size());
    const auto to = reg::Apply(delta, msgs::Point2{cx, cy});
    const double yaw = a * std::remainder(delta.yaw_rad, 2.0 * M_PI);
    const double c = std::cos(yaw), sn = std::sin(yaw);
    // Turn about (cx, cy) by yaw, then shift by a (to - c).
    delta = {cx - (c * cx - sn * cy) + a * (to.x_m - cx),
             cy - (sn * cx + c * cy) + a * (to.y_m - cy), yaw};
  }
  double sum_m2 = 0.0;
  for (const auto& p : moved) {
    const auto q = reg::Apply(delta, msgs::Point2{p.x_m, p.y_m});
    sum_m2 += (q.x_m - p.x_m) * (q.x_m - p.x_m) + (q.y_m - p.y_m) * (q.y_m - p.y_m);
  }
  if (std::sqrt(sum_m2 / static_cast<double>(moved.size())) > options_.refine_max_move_m) return;
  for (auto& p : *poses) p = reg::Compose(delta, p);
}

double OptimizerStage::HeadingTurnFraction(int robot, const team::TeamProblem& problem) const {
  if (options_.placement_heading_weight > 0.0) return options_.placement_heading_weight;
  const double ratio = options_.placement_heading_variance_ratio;
  if (!(ratio > 0.0) || poses_.Find(robot) == nullptr) return 0.0;
  std::vector<std::pair<int, int>> keyframes;
  for (const auto& l : problem.loops) {
    if (l.teammate_robot == robot) keyframes.emplace_back(l.own_keyframe, l.teammate_keyframe);
  }
  const double u = Unspanned(robot, keyframes);
  return u / (u + ratio);
}

double OptimizerStage::Unspanned(int robot,
                                 const std::vector<std::pair<int, int>>& own_mate_keyframes) const {
  const auto* held = poses_.Find(robot);
  // Time spans: [lo, hi] of the keyframes the loops name, [first, last] of all so far.
  struct Span {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    void Add(double t) {
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
    double Length() const { return hi > lo ? hi - lo : 0.0; }
  };
  Span own_all, own_loops, mate_all, mate_loops;
  for (const auto& [k, e] : own_.entries()) own_all.Add(e.time_s);
  if (held != nullptr) {
    for (std::size_t k = 0; k < held->keyframes.size(); ++k) {
      if (held->known[k]) mate_all.Add(held->keyframes[k].time_s);
    }
  }
  for (const auto& [own_kf, mate_kf] : own_mate_keyframes) {
    const auto own = own_.entries().find(own_kf);
    if (own != own_.entries().end()) own_loops.Add(own->second.time_s);
    if (held != nullptr && mate_kf >= 0 && mate_kf < static_cast<int>(held->known.size()) &&
        held->known[static_cast<std::size_t>(mate_kf)]) {
      mate_loops.Add(held->keyframes[static_cast<std::size_t>(mate_kf)].time_s);
    }
  }
  const auto unspanned = [](const Span& loops, const Span& all) {
    return all.Length() > 0.0 ? 1.0 - std::min(1.0, loops.Length() / all.Length()) : 1.0;
  };
  return unspanned(own_loops, own_all) + unspanned(mate_loops, mate_all);
}

double OptimizerStage::MutualGap(int robot, const Pose2& T_own_mate,
                                 const std::vector<Pose2>& own_poses,
                                 const std::vector<bool>& own_real) const {
  const auto held = shared_.find(robot);
  if (held == shared_.end()) return std::numeric_limits<double>::infinity();
  const auto e = std::find_if(held->second.begin(), held->second.end(),
                              [&](const auto& t) { return t.robot_id == options_.robot_id; });
  if (e == held->second.end()) return std::numeric_limits<double>::infinity();
  const Pose2 T_loop = reg::Compose(T_own_mate, e->T_sender_robot);  // identity if they agree
  double sum_m2 = 0.0;
  int n = 0;
  for (std::size_t k = 0; k < own_poses.size() && k < own_real.size(); ++k) {
    if (!own_real[k]) continue;
    const msgs::Point2 p{own_poses[k].x_m, own_poses[k].y_m};
    const msgs::Point2 q = reg::Apply(T_loop, p);
    sum_m2 += (q.x_m - p.x_m) * (q.x_m - p.x_m) + (q.y_m - p.y_m) * (q.y_m - p.y_m);
    ++n;
  }
  return n > 0 ? std::sqrt(sum_m2 / n) : std::numeric_limits<double>::infinity();
}

bool OptimizerStage::Settled(int robot, double now_s, const Pose2& T_own_mate) {
  auto& history = placements_[robot];
  const auto same = [](const Pose2& a, const Pose2& b) {
    return a.x_m == b.x_m && a.y_m == b.y_m && a.yaw_rad == b.yaw_rad;
  };
  if (history.empty() || !same(history.back().second, T_own_mate))
    history.emplace_back(now_s, T_own_mate);  // an unchanged placement keeps its time
  // Keep one placement at or before now - settle_s, the anchor, and every one after it.
  while (history.size() >= 2 && history[1].first <= now_s - options_.settle_s) history.pop_front();
  if (history.front().first > now_s - options_.settle_s) return false;  // not held so long
  const auto* held = poses_.Find(robot);
  if (held == nullptr) return false;
  for (const auto& [t_s, T] : history) {
    double sum_m2 = 0.0;
    int n = 0;
    for (std::size_t k = 0; k < held->keyframes.size(); ++k) {
      if (!held->known[k]) continue;
      const msgs::Point2 p{held->keyframes[k].T_map_kf.x_m, held->keyframes[k].T_map_kf.y_m};
      const msgs::Point2 a = reg::Apply(T, p);
      const msgs::Point2 b = reg::Apply(T_own_mate, p);
      sum_m2 += (a.x_m - b.x_m) * (a.x_m - b.x_m) + (a.y_m - b.y_m) * (a.y_m - b.y_m);
      ++n;
    }
    if (n == 0 || std::sqrt(sum_m2 / n) > options_.settle_max_move_m) return false;
  }
  return true;
}

void OptimizerStage::PlaceSettled(double now_s, const std::vector<Pose2>& own_poses,
                                  const std::vector<bool>& own_real) {
  for (auto it = settling_.begin(); it != settling_.end();) {
    const int robot = it->first;
    if (!loop_verified_.count(robot) || !Settled(robot, now_s, it->second.T_own_teammate)) {
      ++it;
      continue;
    }
    if (options_.mutual_placement_max_gap_m > 0.0 &&
        MutualGap(robot, it->second.T_own_teammate, own_poses, own_real) >
            options_.mutual_placement_max_gap_m) {
      unconfirmed_[robot] = it->second.T_own_teammate;
      estimate_.held[robot] = "mutual";
    } else {
      estimate_.T_own_teammate[robot] = it->second.T_own_teammate;
      estimate_.trajectories[robot] = std::move(it->second.trajectory);
      estimate_.held.erase(robot);
    }
    it = settling_.erase(it);
  }
}

double OptimizerStage::RotationLever(int robot,
                                     const std::vector<msgs::InterRobotLoop>& candidates) const {
  const auto* held = poses_.Find(robot);
  if (held == nullptr) return 0.0;
  const auto known = [&](int k) {
    return k >= 0 && k < static_cast<int>(held->known.size()) &&
           held->known[static_cast<std::size_t>(k)];
  };
  // The centroid of the teammate keyframes the accepted loops name (in the teammate's map).
  std::vector<std::pair<int, int>> keyframes;
  double cx = 0.0, cy = 0.0;
  int n = 0;
  for (const auto& l : candidates) {
    if (!(l.flags & msgs::kLoopAccepted) || l.teammate_robot != robot) continue;
    keyframes.emplace_back(l.own_keyframe, l.teammate_keyframe);
    if (!known(l.teammate_keyframe)) continue;
    const auto& T = held->keyframes[static_cast<std::size_t>(l.teammate_keyframe)].T_map_kf;
    cx += T.x_m;
    cy += T.y_m;
    ++n;
  }
  if (n == 0) return 0.0;
  cx /= n;
  cy /= n;
  double sum_m2 = 0.0;
  int m = 0;
  for (std::size_t k = 0; k < held->keyframes.size(); ++k) {
    if (!held->known[k]) continue;
    const auto& T = held->keyframes[k].T_map_kf;
    sum_m2 += (T.x_m - cx) * (T.x_m - cx) + (T.y_m - cy) * (T.y_m - cy);
    ++m;
  }
  const double lever_m = std::sqrt(sum_m2 / m);
  const double u = Unspanned(robot, keyframes);
  const double ratio = options_.placement_heading_variance_ratio;
  const auto map = teammate_objects_.find(robot);
  const bool headings = options_.placement_heading_weight <= 0.0 && ratio > 0.0 &&
                        map != teammate_objects_.end() &&
                        objects::HeadingYawPrior(own_objects_, map->second.map).has_value();
  return lever_m * std::sqrt(headings ? u * ratio / (u + ratio) : u);
}

std::optional<MapCheck> OptimizerStage::CheckMaps(
    int robot, const std::vector<msgs::InterRobotLoop>& candidates,
    const OwnSonar& own_view) const {
  const auto map = teammate_objects_.find(robot);
  const auto* held = poses_.Find(robot);
  if (map == teammate_objects_.end() || map->second.map.objects.empty() ||
      own_objects_.objects.empty() || held == nullptr) {
    return std::nullopt;
  }
  // T_own_teammate from the accepted loops: the teammate's keyframes (its map frame) against
  // where the loops put them from the own keyframes.
  std::vector<Pose2> local, placed;
  for (const auto& l : candidates) {
    if (!(l.flags & msgs::kLoopAccepted) || l.teammate_robot != robot) continue;
    const auto own = own_.entries().find(l.own_keyframe);
    if (own == own_.entries().end() || !own->second.has_pose || l.teammate_keyframe < 0 ||
        l.teammate_keyframe >= static_cast<int>(held->keyframes.size()) ||
        !held->known[static_cast<std::size_t>(l.teammate_keyframe)]) {
      continue;
    }
    local.push_back(held->keyframes[static_cast<std::size_t>(l.teammate_keyframe)].T_map_kf);
    placed.push_back(reg::Compose(own->second.T_map_kf, l.T_ownkf_teammatekf));
  }
  const auto T = AlignSe2(local, placed);
  if (!T) return std::nullopt;
  MapCheck out;
  out.T_own_teammate = *T;
  if (const auto prior = objects::HeadingYawPrior(own_objects_, map->second.map)) {
    out.heading_gap_rad = std::remainder(T->yaw_rad - *prior, 2.0 * M_PI);
    if (!objects::HeadingAllows(prior, T->yaw_rad, options_.max_heading_gap_rad)) {
      out.contradicted = true;
      return out;
    }
  }
  if (options_.max_map_miss_fraction >= 1.0) return out;
  auto& cached = mate_coverage_[robot];
  const auto seq = poses_seq_.find(robot);
  const std::uint64_t poses_seq = seq == poses_seq_.end() ? 0 : seq->second;
  if (cached.poses_seq != poses_seq || cached.map_time_s != map->second.time_s) {
    std::vector<Pose2> mate_poses;
    for (std::size_t k = 0; k < held->keyframes.size(); ++k) {
      // The keyframes the teammate's map was made from (not those it has seen since).
      if (held->known[k] && held->keyframes[k].time_s <= map->second.time_s)
        mate_poses.push_back(held->keyframes[k].T_map_kf);
    }
    cached = {poses_seq, map->second.time_s, objects::Coverage(mate_poses, options_.map_coverage)};
  }
  const objects::Coverage& mate_coverage = cached.coverage;
  out.agreement = objects::CompareObjectMaps(own_objects_, map->second.map, *T, own_view.coverage,
                                             mate_coverage, options_.map_margin_m);
  out.support = objects::SupportByPoints(map->second.map, *T, own_view.points, own_view.coverage,
                                         options_.map_margin_m, options_.map_min_points);
  out.contradicted = out.support.Misses() >= options_.min_map_misses &&
                     out.support.MissFraction() > options_.max_map_miss_fraction;
  return out;
}

void OptimizerStage::Step(double now_s, const std::vector<msgs::InterRobotLoop>& candidates,
                          const msgs::MapMatches& matches, msgs::TeamStepStats* st) {
  WallTimer wall(st);
  const int own_id = options_.robot_id;
  if (own_.version() != seen_own_version_) {
    own_graph_changed_ = true;
    seen_own_version_ = own_.version();
  }
  // Teammates heard of by any stage (a new one changes the graphs), new matches.
  for (const auto& [robot, g] : matches.guesses) {
    if (robot == own_id) continue;
    if (!graph_changed_.count(robot)) graph_changed_[robot] = true;
    auto& count = match_counts_[robot];
    if (g.matched && g.match_count != count) {
      count = g.match_count;
      graph_changed_[robot] = true;
    }
  }
  std::vector<std::uint64_t> accepted;  // ids, ascending
  for (const auto& l : candidates) {
    if (l.flags & msgs::kLoopAccepted) accepted.push_back(l.id);
  }
  if (!std::is_sorted(accepted.begin(), accepted.end()))
    std::sort(accepted.begin(), accepted.end());
  if (accepted != accepted_ids_) accepted_changed_ = true;
  accepted_ids_ = std::move(accepted);
  // Teammates with enough independent accepted loops (options: min_teammate_loops).
  std::set<int> loop_verified;
  {
    struct Evidence {
      int loops = 0;
      std::vector<int> own_kfs, mate_kfs;  // one entry per loop
    };
    std::map<int, Evidence> evidence;
    for (const auto& l : candidates) {
      if (!(l.flags & msgs::kLoopAccepted) || l.teammate_robot == own_id) continue;
      auto& e = evidence[l.teammate_robot];
      ++e.loops;
      e.own_kfs.push_back(l.own_keyframe);
      e.mate_kfs.push_back(l.teammate_keyframe);
    }
    estimate_.map_checks.clear();
    estimate_.rotation_lever_m.clear();
    estimate_.held.clear();
    for (const auto& [robot, e] : evidence) {
      auto& held = estimate_.held[robot];
      if (e.loops < options_.min_teammate_loops) {
        held = "loops";
        continue;
      }
      if (CountDistinct(e.own_kfs) < options_.min_distinct_keyframes ||
          CountDistinct(e.mate_kfs) < options_.min_distinct_keyframes) {
        held = "keyframes";
        continue;
      }
      if (Contested(robot, candidates)) {
        held = "rival";
        continue;
      }
      if (options_.max_map_miss_fraction < 1.0 || options_.max_heading_gap_rad > 0.0) {
        if (const auto check =
                CheckMaps(robot, candidates, own_view_.Update(own_, options_.map_coverage))) {
          estimate_.map_checks[robot] = *check;
          if (check->contradicted) {
            held = "map";
            continue;
          }
        }
      }
      const double lever_m = RotationLever(robot, candidates);
      estimate_.rotation_lever_m[robot] = lever_m;
      if (options_.max_rotation_lever_m > 0.0 && lever_m > options_.max_rotation_lever_m) {
        held = "lever";
        continue;
      }
      // Still waiting for mutual placement (a step that does not solve keeps it so).
      if (unconfirmed_.count(robot)) {
        held = "mutual";
      } else if (settling_.count(robot)) {
        held = "settling";
      } else {
        estimate_.held.erase(robot);
      }
      loop_verified.insert(robot);
    }
  }
  const auto direct = [&](int robot) -> std::optional<Pose2> {
    const Pose2* g = msgs::GuessOf(matches, robot);
    return g ? std::optional<Pose2>(*g) : std::nullopt;
  };
  // Robots without accepted loops of their own, placed through a teammate that has them and
  // shared its estimate (the lowest sender id wins).
  std::map<int, Pose2> chained;
  for (const auto& [sender, entries] : shared_) {
    if (!loop_verified.count(sender)) continue;
    const auto it = estimate_.T_own_teammate.find(sender);
    const auto g =
        it != estimate_.T_own_teammate.end() ? std::optional<Pose2>(it->second) : direct(sender);
    if (!g) continue;
    for (const auto& e : entries) {
      if (e.robot_id == own_id || loop_verified.count(e.robot_id) || chained.count(e.robot_id))
        continue;
      const Pose2 T = reg::Compose(*g, e.T_sender_robot);
      const auto map = teammate_objects_.find(e.robot_id);
      if (map != teammate_objects_.end() &&
          !objects::HeadingAllows(objects::HeadingYawPrior(own_objects_, map->second.map),
                                  T.yaw_rad, options_.max_heading_gap_rad))
        continue;
      chained[e.robot_id] = T;
    }
  }
  const auto guess = [&](int robot) -> std::optional<Pose2> {
    const auto it = chained.find(robot);
    return it != chained.end() ? std::optional<Pose2>(it->second) : direct(robot);
  };
  // A teammate verified or withdrawn (the filter retracted its loops) is placed anew now.
  bool graphs_changed = own_graph_changed_ || loop_verified != loop_verified_;
  if (loop_verified != loop_verified_) accepted_changed_ = true;
  loop_verified_ = loop_verified;

  for (const auto& [robot, changed] : graph_changed_) graphs_changed = graphs_changed || changed;
  std::vector<Pose2> own_poses;
  std::vector<bool> own_real;
  std::vector<double> own_times;
  own_.Chain(&own_poses, &own_real, &own_times);
  if (own_poses.empty()) return;

  team::TeamProblem problem;
  // The teammates the problem holds: those with keyframes and a map-to-map guess.
  std::set<int> in_problem;
  for (const auto& [robot, held] : poses_.all()) {
    if (!held.keyframes.empty() && guess(robot)) in_problem.insert(robot);
  }
  std::map<std::pair<int, int>, int> loops_at;  // {teammate, keyframe} -> loops in the PGO
  for (const auto& l : candidates) {
    if (!(l.flags & msgs::kLoopAccepted) || !loop_verified.count(l.teammate_robot)) continue;
    if (!in_problem.count(l.teammate_robot)) continue;
    if (l.own_keyframe < 0 || l.own_keyframe >= static_cast<int>(own_poses.size()) ||
        !own_real[static_cast<std::size_t>(l.own_keyframe)] ||
        !poses_.Known(l.teammate_robot, l.teammate_keyframe)) {
      continue;
    }
    int& at = loops_at[{l.teammate_robot, l.teammate_keyframe}];
    if (options_.max_loops_per_teammate_keyframe > 0 &&
        at >= options_.max_loops_per_teammate_keyframe) {
      continue;
    }
    ++at;
    auto loop = l;
    loop.flags = 0;
    problem.loops.push_back(loop);
  }

  const bool have_loops = !problem.loops.empty();
  const bool due = now_s - last_optimize_s_ >= options_.optimize_period_s;
  const bool pgo = have_loops && due && (accepted_changed_ || graphs_changed);
  if (!pgo) {
    const bool stands = have_loops && optimized_once_;  // the last PGO stands until the next one
    if (stands || (!graphs_changed && !estimate_.trajectories.empty())) {  // nothing new
      PlaceSettled(now_s, own_poses, own_real);
      return;
    }
  }
  // The robots' graphs, only for a step that solves or places (the others return above).
  team::RobotGraph own_graph;
  const pg::Matrix3 own_chain_info =
      Information(options_.own_chain_sigma_xy_m, options_.own_chain_sigma_yaw_rad);
  for (std::size_t k = 0; k < own_poses.size(); ++k) {
    own_graph.poses.push_back(ToPg(own_poses[k]));
    if (k > 0) {
      team::ChainFactor f;
      f.from = static_cast<int>(k - 1);
      f.to = static_cast<int>(k);
      f.T_from_to = ToPg(reg::Between(own_poses[k - 1], own_poses[k]));
      f.information = own_chain_info;
      own_graph.factors.push_back(f);
    }
  }
  problem.robots[own_id] = std::move(own_graph);
  const pg::Matrix3 chain_info =
      Information(options_.two_step.chain_sigma_xy_m, options_.two_step.chain_sigma_yaw_rad);
  for (const auto& [robot, held] : poses_.all()) {
    if (!in_problem.count(robot)) continue;
    const auto g = guess(robot);
    team::RobotGraph rg;
    for (std::size_t k = 0; k < held.keyframes.size(); ++k) {
      rg.poses.push_back(ToPg(held.keyframes[k].T_map_kf));
      if (k > 0) {
        team::ChainFactor f;
        f.from = static_cast<int>(k - 1);
        f.to = static_cast<int>(k);
        f.T_from_to =
            ToPg(reg::Between(held.keyframes[k - 1].T_map_kf, held.keyframes[k].T_map_kf));
        f.information = chain_info;
        rg.factors.push_back(f);
      }
    }
    problem.robots[robot] = std::move(rg);
    problem.maps[{own_id, robot}] = ToPg(*g);
  }
  std::map<int, std::vector<Pose2>> placed;
  bool solved = false;
  if (pgo) {
    std::set<std::pair<int, std::uint64_t>> loop_keys;
    for (const auto& l : problem.loops) loop_keys.insert({l.own_robot, l.id});
    if (options_.warm_start && WarmStillHolds(problem, loop_keys)) {
      for (const auto& [robot, w] : warm_) {
        if (problem.robots.count(robot)) problem.warm[robot] = w;
      }
    }
    try {
      const auto e = team::TwoStepPgo(problem, own_id, options_.two_step);
      for (const auto& [robot, poses] : e.trajectories) {
        auto& v = placed[robot];
        for (const auto& p : poses) v.push_back(FromPg(p));
      }
      solved = true;
      warm_.clear();
      warm_loops_ = std::move(loop_keys);
      warm_guesses_.clear();
      for (const auto& [ab, T] : problem.maps) {
        if (ab.first == own_id) warm_guesses_[ab.second] = FromPg(T);
      }
      if (options_.warm_start) {
        std::set<int> with_loops{own_id};
        for (const auto& l : problem.loops) {
          with_loops.insert(l.own_robot);
          with_loops.insert(l.teammate_robot);
        }
        for (const int robot : with_loops) {
          const auto t = e.trajectories.find(robot);
          const auto r = problem.robots.find(robot);
          if (t == e.trajectories.end() || r == problem.robots.end()) continue;
          const auto l = e.local_teammate_poses.find(robot);
          warm_[robot] = {
              r->second.poses, t->second,
              l != e.local_teammate_poses.end() ? l->second : std::map<int, pg::Pose2>{}};
        }
      }
    } catch (const std::exception&) {
      placed.clear();  // the guess placement below
      warm_.clear();
    }
    last_optimize_s_ = now_s;
    accepted_changed_ = false;
    st->optimized = solved;
    optimized_once_ = optimized_once_ || solved;
  }
  own_graph_changed_ = false;
  for (auto& [robot, changed] : graph_changed_) changed = false;
  if (!solved) {  // every robot through its map-to-map guess
    placed[own_id] = own_poses;
    for (const auto& [robot, rg] : problem.robots) {
      if (robot == own_id) continue;
      const Pose2 T = FromPg(problem.maps.at({own_id, robot}));
      auto& v = placed[robot];
      for (const auto& p : rg.poses) v.push_back(reg::Compose(T, FromPg(p)));
    }
  }
  if (!options_.place_unverified_teammates) {
    // A teammate enters the estimate once the consistency filter accepted loops with it: a
    // map-to-map guess alone (object-graph matching) can be wrong where structures repeat.
    std::set<int> verified;
    for (const auto& l : problem.loops) verified.insert(l.teammate_robot);
    if (options_.place_chained_teammates) {
      for (const auto& [robot, T] : chained) verified.insert(robot);
    }
    for (auto it = placed.begin(); it != placed.end();) {
      it = it->first != own_id && !verified.count(it->first) ? placed.erase(it) : std::next(it);
    }
  }
  if (solved) {  // each teammate turned by HeadingTurnFraction (0: not at all)
    for (auto& [robot, poses] : placed) {
      if (robot == own_id) continue;
      TurnTowardHeadings(robot, problem, &poses);
      RefineOnObjects(robot, &poses);
    }
  }
  TeamEstimate next;
  next.time_s = now_s;
  next.map_checks = std::move(estimate_.map_checks);
  next.rotation_lever_m = std::move(estimate_.rotation_lever_m);
  next.held = std::move(estimate_.held);
  next.loops_in_pgo = static_cast<int>(problem.loops.size());
  // Trajectories with real keyframes only; map-to-map estimates.
  for (const auto& [robot, poses] : placed) {
    auto& traj = next.trajectories[robot];
    if (robot == own_id) {
      for (std::size_t k = 0; k < poses.size() && k < own_real.size(); ++k) {
        if (own_real[k]) traj.push_back({static_cast<int>(k), own_times[k], poses[k]});
      }
      continue;
    }
    const auto& held = *poses_.Find(robot);
    std::vector<Pose2> local, moved;
    for (std::size_t k = 0; k < poses.size() && k < held.keyframes.size(); ++k) {
      if (!held.known[k]) continue;
      traj.push_back({static_cast<int>(k), held.keyframes[k].time_s, poses[k]});
      local.push_back(held.keyframes[k].T_map_kf);
      moved.push_back(poses[k]);
    }
    const auto g = guess(robot);
    const auto aligned = solved ? AlignSe2(local, moved) : std::nullopt;
    next.T_own_teammate[robot] = aligned ? *aligned : g.value_or(Pose2{});
    if (aligned && options_.rigid_teammate_trajectories) {
      for (std::size_t i = 0; i < traj.size(); ++i)
        traj[i].T_map_kf = reg::Compose(*aligned, local[i]);
    }
  }
  if (options_.settle_s > 0.0) {
    // A loop-verified teammate stays out until its solved placement has held for settle_s (a
    // step that does not solve keeps the holds; a placement never solved is held).
    if (solved) settling_.clear();
    for (const int robot : loop_verified_) {
      const auto it = next.T_own_teammate.find(robot);
      if (it == next.T_own_teammate.end()) continue;
      if (solved ? Settled(robot, now_s, it->second)
                 : !settling_.count(robot) && placements_.count(robot))
        continue;
      if (solved) settling_[robot] = {it->second, next.trajectories[robot]};
      next.held[robot] = "settling";
      next.T_own_teammate.erase(it);
      next.trajectories.erase(robot);
    }
  }
  if (options_.mutual_placement_max_gap_m > 0.0) {
    // A loop-verified teammate stays out until it placed this robot and the two agree.
    unconfirmed_.clear();
    for (const int robot : loop_verified_) {
      const auto it = next.T_own_teammate.find(robot);
      if (it == next.T_own_teammate.end()) continue;
      const double gap_m = MutualGap(robot, it->second, own_poses, own_real);
      if (gap_m <= options_.mutual_placement_max_gap_m) {
        next.held.erase(robot);
        continue;
      }
      unconfirmed_[robot] = it->second;
      next.held[robot] = "mutual";
      next.T_own_teammate.erase(it);
      next.trajectories.erase(robot);
    }
  }
  estimate_ = std::move(next);
}

}  // namespace draco::agent
