#include "team_setup.hpp"

#include <yaml-cpp/yaml.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "draco/eval/trajectory.hpp"

namespace draco::fleet_app {
namespace fs = std::filesystem;

namespace {

std::string List(const std::vector<std::string>& items) {
  std::string s = "[";
  for (std::size_t i = 0; i < items.size(); ++i) s += (i ? ", " : "") + items[i];
  return s + "]";
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

double LastTimeS(const std::string& path) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) return 0.0;
  const std::streamoff size = f.tellg();
  const std::streamoff start = std::max<std::streamoff>(0, size - 4096);
  f.seekg(start);
  std::string tail(static_cast<std::size_t>(size - start), '\0');
  f.read(tail.data(), static_cast<std::streamsize>(tail.size()));
  while (!tail.empty() && (tail.back() == '\n' || tail.back() == '\r')) tail.pop_back();
  const auto nl = tail.rfind('\n');
  try {
    return std::stod(tail.substr(nl == std::string::npos ? 0 : nl + 1));
  } catch (const std::exception&) {
    return 0.0;
  }
}

eval::Trajectory ReadIfExists(const fs::path& p) {
  if (!fs::exists(p)) return {};
  return eval::ReadTum(p.string());
}

}  // namespace

std::vector<std::string> RobotOverrides(const RobotSetup& s, const std::string& p) {
  const std::string name = s.team.at(static_cast<std::size_t>(s.robot_id));
  std::vector<std::string> ids;
  for (std::size_t i = 0; i < s.team.size(); ++i) ids.push_back(std::to_string(i));
  std::vector<std::string> o = {
      p + "reader.recording=" + s.mission_dir,
      p + "reader.robot=" + name,
      p + "slam.prefix=" + name + ".",
      p + "truth.file=" + name + ".ground_truth.tum",
      p + "agent.robot_id=" + std::to_string(s.robot_id),
      p + "agent.prefix=" + name + ".",
      p + "agent.team_names=" + List(s.team),
      p + "link.robot_id=" + std::to_string(s.robot_id),
      p + "link.team=" + List(ids),
      p + "link.prefix=" + name + ".",
      p + "link.transport=" + s.transport,
      p + "link.bus=" + s.bus,
      p + "link.domain_id=" + std::to_string(s.domain_id),
      p + "link.lockstep=" + std::string(s.lockstep ? "true" : "false"),
  };
  if (!s.dds_config.empty()) o.push_back(p + "link.dds_config=" + s.dds_config);
  if (Airplane(s.world)) {
    // As draco-team-eval: nearer candidates on the airplane (docs/front-end.md).
    o.push_back(p + "agent.candidate_radius_m=20");
    o.push_back(p + "agent.candidate_max_yaw_rad=" + std::to_string(std::numbers::pi / 2));
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
    }
  }
  e << YAML::EndSeq << YAML::EndMap;
  return e.c_str();
}

double MissionLengthS(const std::string& mission_dir, const std::vector<std::string>& team) {
  double t = 0.0;
  for (const auto& r : team) {
    t = std::max(t, LastTimeS((fs::path(mission_dir) / r / "ahrs.csv").string()));
  }
  return t;
}

TeamResult EvaluateTeamRun(const std::string& run_dir, const std::string& mission_dir,
                           const std::vector<std::string>& team) {
  constexpr double kSegmentOffsetS = 1e5;
  TeamResult out;
  std::map<std::string, KindSizes> kinds;
  std::vector<std::string> kind_order;
  const fs::path dir(run_dir);
  std::vector<eval::Trajectory> truth(team.size());
  for (std::size_t i = 0; i < team.size(); ++i) {
    truth[i] = ReadIfExists(fs::path(mission_dir) / team[i] / "groundtruth.tum");
  }
  for (std::size_t i = 0; i < team.size(); ++i) {
    const std::string& name = team[i];
    RobotResult r;
    r.name = name;
    const auto local = ReadIfExists(dir / (name + ".trajectory.tum"));
    const auto dr = ReadIfExists(dir / (name + ".dead_reckoning.tum"));
    r.keyframes = static_cast<int>(local.size());
    if (!local.empty() && !truth[i].empty()) {
      r.local_ate_m = eval::Ate(local, truth[i]).rmse_m;
      r.dr_ate_m = eval::Ate(dr, truth[i]).rmse_m;
      r.mission_s = local.back().time_s - local.front().time_s;
    }
    // The paper's protocol: own trajectory, then the teammates' in mission order, each segment
    // shifted in time, one SE(2) alignment.
    eval::Trajectory est_all, truth_all;
    int segment = 0;
    auto append = [&](const eval::Trajectory& est, const eval::Trajectory& gt) {
      for (auto p : est) {
        p.time_s += segment * kSegmentOffsetS;
        est_all.push_back(p);
      }
      for (auto p : gt) {
        p.time_s += segment * kSegmentOffsetS;
        truth_all.push_back(p);
      }
      ++segment;
    };
    std::vector<std::size_t> order{i};
    for (std::size_t j = 0; j < team.size(); ++j) {
      if (j != i) order.push_back(j);
    }
    for (std::size_t j : order) {
      const auto est = ReadIfExists(dir / (name + ".team." + team[j] + ".tum"));
      if (est.empty() || truth[j].empty()) continue;
      ++r.placed;
      append(est, truth[j]);
    }
    if (!est_all.empty()) r.team_ate_m = eval::Ate(est_all, truth_all).rmse_m;
    if (std::ifstream f(dir / (name + ".inter_loops.csv")); f) {
      std::string line;
      std::getline(f, line);
      while (std::getline(f, line)) {
        if (line.empty()) continue;
        ++r.candidates;
        if (line.back() == '1') ++r.accepted;
      }
    }
    if (std::ifstream f(dir / (name + ".link_stats.json")); f) {
      nlohmann::json j;
      try {
        j = nlohmann::json::parse(f);
      } catch (const std::exception& e) {
        throw std::runtime_error((dir / (name + ".link_stats.json")).string() + ": " + e.what());
      }
      for (const auto& [kind, v] : j["kinds"].items()) {
        auto& k = kinds[kind];
        if (k.kind.empty()) {
          k.kind = kind;
          kind_order.push_back(kind);
        }
        k.frames += v["frames_sent"].get<double>();
        k.bits += v["bits_sent"].get<double>();
        k.max_bits = std::max(k.max_bits, v["max_bits"].get<double>());
        k.dropped += v["dropped_queue"].get<double>() + v["dropped_expired"].get<double>() +
                     v["lost"].get<double>();
        k.rejected += v["rejected"].get<double>();
        r.bits_sent += v["bits_sent"].get<double>();
      }
      for (const auto& t : j["teammates"]) {
        const int id = t["robot_id"].get<int>();
        const std::string tn =
            id >= 0 && id < static_cast<int>(team.size()) ? team[id] : std::to_string(id);
        r.teammate_frames[tn] = t["frames_received"].get<double>();
        r.restarts_seen += t.value("restarts", 0);
      }
    }
    if (r.mission_s > 0) r.mean_bps = r.bits_sent / r.mission_s;
    out.robots.push_back(r);
  }
  for (const auto& k : kind_order) out.kinds.push_back(kinds[k]);
  return out;
}

std::string FormatTeamResult(const TeamResult& t, const std::string& title) {
  std::ostringstream o;
  char line[256];
  o << title << "\n";
  std::snprintf(line, sizeof line, "%-9s %5s %8s %8s %8s %6s %6s %6s %9s %8s\n", "robot", "kfs",
                "DR m", "local m", "team m", "placed", "cand", "accept", "sent kbit", "mean bps");
  o << line;
  for (const auto& r : t.robots) {
    std::snprintf(line, sizeof line, "%-9s %5d %8.3f %8.3f %8.3f %6d %6d %6d %9.1f %8.0f\n",
                  r.name.c_str(), r.keyframes, r.dr_ate_m, r.local_ate_m, r.team_ate_m, r.placed,
                  r.candidates, r.accepted, r.bits_sent / 1000.0, r.mean_bps);
    o << line;
  }
  std::snprintf(line, sizeof line, "\n%-15s %7s %10s %9s %8s %8s\n", "message", "frames",
                "mean bits", "max bits", "dropped", "rejected");
  o << line;
  for (const auto& k : t.kinds) {
    std::snprintf(line, sizeof line, "%-15s %7.0f %10.0f %9.0f %8.0f %8.0f\n", k.kind.c_str(),
                  k.frames, k.frames > 0 ? k.bits / k.frames : 0.0, k.max_bits, k.dropped,
                  k.rejected);
    o << line;
  }
  return o.str();
}

std::string TeamResultMarkdown(const TeamResult& t) {
  std::ostringstream o;
  char line[256];
  o << "| robot | keyframes | DR ATE m | local ATE m | team ATE m | robots placed | candidates "
       "| accepted | sent kbit | mean bps |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : t.robots) {
    std::snprintf(line, sizeof line,
                  "| %s | %d | %.3f | %.3f | %.3f | %d | %d | %d | %.1f | %.0f |\n", r.name.c_str(),
                  r.keyframes, r.dr_ate_m, r.local_ate_m, r.team_ate_m, r.placed, r.candidates,
                  r.accepted, r.bits_sent / 1000.0, r.mean_bps);
    o << line;
  }
  o << "\n| message | frames | mean bits | max bits | dropped | rejected "
       "|\n|---|---|---|---|---|---|\n";
  for (const auto& k : t.kinds) {
    std::snprintf(line, sizeof line, "| %s | %.0f | %.0f | %.0f | %.0f | %.0f |\n", k.kind.c_str(),
                  k.frames, k.frames > 0 ? k.bits / k.frames : 0.0, k.max_bits, k.dropped,
                  k.rejected);
    o << line;
  }
  return o.str();
}

}  // namespace draco::fleet_app
