// One robot's inter-robot SLAM as a running system (DRACo-SLAM2 sections III-A to III-F),
// fed step by step with its own local SLAM and whatever teammates sent. No runtime, no link:
// the fleet.Link component owns encoding, deltas and liveness and hands this class decoded
// messages; the team.Agent component adapts it to the graph.
//
// Per Step(now_s):
//  1. Own object map from the own keyframes at their current poses (incremental DBSCAN,
//     ObjectMapper), published every object_map_period_s when it changed.
//  2. For each teammate whose object map changed since it was last matched: object-graph
//     matching (own map a, teammate map b). A match names the teammate objects; a scan
//     request for the keyframes that observed them is sent (at most max_scans, keyframes
//     already received not again).
//  3. Scans received since the last step: each is registered (sliding window) against the own
//     keyframes near it, seeded by the teammate's latest match transform; accepted
//     registrations are candidate loops.
//  4. Candidates enter the consistency filter (GCM by default, incremental, no time budget so
//     the answer does not depend on load); accepted loops are sent to the teammate involved.
//     Loops received from teammates (their registrations of our scans) are inverted and
//     filtered too.
//  5. Every optimize_period_s with new accepted loops: two-step PGO (own graph as a chain of
//     the local-SLAM poses, teammates' trajectories from the poses they shared); the estimate
//     holds every robot's trajectory in the own map frame.
//
// Serving requests: OnScanRequest queues replies for the own keyframes that observed the
// named objects (most named objects first, newest first, none under min_points, at most
// max_scans, each keyframe at most once per requester).
//
// Bounded memory per teammate: at most max_teammate_keyframes poses and max_teammate_scans
// scans held (oldest scans dropped first); a restarted teammate (new incarnation) is forgotten
// and re-learnt.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "draco/consistency/filter.hpp"
#include "draco/msgs/fleet.hpp"
#include "draco/msgs/map.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "draco/objects/object_mapper.hpp"
#include "draco/registration/registration.hpp"
#include "draco/team/team_pgo.hpp"

namespace draco::agent {

struct AgentOptions {
  int robot_id = 0;
  objects::ObjectMapperOptions mapper;
  objects::MatcherOptions matcher;
  registration::SelectionOptions selection;        // max_requests, min_points, candidates
  registration::RegistrationOptions registration;  // window 3, min_overlap 0.85
  consistency::FilterOptions filter;               // GCM; time_budget_ms forced to 0
  team::TwoStepOptions two_step;
  double object_map_period_s = 10.0;  // own object map published at most this often
  double match_period_s = 10.0;       // a teammate map is matched at most this often
  double optimize_period_s = 10.0;
  int max_scans_per_request = 20;
  // Map-to-map guess uncertainty used by GCM (sigmas).
  double map_sigma_m = 1.0;
  double map_sigma_rad = 0.05;
  // Place teammates in the estimate by the map-to-map guess alone, before any loop with them
  // is accepted (false: only teammates with accepted loops are placed).
  bool place_unverified_teammates = false;
  int max_teammate_keyframes = 20000;
  int max_teammate_scans = 400;
};

// What the agent wants sent after a step (the link encodes, queues and counts it).
struct Outbox {
  bool has_object_map = false;
  msgs::ObjectMap object_map;                  // own, full (the link makes the delta)
  std::vector<msgs::KeyframePoseEntry> poses;  // all own keyframes, current poses
  std::vector<msgs::ScanRequest> requests;
  std::vector<msgs::ScanReply> replies;
  std::vector<msgs::LoopClosureMessage> loops;
};

struct TeammateState {
  int robot_id = 0;
  std::uint32_t incarnation = 0;
  msgs::ObjectMap objects;
  std::vector<msgs::KeyframePoseEntry> keyframes;  // by index (index == position)
  bool matched = false;
  msgs::ObjectMatch last_match;  // the latest kMatched answer
  int scans_received = 0;
  int candidates = 0;
  int accepted = 0;
  // Entries dropped because they name a keyframe the agent does not hold (a scan reply or a
  // loop with an unknown keyframe, a pose index beyond max_teammate_keyframes) or are invalid.
  int ignored = 0;
};

struct AgentEstimate {
  double time_s = 0.0;
  // Every robot's keyframe trajectory in the own map frame (own id included); teammates
  // without a map-to-map guess (an own match, or the inverse of the transform in the
  // teammate's scan request) are absent.
  std::map<int, std::vector<msgs::KeyframePose>> trajectories;
  std::vector<msgs::InterRobotLoop> accepted;  // loops in the consistent set
  std::vector<msgs::InterRobotLoop> candidates;
  std::map<int, msgs::Pose2> T_own_teammate;  // current map-to-map estimates
};

// Work done in one step (the paper's Table II counts these).
struct StepStats {
  double time_s = 0.0;
  int matches_tried = 0;
  int matches_found = 0;
  int requests_sent = 0;
  int scans_registered = 0;
  int candidates_added = 0;
  int loops_accepted = 0;  // size of the consistent set after the step
  bool optimized = false;
  double wall_ms = 0.0;
};

class TeamAgent {
 public:
  explicit TeamAgent(const AgentOptions& options);
  ~TeamAgent();
  TeamAgent(const TeamAgent&) = delete;
  TeamAgent& operator=(const TeamAgent&) = delete;

  // Own local SLAM.
  void OnKeyframe(const msgs::Keyframe& keyframe);                // points (body frame)
  void OnTrajectory(const msgs::KeyframeTrajectory& trajectory);  // current poses

  // Teammates (already decoded and checked by the link; the header says who and which
  // incarnation). A new incarnation of a known teammate resets what was held of it.
  void OnTeammateObjectMap(const msgs::FleetHeader& header, const msgs::ObjectMap& map);
  void OnKeyframePoses(const msgs::KeyframePoses& poses);
  void OnScanRequest(const msgs::ScanRequest& request);
  void OnScanReply(const msgs::ScanReply& reply);
  void OnLoopClosures(const msgs::LoopClosureMessage& message);
  void ForgetTeammate(int robot_id);

  Outbox Step(double now_s);

  const AgentEstimate& estimate() const;
  const std::vector<StepStats>& step_stats() const;
  const std::map<int, TeammateState>& teammates() const;
  msgs::ObjectMap OwnObjects() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace draco::agent
