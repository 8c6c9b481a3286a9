// The graph loader, private to draco_graph: reading a graph's YAML and its includes
// (graph_load.cpp), parameter values and --set overrides (graph_params.cpp), connecting and
// checking the graph (graph_validate.cpp). Every problem is collected with its file, line and
// column, and reported together before anything runs.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "draco/graph/graph.hpp"

namespace draco::graph::detail {

// "expected one of: a, b, c (did you mean 'b'?)" (graph.hpp ExpectedOneOf)
inline std::string Expected(const std::vector<std::string>& allowed, const std::string& got) {
  return ExpectedOneOf(allowed, got);
}

struct RawComponent {
  std::string file;
  YAML::Node yaml;
};

struct PendingInput {
  std::string consumer;
  std::string port;
  std::string producer;
  std::string output;
  std::string file;
  YAML::Mark mark;
};

class Loader {
 public:
  explicit Loader(const LoadOptions& options) : options_(options) {}

  std::unique_ptr<Graph> Load(const YAML::Node& root, const std::string& file,
                              const std::string& base_dir);

  void Error(const std::string& file, const YAML::Mark& mark, std::string message);
  std::vector<Diagnostic>& diagnostics() { return diagnostics_; }

 private:
  // graph_load.cpp
  bool KeyText(const std::string& file, const YAML::Node& key, std::string* text);
  void ReadDocument(const YAML::Node& root, const std::string& file, const std::string& base_dir,
                    bool is_root, std::vector<RawComponent>* raw);
  void ReadSettings(const YAML::Node& root, const std::string& file);
  void ReadComponent(const RawComponent& rc);
  void ReadInput(Node& node, const YAML::Node& key, const YAML::Node& value,
                 const std::string& file);

  // graph_params.cpp
  void SetParam(Node& node, const std::string& name, const YAML::Mark& key_mark,
                const YAML::Node& value, const std::string& file);
  static std::string Assign(const ParamDecl& decl, const YAML::Node& value);
  void ApplyOverrides();

  // graph_validate.cpp
  void SortNodes();
  void ConnectInputs();
  void CheckRequiredInputs();
  void CheckCycles();

 public:
  static std::string Scalar(const YAML::Node& n) {
    if (n.IsScalar()) return n.as<std::string>();
    if (n.IsSequence()) return "a list";
    if (n.IsMap()) return "a mapping";
    return "nothing";
  }
  static bool IsQuoted(const YAML::Node& n) { return n.Tag() == "!"; }
  static bool ParseDouble(const YAML::Node& n, double* out) {
    if (!n.IsScalar() || IsQuoted(n)) return false;
    const std::string s = n.as<std::string>();
    if (s.empty()) return false;
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(s.c_str(), &end);
    if (errno != 0 || end != s.c_str() + s.size() || !std::isfinite(v)) return false;
    *out = v;
    return true;
  }
  static bool ParseInt(const YAML::Node& n, int* out) {
    if (!n.IsScalar() || IsQuoted(n)) return false;
    const std::string s = n.as<std::string>();
    if (s.empty()) return false;
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(s.c_str(), &end, 10);
    if (errno != 0 || end != s.c_str() + s.size() || v < std::numeric_limits<int>::min() ||
        v > std::numeric_limits<int>::max()) {
      return false;
    }
    *out = static_cast<int>(v);
    return true;
  }
  static std::string FormatNumber(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
  }

 private:
  const LoadOptions& options_;
  std::unique_ptr<Graph> graph_;
  std::vector<Diagnostic> diagnostics_;
  std::map<std::string, std::string> id_marks_;
  std::vector<PendingInput> pending_inputs_;
  std::vector<std::string> include_stack_;
};

}  // namespace draco::graph::detail
