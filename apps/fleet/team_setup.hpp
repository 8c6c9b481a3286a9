// What draco-robot (one daemon per robot) and draco-fleet (a whole team) share: the
// per-robot settings of the robot graph, the in-process team graph, and the evaluation of a
// team run's outputs (team ATE with the paper's concatenation protocol, link statistics).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "draco/recording/recording.hpp"

namespace draco::fleet_app {

struct RobotSetup {
  std::string mission_dir;
  std::vector<std::string> team;  // robot names in mission order; the id is the position
  int robot_id = 0;
  std::string world;              // the mission's world (selection radius on the airplane)
  std::string transport = "dds";  // or "inproc"
  std::string bus = "team";
  int domain_id = 0;
  std::string dds_config;
  bool lockstep = true;
};

// Overrides "component.param=value" that make the robot graph run robot `robot_id`; ids are
// prefixed with id_prefix (the in-process team graph's "alpha_", "" for a daemon).
std::vector<std::string> RobotOverrides(const RobotSetup& setup, const std::string& id_prefix);

// The in-process team graph: the robot graph (includes resolved) once per robot, component ids
// prefixed "<robot>_", as YAML text to load with graph::LoadGraphString.
std::string ComposeTeamGraph(const std::string& robot_graph_path,
                             const std::vector<std::string>& team);

// Mission time of the longest robot replay (for progress), from the AHRS streams.
double MissionLengthS(const std::string& mission_dir, const std::vector<std::string>& team);

// A team run's outputs in one folder (files <robot>.*), evaluated against ground truth.
struct RobotResult {
  std::string name;
  int keyframes = 0;
  double dr_ate_m = -1.0;     // own dead reckoning
  double local_ate_m = -1.0;  // own local SLAM
  double team_ate_m = -1.0;   // own + placed teammates, concatenated, one SE(2) alignment
  int placed = 0;             // robots in the estimate (own included)
  int candidates = 0;         // inter-robot loop candidates
  int accepted = 0;           // accepted by the consistency filter
  double mission_s = 0.0;
  // Link (from <robot>.link_stats.json)
  double bits_sent = 0.0;
  double mean_bps = 0.0;
  int restarts_seen = 0;                          // teammate restarts this robot noticed
  std::map<std::string, double> teammate_frames;  // frames received per teammate name
};
struct KindSizes {
  std::string kind;
  double frames = 0.0;
  double bits = 0.0;
  double max_bits = 0.0;
  double dropped = 0.0;
  double rejected = 0.0;
};
struct TeamResult {
  std::vector<RobotResult> robots;
  std::vector<KindSizes> kinds;  // summed over robots
};
TeamResult EvaluateTeamRun(const std::string& run_dir, const std::string& mission_dir,
                           const std::vector<std::string>& team);
// Tables: per robot (ATE, loops, traffic), message sizes per kind (mean and max bits).
std::string FormatTeamResult(const TeamResult& result, const std::string& title);
std::string TeamResultMarkdown(const TeamResult& result);

}  // namespace draco::fleet_app
