// What draco-robot (one daemon per robot) and draco-fleet (a whole team) share: the
// per-robot settings of the robot graph and the in-process team graph.
#pragma once

#include <string>
#include <vector>

#include "draco/recording/recording.hpp"

namespace draco::fleet_app {

struct RobotSetup {
  std::string mission_dir;           // a recorded mission, or
  std::string bag;                   // a ROS 1 bag (then team comes from the command line), or
  std::string simulate;              // a mission YAML simulated live (graph robot-live.yaml)
  double simulate_duration_s = 0.0;  // > 0: cap of each robot's duration (draco-sim --duration-s)
  std::vector<std::string> team;     // robot names in mission order; the id is the position
  int robot_id = 0;
  std::string world;              // the mission's world (selection radius on the airplane)
  std::string transport = "dds";  // or "udp", "inproc"
  std::string bus = "team";
  int domain_id = -1;  // DDS domain; < 0: the graph's (link.domain_id)
  std::string dds_config;
  std::vector<std::string> udp_peers;  // transport udp: host:port or host of every teammate
  int udp_port = -1;                   // transport udp; < 0: the graph's (link.udp_port)
  int ros2_domain_id = -1;  // >= 0: fleet.Ros2Monitor on, on this domain (never the link's)
  std::string ros2_dds_config;
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

// The evaluation of a team run's outputs (EvaluateTeamRun, FormatTeamResult,
// TeamResultMarkdown) lives in the report library: draco/report/team_run.hpp.

}  // namespace draco::fleet_app
