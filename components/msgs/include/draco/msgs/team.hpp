// Messages between the stages of a robot's team pipeline (graph ports, not link traffic):
//   team.ObjectMapper -> team.GraphMatcher -> team.ScanExchange -> team.ConsistencyFilter
//   -> team.TwoStepOptimizer
// Each stage publishes its chain message once per agent step, stamped with the step time, so
// the next stage runs the same step with this step's results (docs/fleet.md).
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include "draco/msgs/loops.hpp"
#include "draco/msgs/map.hpp"
#include "draco/msgs/objects.hpp"

namespace draco::msgs {

// Work done in one agent step, filled in along the chain (agent_steps.csv; the paper's
// Table II counts these). wall_ms sums the stages' processing times.
struct TeamStepStats {
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

// The own object map after a step (every step; version counts its changes).
struct OwnObjectMap {
  std::uint64_t version = 0;
  ObjectMap map;
  TeamStepStats step;
};

// What is known of where a teammate's map frame lies in the own one.
struct MapGuess {
  int robot_id = 0;
  bool matched = false;           // own object-graph matching found it
  ObjectMatch match;              // the latest kMatched answer (T_a_b = T_own_teammate)
  std::uint32_t match_count = 0;  // kMatched answers so far (a new one moves the estimate)
  bool has_reverse = false;       // the inverse of the teammate's scan-request transform
  Pose2 T_own_teammate_reverse;
  // No own match: T_own_c * T_c_teammate through a matched teammate c that verified the
  // teammate by loops and shared its estimate (GraphMatcherStage).
  bool chained = false;
  int chained_via = -1;
  Pose2 T_own_teammate_chained;
  // The teammate object map's absolute heading (ObjectMap::map_heading_rad; kUnknownHeading
  // when unknown): team.ScanExchange holds registrations to the headings with it.
  double teammate_map_heading_rad = kUnknownHeading;
};

// Map-to-map guesses after a step's matching, per teammate (ascending id).
struct MapMatches {
  std::map<int, MapGuess> guesses;
  TeamStepStats step;
};

// New candidate loops registered in a step (ids not assigned yet: the filter numbers them).
struct CandidateLoops {
  std::vector<InterRobotLoop> loops;
  MapMatches matches;  // passed on: the filter and the optimizer need the guesses
};

// Every candidate loop held after a step, flags kLoopAccepted / kLoopRejected set.
struct TeamLoops {
  std::vector<InterRobotLoop> candidates;  // ascending id
  MapMatches matches;
};

// The guess a stage uses: the own match, else the reverse of the teammate's.
inline const Pose2* GuessOf(const MapMatches& m, int robot) {
  const auto it = m.guesses.find(robot);
  if (it == m.guesses.end()) return nullptr;
  if (it->second.matched) return &it->second.match.T_a_b;
  if (it->second.has_reverse) return &it->second.T_own_teammate_reverse;
  if (it->second.chained) return &it->second.T_own_teammate_chained;
  return nullptr;
}

// The team estimate after a two-step PGO: every placed robot's keyframes in the own map frame
// (own robot included; teammates not placed are absent). team.TwoStepOptimizer publishes it
// whenever it optimised; fleet.Ros2Monitor shows it.
struct TeamTrajectories {
  double time_s = 0.0;
  int own_robot = 0;
  std::map<int, std::vector<KeyframePose>> trajectories;
};

}  // namespace draco::msgs
