// Graph loading (graph.hpp): the YAML documents with their includes, the graph settings, the
// components and their input bindings; LoadGraphFile, LoadGraphString and ExpectedOneOf.
// Parameters are set in graph_params.cpp, the graph is connected and checked in
// graph_validate.cpp.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "draco/graph/graph.hpp"
#include "graph_loader.hpp"

namespace draco::graph {
namespace {

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

}  // namespace

std::string ExpectedOneOf(const std::vector<std::string>& allowed, const std::string& got) {
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

namespace detail {
namespace {

constexpr int kSchemaVersion = 1;

bool ValidId(const std::string& id) {
  if (id.empty() || !(std::isalpha(static_cast<unsigned char>(id[0])) || id[0] == '_')) {
    return false;
  }
  return std::all_of(id.begin(), id.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

}  // namespace

std::unique_ptr<Graph> Loader::Load(const YAML::Node& root, const std::string& file,
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

void Loader::Error(const std::string& file, const YAML::Mark& mark, std::string message) {
  const bool known = mark.line >= 0 && !mark.is_null();
  diagnostics_.push_back(
      Diagnostic{file, known ? mark.line + 1 : 0, known ? mark.column + 1 : 0, std::move(message)});
}

// A mapping key as text; false (and a diagnostic) when it is a list, a mapping or empty.
bool Loader::KeyText(const std::string& file, const YAML::Node& key, std::string* text) {
  if (key.IsScalar()) {
    *text = key.Scalar();
    return true;
  }
  Error(file, key.Mark(), "expected a name as key, got " + Scalar(key));
  return false;
}

void Loader::ReadDocument(const YAML::Node& root, const std::string& file,
                          const std::string& base_dir, bool is_root,
                          std::vector<RawComponent>* raw) {
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

void Loader::ReadSettings(const YAML::Node& root, const std::string& file) {
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

void Loader::ReadComponent(const RawComponent& rc) {
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
    Error(
        rc.file, id_node.Mark(),
        "invalid id '" + id + "': expected letters, digits, '_' or '-', not starting with a digit");
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

void Loader::ReadInput(Node& node, const YAML::Node& key, const YAML::Node& value,
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
          "input '" + port + "' of '" + node.id + "': expected 'producer_id/output', got '" + text +
              "'");
    return;
  }
  pending_inputs_.push_back(PendingInput{node.id, port, text.substr(0, slash),
                                         text.substr(slash + 1), file, value.Mark()});
}

}  // namespace detail

namespace {

using detail::Loader;

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

}  // namespace draco::graph
