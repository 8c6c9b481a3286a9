// Parameter values of a loaded graph's components: a YAML value checked against the declared
// type, range and choices, and the command line's --set component_id.param=value overrides.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <string>
#include <vector>

#include "draco/graph/graph.hpp"
#include "graph_loader.hpp"

namespace draco::graph::detail {

void Loader::SetParam(Node& node, const std::string& name, const YAML::Mark& key_mark,
                      const YAML::Node& value, const std::string& file) {
  const ParamDecl* decl = node.FindParam(name);
  if (decl == nullptr) {
    std::vector<std::string> names;
    for (const auto& p : node.params) names.push_back(p.name);
    Error(file, key_mark,
          "component '" + node.id + "' (" + node.type + ") has no parameter '" + name + "'; " +
              Expected(names, name));
    return;
  }
  std::string problem = Assign(*decl, value);
  if (!problem.empty()) {
    Error(file, value.Mark(), "parameter '" + name + "' of '" + node.id + "': " + problem);
  }
}

// Returns "" on success, otherwise what was expected.
std::string Loader::Assign(const ParamDecl& decl, const YAML::Node& value) {
  const std::string expect = std::string("expected ") + ParamTypeName(decl.type);
  auto check_range = [&](double v) -> std::string {
    if (decl.info.min && v < *decl.info.min) {
      return "value " + Scalar(value) + " is below the minimum " + FormatNumber(*decl.info.min);
    }
    if (decl.info.max && v > *decl.info.max) {
      return "value " + Scalar(value) + " is above the maximum " + FormatNumber(*decl.info.max);
    }
    return "";
  };
  switch (decl.type) {
    case ParamType::kBool: {
      const std::string s = value.IsScalar() ? value.as<std::string>() : "";
      if (IsQuoted(value) || (s != "true" && s != "false")) return expect + " (true or false)";
      *static_cast<bool*>(decl.target) = s == "true";
      return "";
    }
    case ParamType::kInt: {
      int v = 0;
      if (!ParseInt(value, &v)) return expect + ", got '" + Scalar(value) + "'";
      if (auto r = check_range(v); !r.empty()) return r;
      *static_cast<int*>(decl.target) = v;
      return "";
    }
    case ParamType::kDouble: {
      double v = 0;
      if (!ParseDouble(value, &v)) return expect + ", got '" + Scalar(value) + "'";
      if (auto r = check_range(v); !r.empty()) return r;
      *static_cast<double*>(decl.target) = v;
      return "";
    }
    case ParamType::kString: {
      if (!value.IsScalar()) return expect;
      const std::string s = value.as<std::string>();
      const auto& choices = decl.info.choices;
      if (!choices.empty() && std::find(choices.begin(), choices.end(), s) == choices.end()) {
        return "'" + s + "' is not allowed; " + Expected(choices, s);
      }
      *static_cast<std::string*>(decl.target) = s;
      return "";
    }
    case ParamType::kDoubleList:
    case ParamType::kIntList:
    case ParamType::kStringList: {
      if (!value.IsSequence()) return expect + " (a YAML list like [1, 2])";
      std::vector<double> doubles;
      std::vector<int> ints;
      std::vector<std::string> strings;
      for (const auto& item : value) {
        if (decl.type == ParamType::kDoubleList) {
          double v = 0;
          if (!ParseDouble(item, &v)) return expect + ", element '" + Scalar(item) + "'";
          if (auto r = check_range(v); !r.empty()) return r;
          doubles.push_back(v);
        } else if (decl.type == ParamType::kIntList) {
          int v = 0;
          if (!ParseInt(item, &v)) return expect + ", element '" + Scalar(item) + "'";
          if (auto r = check_range(v); !r.empty()) return r;
          ints.push_back(v);
        } else {
          if (!item.IsScalar()) return expect;
          strings.push_back(item.as<std::string>());
        }
      }
      if (decl.type == ParamType::kDoubleList) {
        *static_cast<std::vector<double>*>(decl.target) = doubles;
      } else if (decl.type == ParamType::kIntList) {
        *static_cast<std::vector<int>*>(decl.target) = ints;
      } else {
        *static_cast<std::vector<std::string>*>(decl.target) = strings;
      }
      return "";
    }
  }
  return "unsupported parameter type";
}

void Loader::ApplyOverrides() {
  const std::string where = "--set";
  for (const auto& o : options_.overrides) {
    const auto eq = o.find('=');
    const auto dot = o.find('.');
    if (eq == std::string::npos || dot == std::string::npos || dot > eq || dot == 0 ||
        dot + 1 == eq) {
      diagnostics_.push_back(
          Diagnostic{where, 0, 0, "'" + o + "': expected component_id.param=value"});
      continue;
    }
    const std::string id = o.substr(0, dot);
    const std::string name = o.substr(dot + 1, eq - dot - 1);
    Node* node = nullptr;
    for (auto& n : graph_->nodes) {
      if (n->id == id) node = n.get();
    }
    if (node == nullptr) {
      std::vector<std::string> ids;
      for (auto& n : graph_->nodes) ids.push_back(n->id);
      diagnostics_.push_back(
          Diagnostic{where, 0, 0, "'" + o + "': no component '" + id + "'; " + Expected(ids, id)});
      continue;
    }
    YAML::Node value;
    try {
      value = YAML::Load(o.substr(eq + 1));
    } catch (const YAML::Exception& e) {
      diagnostics_.push_back(Diagnostic{where, 0, 0, "'" + o + "': " + e.msg});
      continue;
    }
    const std::size_t before = diagnostics_.size();
    SetParam(*node, name, YAML::Mark::null_mark(), value, where + " " + o);
    for (std::size_t i = before; i < diagnostics_.size(); ++i) {
      diagnostics_[i].line = diagnostics_[i].column = 0;  // marks inside the value text
    }
  }
}

}  // namespace draco::graph::detail
