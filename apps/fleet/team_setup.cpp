#include "team_setup.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <stdexcept>

namespace draco::fleet_app {
namespace fs = std::filesystem;

namespace {

std::string List(const std::vector<std::string>& items) {
  std::string s = "[";
  for (std::size_t i = 0; i < items.size(); ++i) s += (i ? ", " : "") + items[i];
  return s + "]";
}

// The shortest text that reads back as the same double (the value draco-sim was given).
std::string Shortest(double v) {
  char buffer[40];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return std::string(buffer, result.ptr);
}

bool Airplane(const std::string& world) { return world.find("airplane") != std::string::npos; }

// Components of a graph file, includes first (depth first, as the loader does).
void CollectComponents(const fs::path& file, std::vector<YAML::Node>* out, int depth) {
  if (depth > 8) throw std::runtime_error(file.string() + ": includes nested too deeply");
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(file.string() + ": " + e.what());
  }
  if (const auto inc = root["include"]) {
    std::vector<std::string> names;
    if (inc.IsScalar()) names.push_back(inc.as<std::string>());
    if (inc.IsSequence()) {
      for (const auto& i : inc) names.push_back(i.as<std::string>());
    }
    for (const auto& n : names) CollectComponents(file.parent_path() / n, out, depth + 1);
  }
  if (const auto comps = root["components"]) {
    if (!comps.IsSequence()) throw std::runtime_error(file.string() + ": components: a list");
    for (const auto& c : comps) out->push_back(c);
  }
}

}  // namespace

std::vector<std::string> RobotOverrides(const RobotSetup& s, const std::string& p) {
  const std::string name = s.team.at(static_cast<std::size_t>(s.robot_id));
  std::vector<std::string> ids;
  for (std::size_t i = 0; i < s.team.size(); ++i) ids.push_back(std::to_string(i));
  std::vector<std::string> o;
  if (!s.simulate.empty()) {
    o = {p + "reader.mission=" + s.simulate, p + "reader.robot=" + name};
    if (s.simulate_duration_s > 0.0) {
      o.push_back(p + "reader.duration_s=" + Shortest(s.simulate_duration_s));
    }
  } else if (s.bag.empty()) {
    o = {p + "reader.recording=" + s.mission_dir, p + "reader.robot=" + name};
  } else {
    o = {p + "reader.bag=" + s.bag};
  }
  const std::vector<std::string> common = {
      p + "slam.prefix=" + name + ".",
      p + "truth.file=" + name + ".ground_truth.tum",
      p + "mapper.robot_id=" + std::to_string(s.robot_id),
      p + "matcher.robot_id=" + std::to_string(s.robot_id),
      p + "exchange.robot_id=" + std::to_string(s.robot_id),
      p + "filter.robot_id=" + std::to_string(s.robot_id),
      p + "optimizer.robot_id=" + std::to_string(s.robot_id),
      p + "mapper.prefix=" + name + ".",
      p + "matcher.prefix=" + name + ".",
      p + "exchange.prefix=" + name + ".",
      p + "filter.prefix=" + name + ".",
      p + "optimizer.prefix=" + name + ".",
      p + "optimizer.team_names=" + List(s.team),
      p + "monitor.robot=" + name,
      p + "monitor.team_names=" + List(s.team),
      p + "link.robot_id=" + std::to_string(s.robot_id),
      p + "link.team=" + List(ids),
      p + "link.prefix=" + name + ".",
      p + "link.transport=" + s.transport,
      p + "link.bus=" + s.bus,
      p + "link.lockstep=" + std::string(s.lockstep ? "true" : "false"),
  };
  o.insert(o.end(), common.begin(), common.end());
  if (s.domain_id >= 0) o.push_back(p + "link.domain_id=" + std::to_string(s.domain_id));
  if (!s.dds_config.empty()) o.push_back(p + "link.dds_config=" + s.dds_config);
  if (!s.udp_peers.empty()) {
    std::string quoted = "[";  // host:port quoted: a YAML flow list of strings
    for (std::size_t i = 0; i < s.udp_peers.size(); ++i) {
      quoted += (i ? ", \"" : "\"") + s.udp_peers[i] + "\"";
    }
    o.push_back(p + "link.udp_peers=" + quoted + "]");
  }
  if (s.udp_port > 0) o.push_back(p + "link.udp_port=" + std::to_string(s.udp_port));
  if (s.ros2_domain_id >= 0) {
    o.push_back(p + "monitor.enabled=true");
    o.push_back(p + "monitor.domain_id=" + std::to_string(s.ros2_domain_id));
    if (!s.ros2_dds_config.empty()) o.push_back(p + "monitor.dds_config=" + s.ros2_dds_config);
  }
  if (Airplane(s.world)) {
    // As draco-team-eval: nearer candidates on the airplane (docs/front-end.md).
    o.push_back(p + "exchange.candidate_radius_m=20");
    o.push_back(p + "exchange.candidate_max_yaw_rad=" + std::to_string(std::numbers::pi / 2));
  }
  return o;
}

std::string ComposeTeamGraph(const std::string& robot_graph_path,
                             const std::vector<std::string>& team) {
  std::vector<YAML::Node> comps;
  CollectComponents(robot_graph_path, &comps, 0);
  YAML::Emitter e;
  e << YAML::BeginMap << YAML::Key << "schema" << YAML::Value << 1;
  e << YAML::Key << "name" << YAML::Value << "team";
  e << YAML::Key << "executor" << YAML::Value << "deterministic";
  e << YAML::Key << "components" << YAML::Value << YAML::BeginSeq;
  for (const auto& robot : team) {
    for (const auto& c : comps) {
      try {
        if (!c.IsMap() || !c["id"] || !c["type"]) {
          throw std::runtime_error(robot_graph_path + ": a component without id or type");
        }
        e << YAML::BeginMap;
        e << YAML::Key << "id" << YAML::Value << robot + "_" + c["id"].as<std::string>();
        e << YAML::Key << "type" << YAML::Value << c["type"].as<std::string>();
        if (const auto in = c["inputs"]) {
          e << YAML::Key << "inputs" << YAML::Value << YAML::BeginMap;
          for (const auto& kv : in) {
            e << YAML::Key << kv.first.as<std::string>() << YAML::Value
              << robot + "_" + kv.second.as<std::string>();
          }
          e << YAML::EndMap;
        }
        if (const auto params = c["params"]) e << YAML::Key << "params" << YAML::Value << params;
        e << YAML::EndMap;
      } catch (const YAML::Exception& ex) {
        throw std::runtime_error(robot_graph_path + " (or a graph it includes): line " +
                                 std::to_string(ex.mark.line + 1) + ": " + ex.msg);
      }
    }
  }
  e << YAML::EndSeq << YAML::EndMap;
  return e.c_str();
}

double MissionLengthS(const std::string& mission_dir, const std::vector<std::string>& team) {
  double t = 0.0;
  for (const auto& r : team) {
    t = std::max(t, recording::RobotReplayLengthS(mission_dir, r));
  }
  return t;
}

}  // namespace draco::fleet_app
