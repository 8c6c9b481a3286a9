// One robot's inter-robot SLAM (DRACo-SLAM2 sections III-A to III-F) as five stages, each a
// plain class with its Options, fed step by step; the team.* components adapt one each
// (docs/fleet.md) and TeamAgent (team_agent.hpp) chains all five in one object.
//
// Per agent step at now_s, in this order, each stage using what the previous one gave:
//  1. ObjectMapperStage: own object map from the own keyframes at their current poses
//     (incremental DBSCAN); published to teammates every object_map_period_s when it changed,
//     with the own keyframe poses when they changed.
//  2. GraphMatcherStage: for each teammate whose object map (or the own map) changed since it
//     was last matched: object-graph matching; a match asks the teammate for the scans of the
//     keyframes that observed the matched objects. Also keeps the reverse guess from the
//     teammates' requests. Publishes the map-to-map guesses.
//  3. ScanExchangeStage: serves the teammates' requests with own keyframe scans (most named
//     objects first, newest first, none under min_points, at most max_scans, each keyframe at
//     most once per requester); registers the scans received (sliding window) against the own
//     keyframes near them, seeded by the own match: accepted registrations are candidates.
//  4. ConsistencyStage: numbers the candidates, adds the loops teammates sent (their
//     registrations of our scans, inverted), runs GCM (or PCM; incremental, no time budget so
//     the answer does not depend on load); accepted own registrations are sent to the
//     teammate involved.
//  5. OptimizerStage: every optimize_period_s with new accepted loops, two-step PGO (own graph
//     as a chain of the local-SLAM poses, teammates' trajectories from the poses they shared);
//     the estimate holds every verified robot's trajectory in the own map frame.
//
// Teammates: every stage keeps what it needs per teammate and forgets it when the teammate
// restarts (a new incarnation in a message header, or Forget()). Memory per teammate is
// bounded (max_teammate_keyframes poses, max_teammate_scans scans, queued requests, loops).
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "draco/consistency/filter.hpp"
#include "draco/msgs/fleet.hpp"
#include "draco/msgs/map.hpp"
#include "draco/msgs/team.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "draco/objects/object_mapper.hpp"
#include "draco/registration/registration.hpp"
#include "draco/team/team_pgo.hpp"

namespace draco::agent {

// The own local SLAM as a stage sees it: keyframes (points, body frame) and current poses.
class OwnKeyframes {
 public:
  struct Entry {
    double time_s = 0.0;
    bool has_pose = false;
    msgs::Pose2 T_map_kf;
    bool has_points = false;
    std::vector<msgs::Point2> points_kf;
  };
  void OnKeyframe(const msgs::Keyframe& keyframe);
  void OnTrajectory(const msgs::KeyframeTrajectory& trajectory);
  const std::map<int, Entry>& entries() const { return own_; }
  bool Known(int index) const;  // has a pose
  // Poses by position 0..max index (gaps hold the previous pose), which are real keyframes.
  void Chain(std::vector<msgs::Pose2>* poses, std::vector<bool>* real,
             std::vector<double>* times) const;
  std::uint64_t version() const { return version_; }              // any change
  std::uint64_t poses_version() const { return poses_version_; }  // a change to publish
  // The local SLAM's landmarks of the newest trajectory.
  const std::vector<msgs::LandmarkEstimate>& landmarks() const { return landmarks_; }
  std::uint64_t landmarks_version() const { return landmarks_version_; }

 private:
  std::map<int, Entry> own_;
  std::vector<msgs::LandmarkEstimate> landmarks_;
  std::uint64_t landmarks_version_ = 0;
  std::uint64_t version_ = 0;
  std::uint64_t poses_version_ = 0;
};

// The own sonar in the map frame, for negative evidence (the matcher's votes, the optimiser's
// map check): where the own keyframes looked and the points they returned. Update rebuilds
// both only when the keyframes changed since the last call.
struct OwnSonar {
  std::uint64_t version = ~std::uint64_t{0};
  objects::Coverage coverage;
  objects::PointCounts points;
  const OwnSonar& Update(const OwnKeyframes& own, const objects::CoverageOptions& options);
};

// Teammates' keyframe poses as they shared them (index == position; gaps not known).
class TeammatePoses {
 public:
  struct Held {
    std::vector<msgs::KeyframePoseEntry> keyframes;
    std::vector<bool> known;
    int ignored = 0;  // entries with a bad index or pose
  };
  explicit TeammatePoses(int max_keyframes = 20000) : max_keyframes_(max_keyframes) {}
  void OnKeyframePoses(const msgs::KeyframePoses& poses);
  bool Known(int robot, int index) const;
  const Held* Find(int robot) const;
  const std::map<int, Held>& all() const { return held_; }
  void Forget(int robot) { held_.erase(robot); }

 private:
  int max_keyframes_;
  std::map<int, Held> held_;
};

// Which incarnation of each teammate a stage holds. Note() on a message header: false for the
// own id; a new incarnation of a known teammate calls forget(robot) first.
class Roster {
 public:
  template <class Forget>
  bool Note(int own_id, const msgs::FleetHeader& header, Forget&& forget) {
    if (header.robot_id == own_id) return false;
    const auto it = incarnations_.find(header.robot_id);
    if (it != incarnations_.end() && it->second != header.incarnation) forget(header.robot_id);
    incarnations_[header.robot_id] = header.incarnation;
    return true;
  }
  void Erase(int robot) { incarnations_.erase(robot); }
  const std::map<int, std::uint32_t>& all() const { return incarnations_; }

 private:
  std::map<int, std::uint32_t> incarnations_;
};

// ------------------------------------------------------------------------- 1. object map

struct ObjectMapperStageOptions {
  int robot_id = 0;
  objects::ObjectMapperOptions mapper;
  double object_map_period_s = 10.0;  // own object map published at most this often
  // The map frame's absolute heading (msgs::ObjectMap::map_heading_rad) as the circular mean
  // over the keyframes of the AHRS heading minus the local SLAM's yaw, instead of the first
  // AHRS reading alone: the AHRS error (a Gauss-Markov process of a few degrees) averages out
  // over the mission, and the heading follows the local SLAM's frame. false: the first reading.
  bool map_heading_from_keyframes = true;
};

class ObjectMapperStage {
 public:
  struct Output {
    bool has_object_map = false;  // to send (full; the link makes the delta)
    msgs::ObjectMap object_map;
    bool has_poses = false;  // every own keyframe at its current pose, to send
    std::vector<msgs::KeyframePoseEntry> poses;
  };
  explicit ObjectMapperStage(const ObjectMapperStageOptions& options);
  ~ObjectMapperStage();
  void OnKeyframe(const msgs::Keyframe& keyframe) {
    own_.OnKeyframe(keyframe);
    odom_heading_rad_ = keyframe.odom_heading_rad;  // the map frame starts as the odom frame
    if (options_.map_heading_from_keyframes && std::isfinite(keyframe.odom_heading_rad))
      ahrs_heading_rad_[keyframe.index] = keyframe.odom_heading_rad + keyframe.T_odom_body.yaw_rad;
  }
  void OnTrajectory(const msgs::KeyframeTrajectory& t) { own_.OnTrajectory(t); }
  Output Step(double now_s, msgs::TeamStepStats* stats);
  const msgs::ObjectMap& objects() const { return objects_; }  // after the last step
  std::uint64_t version() const { return version_; }

 private:
  ObjectMapperStageOptions options_;
  OwnKeyframes own_;
  std::unique_ptr<objects::ObjectMapper> mapper_;
  std::set<int> mapped_;  // keyframes given to the mapper
  std::uint64_t seen_version_ = 0;
  std::uint64_t seen_poses_version_ = 0;
  std::uint64_t version_ = 0;
  msgs::ObjectMap clusters_;  // the mapper's objects, before the landmarks are appended
  double odom_heading_rad_ = msgs::kUnknownHeading;
  std::map<int, double> ahrs_heading_rad_;  // keyframe -> absolute AHRS heading
  std::uint64_t seen_landmarks_version_ = 0;
  msgs::ObjectMap objects_;
  msgs::ObjectMap last_published_;
  bool published_once_ = false;
  double last_publish_s_;
};

// ------------------------------------------------------------------------- 2. matching

struct GraphMatcherStageOptions {
  int robot_id = 0;
  objects::MatcherOptions matcher;
  double match_period_s = 10.0;  // a teammate map is matched at most this often
  int max_scans_per_request = 20;
  // A teammate the own matching does not place, but a matched teammate c has verified by
  // loops and shared (msgs::TeammateTransforms): T_own_b = T_own_c * T_c_b seeds a request
  // for the scans of b's objects whose rectangles, grown by chain_pair_margin_m, meet own
  // objects' (objects::PairsUnderTransform). docs/front-end.md section 3c.
  bool chain_shared_transforms = true;
  double chain_pair_margin_m = 1.0;
  // Both links of a chain must be steady: the own match of c and c's shared estimate each
  // repeated this many times in a row within chain_agree_m / chain_agree_rad (a match that
  // flips between hypotheses, or an estimate still moving, seeds no request).
  int chain_min_agreeing = 3;
  double chain_agree_m = 1.0;
  double chain_agree_rad = 0.035;
  // Where the own sonar looked, for the votes' negative evidence (matcher.vote_miss_weight;
  // the own keyframes and their points come in through OnKeyframe / OnTrajectory).
  objects::CoverageOptions coverage;
};

class GraphMatcherStage {
 public:
  struct Teammate {
    msgs::ObjectMap objects;  // its map as the link holds it
    bool map_changed = false;
    std::uint32_t map_seq = 0;  // header.seq of the map held
    double last_try_s;
    std::uint64_t own_version_at_try = 0;
    double last_chain_try_s;
    int agreeing_matches = 0;  // consecutive own matches within chain_agree_* of each other
  };
  explicit GraphMatcherStage(const GraphMatcherStageOptions& options);
  void OnTeammateObjectMap(const msgs::FleetHeader& header, const msgs::ObjectMap& map);
  void OnScanRequest(const msgs::ScanRequest& request);                   // the reverse guess
  void OnTeammateTransforms(const msgs::TeammateTransforms& transforms);  // for chaining
  // Own keyframes and poses: the own sonar's evidence (matcher.vote_miss_weight > 0 only).
  void OnKeyframe(const msgs::Keyframe& keyframe) { own_.OnKeyframe(keyframe); }
  void OnTrajectory(const msgs::KeyframeTrajectory& t) { own_.OnTrajectory(t); }
  void Forget(int robot);
  // Matches changed teammate maps against the own map; returns the scan requests to send.
  std::vector<msgs::ScanRequest> Step(double now_s, const msgs::ObjectMap& own,
                                      std::uint64_t own_version, msgs::TeamStepStats* stats);
  const msgs::MapMatches& matches() const { return matches_; }  // guesses after the last step
  const std::map<int, Teammate>& teammates() const { return mates_; }
  // Every matching tried since the last call (any status), oldest first.
  struct Attempt {
    double time_s = 0.0;
    int own_objects = 0, teammate_objects = 0;
    msgs::ObjectMatch match;  // robot_b: the teammate
  };
  std::vector<Attempt> TakeAttempts() { return std::exchange(attempts_, {}); }

 private:
  // Teammates without an own match, placed through a matched teammate's shared estimate;
  // requests their scans (at most every match_period_s).
  void ChainUnmatched(double now_s, const msgs::ObjectMap& own, std::vector<msgs::ScanRequest>* out,
                      msgs::TeamStepStats* st);
  // One request for the teammate objects of `pairs` (in order, each once), seeded by
  // T_own_teammate; none when there is no object to name.
  void Request(double now_s, int robot, const Teammate& mate, const msgs::Pose2& T_own_teammate,
               const std::vector<msgs::ObjectPair>& pairs, std::vector<msgs::ScanRequest>* out,
               msgs::TeamStepStats* st) const;

  GraphMatcherStageOptions options_;
  Roster roster_;
  std::map<int, Teammate> mates_;
  msgs::MapMatches matches_;
  bool Agree(const msgs::Pose2& a, const msgs::Pose2& b) const;
  struct Shared {
    msgs::Pose2 T;     // T_sender_robot
    int agreeing = 1;  // consecutive heartbeats within chain_agree_* of each other
  };
  std::map<int, std::map<int, Shared>> shared_;  // sender -> robot -> its estimate
  std::vector<Attempt> attempts_;
  OwnKeyframes own_;
  OwnSonar own_sonar_;  // the votes' negative evidence
};

// ------------------------------------------------------------------------- 3. scans

struct ScanExchangeStageOptions {
  int robot_id = 0;
  registration::SelectionOptions selection;        // max_requests, min_points, candidates
  registration::RegistrationOptions registration;  // window 3, min_overlap 0.85
  // For evaluation only (the paper's Fig. 3, e.g. {0, 1, 3}): every registration is also run
  // at these windows and logged with its overlap whatever the threshold; decisions use
  // `registration` alone. Empty (default): only the configured window runs. Two more windows
  // cost the marina team replay 35 % of the exchange's time (2.5 s against 1.6 s), 9 % of
  // its wall time, for the same decisions (docs/benchmarks.md).
  std::vector<int> log_windows;
  std::size_t max_logged = 200000;
  int max_scans_per_request = 20;
  // A served keyframe with fewer than selection.min_points points is sent with the points of
  // up to this many neighbours on each side (nearest first, in its frame by the local SLAM's
  // poses) until it reaches min_points; 0: single keyframes only. Where the sonar returns a
  // few points a ping, single keyframes are never served (docs/front-end.md).
  int serve_submap_keyframes = 8;
  int max_teammate_keyframes = 20000;
  int max_teammate_scans = 400;
  // With both maps' absolute headings known: the ambiguity test probes only turns within this
  // of the headings' difference, and a registration implying a map-to-map rotation further
  // from it is refused (kHeadingMismatch). <= 0: off.
  double max_heading_gap_rad = objects::kDefaultMaxHeadingGapRad;  // 15 deg, as the matcher's
  // ... and with it the ambiguity test skips the turns the headings exclude. Off: on tuning
  // seeds 1-10 it accepted 64 % more loops (888, 886 true, against 543, 529 true) and placed
  // 18 pairs right against 16, but 8 wrong at the end against 3 (all 2-4.7 m, <= 4.9 deg off,
  // every loop true: the heading effect, docs/safe-merges.md).
  bool headings_prune_turns = false;
};

// One registration as logged for evaluation: the window it used, its ICP result and overlap
// (rejected ones too), and whether it is the configured window's decision.
struct RegistrationAttempt {
  double time_s = 0.0;
  int window = 0;
  bool configured = false;  // the window decisions use
  registration::RegistrationStatus status = registration::RegistrationStatus::kEmptyTarget;
  msgs::InterRobotLoop loop;  // robots, keyframes, pose, overlap
};

class ScanExchangeStage {
 public:
  struct Output {
    std::vector<msgs::ScanReply> replies;          // served requests
    std::vector<msgs::InterRobotLoop> candidates;  // registered (ids not assigned)
  };
  struct Teammate {
    std::deque<msgs::ScanReply> scans;  // held, oldest first
    std::deque<bool> scan_registered;
    std::set<int> sent_to;                      // own keyframes already sent to it
    std::deque<msgs::ScanRequest> requests_in;  // served at the next step
    int scans_received = 0;
    int ignored = 0;  // replies with a bad keyframe or pose, scans of unshared keyframes
  };
  explicit ScanExchangeStage(const ScanExchangeStageOptions& options);
  void OnKeyframe(const msgs::Keyframe& keyframe) { own_.OnKeyframe(keyframe); }
  void OnTrajectory(const msgs::KeyframeTrajectory& t) { own_.OnTrajectory(t); }
  void OnKeyframePoses(const msgs::KeyframePoses& poses);
  void OnScanRequest(const msgs::ScanRequest& request);
  void OnScanReply(const msgs::ScanReply& reply);
  // Keyframe pairs already held as candidates (the filter's set, every one each step, numbered
  // in the order the filter took them): never registered again.
  void OnLoops(const std::vector<msgs::InterRobotLoop>& loops);
  void Forget(int robot);
  Output Step(double now_s, const msgs::ObjectMap& own_objects, const msgs::MapMatches& matches,
              msgs::TeamStepStats* stats);
  const std::map<int, Teammate>& teammates() const { return mates_; }
  const std::vector<RegistrationAttempt>& attempts() const { return attempts_; }

 private:
  void Log(double now_s, int window, bool configured, const registration::RegistrationResult& r);
  void RebuildOwnScans();
  void Serve(double now_s, const msgs::ObjectMap& own_objects, Output* out);
  // serve_submap_keyframes: the points a served keyframe is sent with, and every keyframe's
  // count as served.
  std::vector<msgs::Point2> Submap(int index) const;
  const std::vector<registration::KeyframeInfo>& ServedInfo();
  std::vector<int> Candidates(const msgs::ObjectMap& own_objects, const msgs::Pose2& T_own_teammate,
                              const msgs::ScanReply& scan) const;
  Teammate* Mate(const msgs::FleetHeader& header);

  ScanExchangeStageOptions options_;
  OwnKeyframes own_;
  TeammatePoses poses_;
  Roster roster_;
  std::map<int, Teammate> mates_;
  std::set<std::tuple<int, int, int>> keys_;  // teammate, own keyframe, teammate keyframe
  std::uint64_t loops_seen_until_ = 0;        // OnLoops: candidates with lower ids are in keys_
  std::uint64_t scans_version_ = ~std::uint64_t{0};
  std::vector<registration::KeyframeScan> own_scans_;
  std::vector<registration::KeyframeInfo> own_info_;
  std::vector<registration::KeyframeInfo> served_info_;
  std::uint64_t served_version_ = ~std::uint64_t{0};
  std::map<int, int> own_scan_position_;
  std::vector<RegistrationAttempt> attempts_;
};

// ------------------------------------------------------------------------- 4. GCM / PCM

struct ConsistencyStageOptions {
  int robot_id = 0;
  consistency::FilterOptions filter;  // GCM; time_budget_ms forced to 0
  // Teammate chain sigmas (as the two-step PGO's) and map-to-map guess sigmas in GCM.
  double chain_sigma_xy_m = 0.1;
  double chain_sigma_yaw_rad = 0.01;
  double map_sigma_m = 1.0;
  double map_sigma_rad = 0.05;
  int max_teammate_keyframes = 20000;
  // Loops a teammate may hand us over a mission (a mission gives tens); beyond, its loops are
  // ignored and counted, so a faulty teammate cannot grow the filter's problem without end.
  int max_received_loops_per_teammate = 2000;
  // Candidates held per teammate (registered here and received), the bound on what one
  // teammate adds to the filter: about 0.9 kB per candidate plus one bit per pair of
  // candidates of all teammates (GCM's consistency graph), so at the bound with T teammates
  // 8192 T x 0.9 kB + (8192 T)^2 / 8 bytes (T = 2: 15 MB + 34 MB). Beyond it the teammate's
  // new candidates are dropped and counted (Teammate::over_bound); the accepted set stays
  // and still places it. The marina repeated for 120 min holds at most 3,665 per teammate.
  int max_candidates_per_teammate = 8192;
  // A new candidate naming a teammate keyframe that already has this many accepted loops is
  // redundant: dropped and counted (Teammate::redundant; its key stays). On repeated passes
  // every pass of a teammate is registered against every earlier own pass, so candidates grow
  // with the square of the mission; with the bound they grow with the teammates' keyframes.
  // Should the accepted loops there be withdrawn, new candidates are taken again. 0: off.
  // 4, as the PGO's max_loops_per_teammate_keyframe: the same placements on tuning seeds 1-10,
  // the marina, the airplane and reporting seeds 101-130; at 120 min of the repeated marina
  // 5,795 candidates held against 8,917 (docs/benchmarks.md).
  int max_accepted_per_teammate_keyframe = 4;
  // At most this many candidates held per teammate keyframe (accepted or not, registered here
  // or received): later ones naming it are dropped and counted (Teammate::crowded; their keys
  // stay). The bound above stops a teammate keyframe's candidates only once 4 are accepted; a
  // new pass of the teammate is still registered against every earlier own pass before any
  // is, so without this the candidates held, and the filter's work per step, grow with the
  // square of the mission. With it they grow with the teammates' keyframes. 0: off.
  int max_candidates_per_teammate_keyframe = 16;
};

class ConsistencyStage {
 public:
  struct Teammate {
    std::vector<msgs::InterRobotLoop> loops_in;  // received, checked at the next step
    int loops_taken = 0;                         // received loops entered into the filter
    int candidates = 0;
    int accepted = 0;
    int ignored = 0;     // received loops naming unknown keyframes, broken, or not ours
    int over_bound = 0;  // candidates dropped at max_candidates_per_teammate
    int redundant = 0;   // candidates dropped at max_accepted_per_teammate_keyframe
    int crowded = 0;     // candidates dropped at max_candidates_per_teammate_keyframe
  };
  explicit ConsistencyStage(const ConsistencyStageOptions& options);
  ~ConsistencyStage();
  void OnTrajectory(const msgs::KeyframeTrajectory& trajectory);
  void OnKeyframePoses(const msgs::KeyframePoses& poses);
  void OnLoopClosures(const msgs::LoopClosureMessage& message);
  void Forget(int robot);
  // Numbers `registered`, adds the received loops, filters; returns the loop messages to send.
  std::vector<msgs::LoopClosureMessage> Step(double now_s,
                                             std::vector<msgs::InterRobotLoop> registered,
                                             const msgs::MapMatches& matches,
                                             msgs::TeamStepStats* stats);
  // Every candidate, flags kLoopAccepted / kLoopRejected (ascending id).
  const std::vector<msgs::InterRobotLoop>& candidates() const { return view_; }
  std::vector<msgs::InterRobotLoop> accepted() const;
  const std::map<int, Teammate>& teammates() const { return mates_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<msgs::InterRobotLoop> view_;
  std::map<int, Teammate> mates_;
  friend struct Impl;
};

// ------------------------------------------------------------------------- 5. two-step PGO

struct OptimizerStageOptions {
  int robot_id = 0;
  team::TwoStepOptions two_step;
  double optimize_period_s = 10.0;
  // Each two-step PGO starts from the previous one's solution (team::TeamProblem::warm) for
  // the own robot and the teammates with loops in it, not from the local-SLAM poses and the
  // map guesses: fewer iterations; the same estimate to the solver's tolerance where the
  // robust loops' cost has one minimum, else the minimum nearest the previous estimate (marina
  // in process: the same loops and verdicts, final errors 0.00-0.19 m apart, smaller).
  bool warm_start = true;
  // The warm start is dropped (every robot solved from its local-SLAM poses and map guess)
  // when an accepted loop of the last solve is no longer accepted (the filter switched to
  // another clique, a placement was withdrawn) or a teammate's map-to-map guess moved by more
  // than these since: the old solution may sit in the minimum the evidence has left.
  double warm_reset_guess_m = 3.0;
  double warm_reset_guess_rad = 0.1745;
  // Place teammates in the estimate by the map-to-map guess alone, before any loop with them
  // is accepted (false: only teammates with accepted loops are placed).
  bool place_unverified_teammates = false;
  // Place a teammate that the own loops do not verify through a teammate's shared estimate
  // (T_own_s * T_s_robot). Off: a shared estimate only seeds the guess (scan requests, the
  // PGO's initial placement) and the robot is placed once the own loops with it pass the
  // evidence rules below; a teammate whose own map is wrong (a dead DVL) then cannot carry
  // its error into every robot's estimate.
  bool place_chained_teammates = false;
  // A placed teammate's trajectory in the estimate is its local SLAM (its shared keyframe
  // poses) moved by T_own_teammate, the rigid fit of the global step's solution, rather than
  // that solution itself: the global step bends the teammate's chain toward its loops, whose
  // errors (median about 0.2 m) exceed the local SLAM's between neighbouring keyframes.
  // Decisions use T_own_teammate either way; only the trajectories differ.
  bool rigid_teammate_trajectories = true;
  // Mutual placement (0: off). A teammate that passes the evidence rules enters the estimate
  // only once it has placed this robot too (its shared transform) and the two agree: the own
  // keyframes moved by T_own_mate * T_mate_own stay within this RMS distance. The two
  // directions stand on different scans registered against different windows through
  // different filters; the shared transforms then carry the placements that wait for this
  // (so that neither waits for the other), so it cannot be combined with
  // place_chained_teammates (std::invalid_argument).
  double mutual_placement_max_gap_m = 2.0;
  // Settled placement (settle_s 0: off). A loop-verified teammate enters the estimate only once
  // its solved placement has held for settle_s: the placement of the last solve at least
  // settle_s ago and of every solve since move the teammate's keyframes by an RMS of at most
  // settle_max_move_m from the current one. A first placement on few loops moves as loops
  // accrue; a placement that has not stopped moving is not yet evidence. Held placements are
  // still shared (mutual placement does not wait on it).
  double settle_s = 0.0;
  double settle_max_move_m = 1.0;
  int max_teammate_keyframes = 20000;
  // The own trajectory enters the two-step PGO as a chain of its relative poses with these
  // sigmas per keyframe step. The reference's 0.1 m / 0.01 rad let true but imprecise loops
  // bend the own local SLAM (airplane charlie 0.67 -> 1.02 m); 0.03 m / 0.003 rad by
  // measurement (docs/back-end.md, "Own chain stiffness").
  double own_chain_sigma_xy_m = 0.03;
  double own_chain_sigma_yaw_rad = 0.003;
  // A teammate is placed (its loops enter the PGO, its estimate is shared) only on enough
  // independent evidence: at least min_teammate_loops accepted loops with it, naming at least
  // min_distinct_keyframes distinct keyframes of each robot (one scan registered against
  // several own windows, or several scans against one, is one piece of evidence). The
  // consistency filter's minimum clique counts loops of every teammate together, so without
  // this one accepted loop could place a teammate. 0: off.
  int min_teammate_loops = 5;
  int min_distinct_keyframes = 3;
  // Loops the PGO holds per teammate keyframe: the first this many accepted (ascending id,
  // so a loop once used stays used while accepted); the others are redundant for placing that
  // keyframe. On repeated passes every pass of a teammate is tied to every earlier own pass,
  // so accepted loops grow with the square of the mission; with the bound the PGO grows with
  // the teammates' keyframes. Placement evidence (the rules above and below) counts every
  // accepted loop. 0: every accepted loop.
  int max_loops_per_teammate_keyframe = 4;
  // Competing evidence: every candidate loop with a teammate implies a map-to-map transform
  // (own keyframe pose * loop * inverse teammate keyframe pose). Candidates the filter did not
  // accept whose transforms agree with each other (within competitor_agree_m at the
  // teammate's keyframe centroid and competitor_agree_rad), but not with the accepted loops'
  // (further than competitor_distinct_m or competitor_distinct_rad), are a second hypothesis
  // (a grid one spacing off, a symmetric structure turned). When such a group names at least
  // min_distinct_keyframes keyframes of each robot and competitor_ratio x the accepted loops'
  // distinct keyframes, the evidence is ambiguous and the teammate is not placed (or is
  // withdrawn) until it is not. competitor_ratio <= 0: off.
  double competitor_ratio = 0.5;
  double competitor_agree_m = 1.5;
  double competitor_agree_rad = 0.0873;  // 5 deg
  double competitor_distinct_m = 3.0;
  double competitor_distinct_rad = 0.1745;  // 10 deg
  // Map-level negative evidence (objects::SupportByPoints): under the transform the accepted
  // loops imply, every teammate object that lands where the own sonar looked (centre within
  // map_coverage of an own keyframe) must hold at least map_min_points own sonar points inside
  // its rectangle grown by map_margin_m. A teammate is not placed, or is withdrawn, while at
  // least min_map_misses of them hold none and they are more than max_map_miss_fraction of
  // those expected (>= 1: off). On tuning seeds 1, 2, 7, 16 and 17, 189 checks of right
  // placements missed at most 1 object, 10 of 53 checks of placements 5 m or more off missed
  // 2 or more (docs/safe-merges.md). The own objects against the teammate's (the other way
  // round) are logged, not used: online, with maps still growing, they miss as often for right
  // placements as for wrong ones.
  double max_map_miss_fraction = 0.1;
  int min_map_misses = 2;
  double map_margin_m = 2.0;
  int map_min_points = 3;
  // Where the own sonar looked: 20 m, +-65 deg of each own keyframe, but not behind the own
  // returns (1 m past the nearest cell of 3 returns in a 2 deg bearing bin): on tuning seed 22
  // an object seen only through own returns held a right placement back to the end.
  objects::CoverageOptions map_coverage = {.shadow_margin_m = 1.0};
  // Absolute headings (msgs::ObjectMap::map_heading_rad, both maps): a teammate whose loops
  // imply a rotation more than this from the headings' difference is not placed (a grid
  // turned 180 deg), nor placed through a teammate's chain. <= 0: off.
  double max_heading_gap_rad = objects::kDefaultMaxHeadingGapRad;  // 15 deg
  // The placed teammate is turned about the centroid of its keyframes in accepted loops by
  // this fraction of the gap between the rotation its placement has and the headings'
  // difference (0: off). Loops fix the placement where the paths meet, but their rotation is
  // that of the two maps there, which bend by a few degrees against their whole-mission frames;
  // the headings (map_heading_from_keyframes) measure the whole-mission rotation, with the
  // AHRS's errors.
  double placement_heading_weight = 0.0;
  // With placement_heading_weight 0, the fraction follows how much of the two missions the
  // loops span: u / (u + placement_heading_variance_ratio), u = (1 - s_own) + (1 - s_mate),
  // s = the time span of the keyframes the loops name over that of the robot's keyframes so
  // far. Loops that span both missions fix the whole-mission rotation (no turn); loops at one
  // instant of each carry both maps' local heading errors there (u = 2). The ratio is the
  // headings' difference's variance in units of one map's local heading variance (0: off);
  // 4 from tuning seeds 1-10, the marina and the airplane (docs/safe-merges.md).
  double placement_heading_variance_ratio = 4.0;
  // A teammate whose map reaches far from where its loops hold it waits: its rotation is
  // uncertain by about sigma sqrt(u R / (u + R)) (sigma one map's local heading error, R the
  // ratio above; sqrt(u) without both headings or with the ratio 0), and that rotation moves
  // its keyframes by their distance from the loops' teammate-keyframe centroid. The lever
  // L sqrt(u R / (u + R)), L the RMS of that distance over the teammate's keyframes so far,
  // must not exceed this (<= 0: off); a teammate beyond it is not placed, or is withdrawn.
  // 52 m from tuning seeds 1-10, the marina and the airplane (docs/safe-merges.md): with one
  // map's local heading error of ~2 deg, about the judge's 2 m at the teammate's keyframes.
  double max_rotation_lever_m = 52.0;
  // A placed teammate is moved onto the own object map: its small objects (length at most
  // refine_max_length_m) placed by the estimate, each paired with the nearest small own object
  // within refine_gate_m, and the estimate replaced by the rigid fit of the pairs
  // (objects::RefineUnderTransform) when at least refine_min_pairs pairs hold it and the fit
  // moves the teammate's keyframes by an RMS of at most refine_max_move_m. Loops tie the maps
  // where the keyframes they name are; the objects gather every keyframe that saw them.
  // 0: off (docs/safe-merges.md, "The placement on the object maps": fewer wrong at the end,
  // larger excursions on the way, on worlds nobody tuned on).
  int refine_min_pairs = 0;
  double refine_gate_m = 1.5;
  double refine_max_length_m = 8.0;
  double refine_max_move_m = 3.0;
  bool refine_rotation = true;  // false: the refinement shifts the placement, never turns it
  // > 0: move only the fraction pairs / (pairs + this) of the way to the objects' fit (few
  // pairs, a small step; 0: all the way).
  double refine_blend_pairs = 0.0;
};

// The map-level check of one teammate's placement (OptimizerStageOptions::max_map_miss_fraction).
struct MapCheck {
  msgs::Pose2 T_own_teammate;       // the transform the accepted loops imply
  objects::PointSupport support;    // teammate objects on own points (decides)
  objects::MapAgreement agreement;  // objects against objects, both ways (logged)
  bool contradicted = false;        // the teammate is not placed
  // T_own_teammate's rotation minus the maps' headings' difference (NaN: a heading unknown);
  // beyond max_heading_gap_rad the teammate is not placed (contradicted).
  double heading_gap_rad = msgs::kUnknownHeading;
};

struct TeamEstimate {
  double time_s = 0.0;
  // Every robot's keyframe trajectory in the own map frame (own id included); teammates
  // without a map-to-map guess are absent.
  std::map<int, std::vector<msgs::KeyframePose>> trajectories;
  std::map<int, msgs::Pose2> T_own_teammate;  // current map-to-map estimates
  // The map-level check of each teammate whose loops pass the evidence rules, this step.
  std::map<int, MapCheck> map_checks;
  // The rotation lever (OptimizerStageOptions::max_rotation_lever_m) of each teammate whose
  // loops pass the evidence rules, this step.
  std::map<int, double> rotation_lever_m;
  // Why each teammate with accepted loops is not placed, this step: "loops" (fewer than
  // min_teammate_loops), "keyframes" (min_distinct_keyframes), "rival" (competitor_ratio),
  // "map" (the map check contradicts it), "lever" (max_rotation_lever_m), "mutual"
  // (mutual_placement_max_gap_m: not placed by it, or the two disagree), "settling"
  // (settle_s: the placement has not held long enough).
  std::map<int, std::string> held;
  int loops_in_pgo = 0;  // accepted loops the problem held (max_loops_per_teammate_keyframe)
};

class OptimizerStage {
 public:
  explicit OptimizerStage(const OptimizerStageOptions& options);
  void OnKeyframe(const msgs::Keyframe& keyframe) { own_.OnKeyframe(keyframe); }
  void OnTrajectory(const msgs::KeyframeTrajectory& t) { own_.OnTrajectory(t); }
  void OnKeyframePoses(const msgs::KeyframePoses& poses);
  // A teammate's loop-verified map-to-map estimates. A robot the own matching did not place
  // (or placed without accepted loops) gets the guess T_own_robot = T_own_s * T_s_robot
  // through a teammate s with verified loops; it is placed on that alone only with
  // place_chained_teammates.
  void OnTeammateTransforms(const msgs::TeammateTransforms& transforms);
  // The object maps for the map-level check (max_map_miss_fraction).
  void OnOwnObjectMap(const msgs::ObjectMap& map) { own_objects_ = map; }
  void OnTeammateObjectMap(const msgs::FleetHeader& header, const msgs::ObjectMap& map);
  void Forget(int robot);
  // candidates: the filter's set after this step (accepted ones flagged).
  void Step(double now_s, const std::vector<msgs::InterRobotLoop>& candidates,
            const msgs::MapMatches& matches, msgs::TeamStepStats* stats);
  const TeamEstimate& estimate() const { return estimate_; }
  // Own map-to-map estimates of the teammates with accepted loops, to share (ascending id).
  std::vector<msgs::Heartbeat::Transform> SharedTransforms() const;
  const TeammatePoses& teammate_poses() const { return poses_; }

 private:
  // True when candidates the filter did not accept form a rival hypothesis for `robot`
  // (OptimizerStageOptions::competitor_ratio).
  bool Contested(int robot, const std::vector<msgs::InterRobotLoop>& candidates) const;
  // Whether the last PGO's solution may start this one (OptimizerStageOptions::warm_reset_*).
  bool WarmStillHolds(const team::TeamProblem& problem,
                      const std::set<std::pair<int, std::uint64_t>>& loop_keys) const;
  // The object maps' agreement under the transform the accepted loops with `robot` imply;
  // nullopt when there is nothing to compare (no map, no loop with known poses).
  // Turns a placed teammate toward the headings' rotation by HeadingTurnFraction.
  void TurnTowardHeadings(int robot, const team::TeamProblem& problem,
                          std::vector<msgs::Pose2>* poses) const;
  // Moves a placed teammate onto the own object map (OptimizerStageOptions::refine_*).
  void RefineOnObjects(int robot, std::vector<msgs::Pose2>* poses) const;
  // The fraction TurnTowardHeadings turns by (placement_heading_weight, or the loops' spans).
  double HeadingTurnFraction(int robot, const team::TeamProblem& problem) const;
  // u of placement_heading_variance_ratio: the fractions of the own and the teammate's
  // missions so far that the keyframes of these loops (own, teammate keyframe) do not span.
  double Unspanned(int robot, const std::vector<std::pair<int, int>>& own_mate_keyframes) const;
  // OptimizerStageOptions::mutual_placement_max_gap_m's gap: the RMS distance the own keyframes
  // move under T_own_mate * T_mate_own, T_mate_own as `robot` shared it (infinity: not shared).
  double MutualGap(int robot, const msgs::Pose2& T_own_mate,
                   const std::vector<msgs::Pose2>& own_poses,
                   const std::vector<bool>& own_real) const;
  // Whether `robot`'s placement T_own_mate, solved at now_s, has held (settle_s); records it.
  bool Settled(int robot, double now_s, const msgs::Pose2& T_own_mate);
  // On a step that does not solve: places the held teammates whose placement has now held
  // (settle_s), through the mutual check (mutual_placement_max_gap_m) as a solving step does.
  void PlaceSettled(double now_s, const std::vector<msgs::Pose2>& own_poses,
                    const std::vector<bool>& own_real);
  // OptimizerStageOptions::max_rotation_lever_m's lever for `robot`'s accepted loops.
  double RotationLever(int robot, const std::vector<msgs::InterRobotLoop>& candidates) const;
  std::optional<MapCheck> CheckMaps(int robot, const std::vector<msgs::InterRobotLoop>& candidates,
                                    const OwnSonar& own_view) const;

  OptimizerStageOptions options_;
  OwnKeyframes own_;
  TeammatePoses poses_;
  Roster roster_;
  std::uint64_t seen_own_version_ = ~std::uint64_t{0};
  bool own_graph_changed_ = true;
  std::map<int, bool> graph_changed_;  // per teammate, since the last PGO
  std::map<int, std::uint32_t> match_counts_;
  std::vector<std::uint64_t> accepted_ids_;  // after the last step, ascending
  bool accepted_changed_ = false;
  double last_optimize_s_;
  bool optimized_once_ = false;
  std::map<int, team::WarmStart> warm_;  // the last PGO's robots with loops, and the own one
  // What the last PGO stood on: its loops (own robot, id) and the teammates' map guesses.
  std::set<std::pair<int, std::uint64_t>> warm_loops_;
  std::map<int, msgs::Pose2> warm_guesses_;
  TeamEstimate estimate_;
  std::map<int, std::vector<msgs::Heartbeat::Transform>> shared_;  // by sender
  std::set<int> loop_verified_;                                    // after the last step
  // Loop-verified teammates waiting for mutual placement: T_own_teammate, shared, not placed.
  std::map<int, msgs::Pose2> unconfirmed_;
  // Loop-verified teammates whose placement has not settled (settle_s): shared, not placed;
  // a step that does not solve places one once its standing placement has held.
  struct Settling {
    msgs::Pose2 T_own_teammate;
    std::vector<msgs::KeyframePose> trajectory;
  };
  std::map<int, Settling> settling_;
  // Per teammate, the solved placements of the last settle_s (and the last one before).
  std::map<int, std::deque<std::pair<double, msgs::Pose2>>> placements_;
  msgs::ObjectMap own_objects_;
  struct HeldObjects {
    double time_s = 0.0;  // when the teammate sent it: its coverage is counted up to then
    msgs::ObjectMap map;
  };
  std::map<int, HeldObjects> teammate_objects_;
  OwnSonar own_view_;  // the map check's evidence
  // A teammate's coverage, rebuilt when its poses or its map's time change.
  struct MateCoverage {
    std::uint64_t poses_seq = ~std::uint64_t{0};
    double map_time_s = -1.0;
    objects::Coverage coverage;
  };
  std::map<int, std::uint64_t> poses_seq_;  // per teammate: KeyframePoses messages taken
  mutable std::map<int, MateCoverage> mate_coverage_;
};

}  // namespace draco::agent
