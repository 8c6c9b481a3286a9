#include "yaml_util.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace draco::sim::yaml {

namespace {

std::string Location(const std::string& file, const YAML::Mark& mark) {
  std::ostringstream out;
  out << file;
  if (mark.line >= 0) out << ":" << mark.line + 1 << ":" << mark.column + 1;
  return out.str();
}

std::string Join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) {
    if (!out.empty()) out += ", ";
    out += n;
  }
  return out;
}

}  // namespace

void Fail(const std::string& file, const YAML::Node& node, const std::string& what) {
  YAML::Mark mark = YAML::Mark::null_mark();
  if (node.IsDefined()) mark = node.Mark();
  throw ConfigError(Location(file, mark) + ": " + what);
}

YAML::Node LoadFile(const std::string& path) {
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open file");
  } catch (const YAML::Exception& e) {
    throw ConfigError(Location(path, e.mark) + ": YAML syntax error: " + e.msg);
  }
}

YAML::Node LoadText(const std::string& text, const std::string& source_name) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(Location(source_name, e.mark) + ": YAML syntax error: " + e.msg);
  }
}

double ToDouble(const std::string& file, const YAML::Node& node, const std::string& what) {
  if (!node.IsScalar()) Fail(file, node, "expected a number for " + what);
  double v = 0.0;
  try {
    v = node.as<double>();
  } catch (const YAML::Exception&) {
    Fail(file, node, "expected a number for " + what + ", got '" + node.Scalar() + "'");
  }
  // yaml-cpp reads .nan and .inf: no size, rate or coordinate may be one.
  if (!std::isfinite(v)) {
    Fail(file, node, "expected a finite number for " + what + ", got '" + node.Scalar() + "'");
  }
  return v;
}

int ToInt(const std::string& file, const YAML::Node& node, const std::string& what) {
  if (!node.IsScalar()) Fail(file, node, "expected an integer for " + what);
  try {
    return node.as<int>();
  } catch (const YAML::Exception&) {
    Fail(file, node, "expected an integer for " + what + ", got '" + node.Scalar() + "'");
  }
}

bool ToBool(const std::string& file, const YAML::Node& node, const std::string& what) {
  if (!node.IsScalar()) Fail(file, node, "expected true or false for " + what);
  try {
    return node.as<bool>();
  } catch (const YAML::Exception&) {
    Fail(file, node, "expected true or false for " + what + ", got '" + node.Scalar() + "'");
  }
}

std::string ToString(const std::string& file, const YAML::Node& node, const std::string& what) {
  if (!node.IsScalar()) Fail(file, node, "expected a string for " + what);
  return node.Scalar();
}

Vec2 ToVec2(const std::string& file, const YAML::Node& node, const std::string& what) {
  if (!node.IsSequence() || node.size() != 2) {
    Fail(file, node, "expected [x, y] (two numbers) for " + what);
  }
  return {ToDouble(file, node[0], what), ToDouble(file, node[1], what)};
}

std::vector<Vec2> ToVec2List(const std::string& file, const YAML::Node& node,
                             const std::string& what, std::size_t min_points) {
  if (!node.IsSequence() || node.size() < min_points) {
    Fail(
        file, node,
        "expected a list of at least " + std::to_string(min_points) + " [x, y] points for " + what);
  }
  std::vector<Vec2> out;
  for (const auto& p : node) out.push_back(ToVec2(file, p, what));
  return out;
}

std::vector<double> ToDoubleList(const std::string& file, const YAML::Node& node,
                                 const std::string& what) {
  if (!node.IsSequence()) Fail(file, node, "expected a list of numbers for " + what);
  std::vector<double> out;
  for (const auto& v : node) out.push_back(ToDouble(file, v, what));
  return out;
}

Map::Map(std::string file, YAML::Node node, std::string what, std::vector<std::string> allowed)
    : file_(std::move(file)),
      node_(std::move(node)),
      what_(std::move(what)),
      allowed_(std::move(allowed)) {
  if (!node_.IsMap()) Fail(file_, node_, "expected a mapping (key: value) for " + what_);
  for (const auto& kv : node_) {
    if (!kv.first.IsScalar()) Fail(file_, kv.first, "expected a name as key in " + what_);
    const std::string key = kv.first.Scalar();
    if (std::find(allowed_.begin(), allowed_.end(), key) == allowed_.end()) {
      Fail(file_, kv.first,
           "unknown key '" + key + "' in " + what_ + " (expected one of: " + Join(allowed_) + ")");
    }
  }
}

bool Map::Has(const std::string& key) const { return static_cast<bool>(node_[key]); }

YAML::Node Map::Get(const std::string& key) const {
  YAML::Node n = node_[key];
  if (!n) Fail(file_, node_, "missing key '" + key + "' in " + what_);
  return n;
}

YAML::Node Map::Optional(const std::string& key) const { return node_[key]; }

double Map::Double(const std::string& key) const {
  return ToDouble(file_, Get(key), key + " in " + what_);
}
double Map::Double(const std::string& key, double fallback) const {
  return Has(key) ? Double(key) : fallback;
}
int Map::Int(const std::string& key, int fallback) const {
  return Has(key) ? ToInt(file_, Get(key), key + " in " + what_) : fallback;
}
bool Map::Bool(const std::string& key, bool fallback) const {
  return Has(key) ? ToBool(file_, Get(key), key + " in " + what_) : fallback;
}
std::string Map::String(const std::string& key) const {
  return ToString(file_, Get(key), key + " in " + what_);
}
std::string Map::String(const std::string& key, const std::string& fallback) const {
  return Has(key) ? String(key) : fallback;
}
Vec2 Map::Vec(const std::string& key) const {
  return ToVec2(file_, Get(key), key + " in " + what_);
}
Vec2 Map::Vec(const std::string& key, Vec2 fallback) const {
  return Has(key) ? Vec(key) : fallback;
}

std::pair<double, double> Map::Range(const std::string& key) const {
  const YAML::Node n = Get(key);
  const Vec2 v = ToVec2(file_, n, key + " in " + what_);
  if (!(v.x < v.y)) Fail(file_, n, "expected [min, max] with min < max for " + key);
  return {v.x, v.y};
}

void Map::FailAt(const std::string& key, const std::string& what) const {
  Fail(file_, Has(key) ? node_[key] : node_, what);
}

}  // namespace draco::sim::yaml
