// Graph loading and validation. Every problem is collected with its file, line and column,
// and reported together before anything runs.
#include "draco/graph/graph.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <sstream>

namespace draco::graph {

std::string Diagnostic::ToString() const {
  std::ostringstream os;
  os << file;
  if (line > 0) {
    os << ":" << line;
    if (column > 0) os << ":" << column;
  }
  os << ": error: " << message;
  return os.str();
}

namespace {
std::string JoinDiagnostics(const std::vector<Diagnostic>& diagnostics) {
  std::string out;
  for (const auto& d : diagnostics) {
    if (!out.empty()) out += "\n";
    out += d.ToString();
  }
  return out;
}
}  // namespace

GraphError::GraphError(std::vector<Diagnostic> diagnostics)
    : std::runtime_error(JoinDiagnostics(diagnostics)), diagnostics_(std::move(diagnostics)) {}

InputPort* Node::FindInput(const std::string& name) const {
  for (const auto& p : inputs) {
    if (p->name() == name) return p.get();
  }
  return nullptr;
}

OutputPort* Node::FindOutput(const std::string& name) const {
  for (const auto& p : outputs) {
    if (p->name() == name) return p.get();
  }
  return nullptr;
}

const ParamDecl* Node::FindParam(const std::string& name) const {
  for (const auto& p : params) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

std::unique_ptr<Node> MakeNode(const std::string& type, const std::string& id) {
  const Registry::Entry* entry = Registry::Global().Find(type);
  if (entry == nullptr) throw std::invalid_argument("unknown component type '" + type + "'");
  auto node = std::make_unique<Node>();
  node->id = id;
  node->type = type;
  node->component = entry->factory();
  Spec spec(node.get());
  node->component->Declare(spec);
  return node;
}

Node* Graph::Find(const std::string& id) const {
  for (const auto& n : nodes) {
    if (n->id == id) return n.get();
  }
  return nullptr;
}

std::vector<std::uint32_t> Graph::TopologicalOrder() const {
  std::vector<int> indegree(nodes.size(), 0);
  for (const auto& e : edges) {
    if (!nodes[e.consumer]->inputs[e.input]->options().delayed) ++indegree[e.consumer];
  }
  std::vector<std::uint32_t> order;
  std::vector<bool> done(nodes.size(), false);
  while (order.size() < nodes.size()) {
    // Smallest index (= smallest id) among the ready nodes; a leftover cycle is broken by id.
    std::uint32_t pick = static_cast<std::uint32_t>(nodes.size());
    for (std::uint32_t i = 0; i < nodes.size() && pick == nodes.size(); ++i) {
      if (!done[i] && indegree[i] == 0) pick = i;
    }
    for (std::uint32_t i = 0; i < nodes.size() && pick == nodes.size(); ++i) {
      if (!done[i]) pick = i;
    }
    done[pick] = true;
    order.push_back(pick);
    for (const auto& e : edges) {
      if (e.producer == pick && !nodes[e.consumer]->inputs[e.input]->options().delayed) {
        --indegree[e.consumer];
      }
    }
  }
  return order;
}

std::vector<const Edge*> Graph::Subscribers(std::uint32_t producer, std::size_t output) const {
  std::vector<const Edge*> out;
  for (const auto& e : edges) {
    if (e.producer == producer && e.output == output) out.push_back(&e);
  }
  return out;
}

namespace {

constexpr int kSchemaVersion = 1;

std::size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

// "expected one of: a, b, c (did you mean 'b'?)"
std::string Expected(const std::vector<std::string>& allowed, const std::string& got) {
  if (allowed.empty()) return "it declares none";
  std::string out = "expected one of: ";
  std::string best;
  std::size_t best_d = 3;
  for (std::size_t i = 0; i < allowed.size(); ++i) {
    if (i > 0) out += ", ";
    out += allowed[i];
    const std::size_t d = EditDistance(got, allowed[i]);
    if (d < best_d) {
      best_d = d;
      best = allowed[i];
    }
  }
  if (!best.empty()) out += " (did you mean '" + best + "'?)";
  return out;
}

bool ValidId(const std::string& id) {
  if (id.empty() || !(std::isalpha(static_cast<unsigned char>(id[0])) || id[0] == '_')) {
    return false;
  }
  return std::all_of(id.begin(), id.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
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
                              const std::string& base_dir) {
    graph_ = std::make_unique<Graph>();
    graph_->source_file = file;
    graph_->settings.name = std::filesystem::path(file).stem().string();
    std::vector<RawComponent> raw;
    ReadDocument(root, file, base_dir, /*is_root=*/true, &raw);
    for (const auto& rc : raw) ReadComponent(rc);
    ApplyOverrides();
    SortNodes();
    ConnectInputs();
    if (!options_.allow_unconnected_inputs) CheckRequiredInputs();
    CheckCycles();
    if (!diagnostics_.empty()) throw GraphError(diagnostics_);
    return std::move(graph_);
  }

  void Error(const std::string& file, const YAML::Mark& mark, std::string message) {
    const bool known = mark.line >= 0 && !mark.is_null();
    diagnostics_.push_back(Diagnostic{file, known ? mark.line + 1 : 0, known ? mark.column + 1 : 0,
                                      std::move(message)});
  }
  std::vector<Diagnostic>& diagnostics() { return diagnostics_; }

 private:
  // A mapping key as text; false (and a diagnostic) when it is a list, a mapping or empty.
  bool KeyText(const std::string& file, const YAML::Node& key, std::string* text) {
    if (key.IsScalar()) {
      *text = key.Scalar();
      return true;
    }
    Error(file, key.Mark(), "expected a name as key, got " + Scalar(key));
    return false;
  }

  void ReadDocument(const YAML::Node& root, const std::string& file, const std::string& base_dir,
                    bool is_root, std::vector<RawComponent>* raw) {
    if (!root.IsMap()) {
      Error(file, root.Mark(), "expected a mapping with keys schema, components");
      return;
    }
    static const std::vector<std::string> kRootKeys = {"schema",  "name",    "executor",  "rate",
                                                       "threads", "include", "components"};
    // An included graph may be a runnable graph of its own (robot.yaml includes
    // local-slam.yaml): its settings are accepted and the including graph's apply.
    static const std::vector<std::string>& kIncludedKeys = kRootKeys;
    const auto& allowed = is_root ? kRootKeys : kIncludedKeys;
    for (const auto& kv : root) {
      std::string key;
      if (!KeyText(file, kv.first, &key)) continue;
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        Error(file, kv.first.Mark(),
              "unknown key '" + key + "' in " + (is_root ? "a graph" : "an included graph") + "; " +
                  Expected(allowed, key));
      }
    }
    const YAML::Node schema = root["schema"];
    if (!schema) {
      Error(file, root.Mark(), "missing 'schema: " + std::to_string(kSchemaVersion) + "'");
    } else {
      int version = 0;
      if (!ParseInt(schema, &version) || version != kSchemaVersion) {
        Error(file, schema.Mark(),
              "unsupported schema '" + Scalar(schema) + "'; expected " +
                  std::to_string(kSchemaVersion));
      }
    }
    if (is_root) ReadSettings(root, file);
    if (const YAML::Node include = root["include"]) {
      std::vector<YAML::Node> items;
      if (include.IsScalar()) {
        items.push_back(include);
      } else if (include.IsSequence()) {
        for (const auto& item : include) items.push_back(item);
      } else {
        Error(file, include.Mark(), "expected a file name or a list of file names");
      }
      for (const auto& item : items) {
        if (!item.IsScalar()) {
          Error(file, item.Mark(), "expected a file name");
          continue;
        }
        const auto path =
            (std::filesystem::path(base_dir) / item.as<std::string>()).lexically_normal();
        // error_code forms: a name the file system refuses (too long, not a folder) is a
        // diagnostic like a missing file, never an exception.
        std::error_code ec;
        std::string canonical = std::filesystem::weakly_canonical(path, ec).string();
        if (ec) canonical = path.string();
        if (std::find(include_stack_.begin(), include_stack_.end(), canonical) !=
            include_stack_.end()) {
          Error(file, item.Mark(), "include cycle through '" + path.string() + "'");
          continue;
        }
        const auto status = std::filesystem::status(path, ec);
        if (!std::filesystem::exists(status)) {
          Error(file, item.Mark(), "included file '" + path.string() + "' does not exist");
          continue;
        }
        // A directory fails inside yaml-cpp with an exception of its own; a named pipe (or
        // /dev/stdin) would block the loader until someone writes to it.
        if (!std::filesystem::is_regular_file(status)) {
          Error(file, item.Mark(),
                "included '" + path.string() +
                    "' is not a regular file (a directory, device or pipe?)");
          continue;
        }
        YAML::Node included;
        try {
          included = YAML::LoadFile(path.string());
        } catch (const YAML::Exception& e) {
          Error(path.string(), e.mark, "YAML syntax: " + e.msg);
          continue;
        }
        include_stack_.push_back(canonical);
        ReadDocument(included, path.string(), path.parent_path().string(), false, raw);
        include_stack_.pop_back();
      }
    }
    const YAML::Node components = root["components"];
    if (!components) {
      if (is_root && raw->empty() && !root["include"]) {
        Error(file, root.Mark(), "missing 'components' (a list of components)");
      }
      return;
    }
    if (!components.IsSequence()) {
      Error(file, components.Mark(), "'components' must be a list, e.g. '- id: x'");
      return;
    }
    for (const auto& c : components) raw->push_back(RawComponent{file, c});
  }

  void ReadSettings(const YAML::Node& root, const std::string& file) {
    auto& s = graph_->settings;
    if (const auto n = root["name"]) {
      if (n.IsScalar()) {
        s.name = n.as<std::string>();
      } else {
        Error(file, n.Mark(), "'name' must be a string");
      }
    }
    if (const auto n = root["executor"]) {
      const std::string v = Scalar(n);
      if (v != "deterministic" && v != "threaded") {
        Error(file, n.Mark(), "unknown executor '" + v + "'; expected deterministic or threaded");
      } else {
        s.executor = v;
      }
    }
    if (const auto n = root["rate"]) {
      if (!ParseDouble(n, &s.rate) || s.rate < 0.0) {
        Error(file, n.Mark(), "'rate' must be a number >= 0 (0: as fast as possible)");
      }
    }
    if (const auto n = root["threads"]) {
      if (!ParseInt(n, &s.threads) || s.threads < 1 || s.threads > 256) {
        Error(file, n.Mark(), "'threads' must be an integer in [1, 256]");
      }
    }
  }

  void ReadComponent(const RawComponent& rc) {
    const YAML::Node& c = rc.yaml;
    if (!c.IsMap()) {
      Error(rc.file, c.Mark(), "a component must be a mapping with keys id, type, params, inputs");
      return;
    }
    static const std::vector<std::string> kKeys = {"id", "type", "params", "inputs", "doc"};
    for (const auto& kv : c) {
      std::string key;
      if (!KeyText(rc.file, kv.first, &key)) continue;
      if (std::find(kKeys.begin(), kKeys.end(), key) == kKeys.end()) {
        Error(rc.file, kv.first.Mark(),
              "unknown key '" + key + "' in a component; " + Expected(kKeys, key));
      }
    }
    const YAML::Node id_node = c["id"];
    const YAML::Node type_node = c["type"];
    if (!id_node || !id_node.IsScalar()) {
      Error(rc.file, c.Mark(), "component without 'id'");
      return;
    }
    const std::string id = id_node.as<std::string>();
    if (!ValidId(id)) {
      Error(rc.file, id_node.Mark(),
            "invalid id '" + id +
                "': expected letters, digits, '_' or '-', not starting with a digit");
      return;
    }
    if (auto it = id_marks_.find(id); it != id_marks_.end()) {
      Error(rc.file, id_node.Mark(),
            "duplicate component id '" + id + "' (first declared at " + it->second + ")");
      return;
    }
    id_marks_[id] = rc.file + ":" + std::to_string(id_node.Mark().line + 1);
    if (!type_node || !type_node.IsScalar()) {
      Error(rc.file, c.Mark(), "component '" + id + "' has no 'type'");
      return;
    }
    const std::string type = type_node.as<std::string>();
    if (Registry::Global().Find(type) == nullptr) {
      Error(rc.file, type_node.Mark(),
            "unknown component type '" + type + "'; " + Expected(Registry::Global().Types(), type));
      return;
    }
    std::unique_ptr<Node> node = MakeNode(type, id);
    node->file = rc.file;
    node->line = c.Mark().line + 1;
    if (const YAML::Node params = c["params"]) {
      if (!params.IsMap()) {
        Error(rc.file, params.Mark(), "'params' must be a mapping of name: value");
      } else {
        for (const auto& kv : params) {
          std::string name;
          if (KeyText(rc.file, kv.first, &name)) {
            SetParam(*node, name, kv.first.Mark(), kv.second, rc.file);
          }
        }
      }
    }
    if (const YAML::Node inputs = c["inputs"]) {
      if (!inputs.IsMap()) {
        Error(rc.file, inputs.Mark(), "'inputs' must be a mapping of port: producer_id/output");
      } else {
        for (const auto& kv : inputs) ReadInput(*node, kv.first, kv.second, rc.file);
      }
    }
    graph_->nodes.push_back(std::move(node));
  }

  void ReadInput(Node& node, const YAML::Node& key, const YAML::Node& value,
                 const std::string& file) {
    std::string port;
    if (!KeyText(file, key, &port)) return;
    if (node.FindInput(port) == nullptr) {
      std::vector<std::string> names;
      for (const auto& p : node.inputs) names.push_back(p->name());
      Error(file, key.Mark(),
            "component '" + node.id + "' (" + node.type + ") has no input '" + port + "'; " +
                Expected(names, port));
      return;
    }
    // Reported here if malformed; never again as "not connected".
    node.FindInput(port)->set_connected(true);
    const std::string text = value.IsScalar() ? value.as<std::string>() : std::string();
    const auto slash = text.find('/');
    if (slash == std::string::npos || slash == 0 || slash + 1 == text.size() ||
        text.find('/', slash + 1) != std::string::npos) {
      Error(file, value.Mark(),
            "input '" + port + "' of '" + node.id + "': expected 'producer_id/output', got '" +
                text + "'");
      return;
    }
    pending_inputs_.push_back(PendingInput{node.id, port, text.substr(0, slash),
                                           text.substr(slash + 1), file, value.Mark()});
  }

  void SetParam(Node& node, const std::string& name, const YAML::Mark& key_mark,
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
  static std::string Assign(const ParamDecl& decl, const YAML::Node& value) {
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

  void ApplyOverrides() {
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
        diagnostics_.push_back(Diagnostic{
            where, 0, 0, "'" + o + "': no component '" + id + "'; " + Expected(ids, id)});
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

  void SortNodes() {
    auto& nodes = graph_->nodes;
    std::sort(nodes.begin(), nodes.end(),
              [](const auto& a, const auto& b) { return a->id < b->id; });
    for (std::size_t i = 0; i < nodes.size(); ++i) nodes[i]->index = static_cast<std::uint32_t>(i);
  }

  void ConnectInputs() {
    std::set<std::pair<std::string, std::string>> seen;
    for (const auto& pi : pending_inputs_) {
      const Node* producer = graph_->Find(pi.producer);
      Node* consumer = graph_->Find(pi.consumer);
      if (producer == nullptr) {
        std::vector<std::string> ids;
        for (auto& n : graph_->nodes) ids.push_back(n->id);
        Error(pi.file, pi.mark,
              "input '" + pi.port + "' of '" + pi.consumer + "' names unknown component '" +
                  pi.producer + "'; " + Expected(ids, pi.producer));
        continue;
      }
      const OutputPort* out = producer->FindOutput(pi.output);
      if (out == nullptr) {
        std::vector<std::string> names;
        for (const auto& p : producer->outputs) names.push_back(p->name());
        Error(pi.file, pi.mark,
              "component '" + producer->id + "' (" + producer->type + ") has no output '" +
                  pi.output + "'; " + Expected(names, pi.output));
        continue;
      }
      InputPort* in = consumer->FindInput(pi.port);
      if (out->type() != in->type()) {
        Error(pi.file, pi.mark,
              "type mismatch: input '" + pi.consumer + "/" + pi.port + "' expects " +
                  in->type_name() + " but '" + pi.producer + "/" + pi.output + "' publishes " +
                  out->type_name());
        continue;
      }
      if (!seen.insert({pi.consumer, pi.port}).second) {
        Error(pi.file, pi.mark, "input '" + pi.port + "' of '" + pi.consumer + "' bound twice");
        continue;
      }
      in->set_connected(true);
      Edge e;
      e.producer = producer->index;
      e.output = out->index();
      e.consumer = consumer->index;
      for (std::size_t i = 0; i < consumer->inputs.size(); ++i) {
        if (consumer->inputs[i].get() == in) e.input = i;
      }
      graph_->edges.push_back(e);
    }
    std::sort(graph_->edges.begin(), graph_->edges.end(), [](const Edge& a, const Edge& b) {
      return std::tie(a.producer, a.output, a.consumer, a.input) <
             std::tie(b.producer, b.output, b.consumer, b.input);
    });
  }

  void CheckRequiredInputs() {
    for (const auto& n : graph_->nodes) {
      for (const auto& in : n->inputs) {
        if (in->options().required && !in->connected()) {
          diagnostics_.push_back(Diagnostic{n->file, n->line, 0,
                                            "required input '" + in->name() + "' of '" + n->id +
                                                "' (" + n->type + ", expects " + in->type_name() +
                                                ") is not connected; add 'inputs: {" + in->name() +
                                                ": producer_id/output}'"});
        }
      }
    }
  }

  // A cycle must pass through at least one input marked delayed.
  void CheckCycles() {
    const auto& nodes = graph_->nodes;
    std::vector<std::vector<std::uint32_t>> next(nodes.size());
    for (const auto& e : graph_->edges) {
      if (!nodes[e.consumer]->inputs[e.input]->options().delayed) {
        next[e.producer].push_back(e.consumer);
      }
    }
    std::vector<int> state(nodes.size(), 0);  // 0 new, 1 on stack, 2 done
    std::vector<std::uint32_t> stack;
    bool reported = false;
    std::function<void(std::uint32_t)> visit = [&](std::uint32_t v) {
      state[v] = 1;
      stack.push_back(v);
      for (std::uint32_t w : next[v]) {
        if (reported) break;
        if (state[w] == 1) {
          std::string path;
          auto it = std::find(stack.begin(), stack.end(), w);
          for (; it != stack.end(); ++it) path += nodes[*it]->id + " -> ";
          path += nodes[w]->id;
          diagnostics_.push_back(
              Diagnostic{nodes[w]->file, nodes[w]->line, 0,
                         "cycle " + path +
                             " passes through no delayed input; mark one input of the "
                             "cycle delayed (InputOptions::delayed) to break it"});
          reported = true;
        } else if (state[w] == 0) {
          visit(w);
        }
      }
      stack.pop_back();
      state[v] = 2;
    };
    for (std::uint32_t v = 0; v < nodes.size() && !reported; ++v) {
      if (state[v] == 0) visit(v);
    }
  }

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

std::unique_ptr<Graph> LoadParsed(const std::string& text_or_path, bool is_file,
                                  const std::string& name, const LoadOptions& options,
                                  const std::string& base_dir) {
  Loader loader(options);
  YAML::Node root;
  try {
    if (is_file) {
      std::error_code ec;
      const auto status = std::filesystem::status(text_or_path, ec);
      if (!std::filesystem::exists(status)) {
        throw GraphError({Diagnostic{text_or_path, 0, 0, "graph file does not exist"}});
      }
      if (!std::filesystem::is_regular_file(status)) {
        throw GraphError(
            {Diagnostic{text_or_path, 0, 0,
                        "not a regular file (a directory, device or pipe?): expected a "
                        "graph file"}});
      }
      root = YAML::LoadFile(text_or_path);
    } else {
      root = YAML::Load(text_or_path);
    }
  } catch (const YAML::Exception& e) {
    loader.Error(name, e.mark, "YAML syntax: " + e.msg);
    throw GraphError(loader.diagnostics());
  }
  return loader.Load(root, name, base_dir);
}

}  // namespace

std::unique_ptr<Graph> LoadGraphFile(const std::string& path, const LoadOptions& options) {
  const std::string base = std::filesystem::path(path).parent_path().string();
  return LoadParsed(path, true, path, options, base.empty() ? "." : base);
}

std::unique_ptr<Graph> LoadGraphString(const std::string& yaml, const std::string& name,
                                       const LoadOptions& options, const std::string& base_dir) {
  return LoadParsed(yaml, false, name, options, base_dir);
}

namespace {
std::string DotEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\' || c == '<' || c == '>' || c == '{' || c == '}' || c == '|') {
      out += '\\';
    }
    out += c;
  }
  return out;
}
}  // namespace

std::string ToDot(const Graph& graph) {
  std::ostringstream os;
  os << "digraph \"" << DotEscape(graph.settings.name) << "\" {\n"
     << "  rankdir=LR;\n  node [shape=record, fontname=\"Helvetica\", fontsize=10];\n"
     << "  edge [fontname=\"Helvetica\", fontsize=8];\n";
  for (const auto& n : graph.nodes) {
    os << "  \"" << DotEscape(n->id) << "\" [label=\"{";
    std::string ins;
    for (const auto& p : n->inputs) {
      ins += (ins.empty() ? "" : "|") + ("<in_" + p->name() + "> " + DotEscape(p->name()));
    }
    std::string outs;
    for (const auto& p : n->outputs) {
      outs += (outs.empty() ? "" : "|") + ("<out_" + p->name() + "> " + DotEscape(p->name()));
    }
    if (!ins.empty()) os << "{" << ins << "}|";
    os << DotEscape(n->id) << "\\n" << DotEscape(n->type);
    if (!outs.empty()) os << "|{" << outs << "}";
    os << "}\"];\n";
  }
  for (const auto& e : graph.edges) {
    const Node& p = *graph.nodes[e.producer];
    const Node& c = *graph.nodes[e.consumer];
    const OutputPort& out = *p.outputs[e.output];
    const InputPort& in = *c.inputs[e.input];
    std::string type = out.type_name();
    if (auto pos = type.rfind("::"); pos != std::string::npos) type = type.substr(pos + 2);
    os << "  \"" << DotEscape(p.id) << "\":out_" << out.name() << " -> \"" << DotEscape(c.id)
       << "\":in_" << in.name() << " [label=\"" << DotEscape(type) << "\"";
    if (in.options().delayed) os << ", style=dashed";
    if (!in.options().trigger) os << ", arrowhead=empty";
    os << "];\n";
  }
  os << "}\n";
  return os.str();
}

std::string DescribeRegistry() {
  std::ostringstream os;
  for (const auto& type : Registry::Global().Types()) {
    auto node = MakeNode(type, type);
    os << type << (node->is_source ? "  [source]" : "") << "\n";
    if (!node->doc.empty()) os << "  " << node->doc << "\n";
    for (const auto& in : node->inputs) {
      const auto& o = in->options();
      os << "  input  " << in->name() << " : " << in->type_name() << "  ("
         << (o.trigger ? "triggers" : "no trigger") << ", "
         << (o.delivery == Delivery::kLatest ? "latest value" : "queue " + std::to_string(o.depth))
         << (o.required ? "" : ", optional") << (o.delayed ? ", delayed" : "") << ")";
      if (!o.doc.empty()) os << "  " << o.doc;
      os << "\n";
    }
    for (const auto& out : node->outputs) {
      os << "  output " << out->name() << " : " << out->type_name();
      if (!out->doc().empty()) os << "  " << out->doc();
      os << "\n";
    }
    for (const auto& t : node->timers) {
      os << "  timer  " << t.name << " every " << t.period.Seconds() << " s";
      if (!t.doc.empty()) os << "  " << t.doc;
      os << "\n";
    }
    for (const auto& p : node->params) {
      os << "  param  " << p.name << " : " << ParamTypeName(p.type) << " = " << p.default_text;
      if (!p.info.unit.empty()) os << " [" << p.info.unit << "]";
      if (p.info.min || p.info.max) {
        os << " range " << (p.info.min ? Loader::FormatNumber(*p.info.min) : "-inf") << ".."
           << (p.info.max ? Loader::FormatNumber(*p.info.max) : "inf");
      }
      if (!p.info.choices.empty()) {
        os << " one of";
        for (const auto& c : p.info.choices) os << " " << c;
      }
      if (!p.info.doc.empty()) os << "  " << p.info.doc;
      os << "\n";
    }
    os << "\n";
  }
  return os.str();
}

}  // namespace draco::graph
