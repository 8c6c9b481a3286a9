// mission.yaml: writing and strict reading (every key known, every key present).
#include <yaml-cpp/yaml.h>

#include <charconv>
#include <map>
#include <set>
#include <system_error>

#include "internal.hpp"

namespace draco::recording {
namespace {

using internal::FormatDouble;
namespace fs = std::filesystem;

// Fixed descriptions of the version-1 conventions, written into every mission.yaml so the
// file explains itself. The reader requires the keys but does not interpret the text.
const std::vector<std::pair<std::string, std::string>>& Conventions() {
  static const std::vector<std::pair<std::string, std::string>> conventions = {
      {"units", "SI: seconds, metres, radians, metres per second; names carry the unit"},
      {"time", "mission seconds on one clock shared by every robot of the mission"},
      {"world_frame", "x east, y north, z up; ground truth is the body pose in this frame"},
      {"body_frame", "x forward, y left, z up; DVL velocity is in this frame"},
      {"sonar_frame", "x along the zero bearing, y left, z up; bearings counter-clockwise"},
      {"attitude", "R = Rz(yaw) Ry(pitch) Rx(roll); yaw counter-clockwise from world x"},
      {"depth", "metres below the surface, positive down"},
  };
  return conventions;
}

void EmitDouble(YAML::Emitter& out, const char* key, double value) {
  out << YAML::Key << key << YAML::Value << FormatDouble(value);
}

// Reads one YAML map, remembering which keys were used so leftovers can be rejected.
class MapReader {
 public:
  MapReader(const YAML::Node& node, std::string path, const fs::path& file)
      : node_(node), path_(std::move(path)), file_(file) {
    if (!node_.IsMap()) Fail(node_, "expected a mapping");
  }

  YAML::Node Get(const std::string& key) {
    used_.insert(key);
    const YAML::Node child = node_[key];
    if (!child) Fail(node_, "missing key '" + Qualified(key) + "'");
    return child;
  }

  bool Has(const std::string& key) const { return static_cast<bool>(node_[key]); }

  std::string String(const std::string& key) {
    const YAML::Node child = Get(key);
    if (!child.IsScalar()) Fail(child, "key '" + Qualified(key) + "': expected a string");
    return child.Scalar();
  }

  double Double(const std::string& key) {
    const YAML::Node child = Get(key);
    std::optional<double> value;
    if (child.IsScalar()) value = internal::ParseDouble(child.Scalar());
    if (!value) Fail(child, "key '" + Qualified(key) + "': expected a finite number");
    return *value;
  }

  template <typename Int>
  Int Integer(const std::string& key) {
    const YAML::Node child = Get(key);
    Int value{};
    bool ok = child.IsScalar();
    if (ok) {
      const std::string& text = child.Scalar();
      const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
      ok = !text.empty() && result.ec == std::errc() && result.ptr == text.data() + text.size();
    }
    if (!ok) Fail(child, "key '" + Qualified(key) + "': expected an integer");
    return value;
  }

  bool Bool(const std::string& key) {
    const YAML::Node child = Get(key);
    if (child.IsScalar()) {
      const std::string& text = child.Scalar();
      if (text == "true") return true;
      if (text == "false") return false;
    }
    Fail(child, "key '" + Qualified(key) + "': expected true or false");
  }

  MapReader Map(const std::string& key) { return MapReader(Get(key), Qualified(key), file_); }

  // Unknown keys are errors: a misspelt key must not be silently ignored.
  void Finish() const {
    for (const auto& entry : node_) {
      const std::string key = entry.first.Scalar();
      if (used_.count(key) == 0) Fail(entry.first, "unknown key '" + Qualified(key) + "'");
    }
  }

  [[noreturn]] void Fail(const YAML::Node& at, const std::string& what) const {
    std::string where = file_.string();
    const YAML::Mark mark = at.Mark();
    if (!mark.is_null()) where += ":" + std::to_string(mark.line + 1);
    throw RecordingError(where + ": " + what);
  }

  std::string Qualified(const std::string& key) const {
    return path_.empty() ? key : path_ + "." + key;
  }

 private:
  YAML::Node node_;
  std::string path_;
  const fs::path& file_;
  std::set<std::string> used_;
};

}  // namespace

namespace internal {

std::string MissionYaml(const MissionInfo& info) {
  YAML::Emitter out;
  out << YAML::Comment(std::string("draco recorded mission; specification: ") +
                       "docs/recording-format.md");
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << kFormatName;
  out << YAML::Key << "version" << YAML::Value << kFormatVersion;
  out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << info.name;
  out << YAML::Key << "world" << YAML::Value << YAML::DoubleQuoted << info.world;
  out << YAML::Key << "seed" << YAML::Value << std::to_string(info.seed);
  out << YAML::Key << "conventions" << YAML::Value << YAML::BeginMap;
  for (const auto& [key, text] : Conventions()) {
    out << YAML::Key << key << YAML::Value << YAML::DoubleQuoted << text;
  }
  out << YAML::EndMap;

  const SonarInfo& sonar = info.sonar;
  out << YAML::Key << "sonar" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "beams" << YAML::Value << sonar.num_beams;
  out << YAML::Key << "range_bins" << YAML::Value << sonar.num_ranges;
  EmitDouble(out, "range_resolution_m", sonar.range_resolution_m);
  EmitDouble(out, "horizontal_aperture_rad", sonar.horizontal_aperture_rad);
  EmitDouble(out, "vertical_aperture_rad", sonar.vertical_aperture_rad);
  EmitDouble(out, "rate_hz", sonar.rate_hz);
  out << YAML::Key << "mount" << YAML::Value << YAML::BeginMap;
  EmitDouble(out, "x_m", sonar.mount.position_m[0]);
  EmitDouble(out, "y_m", sonar.mount.position_m[1]);
  EmitDouble(out, "z_m", sonar.mount.position_m[2]);
  EmitDouble(out, "roll_rad", sonar.mount.roll_rad);
  EmitDouble(out, "pitch_rad", sonar.mount.pitch_rad);
  EmitDouble(out, "yaw_rad", sonar.mount.yaw_rad);
  out << YAML::EndMap << YAML::EndMap;

  out << YAML::Key << "navigation" << YAML::Value << YAML::BeginMap;
  EmitDouble(out, "dvl_rate_hz", info.navigation.dvl_hz);
  EmitDouble(out, "ahrs_rate_hz", info.navigation.ahrs_hz);
  EmitDouble(out, "depth_rate_hz", info.navigation.depth_hz);
  EmitDouble(out, "ground_truth_rate_hz", info.navigation.ground_truth_hz);
  out << YAML::EndMap;

  out << YAML::Key << "robots" << YAML::Value << YAML::BeginSeq;
  for (const RobotInfo& robot : info.robots) {
    out << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << robot.name;
    out << YAML::Key << "id" << YAML::Value << robot.id;
    out << YAML::Key << "ground_truth" << YAML::Value
        << (robot.has_ground_truth ? "true" : "false");
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;

  out << YAML::Key << "notes" << YAML::Value;
  if (info.notes.find('\n') != std::string::npos) {
    out << YAML::Literal << info.notes;
  } else {
    out << YAML::DoubleQuoted << info.notes;
  }
  out << YAML::EndMap;
  if (!out.good()) throw std::logic_error("mission.yaml emitter: " + out.GetLastError());
  return std::string(out.c_str()) + "\n";
}

}  // namespace internal

MissionInfo LoadMissionInfo(const std::filesystem::path& mission_dir) {
  namespace fs = std::filesystem;
  const fs::path file = mission_dir / internal::kMissionFile;
  std::error_code error;
  if (!fs::is_regular_file(file, error)) {
    throw RecordingError(file.string() + ": missing (expected a draco mission directory with " +
                         "mission.yaml)");
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const YAML::Exception& e) {
    throw RecordingError(file.string() + ":" + std::to_string(e.mark.line + 1) +
                         ": malformed YAML: " + e.msg);
  }

  MapReader top(root, "", file);
  const std::string format = top.String("format");
  if (format != kFormatName) {
    top.Fail(root["format"],
             "format is '" + format + "', expected '" + std::string(kFormatName) + "'");
  }
  const int version = top.Integer<int>("version");
  if (version != kFormatVersion) {
    top.Fail(root["version"], "unsupported format version " + std::to_string(version) +
                                  ", this reader reads version " + std::to_string(kFormatVersion));
  }

  MissionInfo info;
  info.name = top.String("name");
  info.world = top.String("world");
  info.seed = top.Integer<std::uint64_t>("seed");
  {
    MapReader conventions = top.Map("conventions");
    for (const auto& entry : Conventions()) conventions.String(entry.first);
    conventions.Finish();
  }
  {
    MapReader sonar = top.Map("sonar");
    info.sonar.num_beams = sonar.Integer<int>("beams");
    info.sonar.num_ranges = sonar.Integer<int>("range_bins");
    info.sonar.range_resolution_m = sonar.Double("range_resolution_m");
    info.sonar.horizontal_aperture_rad = sonar.Double("horizontal_aperture_rad");
    info.sonar.vertical_aperture_rad = sonar.Double("vertical_aperture_rad");
    info.sonar.rate_hz = sonar.Double("rate_hz");
    MapReader mount = sonar.Map("mount");
    info.sonar.mount.position_m = {mount.Double("x_m"), mount.Double("y_m"), mount.Double("z_m")};
    info.sonar.mount.roll_rad = mount.Double("roll_rad");
    info.sonar.mount.pitch_rad = mount.Double("pitch_rad");
    info.sonar.mount.yaw_rad = mount.Double("yaw_rad");
    mount.Finish();
    sonar.Finish();
  }
  {
    MapReader nav = top.Map("navigation");
    info.navigation.dvl_hz = nav.Double("dvl_rate_hz");
    info.navigation.ahrs_hz = nav.Double("ahrs_rate_hz");
    info.navigation.depth_hz = nav.Double("depth_rate_hz");
    info.navigation.ground_truth_hz = nav.Double("ground_truth_rate_hz");
    nav.Finish();
  }
  {
    const YAML::Node robots = top.Get("robots");
    if (!robots.IsSequence()) top.Fail(robots, "key 'robots': expected a list");
    for (std::size_t i = 0; i < robots.size(); ++i) {
      MapReader robot(robots[i], "robots[" + std::to_string(i) + "]", file);
      RobotInfo entry;
      entry.name = robot.String("name");
      entry.id = robot.Integer<int>("id");
      entry.has_ground_truth = robot.Bool("ground_truth");
      robot.Finish();
      info.robots.push_back(entry);
    }
  }
  info.notes = top.Has("notes") && top.Get("notes").IsNull() ? "" : top.String("notes");
  top.Finish();

  const std::string problem = internal::ValidateMissionInfo(info);
  if (!problem.empty()) throw RecordingError(file.string() + ": " + problem);
  return info;
}

}  // namespace draco::recording
