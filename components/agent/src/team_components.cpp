// Runtime adapters of the five team stages (stages.hpp), one robot's inter-robot SLAM between
// its local SLAM and its fleet link (config/graphs/robot.yaml, docs/fleet.md):
//
//   team.ObjectMapper -objects-> team.GraphMatcher -matches-> team.ScanExchange
//     -candidates-> team.ConsistencyFilter -loops-> team.TwoStepOptimizer
//
// team.ObjectMapper owns the step timer (1 s of mission time); every other stage runs its step
// when the previous one publishes, at the same stamp, so one step runs the five stages in
// order, as TeamAgent does. What a stage absorbs before its step (own local SLAM, what the link
// delivered, the previous step's loops) is applied in the order one component would have seen
// it, up to but not including the step's stamp: the outputs do not depend on the order the
// executor runs components in within a stamp.
//
// Files on Stop: <prefix>objects.csv (mapper), <prefix>inter_loops.csv (filter),
// <prefix>team.<robot>.tum and <prefix>agent_steps.csv (optimizer).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "draco/agent/stages.hpp"
#include "draco/graph/component.hpp"
#include "draco/graph/executor.hpp"
#include "draco/icp/icp.hpp"
#include "draco/msgs/fleet.hpp"
#include "draco/msgs/map.hpp"
#include "draco/msgs/team.hpp"

namespace draco::agent {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;

// Absorption order at one stamp: the previous step's chain feedback, the own local SLAM
// (keyframes, then trajectories), then the link's messages (restarts, object maps, poses,
// requests, replies, loops), as the link hands them over in one tick.
enum Rank : int {
  kFeedback = 0,
  kOwnKeyframe,
  kOwnTrajectory,
  kOwnObjects,
  kEvent,
  kObjectMap,
  kPoses,
  kRequest,
  kReply,
  kLoops,
  kTransforms,
};

class Absorber {
 public:
  template <class T, class F>
  void Add(graph::In<T>& in, Rank rank, F apply) {
    for (auto& m : in.TakeAll()) {
      pending_.push_back({m.stamp, rank, seq_++, [m, apply] { apply(*m.value); }});
    }
  }
  // Applies what is stamped before `now` in order; the rest waits for the next step.
  void ApplyBefore(graph::Time now) {
    std::stable_sort(pending_.begin(), pending_.end(), [](const Item& a, const Item& b) {
      return std::tie(a.stamp.ns, a.rank, a.seq) < std::tie(b.stamp.ns, b.rank, b.seq);
    });
    std::size_t n = 0;
    while (n < pending_.size() && pending_[n].stamp < now) pending_[n++].apply();
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<long>(n));
  }

 private:
  struct Item {
    graph::Time stamp;
    int rank = 0;
    std::uint64_t seq = 0;
    std::function<void()> apply;
  };
  std::vector<Item> pending_;
  std::uint64_t seq_ = 0;
};

constexpr std::size_t kLinkDepth = 4096;

graph::InputOptions Absorbed(const char* doc, std::size_t depth = 1024) {
  return {.trigger = false, .depth = depth, .doc = doc};
}
graph::InputOptions FromLink(const char* doc) {
  return {.trigger = false, .depth = kLinkDepth, .delayed = true, .doc = doc};
}

void RobotIdParam(Spec& spec, int* id) {
  spec.Param("robot_id", id, {.doc = "own robot id", .min = 0, .max = 63});
}

Status WriteFiles(const Context& ctx, const std::string& prefix,
                  const std::vector<std::pair<std::string, std::string>>& files) {
  if (ctx.output_dir().empty()) return Status::Ok();
  const auto dir = std::filesystem::path(ctx.output_dir());
  for (const auto& [name, text] : files) {
    const auto path = (dir / (prefix + name)).string();
    if (!graph::WriteFileAtomically(path, text)) return Status::Fatal("cannot write " + path);
  }
  return Status::Ok();
}

// ------------------------------------------------------------------------ team.ObjectMapper

class ObjectMapperComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Own object map (incremental DBSCAN over the own keyframes at their current poses) "
        "every agent step; starts the team pipeline's step. Sends the map to teammates at "
        "most every object_map_period_s when it changed, and the own keyframe poses when they "
        "changed. Writes <prefix>objects.csv.");
    keyframe_ = spec.Input<msgs::Keyframe>("keyframe", Absorbed("own keyframes"));
    trajectory_ = spec.Input<msgs::KeyframeTrajectory>("trajectory",
                                                       Absorbed("own optimised keyframes", 256));
    objects_ = spec.Output<msgs::OwnObjectMap>("objects", "own object map, every step");
    object_map_ = spec.Output<msgs::ObjectMap>("object_map", "own object map to send (full)");
    poses_ = spec.Output<msgs::KeyframePoses>("keyframe_poses",
                                              "every own keyframe pose to send, when changed");
    spec.Timer("step", 1.0, "one agent step every second of mission time");
    RobotIdParam(spec, &o_.robot_id);
    spec.Param("object_map_period_s", &o_.object_map_period_s,
               {.doc = "own object map sent at most this often", .unit = "s", .min = 0.0});
    spec.Param("map_heading_from_keyframes", &o_.map_heading_from_keyframes,
               {.doc = "the map's absolute heading as the circular mean over keyframes of the "
                       "AHRS heading minus the local SLAM yaw (false: the first AHRS reading)",
                .origin = "true: the first reading's error reached 9 deg on the marina (alpha), "
                          "the mean's gap to true loops 9.2 deg at most on tuning seeds 1-10, "
                          "marina and airplane: docs/safe-merges.md, safeguard 1"});
    auto& m = o_.mapper;
    spec.Param("dbscan_eps_m", &m.dbscan.eps_m,
               {.doc = "DBSCAN neighbourhood radius",
                .unit = "m",
                .min = 0.05,
                .max = 20.0,
                .origin = "the reference's 1.5 m (docs/front-end.md, section 1)"});
    spec.Param("dbscan_min_points", &m.dbscan.min_points,
               {.doc = "DBSCAN: a point is core with this many neighbours within eps, itself "
                       "included",
                .min = 1,
                .max = 10000,
                .origin = "the reference's 20"});
    spec.Param("min_points", &m.min_points,
               {.doc = "n_min: clusters with fewer points are dropped",
                .min = 1,
                .max = 100000,
                .origin = "the reference's 20"});
    spec.Param("min_length_m", &m.min_length_m,
               {.doc = "d_min: clusters whose long side is shorter are dropped",
                .unit = "m",
                .min = 0.0,
                .max = 1000.0,
                .origin = "1 m keeps piles and boats (the reference: 3 m; docs/front-end.md)"});
    spec.Param("split_min_length_m", &m.split_min_length_m,
               {.doc = "clusters at least this long and not slender become their straight "
                       "segments (0: off)",
                .unit = "m",
                .min = 0.0,
                .max = 1000.0,
                .origin = "off: docs/front-end.md, \"Structure lines and segment splitting\""});
    spec.Param("prefix", &prefix_, {.doc = "output file name prefix, e.g. the robot name"});
  }
  Status Start(Context&) override {
    stage_ = std::make_unique<ObjectMapperStage>(o_);
    return Status::Ok();
  }
  Status Process(Context& ctx) override {
    in_.Add(keyframe_, kOwnKeyframe, [this](const auto& k) { stage_->OnKeyframe(k); });
    in_.Add(trajectory_, kOwnTrajectory, [this](const auto& t) { stage_->OnTrajectory(t); });
    if (ctx.reason() != graph::Reason::kTimer) return Status::Ok();
    in_.ApplyBefore(ctx.Now());
    msgs::OwnObjectMap step;
    auto out = stage_->Step(ctx.Now().Seconds(), &step.step);
    if (out.has_object_map) object_map_.Publish(std::move(out.object_map));
    if (out.has_poses) {
      msgs::KeyframePoses p;
      p.header.robot_id = o_.robot_id;
      p.header.time_s = ctx.Now().Seconds();
      p.poses = std::move(out.poses);
      poses_.Publish(std::move(p));
    }
    step.version = stage_->version();
    step.map = stage_->objects();
    objects_.Publish(std::move(step));
    return Status::Ok();
  }
  Status Stop(Context& ctx) override {
    if (!stage_) return Status::Ok();
    std::string objects = "id,center_x_m,center_y_m,length_m,breadth_m,yaw_rad,num_points\n";
    for (const auto& ob : stage_->objects().objects) {
      char line[200];
      std::snprintf(line, sizeof line, "%u,%.3f,%.3f,%.3f,%.3f,%.4f,%d\n", ob.id, ob.center.x_m,
                    ob.center.y_m, ob.length_m, ob.breadth_m, ob.yaw_rad, ob.num_points);
      objects += line;
    }
    return WriteFiles(ctx, prefix_, {{"objects.csv", objects}});
  }

 private:
  ObjectMapperStageOptions o_;
  std::string prefix_;
  std::unique_ptr<ObjectMapperStage> stage_;
  Absorber in_;
  graph::In<msgs::Keyframe> keyframe_;
  graph::In<msgs::KeyframeTrajectory> trajectory_;
  graph::Out<msgs::OwnObjectMap> objects_;
  graph::Out<msgs::ObjectMap> object_map_;
  graph::Out<msgs::KeyframePoses> poses_;
};

// ------------------------------------------------------------------------ team.GraphMatcher

class GraphMatcherComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Object-graph matching of the own map against each teammate's (when either changed, "
        "at most every match_period_s); a match asks the teammate for the scans of the "
        "keyframes that observed the matched objects. Publishes the map-to-map guesses every "
        "step.");
    objects_ = spec.Input<msgs::OwnObjectMap>(
        "objects", {.depth = 64, .doc = "own object map from team.ObjectMapper (runs the step)"});
    maps_ = spec.Input<msgs::TeammateObjectMap>("teammate_object_maps",
                                                FromLink("teammates' object maps (link)"));
    requests_ = spec.Input<msgs::ScanRequest>(
        "teammate_scan_requests", FromLink("teammates' scan requests: the reverse guess"));
    events_ =
        spec.Input<msgs::TeammateEvent>("teammate_events", FromLink("teammate restarts (link)"));
    transforms_ = spec.Input<msgs::TeammateTransforms>(
        "teammate_map_transforms",
        FromLink("teammates' verified map-to-map estimates (link): a teammate the own matching "
                 "does not place is chained through them"));
    graph::InputOptions own_keyframes = Absorbed(
        "own keyframes: where the own sonar looked and what it returned (the votes' negative "
        "evidence, vote_miss_weight > 0)");
    own_keyframes.required = false;
    keyframe_ = spec.Input<msgs::Keyframe>("keyframe", own_keyframes);
    own_keyframes.depth = 256;
    own_keyframes.doc = "own optimised keyframes (with keyframe)";
    trajectory_ = spec.Input<msgs::KeyframeTrajectory>("trajectory", own_keyframes);
    matches_ = spec.Output<msgs::MapMatches>("matches", "map-to-map guesses, every step");
    requests_out_ = spec.Output<msgs::ScanRequest>("scan_requests", "scan requests to send");
    RobotIdParam(spec, &o_.robot_id);
    spec.Param("match_period_s", &o_.match_period_s,
               {.doc = "a teammate map matched at most this often", .unit = "s", .min = 0.0});
    spec.Param("max_scans_per_request", &o_.max_scans_per_request,
               {.doc = "scans asked for per request", .min = 0, .max = 256});
    spec.Param("chain_shared_transforms", &o_.chain_shared_transforms,
               {.doc = "request scans of a teammate the own matching does not place, through a "
                       "matched teammate's shared estimate"});
    spec.Param("chain_pair_margin_m", &o_.chain_pair_margin_m,
               {.doc = "chained requests: object rectangles grown by this margin pair when they "
                       "meet",
                .unit = "m",
                .min = 0.0});
    spec.Param("max_heading_gap_rad", &o_.matcher.max_heading_gap_rad,
               {.doc = "hypotheses turned further than this from the maps' absolute headings' "
                       "difference are dropped (<= 0: off)",
                .unit = "rad",
                .origin = "15 deg: with keyframe-mean headings every true loop of tuning seeds "
                          "1-10, marina and airplane within 9.2 deg, false ones beyond 10 deg "
                          "at 21 deg or more; 30 deg let a 37 m wrong placement through on the "
                          "marina at 1 kbit/s: docs/safe-merges.md, safeguard 1"});
    spec.Param("heading_votes", &o_.matcher.heading_votes,
               {.doc = "no answer from the object graphs: translation votes under the maps' "
                       "absolute headings"});
    spec.Param("heading_vote_min_inliers", &o_.matcher.heading_vote_min_inliers,
               {.doc = "... need this many objects within heading_vote_inlier_m",
                .min = 2,
                .origin = "8, with max_vote_ambiguity 0.5, on tuning seeds 1-20: 26 pairs right "
                          "/ 5 wrong against 5 / 0.8's 28 / 5, which answered 30-40 m off in "
                          "the marina's clutter: docs/safe-merges.md, \"Current figures\""});
    spec.Param("max_vote_ambiguity", &o_.matcher.max_vote_ambiguity,
               {.doc = "... and a distinct runner-up below this fraction of the winner's "
                       "support beyond a two-point sample",
                .min = 0.0,
                .origin = "0.5, with heading_vote_min_inliers 8 (see there)"});
    spec.Param("votes_cross_check", &o_.matcher.votes_cross_check,
               {.doc = "an answer of the object graphs is checked against the translation "
                       "votes: a distinct vote at least as well supported replaces it (clear "
                       "winner) or refuses it (ambiguous)"});
    spec.Param("cross_check_max_ambiguity", &o_.matcher.cross_check_max_ambiguity,
               {.doc = "... the answer stands when the best distinct translation's support is "
                       "below this fraction of the answer's, beyond a two-point sample",
                .min = 0.0,
                .origin = "1.0 on tuning seeds 1-10, marina and airplane: 30 pairs right / 3 "
                          "wrong, lowest world precision 0.996, against 27 / 4 and 0.576 without "
                          "the check; 0.5 placed none of seed 2's 10: docs/safe-merges.md"});
    spec.Param("vote_miss_weight", &o_.matcher.vote_miss_weight,
               {.doc = "the votes and the cross-check score a translation by its support less "
                       "this x the teammate objects it lays where the own sonar looked and saw "
                       "(almost) nothing (0: off)",
                .min = 0.0,
                .origin = "off: 2 with the cross-check placed 54 pairs right / 2 wrong at the "
                          "end against 43 / 3 on tuning seeds 21-45, but 57 / 7 against 55 / 5 "
                          "on reporting seeds 101-130: docs/safe-merges.md, \"The own sonar in "
                          "the votes\""});
    spec.Param("vote_miss_cross_check", &o_.matcher.vote_miss_cross_check,
               {.doc = "... in the cross-check too (one-sided: favours hypotheses that put the "
                       "teammate's map where the own sonar never looked)"});
    spec.Param("vote_miss_margin_m", &o_.matcher.vote_miss_margin_m,
               {.doc = "... an object's rectangle grown by this must hold own sonar points",
                .unit = "m",
                .min = 0.0});
    spec.Param("vote_miss_min_points", &o_.matcher.vote_miss_min_points,
               {.doc = "... at least this many of them", .min = 1});
    spec.Param("spectral_components", &o_.matcher.spectral_components,
               {.doc = "spectral relaxation per connected component of the affinity graph "
                       "(each component's positive eigenvector; competing components are "
                       "competing hypotheses) instead of power iteration over the whole matrix"});
    spec.Param("component_tie_ratio", &o_.matcher.component_tie_ratio,
               {.doc = "... a component whose top eigenvalue is at least this fraction of the "
                       "best's gives a competing hypothesis (> 1: the best only)",
                .min = 0.0});
    spec.Param("prefix", &prefix_,
               {.doc = "output file name prefix, e.g. the robot name; writes "
                       "<prefix>matches.csv (every matching tried)"});
  }
  Status Start(Context&) override {
    evidence_ = o_.matcher.vote_miss_weight > 0.0;
    if (evidence_ && !(keyframe_.connected() && trajectory_.connected()))
      return Status::Fatal(
          "vote_miss_weight > 0 needs the own keyframes: connect inputs keyframe and trajectory "
          "(as config/graphs/team-stages.yaml does), or set vote_miss_weight: 0");
    stage_ = std::make_unique<GraphMatcherStage>(o_);
    return Status::Ok();
  }
  Status Process(Context&) override {
    if (evidence_) {
      in_.Add(keyframe_, kOwnKeyframe, [this](const auto& k) { stage_->OnKeyframe(k); });
      in_.Add(trajectory_, kOwnTrajectory, [this](const auto& t) { stage_->OnTrajectory(t); });
    } else {
      keyframe_.TakeAll();
      trajectory_.TakeAll();
    }
    in_.Add(events_, kEvent, [this](const msgs::TeammateEvent& e) {
      if (e.kind == msgs::TeammateEventKind::kRestarted) stage_->Forget(e.robot_id);
    });
    in_.Add(maps_, kObjectMap, [this](const msgs::TeammateObjectMap& m) {
      stage_->OnTeammateObjectMap(m.header, m.map);
    });
    in_.Add(requests_, kRequest, [this](const auto& r) { stage_->OnScanRequest(r); });
    in_.Add(transforms_, kTransforms, [this](const auto& t) { stage_->OnTeammateTransforms(t); });
    for (const auto& own : objects_.TakeAll()) {
      in_.ApplyBefore(own.stamp);
      msgs::MapMatches out;
      out.step = own->step;
      for (auto& r : stage_->Step(own.stamp.Seconds(), own->map, own->version, &out.step)) {
        requests_out_.PublishAt(own.stamp, std::move(r));
      }
      out.guesses = stage_->matches().guesses;
      matches_.PublishAt(own.stamp, std::move(out));
      for (const auto& a : stage_->TakeAttempts()) {
        const auto& m = a.match;
        char line[240];
        const char* by = m.by_votes       ? "votes"
                         : m.by_landmarks ? "landmarks"
                         : m.by_lines     ? "lines"
                                          : "spectral";
        std::snprintf(line, sizeof line, "%.3f,%d,%s,%s,%.4f,%.4f,%.6f,%d,%d,%.3f,%d,%d\n",
                      a.time_s, m.robot_b, msgs::MatchStatusName(m.status), by, m.T_a_b.x_m,
                      m.T_a_b.y_m, m.T_a_b.yaw_rad, m.num_inliers, m.num_ransac_inliers,
                      m.ambiguity, a.own_objects, a.teammate_objects);
        attempts_ += line;
      }
    }
    return Status::Ok();
  }
  Status Stop(Context& ctx) override {
    if (!stage_) return Status::Ok();
    return WriteFiles(ctx, prefix_, {{"matches.csv", attempts_}});
  }

 private:
  GraphMatcherStageOptions o_;
  std::string prefix_;
  std::string attempts_ =
      "time_s,teammate_robot,status,path,x_m,y_m,yaw_rad,inliers,ransac_inliers,ambiguity,"
      "own_objects,teammate_objects\n";
  std::unique_ptr<GraphMatcherStage> stage_;
  bool evidence_ = false;  // the own keyframes feed the votes' negative evidence
  Absorber in_;
  graph::In<msgs::Keyframe> keyframe_;
  graph::In<msgs::KeyframeTrajectory> trajectory_;
  graph::In<msgs::OwnObjectMap> objects_;
  graph::In<msgs::TeammateObjectMap> maps_;
  graph::In<msgs::ScanRequest> requests_;
  graph::In<msgs::TeammateEvent> events_;
  graph::In<msgs::TeammateTransforms> transforms_;
  graph::Out<msgs::MapMatches> matches_;
  graph::Out<msgs::ScanRequest> requests_out_;
};

// ------------------------------------------------------------------------ team.ScanExchange

class ScanExchangeComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Serves teammates' scan requests with own keyframe scans (most named objects first, "
        "newest first, each keyframe once per requester) and registers the scans received "
        "(sliding window) against the own keyframes near them, seeded by the own match: "
        "accepted registrations are candidate loops.");
    matches_ = spec.Input<msgs::MapMatches>(
        "matches",
        {.depth = 64, .doc = "map-to-map guesses from team.GraphMatcher (runs the step)"});
    objects_ =
        spec.Input<msgs::OwnObjectMap>("objects", {.trigger = false,
                                                   .delivery = graph::Delivery::kLatest,
                                                   .doc = "own object map from team.ObjectMapper"});
    keyframe_ = spec.Input<msgs::Keyframe>("keyframe", Absorbed("own keyframes"));
    trajectory_ = spec.Input<msgs::KeyframeTrajectory>("trajectory",
                                                       Absorbed("own optimised keyframes", 256));
    poses_ = spec.Input<msgs::KeyframePoses>("teammate_keyframe_poses",
                                             FromLink("teammates' keyframe poses (link)"));
    requests_ = spec.Input<msgs::ScanRequest>("teammate_scan_requests",
                                              FromLink("teammates' scan requests (link)"));
    replies_ = spec.Input<msgs::ScanReply>("teammate_scan_replies",
                                           FromLink("teammates' scans for our requests (link)"));
    events_ =
        spec.Input<msgs::TeammateEvent>("teammate_events", FromLink("teammate restarts (link)"));
    loops_ = spec.Input<msgs::TeamLoops>(
        "loops", {.trigger = false,
                  .depth = 64,
                  .delayed = true,
                  .doc = "loops held by team.ConsistencyFilter (pairs never registered again)"});
    candidates_ =
        spec.Output<msgs::CandidateLoops>("candidates", "new candidate loops, every step");
    replies_out_ = spec.Output<msgs::ScanReply>("scan_replies", "scans to send");
    RobotIdParam(spec, &o_.robot_id);
    spec.Param("window", &o_.registration.window,
               {.doc = "registration window (keyframes each side)", .min = 0, .max = 20});
    spec.Param("min_overlap", &o_.registration.min_overlap,
               {.doc = "registration acceptance (overlap ratio)",
                .min = 0.0,
                .max = 1.0,
                .origin = "0.85, the reference code's (the paper: 0.9); at window 3 marina "
                          "precision 0.998: docs/front-end.md"});
    spec.Param("backend", &backend_,
               {.doc = "registration back end: draco's 2D ICP, PCL's ICP (2D), GICP or NDT "
                       "(3D with z = 0, projected to SE(2)), or MRPT's 2D ICP; docs/benchmarks.md "
                       "compares them",
                .choices = icp::BackendNames()});
    spec.Param("ndt_resolution_m", &o_.registration.icp.ndt_resolution_m,
               {.doc = "pcl_ndt: voxel size", .unit = "m", .min = 0.05});
    spec.Param("ambiguity_offsets_m", &o_.registration.ambiguity_offsets_m,
               {.doc = "registration ambiguity test: ICP again from the answer moved by each of "
                       "these (8 directions); empty: off",
                .unit = "m"});
    spec.Param("ambiguity_turns_deg", &o_.registration.ambiguity_turns_deg,
               {.doc = "... and from the answer turned by each of these about the scan's centroid",
                .unit = "deg"});
    spec.Param("ambiguity_ratio", &o_.registration.ambiguity_ratio,
               {.doc = "... ambiguous when a distinct answer reaches this fraction of the overlap",
                .min = 0.0,
                .max = 1.0});
    spec.Param("ambiguity_overlap_distance_m", &o_.registration.ambiguity_overlap_distance_m,
               {.doc = "... overlaps compared by the test count source points within this "
                       "distance of the target",
                .unit = "m",
                .min = 0.0,
                .origin = "0.5 m on tuning seeds 1-20, marina and airplane: 19 pairs right / 7 "
                          "wrong against 17 / 9 at 1 m, marina 232 accepted loops against 144: "
                          "docs/safe-merges.md, \"The safeguards\""});
    spec.Param("max_heading_gap_rad", &o_.max_heading_gap_rad,
               {.doc = "with both maps' absolute headings known: the ambiguity test probes only "
                       "turns within this of the headings' difference, and registrations "
                       "implying a rotation further from it are refused (<= 0: off)",
                .unit = "rad"});
    spec.Param(
        "headings_prune_turns", &o_.headings_prune_turns,
        {.doc = "... and the ambiguity test skips the turns the headings exclude (more loops, "
                "and more placements a few metres off where maps bend: "
                "docs/safe-merges.md)"});
    spec.Param("min_scan_points", &o_.selection.min_points,
               {.doc = "a scan with fewer points is neither requested nor served", .min = 1});
    spec.Param("serve_submap_keyframes", &o_.serve_submap_keyframes,
               {.doc = "a served scan under min_scan_points takes the points of up to this "
                       "many neighbours each side (0: single keyframes)",
                .min = 0});
    spec.Param("candidate_radius_m", &o_.selection.candidate_radius_m,
               {.doc = "own keyframes this close to a placed teammate scan are candidates",
                .unit = "m",
                .min = 0.0});
    spec.Param("candidate_max_yaw_rad", &o_.selection.candidate_max_yaw_rad,
               {.doc = "... and within this heading difference", .unit = "rad", .min = 0.0});
    spec.Param("max_scans_per_request", &o_.max_scans_per_request,
               {.doc = "scans served per request at most", .min = 0, .max = 256});
    spec.Param(
        "log_windows", &o_.log_windows,
        {.doc = "also register at these windows, for evaluation only (Fig. 3; e.g. [0, 1, 3]; "
                "default none)",
         .min = 0,
         .max = 20});
    spec.Param("prefix", &prefix_, {.doc = "output file name prefix, e.g. the robot name"});
  }
  Status Start(Context&) override {
    o_.registration.icp.backend = icp::ParseBackend(backend_);
    stage_ = std::make_unique<ScanExchangeStage>(o_);
    return Status::Ok();
  }
  Status Stop(Context& ctx) override {
    if (!stage_ || ctx.output_dir().empty()) return Status::Ok();
    std::string csv =
        "time_s,window,configured,own_robot,own_keyframe,teammate_robot,teammate_keyframe,x_m,"
        "y_m,yaw_rad,overlap,status\n";
    for (const auto& a : stage_->attempts()) {
      char line[256];
      const auto& l = a.loop;
      std::snprintf(line, sizeof line, "%.3f,%d,%d,%d,%d,%d,%d,%.4f,%.4f,%.5f,%.4f,%s\n", a.time_s,
                    a.window, a.configured ? 1 : 0, l.own_robot, l.own_keyframe, l.teammate_robot,
                    l.teammate_keyframe, l.T_ownkf_teammatekf.x_m, l.T_ownkf_teammatekf.y_m,
                    l.T_ownkf_teammatekf.yaw_rad, l.overlap,
                    registration::RegistrationStatusName(a.status));
      csv += line;
    }
    const auto path =
        (std::filesystem::path(ctx.output_dir()) / (prefix_ + "registrations.csv")).string();
    if (!graph::WriteFileAtomically(path, csv)) return Status::Fatal("cannot write " + path);
    return Status::Ok();
  }
  Status Process(Context&) override {
    in_.Add(loops_, kFeedback, [this](const msgs::TeamLoops& l) { stage_->OnLoops(l.candidates); });
    in_.Add(keyframe_, kOwnKeyframe, [this](const auto& k) { stage_->OnKeyframe(k); });
    in_.Add(trajectory_, kOwnTrajectory, [this](const auto& t) { stage_->OnTrajectory(t); });
    in_.Add(events_, kEvent, [this](const msgs::TeammateEvent& e) {
      if (e.kind == msgs::TeammateEventKind::kRestarted) stage_->Forget(e.robot_id);
    });
    in_.Add(poses_, kPoses, [this](const auto& p) { stage_->OnKeyframePoses(p); });
    in_.Add(requests_, kRequest, [this](const auto& r) { stage_->OnScanRequest(r); });
    in_.Add(replies_, kReply, [this](const auto& r) { stage_->OnScanReply(r); });
    if (auto o = objects_.Take()) own_ = o->value;
    for (const auto& m : matches_.TakeAll()) {
      in_.ApplyBefore(m.stamp);
      static const msgs::ObjectMap kEmpty;
      msgs::CandidateLoops out;
      out.matches = *m;
      auto r = stage_->Step(m.stamp.Seconds(), own_ ? own_->map : kEmpty, *m, &out.matches.step);
      for (auto& reply : r.replies) replies_out_.PublishAt(m.stamp, std::move(reply));
      out.loops = std::move(r.candidates);
      candidates_.PublishAt(m.stamp, std::move(out));
    }
    return Status::Ok();
  }

 private:
  ScanExchangeStageOptions o_;
  std::string prefix_;
  std::string backend_ = "draco";
  std::unique_ptr<ScanExchangeStage> stage_;
  Absorber in_;
  std::shared_ptr<const msgs::OwnObjectMap> own_;
  graph::In<msgs::MapMatches> matches_;
  graph::In<msgs::OwnObjectMap> objects_;
  graph::In<msgs::Keyframe> keyframe_;
  graph::In<msgs::KeyframeTrajectory> trajectory_;
  graph::In<msgs::KeyframePoses> poses_;
  graph::In<msgs::ScanRequest> requests_;
  graph::In<msgs::ScanReply> replies_;
  graph::In<msgs::TeammateEvent> events_;
  graph::In<msgs::TeamLoops> loops_;
  graph::Out<msgs::CandidateLoops> candidates_;
  graph::Out<msgs::ScanReply> replies_out_;
};

// ------------------------------------------------------------------------ team.ConsistencyFilter

class ConsistencyFilterComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Numbers the candidate loops, adds the loops teammates sent (inverted), and keeps the "
        "largest consistent set (GCM or PCM, incremental, no time budget); accepted own "
        "registrations are sent to the teammate involved. Writes <prefix>inter_loops.csv.");
    candidates_ = spec.Input<msgs::CandidateLoops>(
        "candidates",
        {.depth = 64, .doc = "new candidates from team.ScanExchange (runs the step)"});
    trajectory_ = spec.Input<msgs::KeyframeTrajectory>("trajectory",
                                                       Absorbed("own optimised keyframes", 256));
    poses_ = spec.Input<msgs::KeyframePoses>("teammate_keyframe_poses",
                                             FromLink("teammates' keyframe poses (link)"));
    loops_in_ = spec.Input<msgs::LoopClosureMessage>(
        "teammate_loop_closures", FromLink("loops teammates accepted with us (link)"));
    events_ =
        spec.Input<msgs::TeammateEvent>("teammate_events", FromLink("teammate restarts (link)"));
    loops_ = spec.Output<msgs::TeamLoops>("loops", "every candidate, accepted flagged, every step");
    loops_out_ = spec.Output<msgs::LoopClosureMessage>("loop_closures", "accepted loops to send");
    RobotIdParam(spec, &o_.robot_id);
    spec.Param("method", &method_, {.doc = "consistency filter", .choices = {"gcm", "pcm"}});
    spec.Param("min_clique_size", &o_.filter.min_clique_size,
               {.doc = "minimum consistent set", .min = 1});
    spec.Param("map_sigma_m", &o_.map_sigma_m,
               {.doc = "map-to-map guess sigma in GCM", .unit = "m", .min = 0.0});
    spec.Param("map_sigma_rad", &o_.map_sigma_rad,
               {.doc = "map-to-map guess sigma in GCM", .unit = "rad", .min = 0.0});
    spec.Param(
        "max_candidates_per_teammate", &o_.max_candidates_per_teammate,
        {.doc = "candidates held per teammate; later ones are dropped and counted", .min = 1});
    spec.Param("max_accepted_per_teammate_keyframe", &o_.max_accepted_per_teammate_keyframe,
               {.doc = "new candidates naming a teammate keyframe with this many accepted "
                       "loops are dropped and counted (0: off)",
                .min = 0});
    spec.Param("max_candidates_per_teammate_keyframe", &o_.max_candidates_per_teammate_keyframe,
               {.doc = "new candidates naming a teammate keyframe that holds this many "
                       "candidates are dropped and counted, so the candidates grow with the "
                       "teammates' keyframes, not with the square of the mission (0: off)",
                .min = 0});
    spec.Param("prefix", &prefix_, {.doc = "output file name prefix, e.g. the robot name"});
  }
  Status Start(Context&) override {
    o_.filter.method = method_ == "pcm" ? consistency::Method::kPcm : consistency::Method::kGcm;
    o_.filter.time_budget_ms = 0.0;  // answers must not depend on machine load
    stage_ = std::make_unique<ConsistencyStage>(o_);
    return Status::Ok();
  }
  Status Process(Context&) override {
    in_.Add(trajectory_, kOwnTrajectory, [this](const auto& t) { stage_->OnTrajectory(t); });
    in_.Add(events_, kEvent, [this](const msgs::TeammateEvent& e) {
      if (e.kind == msgs::TeammateEventKind::kRestarted) stage_->Forget(e.robot_id);
    });
    in_.Add(poses_, kPoses, [this](const auto& p) { stage_->OnKeyframePoses(p); });
    in_.Add(loops_in_, kLoops, [this](const auto& l) { stage_->OnLoopClosures(l); });
    for (const auto& c : candidates_.TakeAll()) {
      in_.ApplyBefore(c.stamp);
      msgs::TeamLoops out;
      out.matches = c->matches;
      for (auto& m : stage_->Step(c.stamp.Seconds(), c->loops, c->matches, &out.matches.step)) {
        loops_out_.PublishAt(c.stamp, std::move(m));
      }
      out.candidates = stage_->candidates();
      loops_.PublishAt(c.stamp, std::move(out));
    }
    return Status::Ok();
  }
  Status Stop(Context& ctx) override {
    if (!stage_) return Status::Ok();
    for (const auto& [robot, mate] : stage_->teammates()) {
      if (mate.over_bound > 0) {
        ctx.Log(log::Level::kWarn,
                "robot " + std::to_string(robot) + ": " + std::to_string(mate.over_bound) +
                    " candidate loops dropped beyond max_candidates_per_teammate (" +
                    std::to_string(o_.max_candidates_per_teammate) + ")");
      }
      if (mate.redundant > 0) {
        ctx.Log(log::Level::kInfo,
                "robot " + std::to_string(robot) + ": " + std::to_string(mate.redundant) +
                    " candidate loops dropped at teammate keyframes with " +
                    std::to_string(o_.max_accepted_per_teammate_keyframe) + " accepted loops");
      }
      if (mate.crowded > 0) {
        ctx.Log(log::Level::kInfo,
                "robot " + std::to_string(robot) + ": " + std::to_string(mate.crowded) +
                    " candidate loops dropped at teammate keyframes holding " +
                    std::to_string(o_.max_candidates_per_teammate_keyframe) + " candidates");
      }
    }
    // The loop's standard deviations (square roots of its covariance's diagonal) after the
    // decision columns.
    std::string loops =
        "id,own_robot,own_keyframe,teammate_robot,teammate_keyframe,x_m,y_m,yaw_rad,overlap,"
        "accepted,sigma_x_m,sigma_y_m,sigma_yaw_rad\n";
    for (const auto& l : stage_->candidates()) {
      const auto sd = [&](int i) { return std::sqrt(std::max(l.covariance[i * 4], 0.0)); };
      char line[320];
      std::snprintf(line, sizeof line, "%llu,%d,%d,%d,%d,%.4f,%.4f,%.5f,%.3f,%d,%.4g,%.4g,%.4g\n",
                    static_cast<unsigned long long>(l.id), l.own_robot, l.own_keyframe,
                    l.teammate_robot, l.teammate_keyframe, l.T_ownkf_teammatekf.x_m,
                    l.T_ownkf_teammatekf.y_m, l.T_ownkf_teammatekf.yaw_rad, l.overlap,
                    (l.flags & msgs::kLoopAccepted) ? 1 : 0, sd(0), sd(1), sd(2));
      loops += line;
    }
    return WriteFiles(ctx, prefix_, {{"inter_loops.csv", loops}});
  }

 private:
  ConsistencyStageOptions o_;
  std::string method_ = "gcm";
  std::string prefix_;
  std::unique_ptr<ConsistencyStage> stage_;
  Absorber in_;
  graph::In<msgs::CandidateLoops> candidates_;
  graph::In<msgs::KeyframeTrajectory> trajectory_;
  graph::In<msgs::KeyframePoses> poses_;
  graph::In<msgs::LoopClosureMessage> loops_in_;
  graph::In<msgs::TeammateEvent> events_;
  graph::Out<msgs::TeamLoops> loops_;
  graph::Out<msgs::LoopClosureMessage> loops_out_;
};

// ------------------------------------------------------------------------ team.TwoStepOptimizer

class TwoStepOptimizerComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Two-step PGO (own chain of local-SLAM poses, teammates' shared trajectories, accepted "
        "loops, map-to-map guesses) at most every optimize_period_s when something changed: "
        "the team estimate in the own map frame. Writes <prefix>team.<robot>.tum per placed "
        "robot, <prefix>agent_steps.csv (the work of every stage per step) and "
        "<prefix>placements.csv (each teammate's map-to-map estimate whenever it changes) and "
        "<prefix>map_checks.csv (the object maps' agreement with a placement whenever it "
        "changes).");
    loops_ = spec.Input<msgs::TeamLoops>(
        "loops", {.depth = 64, .doc = "loops from team.ConsistencyFilter (runs the step)"});
    keyframe_ = spec.Input<msgs::Keyframe>("keyframe", Absorbed("own keyframes"));
    trajectory_ = spec.Input<msgs::KeyframeTrajectory>("trajectory",
                                                       Absorbed("own optimised keyframes", 256));
    poses_ = spec.Input<msgs::KeyframePoses>("teammate_keyframe_poses",
                                             FromLink("teammates' keyframe poses (link)"));
    events_ =
        spec.Input<msgs::TeammateEvent>("teammate_events", FromLink("teammate restarts (link)"));
    transforms_in_ = spec.Input<msgs::TeammateTransforms>(
        "teammate_map_transforms", FromLink("teammates' verified map-to-map estimates (link)"));
    objects_ = spec.Input<msgs::OwnObjectMap>(
        "objects", Absorbed("own object map (map-level check of a placement)", 64));
    maps_ = spec.Input<msgs::TeammateObjectMap>(
        "teammate_object_maps", FromLink("teammates' object maps (link; map-level check)"));
    transforms_out_ = spec.Output<msgs::MapTransforms>(
        "map_transforms", "own verified map-to-map estimates to share, when they change");
    estimate_out_ = spec.Output<msgs::TeamTrajectories>(
        "team_estimate", "every placed robot's keyframes in the own map frame, when optimised");
    RobotIdParam(spec, &o_.robot_id);
    spec.Param("team_names", &team_names_,
               {.doc = "robot names by id (output file names): alpha, bravo, ..."});
    spec.Param("prefix", &prefix_, {.doc = "output file name prefix, e.g. the robot name"});
    spec.Param("optimize_period_s", &o_.optimize_period_s,
               {.doc = "two-step PGO at most this often", .unit = "s", .min = 0.0});
    spec.Param("warm_start", &o_.warm_start,
               {.doc = "start each PGO from the previous one's solution (fewer iterations; "
                       "where the robust cost has several minima, the one nearer the previous "
                       "estimate)"});
    spec.Param("place_unverified_teammates", &o_.place_unverified_teammates,
               {.doc = "place teammates by the map-to-map guess before any loop is accepted"});
    spec.Param("global_anchor", &global_anchor_,
               {.doc = "two-step global step: touched (teammate chain deformed to robust priors "
                       "on its touched poses), first_loop or rigid (teammate placed rigidly)",
                .choices = {"touched", "first_loop", "rigid"}});
    spec.Param("own_chain_sigma_xy_m", &o_.own_chain_sigma_xy_m,
               {.doc = "own trajectory's chain sigma per keyframe step in the two-step PGO",
                .unit = "m",
                .min = 1e-6});
    spec.Param(
        "own_chain_sigma_yaw_rad", &o_.own_chain_sigma_yaw_rad,
        {.doc = "own trajectory's chain yaw sigma per keyframe step", .unit = "rad", .min = 1e-9});
    spec.Param(
        "min_teammate_loops", &o_.min_teammate_loops,
        {.doc = "a teammate is placed only with at least this many accepted loops", .min = 0});
    spec.Param("min_distinct_keyframes", &o_.min_distinct_keyframes,
               {.doc = "... naming at least this many distinct keyframes of each robot", .min = 0});
    spec.Param("max_loops_per_teammate_keyframe", &o_.max_loops_per_teammate_keyframe,
               {.doc = "accepted loops the PGO holds per teammate keyframe, the first ones "
                       "(placement evidence counts all; 0: every accepted loop)",
                .min = 0});
    spec.Param("place_chained_teammates", &o_.place_chained_teammates,
               {.doc = "place a teammate without own verified loops through a teammate's "
                       "shared estimate"});
    spec.Param("placement_heading_weight", &o_.placement_heading_weight,
               {.doc = "turn a placed teammate about its loops' centroid by this fraction of "
                       "the gap between its placement's rotation and the headings' difference "
                       "(0: off)",
                .min = 0.0,
                .max = 1.0});
    spec.Param("placement_heading_variance_ratio", &o_.placement_heading_variance_ratio,
               {.doc = "with placement_heading_weight 0: turn by u / (u + this), u = the "
                       "fractions of the two missions so far the loops' keyframes do not span "
                       "(0: off)",
                .min = 0.0});
    spec.Param("rigid_teammate_trajectories", &o_.rigid_teammate_trajectories,
               {.doc = "a placed teammate's trajectory is its local SLAM moved by the "
                       "map-to-map estimate (false: the global step's bent chain)"});
    spec.Param("mutual_placement_max_gap_m", &o_.mutual_placement_max_gap_m,
               {.doc = "place a loop-verified teammate only once it placed this robot too and "
                       "T_own_mate * T_mate_own moves the own keyframes by an RMS below this "
                       "(0: off)",
                .unit = "m",
                .min = 0.0});
    spec.Param("settle_s", &o_.settle_s,
               {.doc = "place a loop-verified teammate only once its solved placement has held "
                       "this long (settle_max_move_m; 0: off)",
                .unit = "s",
                .min = 0.0});
    spec.Param("settle_max_move_m", &o_.settle_max_move_m,
               {.doc = "the RMS distance the teammate's keyframes may move between the "
                       "placements of the last settle_s",
                .unit = "m",
                .min = 0.0});
    spec.Param("max_rotation_lever_m", &o_.max_rotation_lever_m,
               {.doc = "no placement while the teammate's keyframes reach further than this "
                       "from its loops' keyframes, weighted by the rotation the loops and "
                       "headings leave uncertain: L sqrt(u R / (u + R)) (<= 0: off)",
                .unit = "m"});
    spec.Param("refine_min_pairs", &o_.refine_min_pairs,
               {.doc = "move a placed teammate onto the own object map: the rigid fit of its "
                       "small objects to the nearest own ones, with at least this many pairs "
                       "(0: off)",
                .min = 0});
    spec.Param("refine_gate_m", &o_.refine_gate_m,
               {.doc = "pair a teammate object with the nearest own one within this",
                .unit = "m",
                .min = 0.0});
    spec.Param("refine_max_length_m", &o_.refine_max_length_m,
               {.doc = "objects longer than this are left out of the refinement",
                .unit = "m",
                .min = 0.0});
    spec.Param("refine_max_move_m", &o_.refine_max_move_m,
               {.doc = "keep the refinement only when it moves the teammate's keyframes by an "
                       "RMS of at most this",
                .unit = "m",
                .min = 0.0});
    spec.Param("refine_rotation", &o_.refine_rotation,
               {.doc = "the refinement may turn the placement (false: shift it only)"});
    spec.Param("refine_blend_pairs", &o_.refine_blend_pairs,
               {.doc = "move a refined teammate the fraction pairs / (pairs + this) of the way "
                       "to the objects' fit (0: all the way)",
                .min = 0.0});
    spec.Param("competitor_ratio", &o_.competitor_ratio,
               {.doc = "no placement while candidates the filter rejected agree on another "
                       "transform with this fraction of the accepted loops' distinct keyframes "
                       "(0: off)",
                .min = 0.0});
    spec.Param("max_map_miss_fraction", &o_.max_map_miss_fraction,
               {.doc = "no placement while more than this fraction of the teammate's objects "
                       "that land where the own sonar looked (under the loops' transform) hold "
                       "no own sonar points (>= 1: off)",
                .min = 0.0});
    spec.Param("min_map_misses", &o_.min_map_misses,
               {.doc = "... and at least this many are missing", .min = 1});
    spec.Param("map_margin_m", &o_.map_margin_m,
               {.doc = "a teammate object is seen when its rectangle grown by this margin ...",
                .unit = "m",
                .min = 0.0});
    spec.Param("map_min_points", &o_.map_min_points,
               {.doc = "... and holds at least this many own sonar points", .min = 1});
    spec.Param("map_coverage_range_m", &o_.map_coverage.range_m,
               {.doc = "an object is expected where it lies within this range of a keyframe",
                .unit = "m",
                .min = 0.0});
    spec.Param("map_shadow_margin_m", &o_.map_coverage.shadow_margin_m,
               {.doc = "... but not where the own returns shadow it from that keyframe: "
                       "farther than the nearest 1 m cell holding 3 own returns in its bearing "
                       "plus this (<= 0: off)",
                .unit = "m",
                .origin = "1 m on tuning seeds 21-45: 46 right / 3 wrong / 287 none against 44 / "
                          "3 / 289 off; reporting 101-130, marina and airplane the same tables "
                          "either way: docs/safe-merges.md, safeguard 5"});
    spec.Param("max_heading_gap_rad", &o_.max_heading_gap_rad,
               {.doc = "no placement whose rotation differs from the maps' absolute headings' "
                       "difference by more than this (<= 0: off)",
                .unit = "rad"});
    spec.Param("chain_from_factors", &o_.two_step.teammate_chain_from_factors,
               {.doc = "global step: teammate chain with its own information, not the "
                       "reference's sigmas"});
  }
  Status Start(Context&) override {
    o_.two_step.anchor = global_anchor_ == "rigid"        ? team::GlobalAnchor::kRigid
                         : global_anchor_ == "first_loop" ? team::GlobalAnchor::kFirstLoop
                                                          : team::GlobalAnchor::kTouchedPoses;
    try {
      stage_ = std::make_unique<OptimizerStage>(o_);
    } catch (const std::invalid_argument& e) {
      return Status::Error(e.what());
    }
    return Status::Ok();
  }
  Status Process(Context&) override {
    in_.Add(keyframe_, kOwnKeyframe, [this](const auto& k) { stage_->OnKeyframe(k); });
    in_.Add(trajectory_, kOwnTrajectory, [this](const auto& t) { stage_->OnTrajectory(t); });
    in_.Add(objects_, kOwnObjects,
            [this](const msgs::OwnObjectMap& m) { stage_->OnOwnObjectMap(m.map); });
    in_.Add(events_, kEvent, [this](const msgs::TeammateEvent& e) {
      if (e.kind == msgs::TeammateEventKind::kRestarted) stage_->Forget(e.robot_id);
    });
    in_.Add(maps_, kObjectMap, [this](const msgs::TeammateObjectMap& m) {
      stage_->OnTeammateObjectMap(m.header, m.map);
    });
    in_.Add(poses_, kPoses, [this](const auto& p) { stage_->OnKeyframePoses(p); });
    in_.Add(transforms_in_, kTransforms,
            [this](const auto& t) { stage_->OnTeammateTransforms(t); });
    for (const auto& l : loops_.TakeAll()) {
      in_.ApplyBefore(l.stamp);
      msgs::TeamStepStats st = l->matches.step;
      stage_->Step(l.stamp.Seconds(), l->candidates, l->matches, &st);
      steps_.push_back(st);
      LogPlacements();
      LogMapChecks();
      LogHolds();
      if (st.optimized) {
        const auto& est = stage_->estimate();
        estimate_out_.PublishAt(l.stamp,
                                msgs::TeamTrajectories{est.time_s, o_.robot_id, est.trajectories});
      }
      auto shared = stage_->SharedTransforms();
      if (shared != shared_) {
        shared_ = shared;
        transforms_out_.PublishAt(l.stamp,
                                  msgs::MapTransforms{l.stamp.Seconds(), std::move(shared)});
      }
    }
    return Status::Ok();
  }
  Status Stop(Context& ctx) override {
    if (!stage_) return Status::Ok();
    const auto& est = stage_->estimate();
    std::vector<std::pair<std::string, std::string>> files;
    for (const auto& [id, traj] : est.trajectories) {
      std::string text = "# timestamp x y z qx qy qz qw (robot " + Name(id) +
                         " in the map frame of robot " + Name(o_.robot_id) + ")\n";
      for (const auto& k : traj) {
        char line[200];
        std::snprintf(line, sizeof line, "%.6f %.4f %.4f 0 0 0 %.9f %.9f\n", k.time_s,
                      k.T_map_kf.x_m, k.T_map_kf.y_m, std::sin(0.5 * k.T_map_kf.yaw_rad),
                      std::cos(0.5 * k.T_map_kf.yaw_rad));
        text += line;
      }
      files.push_back({"team." + Name(id) + ".tum", text});
    }
    std::string steps =
        "time_s,matches_tried,matches_found,requests_sent,scans_registered,candidates_added,"
        "loops_accepted,optimized,wall_ms\n";
    for (const auto& s : steps_) {
      char line[200];
      std::snprintf(line, sizeof line, "%.3f,%d,%d,%d,%d,%d,%d,%d,%.3f\n", s.time_s,
                    s.matches_tried, s.matches_found, s.requests_sent, s.scans_registered,
                    s.candidates_added, s.loops_accepted, s.optimized ? 1 : 0, s.wall_ms);
      steps += line;
    }
    files.push_back({"agent_steps.csv", steps});
    files.push_back({"placements.csv", placements_});
    files.push_back({"map_checks.csv", map_checks_});
    files.push_back({"holds.csv", holds_});
    return WriteFiles(ctx, prefix_, files);
  }

 private:
  // A row per change of a teammate's placement: placed with its map-to-map estimate
  // T_own_teammate, or withdrawn (placed 0).
  void LogPlacements() {
    const auto& est = stage_->estimate();
    char line[200];
    std::map<int, msgs::Pose2> now;  // robots in the estimate's trajectories
    for (const auto& [id, traj] : est.trajectories) {
      const auto t = est.T_own_teammate.find(id);
      if (id != o_.robot_id && t != est.T_own_teammate.end()) now[id] = t->second;
    }
    for (const auto& [id, T] : now) {
      const auto it = placed_.find(id);
      if (it != placed_.end() && it->second.x_m == T.x_m && it->second.y_m == T.y_m &&
          it->second.yaw_rad == T.yaw_rad)
        continue;
      placed_[id] = T;
      const auto [expected, misses] = Agreement(id);
      std::snprintf(line, sizeof line, "%.3f,%s,1,%.4f,%.4f,%.6f,%d,%d,%.2f\n", est.time_s,
                    Name(id).c_str(), T.x_m, T.y_m, T.yaw_rad, expected, misses, Lever(id));
      placements_ += line;
    }
    for (auto it = placed_.begin(); it != placed_.end();) {
      if (now.count(it->first)) {
        ++it;
        continue;
      }
      const auto [expected, misses] = Agreement(it->first);
      std::snprintf(line, sizeof line, "%.3f,%s,0,0,0,0,%d,%d,%.2f\n", est.time_s,
                    Name(it->first).c_str(), expected, misses, Lever(it->first));
      placements_ += line;
      it = placed_.erase(it);
    }
  }

  // The map-level check of this step for a teammate: objects expected, missing (-1: none).
  std::pair<int, int> Agreement(int id) const {
    const auto& m = stage_->estimate().map_checks;
    const auto it = m.find(id);
    return it == m.end() ? std::pair{-1, -1}
                         : std::pair{it->second.support.expected, it->second.support.Misses()};
  }

  // The rotation lever of this step for a teammate (-1: not computed).
  double Lever(int id) const {
    const auto& m = stage_->estimate().rotation_lever_m;
    const auto it = m.find(id);
    return it == m.end() ? -1.0 : it->second;
  }

  // A row per change of a teammate's map-level check (counts or verdict).
  void LogMapChecks() {
    const auto& est = stage_->estimate();
    for (const auto& [id, c] : est.map_checks) {
      const auto& a = c.agreement;
      const auto key = std::make_tuple(c.support.expected, c.support.met, a.b_expected, a.b_met,
                                       a.a_expected, a.a_met, c.contradicted);
      const auto it = checked_.find(id);
      if (it != checked_.end() && it->second == key) continue;
      checked_[id] = key;
      char line[260];
      std::snprintf(line, sizeof line, "%.3f,%s,%.4f,%.4f,%.6f,%d,%d,%d,%d,%d,%d,%.4f\n",
                    est.time_s, Name(id).c_str(), c.T_own_teammate.x_m, c.T_own_teammate.y_m,
                    c.T_own_teammate.yaw_rad, c.support.expected, c.support.met, a.b_met,
                    a.a_expected, a.a_met, c.contradicted ? 1 : 0, c.heading_gap_rad);
      map_checks_ += line;
    }
  }

  // A row per change of why a teammate with accepted loops is not placed (an empty reason:
  // no longer held).
  void LogHolds() {
    const auto& est = stage_->estimate();
    std::map<int, std::string> now = est.held;
    for (const auto& [id, reason] : held_) {
      if (!now.count(id)) now[id] = "";
    }
    for (const auto& [id, reason] : now) {
      const auto it = held_.find(id);
      if ((it == held_.end() && reason.empty()) || (it != held_.end() && it->second == reason))
        continue;
      char line[200];
      std::snprintf(line, sizeof line, "%.3f,%s,%s\n", est.time_s, Name(id).c_str(),
                    reason.c_str());
      holds_ += line;
      if (reason.empty()) {
        held_.erase(id);
      } else {
        held_[id] = reason;
      }
    }
  }

  std::string Name(int id) const {
    if (id >= 0 && id < static_cast<int>(team_names_.size())) return team_names_[id];
    return "robot" + std::to_string(id);
  }

  OptimizerStageOptions o_;
  std::vector<std::string> team_names_{"alpha", "bravo", "charlie"};
  std::string prefix_;
  std::string global_anchor_ = "touched";
  std::unique_ptr<OptimizerStage> stage_;
  std::vector<msgs::TeamStepStats> steps_;
  std::map<int, msgs::Pose2> placed_;  // teammates placed after the last step
  std::string placements_ =
      "time_s,teammate,placed,x_m,y_m,yaw_rad,map_expected,map_misses,rotation_lever_m\n";
  std::map<int, std::tuple<int, int, int, int, int, int, bool>> checked_;  // last logged
  std::string map_checks_ =
      "time_s,teammate,x_m,y_m,yaw_rad,mate_objects_expected,mate_objects_on_own_points,"
      "mate_objects_met,own_objects_expected,own_objects_met,contradicted,heading_gap_rad\n";
  std::map<int, std::string> held_;  // last logged
  std::string holds_ = "time_s,teammate,held\n";
  Absorber in_;
  graph::In<msgs::TeamLoops> loops_;
  graph::In<msgs::Keyframe> keyframe_;
  graph::In<msgs::KeyframeTrajectory> trajectory_;
  graph::In<msgs::TeammateTransforms> transforms_in_;
  graph::In<msgs::OwnObjectMap> objects_;
  graph::In<msgs::TeammateObjectMap> maps_;
  graph::Out<msgs::MapTransforms> transforms_out_;
  graph::Out<msgs::TeamTrajectories> estimate_out_;
  std::vector<msgs::Heartbeat::Transform> shared_;  // last published
  graph::In<msgs::KeyframePoses> poses_;
  graph::In<msgs::TeammateEvent> events_;
};

}  // namespace

DRACO_REGISTER_COMPONENT(ObjectMapperComponent, "team.ObjectMapper")
DRACO_REGISTER_COMPONENT(GraphMatcherComponent, "team.GraphMatcher")
DRACO_REGISTER_COMPONENT(ScanExchangeComponent, "team.ScanExchange")
DRACO_REGISTER_COMPONENT(ConsistencyFilterComponent, "team.ConsistencyFilter")
DRACO_REGISTER_COMPONENT(TwoStepOptimizerComponent, "team.TwoStepOptimizer")

}  // namespace draco::agent
