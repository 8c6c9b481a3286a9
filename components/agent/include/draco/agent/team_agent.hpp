// One robot's inter-robot SLAM as one object: the five stages of stages.hpp chained in one
// step, fed with its own local SLAM and whatever teammates sent (already decoded by the link).
// The robot graph runs the same stages as separate components (team.ObjectMapper,
// team.GraphMatcher, team.ScanExchange, team.ConsistencyFilter, team.TwoStepOptimizer);
// this class gives tests and tools the whole chain without a runtime, and the same answers.
//
// Per Step(now_s): ObjectMapperStage, GraphMatcherStage, ScanExchangeStage,
// ConsistencyStage, OptimizerStage, in that order (stages.hpp says what each does).
// A teammate's new incarnation (in any message header) or ForgetTeammate() resets what every
// stage holds of it.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "draco/agent/stages.hpp"
#include "draco/msgs/fleet.hpp"
#include "draco/msgs/map.hpp"
#include "draco/msgs/team.hpp"

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
using StepStats = msgs::TeamStepStats;

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
  // A teammate's shared map-to-map estimates (heartbeats): placement and chained requests.
  void OnTeammateTransforms(const msgs::TeammateTransforms& transforms);
  // The own loop-verified map-to-map estimates to share (OptimizerStage::SharedTransforms).
  std::vector<msgs::Heartbeat::Transform> SharedTransforms() const;
  void ForgetTeammate(int robot_id);

  Outbox Step(double now_s);

  const AgentEstimate& estimate() const;
  const std::vector<StepStats>& step_stats() const;
  const std::map<int, TeammateState>& teammates() const;  // valid until the next call
  msgs::ObjectMap OwnObjects() const;

  // The stages, for tests.
  const ObjectMapperStage& mapper() const;
  const GraphMatcherStage& matcher() const;
  const ScanExchangeStage& exchange() const;
  const ConsistencyStage& consistency() const;
  const OptimizerStage& optimizer() const;

  // The options of each stage as AgentOptions sets them.
  static ObjectMapperStageOptions MapperOptions(const AgentOptions& o);
  static GraphMatcherStageOptions MatcherOptions(const AgentOptions& o);
  static ScanExchangeStageOptions ExchangeOptions(const AgentOptions& o);
  static ConsistencyStageOptions ConsistencyOptions(const AgentOptions& o);
  static OptimizerStageOptions OptimizerOptions(const AgentOptions& o);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace draco::agent
