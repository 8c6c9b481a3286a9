// Strict YAML reading: every key must be known and is used once; errors name file, line,
// column and what was expected.
#pragma once

#include <yaml-cpp/yaml.h>

#include <set>
#include <string>
#include <utility>
#include <vector>

#include "draco/sim/geometry.hpp"
#include "draco/sim/world.hpp"

namespace draco::sim::yaml {

[[noreturn]] void Fail(const std::string& file, const YAML::Node& node, const std::string& what);

// Loads a file or text; parse errors become ConfigError with the location.
YAML::Node LoadFile(const std::string& path);
YAML::Node LoadText(const std::string& text, const std::string& source_name);

double ToDouble(const std::string& file, const YAML::Node& node, const std::string& what);
int ToInt(const std::string& file, const YAML::Node& node, const std::string& what);
bool ToBool(const std::string& file, const YAML::Node& node, const std::string& what);
std::string ToString(const std::string& file, const YAML::Node& node, const std::string& what);
Vec2 ToVec2(const std::string& file, const YAML::Node& node, const std::string& what);
std::vector<Vec2> ToVec2List(const std::string& file, const YAML::Node& node,
                             const std::string& what, std::size_t min_points);
std::vector<double> ToDoubleList(const std::string& file, const YAML::Node& node,
                                 const std::string& what);

// A mapping whose keys are checked: Get() marks a key used; Finish() fails on any key not in
// the allowed set.
class Map {
 public:
  Map(std::string file, YAML::Node node, std::string what, std::vector<std::string> allowed);

  bool Has(const std::string& key) const;
  YAML::Node Get(const std::string& key) const;       // Fail when missing
  YAML::Node Optional(const std::string& key) const;  // null node when missing
  double Double(const std::string& key) const;
  double Double(const std::string& key, double fallback) const;
  int Int(const std::string& key, int fallback) const;
  bool Bool(const std::string& key, bool fallback) const;
  std::string String(const std::string& key) const;
  std::string String(const std::string& key, const std::string& fallback) const;
  Vec2 Vec(const std::string& key) const;
  Vec2 Vec(const std::string& key, Vec2 fallback) const;
  // A [min, max] pair with min < max.
  std::pair<double, double> Range(const std::string& key) const;

  const std::string& file() const { return file_; }
  const YAML::Node& node() const { return node_; }
  [[noreturn]] void FailAt(const std::string& key, const std::string& what) const;

 private:
  std::string file_;
  YAML::Node node_;
  std::string what_;
  std::vector<std::string> allowed_;
};

}  // namespace draco::sim::yaml
