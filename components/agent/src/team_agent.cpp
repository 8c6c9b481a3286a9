// TeamAgent: the five stages of stages.hpp chained in one object (team_agent.hpp). Glue only.
#include "draco/agent/team_agent.hpp"

#include <set>
#include <utility>

namespace draco::agent {

ObjectMapperStageOptions TeamAgent::MapperOptions(const AgentOptions& o) {
  ObjectMapperStageOptions s;
  s.robot_id = o.robot_id;
  s.mapper = o.mapper;
  s.object_map_period_s = o.object_map_period_s;
  return s;
}

GraphMatcherStageOptions TeamAgent::MatcherOptions(const AgentOptions& o) {
  GraphMatcherStageOptions s;
  s.robot_id = o.robot_id;
  s.matcher = o.matcher;
  s.match_period_s = o.match_period_s;
  s.max_scans_per_request = o.max_scans_per_request;
  return s;
}

ScanExchangeStageOptions TeamAgent::ExchangeOptions(const AgentOptions& o) {
  ScanExchangeStageOptions s;
  s.robot_id = o.robot_id;
  s.selection = o.selection;
  s.registration = o.registration;
  s.max_scans_per_request = o.max_scans_per_request;
  s.max_teammate_keyframes = o.max_teammate_keyframes;
  s.max_teammate_scans = o.max_teammate_scans;
  return s;
}

ConsistencyStageOptions TeamAgent::ConsistencyOptions(const AgentOptions& o) {
  ConsistencyStageOptions s;
  s.robot_id = o.robot_id;
  s.filter = o.filter;
  s.chain_sigma_xy_m = o.two_step.chain_sigma_xy_m;
  s.chain_sigma_yaw_rad = o.two_step.chain_sigma_yaw_rad;
  s.map_sigma_m = o.map_sigma_m;
  s.map_sigma_rad = o.map_sigma_rad;
  s.max_teammate_keyframes = o.max_teammate_keyframes;
  return s;
}

OptimizerStageOptions TeamAgent::OptimizerOptions(const AgentOptions& o) {
  OptimizerStageOptions s;
  s.robot_id = o.robot_id;
  s.two_step = o.two_step;
  s.optimize_period_s = o.optimize_period_s;
  s.place_unverified_teammates = o.place_unverified_teammates;
  s.max_teammate_keyframes = o.max_teammate_keyframes;
  return s;
}

struct TeamAgent::Impl {
  explicit Impl(const AgentOptions& o)
      : options(o),
        mapper(MapperOptions(o)),
        matcher(MatcherOptions(o)),
        exchange(ExchangeOptions(o)),
        consistency(ConsistencyOptions(o)),
        optimizer(OptimizerOptions(o)) {}

  AgentOptions options;
  ObjectMapperStage mapper;
  GraphMatcherStage matcher;
  ScanExchangeStage exchange;
  ConsistencyStage consistency;
  OptimizerStage optimizer;
  Roster roster;  // every teammate heard of, by any message
  std::vector<StepStats> stats;
  AgentEstimate estimate;
  std::map<int, TeammateState> teammates;

  void Forget(int robot) {
    roster.Erase(robot);
    matcher.Forget(robot);
    exchange.Forget(robot);
    consistency.Forget(robot);
    optimizer.Forget(robot);
  }
  // False for the own id; a new incarnation resets every stage first.
  bool Note(const msgs::FleetHeader& header) {
    return roster.Note(options.robot_id, header, [this](int r) { Forget(r); });
  }
};

TeamAgent::TeamAgent(const AgentOptions& options) : impl_(std::make_unique<Impl>(options)) {}
TeamAgent::~TeamAgent() = default;

void TeamAgent::OnKeyframe(const msgs::Keyframe& keyframe) {
  impl_->mapper.OnKeyframe(keyframe);
  impl_->exchange.OnKeyframe(keyframe);
  impl_->optimizer.OnKeyframe(keyframe);
}

void TeamAgent::OnTrajectory(const msgs::KeyframeTrajectory& trajectory) {
  impl_->mapper.OnTrajectory(trajectory);
  impl_->exchange.OnTrajectory(trajectory);
  impl_->consistency.OnTrajectory(trajectory);
  impl_->optimizer.OnTrajectory(trajectory);
}

void TeamAgent::OnTeammateObjectMap(const msgs::FleetHeader& header, const msgs::ObjectMap& map) {
  if (!impl_->Note(header)) return;
  impl_->matcher.OnTeammateObjectMap(header, map);
}

void TeamAgent::OnKeyframePoses(const msgs::KeyframePoses& poses) {
  if (!impl_->Note(poses.header)) return;
  impl_->exchange.OnKeyframePoses(poses);
  impl_->consistency.OnKeyframePoses(poses);
  impl_->optimizer.OnKeyframePoses(poses);
}

void TeamAgent::OnScanRequest(const msgs::ScanRequest& request) {
  if (request.target_robot != impl_->options.robot_id || !impl_->Note(request.header)) return;
  impl_->matcher.OnScanRequest(request);
  impl_->exchange.OnScanRequest(request);
}

void TeamAgent::OnScanReply(const msgs::ScanReply& reply) {
  if (reply.requester_robot != impl_->options.robot_id || !impl_->Note(reply.header)) return;
  impl_->exchange.OnScanReply(reply);
}

std::vector<msgs::Heartbeat::Transform> TeamAgent::SharedTransforms() const {
  return impl_->optimizer.SharedTransforms();
}

void TeamAgent::OnTeammateTransforms(const msgs::TeammateTransforms& transforms) {
  if (!impl_->Note(transforms.header)) return;
  impl_->matcher.OnTeammateTransforms(transforms);
  impl_->optimizer.OnTeammateTransforms(transforms);
}

void TeamAgent::OnLoopClosures(const msgs::LoopClosureMessage& message) {
  if (message.target_robot != impl_->options.robot_id || !impl_->Note(message.header)) return;
  impl_->consistency.OnLoopClosures(message);
}

void TeamAgent::ForgetTeammate(int robot_id) {
  if (robot_id == impl_->options.robot_id) return;
  impl_->Forget(robot_id);
}

Outbox TeamAgent::Step(double now_s) {
  Impl& a = *impl_;
  Outbox out;
  StepStats st;
  auto mapped = a.mapper.Step(now_s, &st);
  out.has_object_map = mapped.has_object_map;
  out.object_map = std::move(mapped.object_map);
  out.poses = std::move(mapped.poses);
  out.requests = a.matcher.Step(now_s, a.mapper.objects(), a.mapper.version(), &st);
  const msgs::MapMatches& matches = a.matcher.matches();
  auto scans = a.exchange.Step(now_s, a.mapper.objects(), matches, &st);
  out.replies = std::move(scans.replies);
  out.loops = a.consistency.Step(now_s, std::move(scans.candidates), matches, &st);
  a.exchange.OnLoops(a.consistency.candidates());
  a.optimizer.Step(now_s, a.consistency.candidates(), matches, &st);
  a.stats.push_back(st);
  return out;
}

const AgentEstimate& TeamAgent::estimate() const {
  AgentEstimate& e = impl_->estimate;
  const TeamEstimate& t = impl_->optimizer.estimate();
  e.time_s = t.time_s;
  e.trajectories = t.trajectories;
  e.T_own_teammate = t.T_own_teammate;
  e.candidates = impl_->consistency.candidates();
  e.accepted = impl_->consistency.accepted();
  return e;
}

const std::vector<StepStats>& TeamAgent::step_stats() const { return impl_->stats; }

const std::map<int, TeammateState>& TeamAgent::teammates() const {
  const Impl& a = *impl_;
  auto& out = impl_->teammates;
  out.clear();
  for (const auto& [robot, incarnation] : a.roster.all()) {
    TeammateState s;
    s.robot_id = robot;
    s.incarnation = incarnation;
    if (const auto m = a.matcher.teammates().find(robot); m != a.matcher.teammates().end()) {
      s.objects = m->second.objects;
    }
    if (const auto g = a.matcher.matches().guesses.find(robot);
        g != a.matcher.matches().guesses.end() && g->second.matched) {
      s.matched = true;
      s.last_match = g->second.match;
    }
    if (const auto* held = a.optimizer.teammate_poses().Find(robot)) {
      s.keyframes = held->keyframes;
      s.ignored += held->ignored;
    }
    if (const auto x = a.exchange.teammates().find(robot); x != a.exchange.teammates().end()) {
      s.scans_received = x->second.scans_received;
      s.ignored += x->second.ignored;
    }
    if (const auto c = a.consistency.teammates().find(robot);
        c != a.consistency.teammates().end()) {
      s.candidates = c->second.candidates;
      s.accepted = c->second.accepted;
      s.ignored += c->second.ignored;
    }
    out[robot] = std::move(s);
  }
  return out;
}

msgs::ObjectMap TeamAgent::OwnObjects() const { return impl_->mapper.objects(); }

const ObjectMapperStage& TeamAgent::mapper() const { return impl_->mapper; }
const GraphMatcherStage& TeamAgent::matcher() const { return impl_->matcher; }
const ScanExchangeStage& TeamAgent::exchange() const { return impl_->exchange; }
const ConsistencyStage& TeamAgent::consistency() const { return impl_->consistency; }
const OptimizerStage& TeamAgent::optimizer() const { return impl_->optimizer; }

}  // namespace draco::agent
