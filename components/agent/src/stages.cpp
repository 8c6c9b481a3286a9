// The five stages of a robot's inter-robot SLAM (stages.hpp, docs/fleet.md). Glue only:
// ObjectMapper, MatchObjectMaps, SelectScanRequests, RegisterScan, ConsistencyFilter and
// TwoStepPgo do the work.
#include "draco/agent/stages.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "draco/consistency/pairwise.hpp"
#include "draco/consistency/se2.hpp"
#include "draco/msgs/rigid_fit.hpp"

namespace draco::agent {
namespace {

using msgs::Point2;
using msgs::Pose2;
namespace reg = registration;
namespace cons = consistency;
namespace pg = pose_graph;

constexpr double kNever = -std::numeric_limits<double>::infinity();

pg::Pose2 ToPg(const Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }
Pose2 FromPg(const pg::Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }

bool Finite(const Pose2& p) {
  return std::isfinite(p.x_m) && std::isfinite(p.y_m) && std::isfinite(p.yaw_rad);
}

bool PositiveDefinite(const msgs::Covariance3& c) {
  for (const double v : c) {
    if (!std::isfinite(v)) return false;
  }
  const Eigen::Matrix3d m = cons::ToMatrix(c);
  if ((m - m.transpose()).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + m.cwiseAbs().maxCoeff())) {
    return false;
  }
  const Eigen::LLT<Eigen::Matrix3d> llt(m);
  return llt.info() == Eigen::Success;
}

Eigen::Matrix3d DiagonalCovariance(double sigma_xy, double sigma_yaw) {
  return Eigen::Vector3d(sigma_xy * sigma_xy, sigma_xy * sigma_xy, sigma_yaw * sigma_yaw)
      .asDiagonal();
}

pg::Matrix3 Information(double sigma_xy, double sigma_yaw) {
  return pg::Diagonal3(1.0 / (sigma_xy * sigma_xy), 1.0 / (sigma_xy * sigma_xy),
                       1.0 / (sigma_yaw * sigma_yaw));
}

// T with placed[i] ~ T * local[i] (least squares over the positions; SE(2) alignment).
std::optional<Pose2> AlignSe2(const std::vector<Pose2>& local, const std::vector<Pose2>& placed) {
  if (std::min(local.size(), placed.size()) < 2) return std::nullopt;
  return msgs::FitRigid2d(local, placed);
}

using LoopKey = std::tuple<int, int, int>;  // teammate, own keyframe, teammate keyframe

class WallTimer {
 public:
  explicit WallTimer(msgs::TeamStepStats* stats)
      : stats_(stats), t0_(std::chrono::steady_clock::now()) {}
  ~WallTimer() {
    if (stats_ == nullptr) return;
    stats_->wall_ms +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0_).count();
  }
  WallTimer(const WallTimer&) = delete;
  WallTimer& operator=(const WallTimer&) = delete;

 private:
  msgs::TeamStepStats* stats_;
  std::chrono::steady_clock::time_point t0_;
};

// Distinct keyframes of each robot named by a set of loops: the smaller of the two counts.
int DistinctKeyframes(const std::vector<const msgs::InterRobotLoop*>& loops) {
  std::set<int> own, mate;
  for (const auto* l : loops) {
    own.insert(l->own_keyframe);
    mate.insert(l->teammate_keyframe);
  }
  return static_cast<int>(std::min(own.size(), mate.size()));
}

// Distance between two map-to-map transforms where it matters: at the point c (teammate map
// frame) they both move, and the yaw difference.
std::pair<double, double> TransformGap(const Pose2& a, const Pose2& b, const msgs::Point2& c) {
  const auto pa = reg::Apply(a, c), pb = reg::Apply(b, c);
  return {std::hypot(pa.x_m - pb.x_m, pa.y_m - pb.y_m),
          std::abs(reg::WrapAngle(a.yaw_rad - b.yaw_rad))};
}

}  // namespace

// ------------------------------------------------------------------------ shared pieces

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

// ------------------------------------------------------------------------ 1. object map

ObjectMapperStage::ObjectMapperStage(const ObjectMapperStageOptions& options)
    : options_(options),
      mapper_(std::make_unique<objects::ObjectMapper>(options.mapper)),
      last_publish_s_(kNever) {
  objects_.robot_id = options.robot_id;
}
ObjectMapperStage::~ObjectMapperStage() = default;

ObjectMapperStage::Output ObjectMapperStage::Step(double now_s, msgs::TeamStepStats* st) {
  WallTimer wall(st);
  if (st != nullptr) st->time_s = now_s;
  Output out;
  if (own_.version() != seen_version_) {
    bool changed = false;
    std::vector<objects::KeyframePose> poses;
    for (const auto& [index, kf] : own_.entries()) {
      if (mapped_.count(index) && kf.has_pose) poses.push_back({index, kf.T_map_kf});
    }
    changed = mapper_->UpdatePoses(poses) || changed;
    for (const auto& [index, kf] : own_.entries()) {
      if (!mapped_.count(index) && kf.has_pose && kf.has_points) {
        mapper_->AddKeyframe(index, kf.T_map_kf, kf.points_kf);
        mapped_.insert(index);
        changed = true;
      }
    }
    // Clusters are re-described only when the mapper changed; landmarks (which move with
    // every solve of the local SLAM) are appended to them.
    if (changed) clusters_ = mapper_->Objects(options_.robot_id, now_s);
    if (changed || own_.landmarks_version() != seen_landmarks_version_) {
      objects_ = clusters_;
      const int last = mapped_.empty() ? -1 : *mapped_.rbegin();
      objects::AppendLandmarks(own_.landmarks(), last, options_.mapper.landmark_min_sightings,
                               &objects_);
      seen_landmarks_version_ = own_.landmarks_version();
      ++version_;
    }
    seen_version_ = own_.version();
  }
  objects_.robot_id = options_.robot_id;
  objects_.map_heading_rad = map_heading_rad_;
  if (now_s - last_publish_s_ >= options_.object_map_period_s && !objects_.objects.empty()) {
    bool same = published_once_ && last_published_.objects.size() == objects_.objects.size();
    for (std::size_t i = 0; same && i < objects_.objects.size(); ++i) {
      const auto& a = objects_.objects[i];
      const auto& b = last_published_.objects[i];
      same = a.id == b.id && a.num_points == b.num_points && a.center.x_m == b.center.x_m &&
             a.center.y_m == b.center.y_m && a.length_m == b.length_m &&
             a.breadth_m == b.breadth_m && a.yaw_rad == b.yaw_rad && a.keyframes == b.keyframes;
    }
    if (!same) {
      out.has_object_map = true;
      out.object_map = objects_;
      out.object_map.time_s = now_s;
      last_published_ = objects_;
      published_once_ = true;
      last_publish_s_ = now_s;
    }
  }
  if (own_.poses_version() != seen_poses_version_) {
    for (const auto& [index, kf] : own_.entries()) {
      if (!kf.has_pose) continue;
      out.poses.push_back({index, kf.time_s, kf.T_map_kf, static_cast<int>(kf.points_kf.size())});
    }
    out.has_poses = !out.poses.empty();
    seen_poses_version_ = own_.poses_version();
  }
  return out;
}

// ------------------------------------------------------------------------ 2. matching

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
    auto match = objects::MatchObjectMaps(own, mate.objects, options_.matcher);
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

// ------------------------------------------------------------------------ 3. scans

ScanExchangeStage::ScanExchangeStage(const ScanExchangeStageOptions& options)
    : options_(options), poses_(options.max_teammate_keyframes) {}

void ScanExchangeStage::Forget(int robot) {
  roster_.Erase(robot);
  mates_.erase(robot);
  poses_.Forget(robot);
  for (auto it = keys_.begin(); it != keys_.end();) {
    it = std::get<0>(*it) == robot ? keys_.erase(it) : std::next(it);
  }
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
  for (const auto& l : loops) keys_.insert({l.teammate_robot, l.own_keyframe, l.teammate_keyframe});
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
      const auto picks =
          reg::SelectScanRequests(own_objects, own_objects, m, own_info_, own_info_, s, exclude);
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
        reply.points_kf = it->second.points_kf;
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

// ------------------------------------------------------------------------ 4. GCM / PCM

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
  std::uint64_t next_loop_id = 0;
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
    for (auto l : candidates) {
      const bool acc = accepted_ids.count(l.id) > 0;
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
    if (!had) return;
    candidates = std::move(keep);
    filter = std::make_unique<cons::ConsistencyFilter>(options.filter);
    accepted_ids.clear();
    if (!candidates.empty()) {
      const auto source = BuildPoseSource();
      const auto d = filter->Add(candidates, source);
      accepted_ids.insert(d.accepted.begin(), d.accepted.end());
    }
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
  st->candidates_added = static_cast<int>(fresh.size());
  if (!fresh.empty()) {
    const auto source = a.BuildPoseSource();
    const auto d = a.filter->Add(fresh, source);
    a.candidates.insert(a.candidates.end(), fresh.begin(), fresh.end());
    a.accepted_ids = std::set<std::uint64_t>(d.accepted.begin(), d.accepted.end());
    a.RefreshLoopViews();
  }
  std::map<int, msgs::LoopClosureMessage> messages;
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
  std::vector<msgs::LoopClosureMessage> out;
  for (auto& [robot, m] : messages) out.push_back(std::move(m));
  st->loops_accepted = static_cast<int>(a.accepted_ids.size());
  return out;
}

// ------------------------------------------------------------------------ 5. two-step PGO

OptimizerStage::OptimizerStage(const OptimizerStageOptions& options)
    : options_(options), poses_(options.max_teammate_keyframes), last_optimize_s_(kNever) {
  options_.two_step.solver.num_threads = 1;  // bit-identical solves
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
    if (it != estimate_.T_own_teammate.end()) out.push_back({robot, it->second});
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
  own_graph_changed_ = true;  // the estimate is recomputed without it
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

const OptimizerStage::OwnView& OptimizerStage::UpdateOwnView() {
  if (own_view_.version == own_.version()) return own_view_;
  std::vector<Pose2> poses;
  std::vector<Point2> points;
  for (const auto& [k, e] : own_.entries()) {
    if (!e.has_pose) continue;
    poses.push_back(e.T_map_kf);
    if (!e.has_points) continue;
    for (const auto& p : e.points_kf) points.push_back(reg::Apply(e.T_map_kf, p));
  }
  own_view_.version = own_.version();
  own_view_.coverage = objects::Coverage(poses, options_.map_coverage);
  own_view_.points = objects::PointCounts(points);
  return own_view_;
}

std::optional<MapCheck> OptimizerStage::CheckMaps(
    int robot, const std::vector<msgs::InterRobotLoop>& candidates, const OwnView& own_view) const {
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
  std::set<std::uint64_t> accepted;
  for (const auto& l : candidates) {
    if (l.flags & msgs::kLoopAccepted) accepted.insert(l.id);
  }
  if (accepted != accepted_ids_) accepted_changed_ = true;
  accepted_ids_ = std::move(accepted);
  // Teammates with enough independent accepted loops (options: min_teammate_loops).
  std::set<int> loop_verified;
  {
    struct Evidence {
      int loops = 0;
      std::set<int> own_kfs, mate_kfs;
    };
    std::map<int, Evidence> evidence;
    for (const auto& l : candidates) {
      if (!(l.flags & msgs::kLoopAccepted) || l.teammate_robot == own_id) continue;
      auto& e = evidence[l.teammate_robot];
      ++e.loops;
      e.own_kfs.insert(l.own_keyframe);
      e.mate_kfs.insert(l.teammate_keyframe);
    }
    estimate_.map_checks.clear();
    for (const auto& [robot, e] : evidence) {
      if (e.loops < options_.min_teammate_loops ||
          static_cast<int>(e.own_kfs.size()) < options_.min_distinct_keyframes ||
          static_cast<int>(e.mate_kfs.size()) < options_.min_distinct_keyframes ||
          Contested(robot, candidates)) {
        continue;
      }
      if (options_.max_map_miss_fraction < 1.0 || options_.max_heading_gap_rad > 0.0) {
        if (const auto check = CheckMaps(robot, candidates, UpdateOwnView())) {
          estimate_.map_checks[robot] = *check;
          if (check->contradicted) continue;
        }
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
    const auto g = guess(robot);
    if (!g || held.keyframes.empty()) continue;
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
  for (const auto& l : candidates) {
    if (!(l.flags & msgs::kLoopAccepted) || !loop_verified.count(l.teammate_robot)) continue;
    const auto r = problem.robots.find(l.teammate_robot);
    if (r == problem.robots.end()) continue;
    if (l.own_keyframe < 0 || l.own_keyframe >= static_cast<int>(own_poses.size()) ||
        !own_real[static_cast<std::size_t>(l.own_keyframe)] ||
        !poses_.Known(l.teammate_robot, l.teammate_keyframe)) {
      continue;
    }
    auto loop = l;
    loop.flags = 0;
    problem.loops.push_back(loop);
  }

  const bool have_loops = !problem.loops.empty();
  const bool due = now_s - last_optimize_s_ >= options_.optimize_period_s;
  const bool pgo = have_loops && due && (accepted_changed_ || graphs_changed);
  if (!pgo) {
    if (have_loops && optimized_once_) return;  // the last PGO stands until the next one
    if (!graphs_changed && !estimate_.trajectories.empty()) return;  // nothing new to place
  }
  std::map<int, std::vector<Pose2>> placed;
  bool solved = false;
  if (pgo) {
    try {
      const auto e = team::TwoStepPgo(problem, own_id, options_.two_step);
      for (const auto& [robot, poses] : e.trajectories) {
        auto& v = placed[robot];
        for (const auto& p : poses) v.push_back(FromPg(p));
      }
      solved = true;
    } catch (const std::exception&) {
      placed.clear();  // the guess placement below
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
  TeamEstimate next;
  next.time_s = now_s;
  next.map_checks = std::move(estimate_.map_checks);
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
  }
  estimate_ = std::move(next);
}

}  // namespace draco::agent
