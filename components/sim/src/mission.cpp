#include "draco/sim/mission.hpp"

#include <cctype>
#include <cstdint>
#include <string>

#include "yaml_util.hpp"

namespace draco::sim {

namespace {

constexpr double kDeg = M_PI / 180.0;

class MissionParser {
 public:
  MissionParser(Mission* mission, std::string file, std::filesystem::path base)
      : m_(mission), file_(std::move(file)), base_(std::move(base)) {}

  void Parse(const YAML::Node& root) {
    yaml::Map top(file_, root, "mission",
                  {"name", "description", "world", "seed", "duration_s", "sonar", "navigation",
                   "vehicle", "robots"});
    m_->name = top.String("name", "mission");
    const std::string world = top.String("world");
    m_->world_path =
        std::filesystem::path(world).is_absolute() ? std::filesystem::path(world) : base_ / world;
    const int seed = top.Int("seed", 1);
    if (seed < 0) top.FailAt("seed", "seed must be >= 0");
    m_->seed = static_cast<std::uint64_t>(seed);
    m_->duration_s = top.Double("duration_s", 0.0);
    if (m_->duration_s < 0.0) top.FailAt("duration_s", "duration_s must be >= 0");
    if (top.Has("sonar")) ParseSonar(top.Get("sonar"));
    if (top.Has("navigation")) ParseNavigation(top.Get("navigation"));
    if (top.Has("vehicle")) ParseVehicle(top.Get("vehicle"));
    const YAML::Node robots = top.Get("robots");
    if (!robots.IsSequence() || robots.size() == 0) {
      yaml::Fail(file_, robots, "expected a non-empty list of robots");
    }
    for (const auto& r : robots) ParseRobot(r);
    for (std::size_t i = 0; i < m_->robots.size(); ++i) {
      for (std::size_t j = 0; j < i; ++j) {
        if (m_->robots[i].name == m_->robots[j].name) {
          yaml::Fail(file_, robots[i], "duplicate robot name '" + m_->robots[i].name + "'");
        }
      }
    }
  }

 private:
  static void Positive(const yaml::Map& m, const std::string& key, double v) {
    if (!(v > 0.0)) m.FailAt(key, key + " must be positive");
  }

  void ParseSonar(const YAML::Node& node) {
    yaml::Map m(file_, node, "sonar",
                {"num_beams",
                 "num_ranges",
                 "range_max_m",
                 "horizontal_aperture_deg",
                 "vertical_aperture_deg",
                 "tilt_deg",
                 "rate_hz",
                 "bearing_nonuniformity",
                 "elevation_rays",
                 "absorption_db_per_m",
                 "beam_blur_fwhm_deg",
                 "range_blur_sigma_bins",
                 "range_jitter_sigma_m",
                 "speckle_looks",
                 "noise_sigma",
                 "noise_floor_sigma",
                 "near_field_amplitude",
                 "near_field_length_m",
                 "streak_fraction",
                 "streak_level",
                 "ghost_amplitude",
                 "gain",
                 "object_gain"});
    SonarOptions& s = m_->sonar;
    s.num_beams = m.Int("num_beams", s.num_beams);
    s.num_ranges = m.Int("num_ranges", s.num_ranges);
    if (s.num_beams < 2 || s.num_ranges < 16) {
      yaml::Fail(file_, node, "sonar needs num_beams >= 2 and num_ranges >= 16");
    }
    // The recording format's bounds (docs/recording-format.md), checked here so that an
    // absurd size names the mission file before anything is simulated.
    if (s.num_beams > 65536 || s.num_ranges > 65536 ||
        std::int64_t{s.num_beams} * s.num_ranges > (std::int64_t{64} << 20)) {
      yaml::Fail(file_, node,
                 "sonar images of " + std::to_string(s.num_ranges) + " x " +
                     std::to_string(s.num_beams) +
                     " exceed what a recording holds (65536 a side, 64 Mi pixels)");
    }
    s.range_max_m = m.Double("range_max_m", s.range_max_m);
    Positive(m, "range_max_m", s.range_max_m);
    s.horizontal_aperture_rad = m.Double("horizontal_aperture_deg", 130.0) * kDeg;
    if (s.horizontal_aperture_rad <= 0.0 || s.horizontal_aperture_rad >= M_PI) {
      m.FailAt("horizontal_aperture_deg", "horizontal_aperture_deg must be in (0, 180)");
    }
    s.vertical_aperture_rad = m.Double("vertical_aperture_deg", 20.0) * kDeg;
    Positive(m, "vertical_aperture_deg", s.vertical_aperture_rad);
    m_->sonar_tilt_rad = m.Double("tilt_deg", m_->sonar_tilt_rad / kDeg) * kDeg;
    s.rate_hz = m.Double("rate_hz", s.rate_hz);
    Positive(m, "rate_hz", s.rate_hz);
    s.bearing_nonuniformity = m.Double("bearing_nonuniformity", s.bearing_nonuniformity);
    s.elevation_rays = m.Int("elevation_rays", s.elevation_rays);
    if (s.elevation_rays < 1) m.FailAt("elevation_rays", "elevation_rays must be >= 1");
    s.absorption_db_per_m = m.Double("absorption_db_per_m", s.absorption_db_per_m);
    s.beam_blur_fwhm_rad = m.Double("beam_blur_fwhm_deg", s.beam_blur_fwhm_rad / kDeg) * kDeg;
    s.range_blur_sigma_bins = m.Double("range_blur_sigma_bins", s.range_blur_sigma_bins);
    s.range_jitter_sigma_m = m.Double("range_jitter_sigma_m", s.range_jitter_sigma_m);
    s.speckle_looks = m.Double("speckle_looks", s.speckle_looks);
    Positive(m, "speckle_looks", s.speckle_looks);
    s.noise_sigma = m.Double("noise_sigma", s.noise_sigma);
    s.noise_floor_sigma = m.Double("noise_floor_sigma", s.noise_floor_sigma);
    s.near_field_amplitude = m.Double("near_field_amplitude", s.near_field_amplitude);
    s.near_field_length_m = m.Double("near_field_length_m", s.near_field_length_m);
    Positive(m, "near_field_length_m", s.near_field_length_m);
    s.streak_fraction = m.Double("streak_fraction", s.streak_fraction);
    s.streak_level = m.Double("streak_level", s.streak_level);
    s.ghost_amplitude = m.Double("ghost_amplitude", s.ghost_amplitude);
    s.gain = m.Double("gain", s.gain);
    Positive(m, "gain", s.gain);
    s.object_gain = m.Double("object_gain", s.object_gain);
    s.seabed_gain = m.Double("seabed_gain", s.seabed_gain);
  }

  void ParseNavigation(const YAML::Node& node) {
    yaml::Map m(file_, node, "navigation", {"dvl", "ahrs", "depth", "ground_truth_rate_hz"});
    NavigationOptions& n = m_->navigation;
    n.ground_truth_rate_hz = m.Double("ground_truth_rate_hz", n.ground_truth_rate_hz);
    Positive(m, "ground_truth_rate_hz", n.ground_truth_rate_hz);
    if (m.Has("dvl")) {
      yaml::Map d(file_, m.Get("dvl"), "navigation.dvl",
                  {"rate_hz", "noise_sigma_mps", "scale_sigma", "misalignment_sigma_deg",
                   "dropout_probability", "max_altitude_m", "altitude_noise_sigma_m"});
      n.dvl.rate_hz = d.Double("rate_hz", n.dvl.rate_hz);
      Positive(d, "rate_hz", n.dvl.rate_hz);
      n.dvl.noise_sigma_mps = d.Double("noise_sigma_mps", n.dvl.noise_sigma_mps);
      n.dvl.scale_sigma = d.Double("scale_sigma", n.dvl.scale_sigma);
      n.dvl.misalignment_sigma_rad =
          d.Double("misalignment_sigma_deg", n.dvl.misalignment_sigma_rad / kDeg) * kDeg;
      n.dvl.dropout_probability = d.Double("dropout_probability", n.dvl.dropout_probability);
      if (n.dvl.dropout_probability < 0.0 || n.dvl.dropout_probability > 1.0) {
        d.FailAt("dropout_probability", "dropout_probability must be in [0, 1]");
      }
      n.dvl.max_altitude_m = d.Double("max_altitude_m", n.dvl.max_altitude_m);
      n.dvl.altitude_noise_sigma_m =
          d.Double("altitude_noise_sigma_m", n.dvl.altitude_noise_sigma_m);
    }
    if (m.Has("ahrs")) {
      yaml::Map a(file_, m.Get("ahrs"), "navigation.ahrs",
                  {"rate_hz", "yaw_drift_sigma_deg", "yaw_drift_tau_s", "yaw_noise_sigma_deg",
                   "roll_pitch_noise_sigma_deg", "yaw_rate_noise_sigma_radps", "steel_anomaly_deg",
                   "steel_anomaly_length_m"});
      n.ahrs.rate_hz = a.Double("rate_hz", n.ahrs.rate_hz);
      Positive(a, "rate_hz", n.ahrs.rate_hz);
      n.ahrs.yaw_drift_sigma_rad =
          a.Double("yaw_drift_sigma_deg", n.ahrs.yaw_drift_sigma_rad / kDeg) * kDeg;
      n.ahrs.yaw_drift_tau_s = a.Double("yaw_drift_tau_s", n.ahrs.yaw_drift_tau_s);
      Positive(a, "yaw_drift_tau_s", n.ahrs.yaw_drift_tau_s);
      n.ahrs.yaw_noise_sigma_rad =
          a.Double("yaw_noise_sigma_deg", n.ahrs.yaw_noise_sigma_rad / kDeg) * kDeg;
      n.ahrs.roll_pitch_noise_sigma_rad =
          a.Double("roll_pitch_noise_sigma_deg", n.ahrs.roll_pitch_noise_sigma_rad / kDeg) * kDeg;
      n.ahrs.yaw_rate_noise_sigma_radps =
          a.Double("yaw_rate_noise_sigma_radps", n.ahrs.yaw_rate_noise_sigma_radps);
      n.ahrs.steel_anomaly_rad =
          a.Double("steel_anomaly_deg", n.ahrs.steel_anomaly_rad / kDeg) * kDeg;
      n.ahrs.steel_anomaly_length_m =
          a.Double("steel_anomaly_length_m", n.ahrs.steel_anomaly_length_m);
      Positive(a, "steel_anomaly_length_m", n.ahrs.steel_anomaly_length_m);
    }
    if (m.Has("depth")) {
      yaml::Map d(file_, m.Get("depth"), "navigation.depth", {"rate_hz", "noise_sigma_m"});
      n.depth.rate_hz = d.Double("rate_hz", n.depth.rate_hz);
      Positive(d, "rate_hz", n.depth.rate_hz);
      n.depth.noise_sigma_m = d.Double("noise_sigma_m", n.depth.noise_sigma_m);
    }
  }

  void ParseVehicle(const YAML::Node& node) {
    yaml::Map m(
        file_, node, "vehicle",
        {"lookahead_m", "max_yaw_rate_deg_s", "heading_gain_per_s", "yaw_rate_lag_s", "accel_mps2",
         "roll_amplitude_deg", "pitch_amplitude_deg", "heave_amplitude_m", "current_mps"});
    VehicleOptions& v = m_->vehicle;
    v.lookahead_m = m.Double("lookahead_m", v.lookahead_m);
    Positive(m, "lookahead_m", v.lookahead_m);
    v.max_yaw_rate_radps = m.Double("max_yaw_rate_deg_s", v.max_yaw_rate_radps / kDeg) * kDeg;
    Positive(m, "max_yaw_rate_deg_s", v.max_yaw_rate_radps);
    v.heading_gain_per_s = m.Double("heading_gain_per_s", v.heading_gain_per_s);
    v.yaw_rate_lag_s = m.Double("yaw_rate_lag_s", v.yaw_rate_lag_s);
    v.accel_mps2 = m.Double("accel_mps2", v.accel_mps2);
    Positive(m, "accel_mps2", v.accel_mps2);
    v.roll_amplitude_rad = m.Double("roll_amplitude_deg", v.roll_amplitude_rad / kDeg) * kDeg;
    v.pitch_amplitude_rad = m.Double("pitch_amplitude_deg", v.pitch_amplitude_rad / kDeg) * kDeg;
    v.heave_amplitude_m = m.Double("heave_amplitude_m", v.heave_amplitude_m);
    v.current_mps = m.Vec("current_mps", v.current_mps);
  }

  PatternSpec ParsePattern(const YAML::Node& node) {
    if (!node.IsMap() || !node["type"]) {
      yaml::Fail(file_, node,
                 "expected a pattern with a 'type' (waypoints, loop, lawnmower, figure_eight, "
                 "orbit)");
    }
    const std::string type = yaml::ToString(file_, node["type"], "pattern type");
    PatternSpec p;
    if (type == "waypoints" || type == "loop") {
      yaml::Map m(file_, node, type + " pattern", {"type", "waypoints_m", "laps"});
      p.type = type == "loop" ? PatternSpec::Type::kLoop : PatternSpec::Type::kWaypoints;
      p.waypoints_m =
          yaml::ToVec2List(file_, m.Get("waypoints_m"), "waypoints_m", type == "loop" ? 3 : 1);
      p.laps = m.Int("laps", 1);
    } else if (type == "lawnmower") {
      yaml::Map m(file_, node, "lawnmower pattern",
                  {"type", "origin_m", "heading_deg", "lane_length_m", "lane_spacing_m", "lanes"});
      p.type = PatternSpec::Type::kLawnmower;
      p.origin_m = m.Vec("origin_m");
      p.heading_rad = m.Double("heading_deg", 0.0) * kDeg;
      p.lane_length_m = m.Double("lane_length_m", p.lane_length_m);
      Positive(m, "lane_length_m", p.lane_length_m);
      p.lane_spacing_m = m.Double("lane_spacing_m", p.lane_spacing_m);
      p.lanes = m.Int("lanes", p.lanes);
      if (p.lanes < 1) m.FailAt("lanes", "lanes must be >= 1");
    } else if (type == "figure_eight" || type == "orbit") {
      yaml::Map m(file_, node, type + " pattern",
                  {"type", "center_m", "radius_m", "heading_deg", "laps", "clockwise"});
      p.type = type == "orbit" ? PatternSpec::Type::kOrbit : PatternSpec::Type::kFigureEight;
      p.center_m = m.Vec("center_m");
      p.radius_m = m.Double("radius_m");
      Positive(m, "radius_m", p.radius_m);
      p.heading_rad = m.Double("heading_deg", 0.0) * kDeg;
      p.laps = m.Int("laps", 1);
      p.clockwise = m.Bool("clockwise", false);
    } else {
      yaml::Fail(file_, node["type"],
                 "unknown pattern type '" + type +
                     "' (expected waypoints, loop, lawnmower, figure_eight or orbit)");
    }
    if (p.laps < 1) yaml::Fail(file_, node, "laps must be >= 1");
    return p;
  }

  void ParseRobot(const YAML::Node& node) {
    yaml::Map m(file_, node, "robot",
                {"name", "start_m", "start_yaw_deg", "depth_m", "speed_mps", "start_time_s",
                 "pattern", "patterns"});
    RobotSpec r;
    r.name = m.String("name");
    for (char ch : r.name) {
      if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-')) {
        m.FailAt("name", "robot name may hold letters, digits, '_' and '-' only");
      }
    }
    if (r.name.empty()) m.FailAt("name", "robot name must not be empty");
    r.start_m = m.Vec("start_m");
    r.start_yaw_rad = m.Double("start_yaw_deg", 0.0) * kDeg;
    r.depth_m = m.Double("depth_m", r.depth_m);
    Positive(m, "depth_m", r.depth_m);
    r.speed_mps = m.Double("speed_mps", r.speed_mps);
    Positive(m, "speed_mps", r.speed_mps);
    r.start_time_s = m.Double("start_time_s", 0.0);
    if (m.Has("pattern") == m.Has("patterns")) {
      yaml::Fail(file_, node, "robot '" + r.name + "' needs exactly one of pattern or patterns");
    }
    if (m.Has("pattern")) {
      r.patterns.push_back(ParsePattern(m.Get("pattern")));
    } else {
      const YAML::Node list = m.Get("patterns");
      if (!list.IsSequence() || list.size() == 0) {
        yaml::Fail(file_, list, "expected a non-empty list of patterns");
      }
      for (const auto& p : list) r.patterns.push_back(ParsePattern(p));
    }
    m_->robots.push_back(std::move(r));
  }

  Mission* m_;
  std::string file_;
  std::filesystem::path base_;
};

}  // namespace

Mission ParseMission(const std::string& yaml_text, const std::string& source_name,
                     const std::filesystem::path& base_dir) {
  Mission mission;
  mission.source = source_name;
  MissionParser(&mission, source_name, base_dir).Parse(yaml::LoadText(yaml_text, source_name));
  return mission;
}

Mission LoadMission(const std::filesystem::path& path) {
  Mission mission;
  mission.source = path.string();
  MissionParser(&mission, path.string(), path.parent_path()).Parse(yaml::LoadFile(path.string()));
  return mission;
}

}  // namespace draco::sim
