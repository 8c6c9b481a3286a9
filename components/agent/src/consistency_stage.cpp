// Stage 4, the consistency filter (stages.hpp): GCM (or PCM) over the inter-robot loop
// candidates, incrementally.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include "draco/agent/stages.hpp"
#include "stage_util.hpp"

namespace draco::agent {

using namespace stage_util;  // NOLINT(google-build-using-namespace): private helpers

struct ConsistencyStage::Impl {
  Impl(ConsistencyStage* o, const ConsistencyStageOptions& opt)
      : owner(o), options(opt), poses(opt.max_teammate_keyframes) {
    options.filter.time_budget_ms = 0.0;  // decisions independent of load
    filter = std::make_unique<cons::ConsistencyFilter>(options.filter);
  }

  ConsistencyStage* owner;
  ConsistencyStageOptions options;
  OwnKeyframes own;
  TeammatePoses poses;
  Roster roster;
  msgs::MapMatches matches;  // the latest guesses

  std::vector<msgs::InterRobotLoop> candidates;  // ascending id
  std::set<LoopKey> keys;
  std::set<std::uint64_t> received_ids;  // candidates that came from a teammate
  std::set<std::uint64_t> accepted_ids;
  std::set<std::uint64_t> sent_ids;
  std::map<int, int> held_per_teammate;  // candidates
  // Accepted loops per (teammate, teammate keyframe), after the last decision.
  std::map<std::pair<int, int>, int> accepted_at;
  // Candidates held per (teammate, teammate keyframe).
  std::map<std::pair<int, int>, int> held_at;
  std::uint64_t next_loop_id = 0;
  // The accepted set may have changed since the last Step looked for loops to send (every
  // accepted loop not received is sent in the step it is first accepted).
  bool accepted_changed = false;
  std::unique_ptr<cons::ConsistencyFilter> filter;

  int own_id() const { return options.robot_id; }

  cons::ChainPoseSource BuildPoseSource() const {
    cons::ChainPoseSource source;
    std::vector<Pose2> chain;
    std::vector<bool> real;
    own.Chain(&chain, &real, nullptr);
    const Eigen::Matrix3d own_step = DiagonalCovariance(0.1, 0.01);
    for (const auto& p : chain) source.AddKeyframe(own_id(), p, own_step);
    const Eigen::Matrix3d mate_step =
        DiagonalCovariance(options.chain_sigma_xy_m, options.chain_sigma_yaw_rad);
    std::set<int> robots;
    for (const auto& [robot, held] : poses.all()) robots.insert(robot);
    for (const auto& [robot, g] : matches.guesses) robots.insert(robot);
    for (const int robot : robots) {
      if (const auto* held = poses.Find(robot)) {
        for (const auto& e : held->keyframes) source.AddKeyframe(robot, e.T_map_kf, mate_step);
      }
      if (const Pose2* g = msgs::GuessOf(matches, robot)) {
        cons::UncertainPose m;
        m.pose = *g;
        m.covariance = DiagonalCovariance(options.map_sigma_m, options.map_sigma_rad);
        source.SetMapTransform(own_id(), robot, m);
      }
    }
    return source;
  }

  // Candidate and accepted lists and per-teammate counts.
  void RefreshLoopViews() {
    owner->view_.clear();
    for (auto& [robot, s] : owner->mates_) s.candidates = s.accepted = 0;
    accepted_at.clear();
    for (auto l : candidates) {
      const bool acc = accepted_ids.count(l.id) > 0;
      if (acc) ++accepted_at[{l.teammate_robot, l.teammate_keyframe}];
      l.flags &= ~(msgs::kLoopAccepted | msgs::kLoopRejected);
      l.flags |= acc ? msgs::kLoopAccepted : msgs::kLoopRejected;
      owner->view_.push_back(l);
      const auto t = owner->mates_.find(l.teammate_robot);
      if (t != owner->mates_.end()) {
        ++t->second.candidates;
        t->second.accepted += acc ? 1 : 0;
      }
    }
  }

  void Forget(int robot) {
    roster.Erase(robot);
    owner->mates_.erase(robot);
    poses.Forget(robot);
    matches.guesses.erase(robot);
    // Its candidates leave the filter: rebuild it from the others.
    std::vector<msgs::InterRobotLoop> keep;
    bool had = false;
    for (const auto& l : candidates) {
      if (l.teammate_robot == robot) {
        had = true;
        keys.erase({l.teammate_robot, l.own_keyframe, l.teammate_keyframe});
        received_ids.erase(l.id);
        accepted_ids.erase(l.id);
        sent_ids.erase(l.id);
      } else {
        keep.push_back(l);
      }
    }
    held_per_teammate.erase(robot);
    held_at.erase(held_at.lower_bound({robot, std::numeric_limits<int>::min()}),
                  held_at.upper_bound({robot, std::numeric_limits<int>::max()}));
    if (!had) return;
    candidates = std::move(keep);
    filter = std::make_unique<cons::ConsistencyFilter>(options.filter);
    accepted_ids.clear();
    if (!candidates.empty()) {
      const auto source = BuildPoseSource();
      const auto d = filter->Add(candidates, source);
      accepted_ids.insert(d.accepted.begin(), d.accepted.end());
    }
    accepted_changed = true;
    RefreshLoopViews();
  }

  Teammate* Mate(const msgs::FleetHeader& header) {
    if (!roster.Note(own_id(), header, [this](int r) { Forget(r); })) return nullptr;
    return &owner->mates_[header.robot_id];
  }

  // Loops received from teammates, in the own convention.
  std::vector<msgs::InterRobotLoop> TakeReceivedLoops() {
    std::vector<msgs::InterRobotLoop> out;
    for (auto& [robot, mate] : owner->mates_) {
      for (const auto& in : mate.loops_in) {
        // Theirs: own = teammate, teammate = us. Ours: swapped, inverted.
        if (!own.Known(in.teammate_keyframe) || !poses.Known(robot, in.own_keyframe) ||
            !Finite(in.T_ownkf_teammatekf) || !PositiveDefinite(in.covariance)) {
          ++mate.ignored;
          continue;
        }
        const LoopKey key{robot, in.teammate_keyframe, in.own_keyframe};
        if (keys.count(key)) continue;  // the same pair registered here or received before
        if (mate.loops_taken >= options.max_received_loops_per_teammate) {
          ++mate.ignored;
          continue;
        }
        cons::UncertainPose z;
        z.pose = in.T_ownkf_teammatekf;
        z.covariance = cons::ToMatrix(in.covariance);
        const cons::UncertainPose inv = cons::Inverse(z);
        msgs::InterRobotLoop loop;
        loop.id = next_loop_id++;
        loop.own_robot = own_id();
        loop.own_keyframe = in.teammate_keyframe;
        loop.teammate_robot = robot;
        loop.teammate_keyframe = in.own_keyframe;
        loop.T_ownkf_teammatekf = inv.pose;
        const Eigen::Matrix3d c = 0.5 * (inv.covariance + inv.covariance.transpose());
        loop.covariance = cons::FromMatrix(c);
        loop.overlap = in.overlap;
        loop.flags = 0;
        if (!PositiveDefinite(loop.covariance)) {
          ++mate.ignored;
          continue;
        }
        keys.insert(key);
        received_ids.insert(loop.id);
        ++mate.loops_taken;
        out.push_back(loop);
      }
      mate.loops_in.clear();
    }
    return out;
  }
};

ConsistencyStage::ConsistencyStage(const ConsistencyStageOptions& options)
    : impl_(std::make_unique<Impl>(this, options)) {}
ConsistencyStage::~ConsistencyStage() = default;

void ConsistencyStage::OnTrajectory(const msgs::KeyframeTrajectory& trajectory) {
  impl_->own.OnTrajectory(trajectory);
}

void ConsistencyStage::OnKeyframePoses(const msgs::KeyframePoses& poses) {
  if (!impl_->Mate(poses.header)) return;
  impl_->poses.OnKeyframePoses(poses);
}

void ConsistencyStage::OnLoopClosures(const msgs::LoopClosureMessage& message) {
  if (message.target_robot != impl_->own_id()) return;
  Teammate* mate = impl_->Mate(message.header);
  if (!mate) return;
  for (const auto& l : message.loops) {
    if (l.own_robot != message.header.robot_id || l.teammate_robot != impl_->own_id()) {
      ++mate->ignored;
      continue;
    }
    mate->loops_in.push_back(l);
  }
  const std::size_t kMaxQueued = 4096;
  if (mate->loops_in.size() > kMaxQueued) {
    mate->ignored += static_cast<int>(mate->loops_in.size() - kMaxQueued);
    mate->loops_in.resize(kMaxQueued);
  }
}

void ConsistencyStage::Forget(int robot) {
  if (robot == impl_->own_id()) return;
  impl_->Forget(robot);
}

std::vector<msgs::InterRobotLoop> ConsistencyStage::accepted() const {
  std::vector<msgs::InterRobotLoop> out;
  for (const auto& l : view_) {
    if (l.flags & msgs::kLoopAccepted) out.push_back(l);
  }
  return out;
}

std::vector<msgs::LoopClosureMessage> ConsistencyStage::Step(
    double now_s, std::vector<msgs::InterRobotLoop> fresh, const msgs::MapMatches& matches,
    msgs::TeamStepStats* st) {
  WallTimer wall(st);
  Impl& a = *impl_;
  a.matches = matches;
  for (auto& l : fresh) {
    l.id = a.next_loop_id++;
    a.keys.insert({l.teammate_robot, l.own_keyframe, l.teammate_keyframe});
  }
  auto received = a.TakeReceivedLoops();
  fresh.insert(fresh.end(), received.begin(), received.end());
  // At most max_candidates_per_teammate held per teammate: later ones are dropped (their
  // keys stay, so the same pair is not taken again).
  std::erase_if(fresh, [&](const msgs::InterRobotLoop& l) {
    int& n = a.held_per_teammate[l.teammate_robot];
    if (n < a.options.max_candidates_per_teammate) {
      ++n;
      return false;
    }
    if (const auto m = mates_.find(l.teammate_robot); m != mates_.end()) ++m->second.over_bound;
    return true;
  });
  // Candidates at teammate keyframes that already have max_accepted_per_teammate_keyframe
  // accepted loops add nothing the filter or the PGO uses.
  if (const int k_max = a.options.max_accepted_per_teammate_keyframe; k_max > 0) {
    std::erase_if(fresh, [&](const msgs::InterRobotLoop& l) {
      const auto it = a.accepted_at.find({l.teammate_robot, l.teammate_keyframe});
      if (it == a.accepted_at.end() || it->second < k_max) return false;
      if (const auto m = mates_.find(l.teammate_robot); m != mates_.end()) ++m->second.redundant;
      --a.held_per_teammate[l.teammate_robot];
      return true;
    });
  }
  if (const int k_max = a.options.max_candidates_per_teammate_keyframe; k_max > 0) {
    std::erase_if(fresh, [&](const msgs::InterRobotLoop& l) {
      int& n = a.held_at[{l.teammate_robot, l.teammate_keyframe}];
      if (n < k_max) {
        ++n;
        return false;
      }
      if (const auto m = mates_.find(l.teammate_robot); m != mates_.end()) ++m->second.crowded;
      --a.held_per_teammate[l.teammate_robot];
      return true;
    });
  }
  st->candidates_added = static_cast<int>(fresh.size());
  if (!fresh.empty()) {
    const auto source = a.BuildPoseSource();
    const auto d = a.filter->Add(fresh, source);
    a.candidates.insert(a.candidates.end(), fresh.begin(), fresh.end());
    a.accepted_ids = std::set<std::uint64_t>(d.accepted.begin(), d.accepted.end());
    a.accepted_changed = true;
    a.RefreshLoopViews();
  }
  std::map<int, msgs::LoopClosureMessage> messages;
  // Newly accepted loops that were not received go to their teammates (only when the
  // accepted set may have changed: O(candidates)).
  if (a.accepted_changed) {
    for (const auto& l : a.candidates) {
      if (!a.accepted_ids.count(l.id) || a.received_ids.count(l.id) || a.sent_ids.count(l.id)) {
        continue;
      }
      a.sent_ids.insert(l.id);
      auto& m = messages[l.teammate_robot];
      m.header.robot_id = a.own_id();
      m.header.time_s = now_s;
      m.target_robot = l.teammate_robot;
      auto sent = l;
      sent.flags = msgs::kLoopAccepted;
      m.loops.push_back(sent);
    }
  }
  a.accepted_changed = false;
  std::vector<msgs::LoopClosureMessage> out;
  for (auto& [robot, m] : messages) out.push_back(std::move(m));
  st->loops_accepted = static_cast<int>(a.accepted_ids.size());
  return out;
}

}  // namespace draco::agent
