// TeamAgent: the inter-robot front and back end of one robot, step by step (team_agent.hpp,
// docs/fleet.md "The team agent"). Glue only: ObjectMapper, MatchObjectMaps,
// SelectScanRequests, RegisterScan, ConsistencyFilter and TwoStepPgo do the work.
#include "draco/agent/team_agent.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>
#include <optional>
#include <set>
#include <tuple>
#include <utility>

#include "draco/consistency/pairwise.hpp"
#include "draco/consistency/se2.hpp"

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
  const std::size_t n = std::min(local.size(), placed.size());
  if (n < 2) return std::nullopt;
  double lx = 0, ly = 0, px = 0, py = 0;
  for (std::size_t i = 0; i < n; ++i) {
    lx += local[i].x_m, ly += local[i].y_m, px += placed[i].x_m, py += placed[i].y_m;
  }
  lx /= double(n), ly /= double(n), px /= double(n), py /= double(n);
  double sc = 0, ss = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double ax = local[i].x_m - lx, ay = local[i].y_m - ly;
    const double bx = placed[i].x_m - px, by = placed[i].y_m - py;
    sc += ax * bx + ay * by;
    ss += ax * by - ay * bx;
  }
  if (std::abs(sc) + std::abs(ss) < 1e-9) return std::nullopt;  // all at one point
  const double yaw = std::atan2(ss, sc);
  const double c = std::cos(yaw), s = std::sin(yaw);
  return Pose2{px - (c * lx - s * ly), py - (s * lx + c * ly), yaw};
}

using LoopKey = std::tuple<int, int, int>;  // teammate, own keyframe, teammate keyframe

}  // namespace

struct TeamAgent::Impl {
  // ---- own robot
  struct OwnKeyframe {
    double time_s = 0.0;
    bool has_pose = false;
    Pose2 T_map_kf;
    bool has_points = false;
    std::vector<Point2> points_kf;
    bool mapped = false;  // given to the ObjectMapper
  };

  // ---- one teammate, beyond the public TeammateState
  struct Mate {
    std::vector<bool> known;  // keyframes[i] holds a pose the teammate sent
    bool map_changed = false;
    std::uint32_t map_seq = 0;  // header.seq of the object map held
    double last_match_try_s = kNever;
    std::uint64_t own_map_version_at_try = 0;
    bool has_reverse_guess = false;  // from the teammate's scan requests
    Pose2 T_own_teammate_reverse;
    std::deque<msgs::ScanReply> scans;  // held, oldest first
    std::deque<bool> scan_registered;
    std::set<int> sent_to;                       // own keyframes already sent to this teammate
    std::deque<msgs::ScanRequest> requests_in;   // served at the next step
    std::vector<msgs::InterRobotLoop> loops_in;  // received, checked at the next step
    bool graph_changed = true;                   // poses changed since the last PGO
  };

  explicit Impl(const AgentOptions& o) : options(o) {
    options.filter.time_budget_ms = 0.0;      // decisions independent of load
    options.two_step.solver.num_threads = 1;  // bit-identical solves
    mapper = std::make_unique<objects::ObjectMapper>(options.mapper);
    filter = std::make_unique<cons::ConsistencyFilter>(options.filter);
  }

  AgentOptions options;
  int own_id() const { return options.robot_id; }

  std::map<int, OwnKeyframe> own;
  std::unique_ptr<objects::ObjectMapper> mapper;
  bool own_keyframes_dirty = false;  // new keyframes or poses since the last step
  bool own_poses_dirty = false;      // poses to publish
  bool own_graph_changed = true;     // since the last PGO
  std::uint64_t own_map_version = 0;
  msgs::ObjectMap own_objects;
  msgs::ObjectMap last_published;
  bool published_once = false;
  double last_publish_s = kNever;
  double last_step_s = 0.0;

  // Registration targets (own keyframes with pose and points, ascending index).
  std::vector<reg::KeyframeScan> own_scans;
  std::vector<reg::KeyframeInfo> own_info;
  std::map<int, int> own_scan_position;
  bool own_scans_dirty = true;

  std::map<int, TeammateState> teammates;
  std::map<int, Mate> mates;

  // Loops: every candidate held (ascending id), dedup keys, origin, filter.
  std::vector<msgs::InterRobotLoop> candidates;
  std::set<LoopKey> keys;
  std::set<std::uint64_t> received_ids;  // candidates that came from a teammate
  std::set<std::uint64_t> accepted_ids;
  std::set<std::uint64_t> sent_ids;
  std::uint64_t next_loop_id = 0;
  std::unique_ptr<cons::ConsistencyFilter> filter;
  bool accepted_changed = false;  // since the last PGO

  double last_optimize_s = kNever;
  bool optimized_once = false;
  AgentEstimate estimate;
  std::vector<StepStats> stats;

  // ------------------------------------------------------------------ helpers

  // Own poses by position 0..max index (gaps filled with the previous pose), and whether a
  // position is a real keyframe.
  void OwnChain(std::vector<Pose2>* poses, std::vector<bool>* real,
                std::vector<double>* times) const {
    poses->clear();
    real->clear();
    if (times) times->clear();
    int last = -1;
    for (const auto& [index, kf] : own) {
      if (kf.has_pose) last = index;
    }
    if (last < 0) return;
    poses->resize(static_cast<std::size_t>(last) + 1);
    real->assign(poses->size(), false);
    if (times) times->assign(poses->size(), 0.0);
    std::optional<Pose2> first;
    for (const auto& [index, kf] : own) {
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

  bool OwnKeyframeKnown(int index) const {
    const auto it = own.find(index);
    return it != own.end() && it->second.has_pose;
  }

  bool TeammateKeyframeKnown(int robot, int index) const {
    const auto it = mates.find(robot);
    if (it == mates.end() || index < 0) return false;
    const auto& known = it->second.known;
    return static_cast<std::size_t>(index) < known.size() && known[static_cast<std::size_t>(index)];
  }

  // The map-to-map guess: the latest own match, else the inverse of the teammate's.
  std::optional<Pose2> Guess(int robot) const {
    const auto t = teammates.find(robot);
    if (t != teammates.end() && t->second.matched) return t->second.last_match.T_a_b;
    const auto m = mates.find(robot);
    if (m != mates.end() && m->second.has_reverse_guess) return m->second.T_own_teammate_reverse;
    return std::nullopt;
  }

  cons::ChainPoseSource BuildPoseSource() const {
    cons::ChainPoseSource source;
    std::vector<Pose2> poses;
    std::vector<bool> real;
    OwnChain(&poses, &real, nullptr);
    const Eigen::Matrix3d own_step = DiagonalCovariance(0.1, 0.01);
    for (const auto& p : poses) source.AddKeyframe(own_id(), p, own_step);
    const Eigen::Matrix3d mate_step =
        DiagonalCovariance(options.two_step.chain_sigma_xy_m, options.two_step.chain_sigma_yaw_rad);
    for (const auto& [robot, state] : teammates) {
      for (const auto& e : state.keyframes) source.AddKeyframe(robot, e.T_map_kf, mate_step);
      if (const auto g = Guess(robot)) {
        cons::UncertainPose m;
        m.pose = *g;
        m.covariance = DiagonalCovariance(options.map_sigma_m, options.map_sigma_rad);
        source.SetMapTransform(own_id(), robot, m);
      }
    }
    return source;
  }

  void RebuildOwnScans() {
    if (!own_scans_dirty) return;
    own_scans.clear();
    own_info.clear();
    own_scan_position.clear();
    for (const auto& [index, kf] : own) {
      if (!kf.has_pose || !kf.has_points) continue;
      own_scan_position[index] = static_cast<int>(own_scans.size());
      own_scans.push_back({index, kf.time_s, kf.T_map_kf, kf.points_kf});
      own_info.push_back({index, kf.T_map_kf, static_cast<int>(kf.points_kf.size())});
    }
    own_scans_dirty = false;
  }

  // Teammate state for a message from `header`; nullptr for the own id. A new incarnation of
  // a known teammate forgets the old one first.
  std::pair<TeammateState*, Mate*> Teammate(const msgs::FleetHeader& header) {
    if (header.robot_id == own_id()) return {nullptr, nullptr};
    auto it = teammates.find(header.robot_id);
    if (it != teammates.end() && it->second.incarnation != header.incarnation) {
      Forget(header.robot_id);
      it = teammates.end();
    }
    if (it == teammates.end()) {
      TeammateState s;
      s.robot_id = header.robot_id;
      s.incarnation = header.incarnation;
      it = teammates.emplace(header.robot_id, s).first;
      mates[header.robot_id] = Mate{};
    }
    return {&it->second, &mates.at(header.robot_id)};
  }

  void Forget(int robot) {
    teammates.erase(robot);
    mates.erase(robot);
    estimate.trajectories.erase(robot);
    estimate.T_own_teammate.erase(robot);
    own_graph_changed = true;  // the estimate is recomputed without it
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
    accepted_changed = true;
    RefreshLoopViews();
  }

  // Candidate and accepted lists of the estimate and per-teammate counts.
  void RefreshLoopViews() {
    estimate.candidates.clear();
    estimate.accepted.clear();
    for (auto& [robot, s] : teammates) s.candidates = s.accepted = 0;
    for (auto l : candidates) {
      const bool acc = accepted_ids.count(l.id) > 0;
      l.flags &= ~(msgs::kLoopAccepted | msgs::kLoopRejected);
      l.flags |= acc ? msgs::kLoopAccepted : msgs::kLoopRejected;
      estimate.candidates.push_back(l);
      if (acc) estimate.accepted.push_back(l);
      const auto t = teammates.find(l.teammate_robot);
      if (t != teammates.end()) {
        ++t->second.candidates;
        t->second.accepted += acc ? 1 : 0;
      }
    }
  }

  // ------------------------------------------------------------------ step parts

  // 1. Own object map; poses to publish.
  void UpdateOwnMap(double now_s, Outbox* out) {
    if (own_keyframes_dirty) {
      bool changed = false;
      std::vector<objects::KeyframePose> poses;
      for (const auto& [index, kf] : own) {
        if (kf.mapped && kf.has_pose) poses.push_back({index, kf.T_map_kf});
      }
      changed = mapper->UpdatePoses(poses) || changed;
      for (auto& [index, kf] : own) {
        if (!kf.mapped && kf.has_pose && kf.has_points) {
          mapper->AddKeyframe(index, kf.T_map_kf, kf.points_kf);
          kf.mapped = true;
          changed = true;
        }
      }
      if (changed) {
        own_objects = mapper->Objects(own_id(), now_s);
        ++own_map_version;
      }
      own_keyframes_dirty = false;
    }
    own_objects.robot_id = own_id();
    if (now_s - last_publish_s >= options.object_map_period_s && !own_objects.objects.empty()) {
      bool same = published_once && last_published.objects.size() == own_objects.objects.size();
      for (std::size_t i = 0; same && i < own_objects.objects.size(); ++i) {
        const auto& a = own_objects.objects[i];
        const auto& b = last_published.objects[i];
        same = a.id == b.id && a.num_points == b.num_points && a.center.x_m == b.center.x_m &&
               a.center.y_m == b.center.y_m && a.length_m == b.length_m &&
               a.breadth_m == b.breadth_m && a.yaw_rad == b.yaw_rad && a.keyframes == b.keyframes;
      }
      if (!same) {
        out->has_object_map = true;
        out->object_map = own_objects;
        out->object_map.time_s = now_s;
        last_published = own_objects;
        published_once = true;
        last_publish_s = now_s;
      }
    }
    if (own_poses_dirty) {
      for (const auto& [index, kf] : own) {
        if (!kf.has_pose) continue;
        out->poses.push_back(
            {index, kf.time_s, kf.T_map_kf, static_cast<int>(kf.points_kf.size())});
      }
      own_poses_dirty = false;
    }
  }

  // 2. Matching and scan requests.
  void MatchTeammates(double now_s, Outbox* out, StepStats* st) {
    for (auto& [robot, state] : teammates) {
      Mate& mate = mates.at(robot);
      const bool changed = mate.map_changed || mate.own_map_version_at_try != own_map_version;
      if (!changed || state.objects.objects.empty() || own_objects.objects.empty()) continue;
      if (now_s - mate.last_match_try_s < options.match_period_s) continue;
      mate.last_match_try_s = now_s;
      mate.map_changed = false;
      mate.own_map_version_at_try = own_map_version;
      ++st->matches_tried;
      auto match = objects::MatchObjectMaps(own_objects, state.objects, options.matcher);
      match.robot_a = own_id();
      match.robot_b = robot;
      if (match.status != msgs::MatchStatus::kMatched) continue;
      ++st->matches_found;
      state.matched = true;
      state.last_match = match;
      estimate.T_own_teammate[robot] = match.T_a_b;
      mate.graph_changed = true;
      // Request the scans of the matched objects, best fitting first.
      std::vector<msgs::ObjectPair> pairs = match.pairs;
      std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) {
        return std::tie(a.residual_m, a.id_b) < std::tie(b.residual_m, b.id_b);
      });
      msgs::ScanRequest req;
      req.header.robot_id = own_id();
      req.header.time_s = now_s;
      req.target_robot = robot;
      req.object_map_version = mate.map_seq;
      req.T_requester_target = match.T_a_b;
      for (const auto& p : pairs) {
        if (std::find(req.object_ids.begin(), req.object_ids.end(), p.id_b) ==
            req.object_ids.end()) {
          req.object_ids.push_back(p.id_b);
        }
      }
      req.max_scans = options.max_scans_per_request;
      if (req.object_ids.empty() || req.max_scans <= 0) continue;
      out->requests.push_back(std::move(req));
      ++st->requests_sent;
    }
  }

  // Serving: replies for the own keyframes that observed the named objects.
  void ServeRequests(double now_s, Outbox* out) {
    RebuildOwnScans();
    for (auto& [robot, mate] : mates) {
      while (!mate.requests_in.empty()) {
        const msgs::ScanRequest req = std::move(mate.requests_in.front());
        mate.requests_in.pop_front();
        const int max_scans = std::min(req.max_scans, options.max_scans_per_request);
        if (max_scans <= 0 || own_info.empty()) continue;
        // SelectScanRequests with the own map on both sides: named objects as the pairs,
        // identity transform (every keyframe is its own candidate). It orders by named objects
        // observed (most first), then newest first, skips min_points and `exclude`.
        msgs::ObjectMatch m;
        m.status = msgs::MatchStatus::kMatched;
        for (const auto id : req.object_ids) m.pairs.push_back({id, id, 0.0});
        reg::SelectionOptions s = options.selection;
        s.max_requests = max_scans;
        s.max_candidates_per_request = 1;
        s.candidate_radius_m = 1.0;
        s.candidate_max_yaw_rad = 1.0;
        const std::vector<int> exclude(mate.sent_to.begin(), mate.sent_to.end());
        const auto picks =
            reg::SelectScanRequests(own_objects, own_objects, m, own_info, own_info, s, exclude);
        for (const auto& p : picks) {
          const auto it = own.find(p.teammate_keyframe);
          if (it == own.end() || !it->second.has_pose || !it->second.has_points) continue;
          mate.sent_to.insert(p.teammate_keyframe);
          msgs::ScanReply reply;
          reply.header.robot_id = own_id();
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
  std::vector<int> Candidates(const Pose2& T_own_teammate, const msgs::ScanReply& scan) const {
    msgs::ObjectMap fake;
    fake.objects.resize(1);
    fake.objects[0].keyframes = {scan.keyframe};
    msgs::ObjectMatch m;
    m.status = msgs::MatchStatus::kMatched;
    m.T_a_b = T_own_teammate;
    m.pairs = {{0, 0, 0.0}};
    reg::SelectionOptions s = options.selection;
    s.max_requests = 1;
    s.min_points = 0;
    const std::vector<reg::KeyframeInfo> team{
        {scan.keyframe, scan.T_map_kf, static_cast<int>(scan.points_kf.size())}};
    const auto r = reg::SelectScanRequests(own_objects, fake, m, own_info, team, s);
    return r.empty() ? std::vector<int>{} : r.front().candidates;
  }

  // 3. Registration of the scans received since the last step.
  std::vector<msgs::InterRobotLoop> RegisterScans(StepStats* st) {
    std::vector<msgs::InterRobotLoop> out;
    RebuildOwnScans();
    for (auto& [robot, mate] : mates) {
      TeammateState& state = teammates.at(robot);
      const auto guess =
          state.matched ? std::optional<Pose2>(state.last_match.T_a_b) : std::optional<Pose2>();
      for (std::size_t i = 0; i < mate.scans.size(); ++i) {
        if (mate.scan_registered[i]) continue;
        const msgs::ScanReply& scan = mate.scans[i];
        if (!TeammateKeyframeKnown(robot, scan.keyframe)) {
          // The teammate never shared this keyframe's pose: not usable in its graph.
          ++state.ignored;
          mate.scan_registered[i] = true;
          continue;
        }
        if (!guess) continue;  // held until a match seeds it
        mate.scan_registered[i] = true;
        ++st->scans_registered;
        for (const int own_index : Candidates(*guess, scan)) {
          const auto pos = own_scan_position.find(own_index);
          if (pos == own_scan_position.end()) continue;
          const int k = pos->second;
          if (keys.count({robot, own_index, scan.keyframe})) continue;
          const Pose2 seed =
              reg::SeedPose(own_scans[static_cast<std::size_t>(k)].T_map_kf, *guess, scan.T_map_kf);
          const auto r = reg::RegisterScan(own_scans, k, scan.points_kf, seed, options.registration,
                                           own_id(), robot, scan.keyframe);
          if (!r.accepted() || !Finite(r.loop.T_ownkf_teammatekf) ||
              !PositiveDefinite(r.loop.covariance)) {
            continue;
          }
          msgs::InterRobotLoop loop = r.loop;
          loop.id = next_loop_id++;
          loop.flags = 0;
          keys.insert({robot, own_index, scan.keyframe});
          out.push_back(loop);
        }
      }
      // Registered scans stay held (bounded) so a request never asks for them again.
    }
    return out;
  }

  // Loops received from teammates, in the own convention.
  std::vector<msgs::InterRobotLoop> TakeReceivedLoops() {
    std::vector<msgs::InterRobotLoop> out;
    for (auto& [robot, mate] : mates) {
      TeammateState& state = teammates.at(robot);
      for (const auto& in : mate.loops_in) {
        // Theirs: own = teammate, teammate = us. Ours: swapped, inverted.
        if (!OwnKeyframeKnown(in.teammate_keyframe) ||
            !TeammateKeyframeKnown(robot, in.own_keyframe) || !Finite(in.T_ownkf_teammatekf) ||
            !PositiveDefinite(in.covariance)) {
          ++state.ignored;
          continue;
        }
        const LoopKey key{robot, in.teammate_keyframe, in.own_keyframe};
        if (keys.count(key)) continue;  // the same pair registered here or received before
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
          ++state.ignored;
          continue;
        }
        keys.insert(key);
        received_ids.insert(loop.id);
        out.push_back(loop);
      }
      mate.loops_in.clear();
    }
    return out;
  }

  // 4. Consistency filter; accepted own registrations are sent to their teammate.
  void Filter(std::vector<msgs::InterRobotLoop> fresh, double now_s, Outbox* out, StepStats* st) {
    st->candidates_added = static_cast<int>(fresh.size());
    if (!fresh.empty()) {
      const auto source = BuildPoseSource();
      const auto d = filter->Add(fresh, source);
      candidates.insert(candidates.end(), fresh.begin(), fresh.end());
      const std::set<std::uint64_t> now_accepted(d.accepted.begin(), d.accepted.end());
      if (now_accepted != accepted_ids) accepted_changed = true;
      accepted_ids = now_accepted;
      RefreshLoopViews();
    }
    std::map<int, msgs::LoopClosureMessage> messages;
    for (const auto& l : candidates) {
      if (!accepted_ids.count(l.id) || received_ids.count(l.id) || sent_ids.count(l.id)) continue;
      sent_ids.insert(l.id);
      auto& m = messages[l.teammate_robot];
      m.header.robot_id = own_id();
      m.header.time_s = now_s;
      m.target_robot = l.teammate_robot;
      auto sent = l;
      sent.flags = msgs::kLoopAccepted;
      m.loops.push_back(sent);
    }
    for (auto& [robot, m] : messages) out->loops.push_back(std::move(m));
    st->loops_accepted = static_cast<int>(accepted_ids.size());
  }

  // 5. Two-step PGO (or, without accepted loops, the placement by the guesses).
  void Estimate(double now_s, StepStats* st) {
    bool graphs_changed = own_graph_changed;
    for (const auto& [robot, mate] : mates) graphs_changed = graphs_changed || mate.graph_changed;
    std::vector<Pose2> own_poses;
    std::vector<bool> own_real;
    std::vector<double> own_times;
    OwnChain(&own_poses, &own_real, &own_times);
    if (own_poses.empty()) return;

    team::TeamProblem problem;
    team::RobotGraph own_graph;
    const pg::Matrix3 own_chain_info = Information(0.1, 0.01);
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
    problem.robots[own_id()] = std::move(own_graph);
    const pg::Matrix3 chain_info =
        Information(options.two_step.chain_sigma_xy_m, options.two_step.chain_sigma_yaw_rad);
    for (const auto& [robot, state] : teammates) {
      const auto g = Guess(robot);
      if (!g || state.keyframes.empty()) continue;
      team::RobotGraph rg;
      for (std::size_t k = 0; k < state.keyframes.size(); ++k) {
        rg.poses.push_back(ToPg(state.keyframes[k].T_map_kf));
        if (k > 0) {
          team::ChainFactor f;
          f.from = static_cast<int>(k - 1);
          f.to = static_cast<int>(k);
          f.T_from_to =
              ToPg(reg::Between(state.keyframes[k - 1].T_map_kf, state.keyframes[k].T_map_kf));
          f.information = chain_info;
          rg.factors.push_back(f);
        }
      }
      problem.robots[robot] = std::move(rg);
      problem.maps[{own_id(), robot}] = ToPg(*g);
    }
    for (const auto& l : candidates) {
      if (!accepted_ids.count(l.id)) continue;
      const auto r = problem.robots.find(l.teammate_robot);
      if (r == problem.robots.end()) continue;
      if (l.own_keyframe < 0 || l.own_keyframe >= static_cast<int>(own_poses.size()) ||
          !own_real[static_cast<std::size_t>(l.own_keyframe)] ||
          !TeammateKeyframeKnown(l.teammate_robot, l.teammate_keyframe)) {
        continue;
      }
      problem.loops.push_back(l);
    }

    const bool have_loops = !problem.loops.empty();
    const bool due = now_s - last_optimize_s >= options.optimize_period_s;
    const bool pgo = have_loops && due && (accepted_changed || graphs_changed);
    if (!pgo) {
      if (have_loops && optimized_once) return;  // the last PGO stands until the next one
      if (!graphs_changed && !estimate.trajectories.empty()) return;  // nothing new to place
    }
    std::map<int, std::vector<Pose2>> placed;
    bool solved = false;
    if (pgo) {
      try {
        const auto e = team::TwoStepPgo(problem, own_id(), options.two_step);
        for (const auto& [robot, poses] : e.trajectories) {
          auto& v = placed[robot];
          for (const auto& p : poses) v.push_back(FromPg(p));
        }
        solved = true;
      } catch (const std::exception&) {
        placed.clear();  // the guess placement below
      }
      last_optimize_s = now_s;
      accepted_changed = false;
      st->optimized = solved;
      optimized_once = optimized_once || solved;
    }
    own_graph_changed = false;
    for (auto& [robot, mate] : mates) mate.graph_changed = false;
    if (!solved) {  // every robot through its map-to-map guess
      placed[own_id()] = own_poses;
      for (const auto& [robot, rg] : problem.robots) {
        if (robot == own_id()) continue;
        const Pose2 T = FromPg(problem.maps.at({own_id(), robot}));
        auto& v = placed[robot];
        for (const auto& p : rg.poses) v.push_back(reg::Compose(T, FromPg(p)));
      }
    }
    if (!options.place_unverified_teammates) {
      // A teammate enters the estimate once the consistency filter accepted loops with it: a
      // map-to-map guess alone (object-graph matching) can be wrong where structures repeat.
      std::set<int> verified;
      for (const auto& l : problem.loops) verified.insert(l.teammate_robot);
      for (auto it = placed.begin(); it != placed.end();) {
        it = it->first != own_id() && !verified.count(it->first) ? placed.erase(it) : std::next(it);
      }
    }
    AgentEstimate next;
    next.time_s = now_s;
    next.candidates = std::move(estimate.candidates);
    next.accepted = std::move(estimate.accepted);
    // Trajectories with real keyframes only; map-to-map estimates.
    for (const auto& [robot, poses] : placed) {
      auto& traj = next.trajectories[robot];
      if (robot == own_id()) {
        for (std::size_t k = 0; k < poses.size() && k < own_real.size(); ++k) {
          if (own_real[k]) traj.push_back({static_cast<int>(k), own_times[k], poses[k]});
        }
        continue;
      }
      const auto& state = teammates.at(robot);
      const auto& known = mates.at(robot).known;
      std::vector<Pose2> local, moved;
      for (std::size_t k = 0; k < poses.size() && k < state.keyframes.size(); ++k) {
        if (!known[k]) continue;
        traj.push_back({static_cast<int>(k), state.keyframes[k].time_s, poses[k]});
        local.push_back(state.keyframes[k].T_map_kf);
        moved.push_back(poses[k]);
      }
      const auto g = Guess(robot);
      const auto aligned = solved ? AlignSe2(local, moved) : std::nullopt;
      next.T_own_teammate[robot] = aligned ? *aligned : g.value_or(Pose2{});
    }
    estimate = std::move(next);
  }
};

// ------------------------------------------------------------------------ public

TeamAgent::TeamAgent(const AgentOptions& options) : impl_(std::make_unique<Impl>(options)) {}
TeamAgent::~TeamAgent() = default;

void TeamAgent::OnKeyframe(const msgs::Keyframe& keyframe) {
  if (keyframe.index < 0) return;
  auto& kf = impl_->own[keyframe.index];
  if (kf.has_points) return;  // a keyframe's points never change
  kf.time_s = keyframe.time_s;
  kf.has_points = true;
  kf.points_kf = keyframe.points_body;
  impl_->own_keyframes_dirty = true;
  impl_->own_poses_dirty = impl_->own_poses_dirty || kf.has_pose;
  impl_->own_scans_dirty = true;
  impl_->own_graph_changed = true;
}

void TeamAgent::OnTrajectory(const msgs::KeyframeTrajectory& trajectory) {
  for (const auto& p : trajectory.keyframes) {
    if (p.index < 0 || !Finite(p.T_map_kf)) continue;
    auto& kf = impl_->own[p.index];
    if (kf.has_pose && kf.T_map_kf.x_m == p.T_map_kf.x_m && kf.T_map_kf.y_m == p.T_map_kf.y_m &&
        kf.T_map_kf.yaw_rad == p.T_map_kf.yaw_rad) {
      continue;
    }
    kf.has_pose = true;
    kf.T_map_kf = p.T_map_kf;
    if (!kf.has_points) kf.time_s = p.time_s;
    impl_->own_keyframes_dirty = true;
    impl_->own_poses_dirty = true;
    impl_->own_scans_dirty = true;
    impl_->own_graph_changed = true;
  }
}

void TeamAgent::OnTeammateObjectMap(const msgs::FleetHeader& header, const msgs::ObjectMap& map) {
  auto [state, mate] = impl_->Teammate(header);
  if (!state) return;
  state->objects = map;
  state->objects.robot_id = header.robot_id;
  mate->map_changed = true;
  mate->map_seq = header.seq;
}

void TeamAgent::OnKeyframePoses(const msgs::KeyframePoses& poses) {
  auto [state, mate] = impl_->Teammate(poses.header);
  if (!state) return;
  const int max_kf = std::max(0, impl_->options.max_teammate_keyframes);
  if (poses.full) {
    state->keyframes.clear();
    mate->known.clear();
  }
  for (const auto& e : poses.poses) {
    if (e.index < 0 || e.index >= max_kf || !Finite(e.T_map_kf)) {
      ++state->ignored;
      continue;
    }
    const auto i = static_cast<std::size_t>(e.index);
    if (i >= state->keyframes.size()) {
      // Gaps (keyframes not heard of yet) hold the previous pose and are not "known".
      const Pose2 fill = state->keyframes.empty() ? e.T_map_kf : state->keyframes.back().T_map_kf;
      while (state->keyframes.size() < i) {
        msgs::KeyframePoseEntry g;
        g.index = static_cast<int>(state->keyframes.size());
        g.T_map_kf = fill;
        state->keyframes.push_back(g);
        mate->known.push_back(false);
      }
      state->keyframes.push_back(e);
      mate->known.push_back(true);
    } else {
      state->keyframes[i] = e;
      mate->known[i] = true;
    }
  }
  mate->graph_changed = true;
}

void TeamAgent::OnScanRequest(const msgs::ScanRequest& request) {
  if (request.target_robot != impl_->own_id()) return;
  auto [state, mate] = impl_->Teammate(request.header);
  if (!state) return;
  if (Finite(request.T_requester_target)) {
    mate->has_reverse_guess = true;
    mate->T_own_teammate_reverse = reg::Inverse(request.T_requester_target);
  }
  mate->requests_in.push_back(request);
  const std::size_t kMaxQueued = 16;  // a flooding teammate cannot grow the queue
  while (mate->requests_in.size() > kMaxQueued) mate->requests_in.pop_front();
}

void TeamAgent::OnScanReply(const msgs::ScanReply& reply) {
  if (reply.requester_robot != impl_->own_id()) return;
  auto [state, mate] = impl_->Teammate(reply.header);
  if (!state) return;
  if (reply.keyframe < 0 || reply.keyframe >= impl_->options.max_teammate_keyframes ||
      !Finite(reply.T_map_kf)) {
    ++state->ignored;
    return;
  }
  ++state->scans_received;
  for (std::size_t i = 0; i < mate->scans.size(); ++i) {
    if (mate->scans[i].keyframe == reply.keyframe) {  // a resend: the newer replaces it
      mate->scans.erase(mate->scans.begin() + static_cast<long>(i));
      mate->scan_registered.erase(mate->scan_registered.begin() + static_cast<long>(i));
      break;
    }
  }
  mate->scans.push_back(reply);
  mate->scan_registered.push_back(false);
  const auto max_scans = static_cast<std::size_t>(std::max(0, impl_->options.max_teammate_scans));
  while (mate->scans.size() > max_scans) {
    mate->scans.pop_front();
    mate->scan_registered.pop_front();
  }
}

void TeamAgent::OnLoopClosures(const msgs::LoopClosureMessage& message) {
  if (message.target_robot != impl_->own_id()) return;
  auto [state, mate] = impl_->Teammate(message.header);
  if (!state) return;
  for (const auto& l : message.loops) {
    if (l.own_robot != message.header.robot_id || l.teammate_robot != impl_->own_id()) {
      ++state->ignored;
      continue;
    }
    mate->loops_in.push_back(l);
  }
  const std::size_t kMaxQueued = 4096;
  if (mate->loops_in.size() > kMaxQueued) {
    state->ignored += static_cast<int>(mate->loops_in.size() - kMaxQueued);
    mate->loops_in.resize(kMaxQueued);
  }
}

void TeamAgent::ForgetTeammate(int robot_id) {
  if (robot_id == impl_->own_id()) return;
  impl_->Forget(robot_id);
}

Outbox TeamAgent::Step(double now_s) {
  const auto wall0 = std::chrono::steady_clock::now();
  Impl& a = *impl_;
  Outbox out;
  StepStats st;
  st.time_s = now_s;
  a.last_step_s = now_s;
  a.UpdateOwnMap(now_s, &out);
  a.MatchTeammates(now_s, &out, &st);
  a.ServeRequests(now_s, &out);
  auto fresh = a.RegisterScans(&st);
  auto received = a.TakeReceivedLoops();
  fresh.insert(fresh.end(), received.begin(), received.end());
  a.Filter(std::move(fresh), now_s, &out, &st);
  a.Estimate(now_s, &st);
  st.wall_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall0).count();
  a.stats.push_back(st);
  return out;
}

const AgentEstimate& TeamAgent::estimate() const { return impl_->estimate; }
const std::vector<StepStats>& TeamAgent::step_stats() const { return impl_->stats; }
const std::map<int, TeammateState>& TeamAgent::teammates() const { return impl_->teammates; }
msgs::ObjectMap TeamAgent::OwnObjects() const {
  msgs::ObjectMap m = impl_->own_objects;
  m.robot_id = impl_->own_id();
  return m;
}

}  // namespace draco::agent
