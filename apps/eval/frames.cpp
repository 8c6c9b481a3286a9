#include "frames.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "draco/cfar/cfar.hpp"
#include "draco/graph/progress.hpp"
#include "draco/recording/recording.hpp"
#include "draco/report/sonar_frame.hpp"

namespace fs = std::filesystem;

namespace draco::eval_app {
namespace {

// The feature extractor as config/graphs/local-slam.yaml configures it.
cfar::FeatureOptions LocalSlamFeatureOptions() {
  cfar::FeatureOptions o;
  o.voxel_size_m = 0.25;
  o.outlier_radius_m = 0.0;
  return o;
}

// Progress of a pass over a robot's pings, at most every 5 s of mission time.
class PingProgress {
 public:
  PingProgress(const std::string& label, double total_s) : printer_(label, total_s) {}
  void Update(double t) {
    if (t < next_s_) return;
    next_s_ = t + 5.0;
    last_s_ = t;
    printer_.Update(graph::Time::FromSeconds(t));
  }
  void Finish() { printer_.Finish(graph::Time::FromSeconds(last_s_)); }
  void Seen(double t) { last_s_ = std::max(last_s_, t); }

 private:
  graph::ProgressPrinter printer_;
  double next_s_ = 0.0;
  double last_s_ = 0.0;
};

std::vector<std::uint32_t> PickPings(const std::string& mission, const std::string& robot,
                                     int count) {
  recording::ReadOptions ro;
  ro.dvl = ro.ahrs = ro.depth = ro.ground_truth = false;
  auto reader = recording::RobotReader::Open(mission, robot, ro);
  std::vector<std::pair<double, std::uint32_t>> scored;
  PingProgress progress("draco-eval: scoring " + robot + "'s pings",
                        draco::recording::RobotReplayLengthS(mission, robot));
  while (auto rec = reader.Next()) {
    if (const auto* ping = std::get_if<msgs::SonarPing>(&*rec)) {
      scored.push_back({report::PingStructureScore(*ping), ping->ping_id});
      progress.Seen(ping->time_s);
      progress.Update(ping->time_s);
    }
  }
  progress.Finish();
  if (scored.empty()) return {};
  // Best first, at least a tenth of the mission apart so the frames show different places.
  const std::uint32_t min_gap = static_cast<std::uint32_t>(scored.size() / 10);
  std::vector<std::pair<double, std::uint32_t>> order = scored;
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::uint32_t> picked;
  for (const auto& scored_ping : order) {
    // Not a structured binding: clang 14 (the fuzz and sanitizer build) cannot capture one.
    const std::uint32_t id = scored_ping.second;
    if (static_cast<int>(picked.size()) >= count) break;
    const bool far = std::all_of(picked.begin(), picked.end(), [&](std::uint32_t p) {
      return (p > id ? p - id : id - p) >= min_gap;
    });
    if (far) picked.push_back(id);
  }
  std::sort(picked.begin(), picked.end());
  return picked;
}

}  // namespace

std::vector<report::ReportFigure> RenderFrames(const std::string& run_dir,
                                               const FramesOptions& options) {
  std::vector<report::ReportFigure> out;
  const auto info = recording::LoadMissionInfo(options.mission_dir);
  fs::create_directories(fs::path(run_dir) / "frames");
  for (const auto& r : info.robots) {
    if (!options.robot.empty() && r.name != options.robot) continue;
    const auto ids = PickPings(options.mission_dir, r.name, options.per_robot);
    recording::ReadOptions ro;
    ro.dvl = ro.ahrs = ro.depth = ro.ground_truth = false;
    auto reader = recording::RobotReader::Open(options.mission_dir, r.name, ro);
    cfar::FeatureExtractor extractor(LocalSlamFeatureOptions());
    std::size_t next = 0;
    PingProgress progress("draco-eval: drawing " + r.name + "'s frames",
                          draco::recording::RobotReplayLengthS(options.mission_dir, r.name));
    while (next < ids.size()) {
      auto rec = reader.Next();
      if (!rec) break;
      const auto* ping = std::get_if<msgs::SonarPing>(&*rec);
      if (ping != nullptr) {
        progress.Seen(ping->time_s);
        progress.Update(ping->time_s);
      }
      if (ping == nullptr || ping->ping_id != ids[next]) continue;
      ++next;
      cfar::FeatureStats stats;
      const auto points = extractor.Extract(*ping, &stats);
      char caption[160];
      std::snprintf(caption, sizeof(caption),
                    "%s ping %u, t = %.1f s: %d CFAR detections, %d features", r.name.c_str(),
                    ping->ping_id, ping->time_s, stats.detections, stats.kept);
      report::SonarFrameOptions fo;
      char title[128];
      std::snprintf(title, sizeof(title), "%s  ping %u  t = %.1f s  CFAR %d  features %d (circles)",
                    r.name.c_str(), ping->ping_id, ping->time_s, stats.detections, stats.kept);
      fo.caption = title;
      const std::string rel = "frames/" + r.name + "_ping" + std::to_string(ping->ping_id) + ".png";
      report::RenderSonarFrame(*ping, points, (fs::path(run_dir) / rel).string(), fo);
      out.push_back({rel, caption});
    }
    progress.Finish();
  }
  return out;
}

}  // namespace draco::eval_app
