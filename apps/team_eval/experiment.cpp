// The experiment file of draco-team-eval (experiment.hpp): one table of keys (section, name,
// type, range or choices, what it means) drives reading a file, the --exp-set overrides and
// writing the resolved file, so the three cannot disagree.
#include "experiment.hpp"

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace draco::team_eval {
namespace {

using Target = std::variant<bool*, int*, double*, std::uint64_t*, std::string*>;

// A number's allowed range; open ends excluded.
struct Range {
  std::optional<double> min;
  std::optional<double> max;
  bool min_open = false;
  bool max_open = false;
};

struct Field {
  const char* section;
  const char* key;
  Target target;
  const char* doc;
  Range range{};
  std::vector<std::string> choices{};
};

constexpr const char* kSections[] = {"matching", "candidates", "filter", "optimizer", "inject"};

Range AtLeast(double v) { return {v, std::nullopt, false, false}; }
Range Above(double v) { return {v, std::nullopt, true, false}; }

// Every key, in the order ExperimentYaml writes them, pointing into `e`.
std::vector<Field> Fields(Experiment& e) {
  auto& m = e.matching;
  auto& c = e.candidates;
  auto& f = e.filter;
  auto& o = e.optimizer;
  auto& i = e.inject;
  return {
      {"matching", "oracle", &m.oracle,
       "where object-graph matching is not right, the ground-truth map-to-map transform (and the "
       "true object pairs) seed scan selection and registration and are the PGO guess"},
      {"matching", "shared_transforms", &m.shared_transforms,
       "a teammate the own matching does not place is placed through the teammates' matches, as "
       "the running team shares its map-to-map estimates"},
      {"candidates", "window", &c.window,
       "registration window: own keyframes k-w .. k+w are the target of a teammate's scan",
       AtLeast(0)},
      {"candidates", "min_overlap", &c.min_overlap,
       "an accepted registration with at least this overlap is a candidate loop", Range{0.0, 1.0}},
      {"filter", "min_clique_size", &f.min_clique_size,
       "PCM / GCM: the smallest consistent set that is accepted", AtLeast(1)},
      {"filter", "map_sigma_m", &f.map_sigma_m, "GCM: sigma of the map-to-map guess (m)", Above(0)},
      {"filter", "map_sigma_deg", &f.map_sigma_deg, "GCM: ... and of its rotation (deg)", Above(0)},
      {"filter",
       "pose_covariance",
       &f.pose_covariance,
       "relative-pose covariance: graph (marginals of each robot's whole local pose graph, its "
       "loop closures included) or chain (its odometry as an open chain)",
       {},
       {"graph", "chain"}},
      {"filter", "map_frame_drift", &f.map_frame_drift,
       "graph covariance: a keyframe's pose in its map frame carries the drift since the first "
       "keyframe when compared with the map-to-map guess (false: none, the guess was fitted to "
       "the drifted maps)"},
      {"optimizer",
       "local_graph",
       &o.local_graph,
       "each robot's local pose graph in both PGOs: chain (the local SLAM's optimised trajectory "
       "as a chain of relative poses) or full (every local-SLAM factor, re-solved without the "
       "local robust losses)",
       {},
       {"chain", "full"}},
      {"optimizer", "local_chain_sigma_xy_m", &o.local_chain_sigma_xy_m,
       "chain: sigma per keyframe step (m); 0 together with local_chain_sigma_yaw_deg 0: the "
       "information of the local graph's factors between consecutive keyframes",
       AtLeast(0)},
      {"optimizer", "local_chain_sigma_yaw_deg", &o.local_chain_sigma_yaw_deg,
       "chain: yaw sigma per keyframe step (deg)", AtLeast(0)},
      {"optimizer",
       "global_anchor",
       &o.global_anchor,
       "two-step global step: touched (robust priors on every touched teammate pose, teammate "
       "chain deformed), first_loop (rigid, by the first loop), rigid (rigid, least-squares fit "
       "of every touched pose)",
       {},
       {"touched", "first_loop", "rigid"}},
      {"optimizer", "chain_from_factors", &o.chain_from_factors,
       "two-step global step: teammate chain with its own information (false: the reference's "
       "0.1 m / 0.01 rad)"},
      {"optimizer", "loop_sigma_xy_m", &o.loop_sigma_xy_m,
       "fixed inter-robot loop sigma in both PGOs (m); 0 together with loop_sigma_yaw_deg 0: "
       "each loop's own covariance",
       AtLeast(0)},
      {"optimizer", "loop_sigma_yaw_deg", &o.loop_sigma_yaw_deg,
       "fixed inter-robot loop yaw sigma (deg)", AtLeast(0)},
      {"inject", "fraction", &i.fraction,
       "robustness test: wrong loops added to every robot's real candidates, this fraction of "
       "the stream (0: none)",
       Range{0.0, 1.0, false, true}},
      {"inject",
       "kind",
       &i.kind,
       "random (each loop 2-10 m, +-30 deg off) or correlated (groups sharing one map offset)",
       {},
       {"random", "correlated"}},
      {"inject", "group_size", &i.group_size, "correlated: loops per group", AtLeast(1)},
      {"inject", "offset_m", &i.offset_m,
       "correlated: the group's offset in the own map frame (m; 2.4: the marina's pile-bent "
       "spacing)",
       Above(0)},
      {"inject", "directions", &i.directions,
       "correlated: 0 any direction, N one of N evenly spaced (4: +-x, +-y)", AtLeast(0)},
      {"inject", "seed", &i.seed,
       "seed of the wrong loops (the robot at index r in the mission uses seed * 1000 + r)"},
  };
}

// The shortest text that reads back as exactly v: "0.85", "2", "1e-06".
std::string Shortest(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// As YAML: with a decimal point, so the file shows a number is not an integer ("2.0").
std::string FormatNumber(double v) {
  std::string s = Shortest(v);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

std::string Scalar(const YAML::Node& n) {
  if (n.IsScalar()) return n.Scalar();
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a mapping";
  return "nothing";
}

// A plain (unquoted) scalar's text, or nothing: "5" in quotes is a string, not a number.
std::optional<std::string> Plain(const YAML::Node& n) {
  if (!n.IsScalar() || n.Tag() == "!" || n.Scalar().empty()) return std::nullopt;
  return n.Scalar();
}

std::string RangeText(const Range& r) {
  if (r.min && r.max) {
    return std::string(r.min_open ? "(" : "[") + Shortest(*r.min) + ", " + Shortest(*r.max) +
           (r.max_open ? ")" : "]");
  }
  if (r.min) return std::string(r.min_open ? "> " : ">= ") + Shortest(*r.min);
  if (r.max) return std::string(r.max_open ? "< " : "<= ") + Shortest(*r.max);
  return "";
}

bool InRange(const Range& r, double v) {
  if (r.min && (r.min_open ? !(v > *r.min) : !(v >= *r.min))) return false;
  if (r.max && (r.max_open ? !(v < *r.max) : !(v <= *r.max))) return false;
  return true;
}

// Sets the field from `value`; "" on success, otherwise what was expected.
std::string Assign(const Field& f, const YAML::Node& value) {
  const auto text = Plain(value);
  const std::string got =
      value.IsScalar() ? ", got '" + value.Scalar() + "'" : ", got " + Scalar(value);
  const std::string range = RangeText(f.range);
  const std::string in =
      range.empty() ? "" : (range[0] == '[' || range[0] == '(' ? " in " : " ") + range;
  return std::visit(
      [&](auto* target) -> std::string {
        using T = std::remove_pointer_t<decltype(target)>;
        if constexpr (std::is_same_v<T, bool>) {
          if (!text || (*text != "true" && *text != "false")) return "expected true or false" + got;
          *target = *text == "true";
        } else if constexpr (std::is_same_v<T, int>) {
          const std::string expect = "expected an integer" + in;
          if (!text) return expect + got;
          char* end = nullptr;
          errno = 0;
          const long long v = std::strtoll(text->c_str(), &end, 10);
          if (errno != 0 || end != text->c_str() + text->size() ||
              v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max()) {
            return expect + got;
          }
          if (!InRange(f.range, static_cast<double>(v))) return expect + got;
          *target = static_cast<int>(v);
        } else if constexpr (std::is_same_v<T, double>) {
          const std::string expect = "expected a number" + in;
          if (!text) return expect + got;
          char* end = nullptr;
          errno = 0;
          const double v = std::strtod(text->c_str(), &end);
          if (errno != 0 || end != text->c_str() + text->size() || !std::isfinite(v)) {
            return expect + got;
          }
          if (!InRange(f.range, v)) return expect + got;
          *target = v;
        } else if constexpr (std::is_same_v<T, std::uint64_t>) {
          const std::string expect = "expected an integer >= 0";
          if (!text || (*text)[0] == '-' || (*text)[0] == '+') return expect + got;
          char* end = nullptr;
          errno = 0;
          const unsigned long long v = std::strtoull(text->c_str(), &end, 10);
          if (errno != 0 || end != text->c_str() + text->size()) return expect + got;
          *target = static_cast<std::uint64_t>(v);
        } else {
          if (!value.IsScalar()) {
            std::string list;
            for (const auto& c : f.choices) list += (list.empty() ? "" : ", ") + c;
            return "expected one of: " + list + got;
          }
          const std::string s = value.Scalar();
          bool known = false;
          for (const auto& c : f.choices) known = known || c == s;
          if (!known) return "'" + s + "' is not allowed; " + graph::ExpectedOneOf(f.choices, s);
          *target = s;
        }
        return "";
      },
      f.target);
}

std::vector<std::string> Keys(const std::vector<Field>& fields, const std::string& section) {
  std::vector<std::string> out;
  for (const auto& f : fields) {
    if (section == f.section) out.push_back(f.key);
  }
  return out;
}

const Field* Find(const std::vector<Field>& fields, const std::string& section,
                  const std::string& key) {
  for (const auto& f : fields) {
    if (section == f.section && key == f.key) return &f;
  }
  return nullptr;
}

class Reader {
 public:
  Reader() : fields_(Fields(experiment_)) {}

  void ReadDocument(const YAML::Node& root, const std::string& file) {
    if (!root || root.IsNull()) return;  // an empty file: the defaults
    if (!root.IsMap()) {
      Error(file, root.Mark(), "expected a mapping of sections: " + SectionList());
      return;
    }
    std::set<std::string> seen_sections;
    for (const auto& kv : root) {
      if (!kv.first.IsScalar()) {
        Error(file, kv.first.Mark(), "expected a section name as key, got " + Scalar(kv.first));
        continue;
      }
      const std::string section = kv.first.Scalar();
      if (Keys(fields_, section).empty()) {
        Error(file, kv.first.Mark(),
              "unknown section '" + section + "'; " +
                  graph::ExpectedOneOf({std::begin(kSections), std::end(kSections)}, section));
        continue;
      }
      if (!seen_sections.insert(section).second) {
        Error(file, kv.first.Mark(), "section '" + section + "' given twice");
        continue;
      }
      if (kv.second.IsNull()) continue;  // "inject:" with nothing under it
      if (!kv.second.IsMap()) {
        Error(file, kv.second.Mark(),
              section + ": expected a mapping of keys: " + KeyList(section) + ", got " +
                  Scalar(kv.second));
        continue;
      }
      std::set<std::string> seen_keys;
      for (const auto& item : kv.second) {
        if (!item.first.IsScalar()) {
          Error(file, item.first.Mark(),
                section + ": expected a key name, got " + Scalar(item.first));
          continue;
        }
        const std::string key = item.first.Scalar();
        if (!seen_keys.insert(key).second) {
          Error(file, item.first.Mark(), section + "." + key + " given twice");
          continue;
        }
        Set(section, key, item.first.Mark(), item.second,
            item.second.IsNull() ? item.first.Mark() : item.second.Mark(), file);
      }
    }
  }

  void ApplyOverride(const std::string& o) {
    const std::string where = "--exp-set " + o;
    const auto eq = o.find('=');
    const auto dot = o.find('.');
    if (eq == std::string::npos || dot == std::string::npos || dot > eq || dot == 0 ||
        dot + 1 == eq) {
      diagnostics_.push_back({"--exp-set", 0, 0, "'" + o + "': expected section.key=value"});
      return;
    }
    const std::string section = o.substr(0, dot);
    const std::string key = o.substr(dot + 1, eq - dot - 1);
    if (Keys(fields_, section).empty()) {
      diagnostics_.push_back(
          {where, 0, 0,
           "unknown section '" + section + "'; " +
               graph::ExpectedOneOf({std::begin(kSections), std::end(kSections)}, section)});
      return;
    }
    YAML::Node value;
    try {
      value = YAML::Load(o.substr(eq + 1));
    } catch (const YAML::Exception& e) {
      diagnostics_.push_back({where, 0, 0, "'" + o + "': " + e.msg});
      return;
    }
    Set(section, key, YAML::Mark::null_mark(), value, YAML::Mark::null_mark(), where);
  }

  // The keys that only make sense together.
  void CheckPairs() {
    const auto& o = experiment_.optimizer;
    Pair("optimizer", "local_chain_sigma_xy_m", o.local_chain_sigma_xy_m,
         "local_chain_sigma_yaw_deg", o.local_chain_sigma_yaw_deg, "the local graph's information");
    Pair("optimizer", "loop_sigma_xy_m", o.loop_sigma_xy_m, "loop_sigma_yaw_deg",
         o.loop_sigma_yaw_deg, "each loop's own covariance");
  }

  Experiment Result() const {
    if (!diagnostics_.empty()) throw ExperimentError(diagnostics_);
    return experiment_;
  }

 private:
  struct Where {
    std::string file;
    YAML::Mark mark;
  };

  void Error(const std::string& file, const YAML::Mark& mark, std::string message) {
    const bool known = !mark.is_null() && mark.line >= 0;
    diagnostics_.push_back(
        {file, known ? mark.line + 1 : 0, known ? mark.column + 1 : 0, std::move(message)});
  }

  // key_mark and value_mark: where the key and its value stand (null for an override).
  void Set(const std::string& section, const std::string& key, const YAML::Mark& key_mark,
           const YAML::Node& value, const YAML::Mark& value_mark, const std::string& file) {
    const Field* f = Find(fields_, section, key);
    if (f == nullptr) {
      Error(file, key_mark,
            "unknown key '" + key + "' in " + section + "; " +
                graph::ExpectedOneOf(Keys(fields_, section), key));
      return;
    }
    if (const std::string problem = Assign(*f, value); !problem.empty()) {
      Error(file, value_mark, section + "." + key + ": " + problem);
      return;
    }
    set_[section + "." + key] = {file, value_mark};
  }

  void Pair(const std::string& section, const std::string& a, double va, const std::string& b,
            double vb, const std::string& zero_means) {
    if ((va > 0) == (vb > 0)) return;
    // Reported where the one that was given stands.
    const auto it =
        set_.count(section + "." + a) ? set_.find(section + "." + a) : set_.find(section + "." + b);
    const Where w = it != set_.end() ? it->second : Where{"experiment", YAML::Mark::null_mark()};
    Error(w.file, w.mark,
          section + "." + a + " and " + section + "." + b + " go together: both > 0, or both 0 (" +
              zero_means + ")");
  }

  std::string SectionList() const {
    std::string out;
    for (const char* s : kSections) out += (out.empty() ? "" : ", ") + std::string(s);
    return out;
  }
  std::string KeyList(const std::string& section) const {
    std::string out;
    for (const auto& k : Keys(fields_, section)) out += (out.empty() ? "" : ", ") + k;
    return out;
  }

  Experiment experiment_;
  std::vector<Field> fields_;
  std::vector<graph::Diagnostic> diagnostics_;
  std::map<std::string, Where> set_;  // "section.key" -> where it was last given
};

Experiment Load(const YAML::Node* root, const std::string& file,
                const std::vector<std::string>& overrides) {
  Reader reader;
  if (root != nullptr) reader.ReadDocument(*root, file);
  for (const auto& o : overrides) reader.ApplyOverride(o);
  reader.CheckPairs();
  return reader.Result();
}

// Wraps `text` into comment lines of at most 100 columns, each starting with `indent` "# ".
std::string Comment(const std::string& text, const std::string& indent) {
  std::string out, line;
  std::istringstream words(text);
  std::string w;
  while (words >> w) {
    if (!line.empty() && indent.size() + 2 + line.size() + 1 + w.size() > 100) {
      out += indent + "# " + line + "\n";
      line.clear();
    }
    line += (line.empty() ? "" : " ") + w;
  }
  if (!line.empty()) out += indent + "# " + line + "\n";
  return out;
}

}  // namespace

ExperimentError::ExperimentError(std::vector<graph::Diagnostic> diagnostics)
    : std::runtime_error([&] {
        std::string out;
        for (const auto& d : diagnostics) out += (out.empty() ? "" : "\n") + d.ToString();
        return out;
      }()),
      diagnostics_(std::move(diagnostics)) {}

Experiment LoadExperiment(const std::string& path, const std::vector<std::string>& overrides) {
  if (path.empty()) return Load(nullptr, "", overrides);
  std::error_code ec;
  std::ifstream in(path);
  if (!std::filesystem::is_regular_file(path, ec) || !in) {
    throw ExperimentError({{path, 0, 0, "not a readable file"}});
  }
  std::stringstream text;
  text << in.rdbuf();
  return LoadExperimentString(text.str(), path, overrides);
}

Experiment LoadExperimentString(const std::string& yaml, const std::string& name,
                                const std::vector<std::string>& overrides) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    const bool known = !e.mark.is_null() && e.mark.line >= 0;
    throw ExperimentError({{name, known ? e.mark.line + 1 : 0, known ? e.mark.column + 1 : 0,
                            "YAML syntax error: " + e.msg}});
  }
  return Load(&root, name, overrides);
}

std::string ExperimentYaml(const Experiment& experiment) {
  Experiment copy = experiment;
  const auto fields = Fields(copy);
  std::string out =
      "# A draco-team-eval experiment, every key with its value (apps/team_eval/experiment.hpp).\n"
      "# draco-team-eval MISSION --experiment FILE runs it.\n";
  std::string section;
  for (const auto& f : fields) {
    if (section != f.section) {
      section = f.section;
      out += section + ":\n";
    }
    out += Comment(f.doc, "  ");
    const std::string value = std::visit(
        [](auto* v) -> std::string {
          using T = std::remove_pointer_t<decltype(v)>;
          if constexpr (std::is_same_v<T, bool>) {
            return *v ? "true" : "false";
          } else if constexpr (std::is_same_v<T, double>) {
            return FormatNumber(*v);
          } else if constexpr (std::is_same_v<T, std::string>) {
            return *v;
          } else {
            return std::to_string(*v);
          }
        },
        f.target);
    out += "  " + std::string(f.key) + ": " + value + "\n";
  }
  return out;
}

}  // namespace draco::team_eval
