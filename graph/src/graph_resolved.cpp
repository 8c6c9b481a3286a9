// The graph as loaded, as YAML (graph.hpp ResolvedYaml): every component with its inputs and
// every parameter's value, the in-code defaults included, so a run folder holds what ran.
#include <cmath>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "draco/graph/graph.hpp"

namespace draco::graph {
namespace {

void EmitParam(YAML::Emitter& out, const ParamDecl& p) {
  switch (p.type) {
    case ParamType::kBool:
      out << *static_cast<const bool*>(p.target);
      return;
    case ParamType::kInt:
      out << *static_cast<const int*>(p.target);
      return;
    case ParamType::kDouble:
      out << *static_cast<const double*>(p.target);
      return;
    case ParamType::kString:
      out << YAML::DoubleQuoted << *static_cast<const std::string*>(p.target);
      return;
    case ParamType::kDoubleList:
      out << YAML::Flow << *static_cast<const std::vector<double>*>(p.target);
      return;
    case ParamType::kIntList:
      out << YAML::Flow << *static_cast<const std::vector<int>*>(p.target);
      return;
    case ParamType::kStringList:
      out << YAML::Flow << YAML::BeginSeq;
      for (const auto& s : *static_cast<const std::vector<std::string>*>(p.target)) {
        out << YAML::DoubleQuoted << s;
      }
      out << YAML::EndSeq;
      return;
  }
}

// A graph file takes finite numbers only, so a parameter holding infinity or NaN holds its
// in-code default ("never", "off"): it is left out, which gives it back on loading.
bool Finite(const ParamDecl& p) {
  if (p.type == ParamType::kDouble) return std::isfinite(*static_cast<const double*>(p.target));
  if (p.type == ParamType::kDoubleList) {
    for (double v : *static_cast<const std::vector<double>*>(p.target)) {
      if (!std::isfinite(v)) return false;
    }
  }
  return true;
}

}  // namespace

std::string ResolvedYaml(const Graph& graph) {
  YAML::Emitter out;
  out.SetDoublePrecision(15);
  out << YAML::Comment(
      "The graph as it ran (" +
      (graph.source_file.empty() ? std::string("composed") : graph.source_file) +
      "): every component, its inputs and every parameter's value, defaults included. "
      "Runs again with: draco run <this file>");
  out << YAML::BeginMap;
  out << YAML::Key << "schema" << YAML::Value << 1;
  out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << graph.settings.name;
  out << YAML::Key << "executor" << YAML::Value << graph.settings.executor;
  out << YAML::Key << "rate" << YAML::Value << graph.settings.rate;
  out << YAML::Key << "threads" << YAML::Value << graph.settings.threads;
  out << YAML::Key << "components" << YAML::Value << YAML::BeginSeq;
  for (const auto& node : graph.nodes) {
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << node->id;
    out << YAML::Key << "type" << YAML::Value << node->type;
    // Inputs from the edges: consumer port -> producer_id/output.
    std::vector<std::pair<std::string, std::string>> inputs;
    for (const auto& e : graph.edges) {
      if (e.consumer != node->index) continue;
      const Node& producer = *graph.nodes[e.producer];
      inputs.emplace_back(node->inputs[e.input]->name(),
                          producer.id + "/" + producer.outputs[e.output]->name());
    }
    if (!inputs.empty()) {
      out << YAML::Key << "inputs" << YAML::Value << YAML::Flow << YAML::BeginMap;
      for (const auto& [port, from] : inputs) out << YAML::Key << port << YAML::Value << from;
      out << YAML::EndMap;
    }
    if (!node->params.empty()) {
      out << YAML::Key << "params" << YAML::Value << YAML::BeginMap;
      for (const auto& p : node->params) {
        if (!Finite(p)) {
          out << YAML::Comment(p.name + ": not finite, the in-code default");
          continue;
        }
        out << YAML::Key << p.name << YAML::Value;
        EmitParam(out, p);
      }
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace draco::graph
