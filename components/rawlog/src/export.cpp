#include "draco/rawlog/export.hpp"

#include <algorithm>
#include <variant>

#include "draco/cfar/cfar.hpp"
#include "draco/eval/trajectory.hpp"
#include "draco/navigation/dead_reckoning.hpp"
#include "draco/recording/recording.hpp"

namespace draco::rawlog {

std::vector<Entry> MissionEntries(const std::filesystem::path& mission_dir,
                                  const std::string& robot, ExportStats* stats) {
  const auto info = recording::LoadMissionInfo(mission_dir);
  const auto& mount = info.sonar.mount;
  recording::ReadOptions ro;
  ro.depth = ro.ground_truth = false;
  auto reader = recording::RobotReader::Open(mission_dir, robot, ro);
  cfar::FeatureOptions fo;  // as config/graphs/local-slam.yaml
  fo.voxel_size_m = 0.25;
  fo.outlier_radius_m = 0.0;
  cfar::FeatureExtractor extractor(fo);
  navigation::DeadReckoner dr;
  ExportStats local;
  ExportStats& st = stats != nullptr ? *stats : local;
  std::vector<Entry> out;
  while (auto rec = reader.Next()) {
    if (const auto* ahrs = std::get_if<msgs::Ahrs>(&*rec)) {
      dr.AddAhrs(*ahrs);
    } else if (const auto* dvl = std::get_if<msgs::DvlVelocity>(&*rec)) {
      if (auto d = dr.AddDvl(*dvl)) {
        out.push_back(Odometry{d->time_s, d->T_odom_body});
        ++st.odometry;
      }
    } else if (const auto* ping = std::get_if<msgs::SonarPing>(&*rec)) {
      if (ping->num_beams < 2 || ping->bearings_rad.size() < 2) continue;
      const double lo = ping->bearings_rad.front(), hi = ping->bearings_rad.back();
      // The beams centred on the sensor's x axis: the wider side of the bearing table.
      const double aperture = 2.0 * std::max(std::abs(lo), std::abs(hi));
      RangeScan s = ScanFromPoints(ping->time_s, extractor.Extract(*ping), ping->num_beams,
                                   aperture, ping->MaxRangeM());
      s.T_body_sensor = {mount.position_m[0], mount.position_m[1], mount.yaw_rad};
      st.valid_beams += static_cast<int>(std::count(s.valid.begin(), s.valid.end(), 1));
      out.push_back(std::move(s));
      ++st.scans;
    }
  }
  return out;
}

std::vector<Entry> TrajectoryEntries(const std::string& tum_path) {
  std::vector<Entry> out;
  for (const auto& p : eval::ReadTum(tum_path)) {
    out.push_back(PoseEstimate{p.time_s, {p.x_m, p.y_m, p.yaw_rad}});
  }
  return out;
}

std::vector<Entry> MergeByTime(std::vector<Entry> a, const std::vector<Entry>& b) {
  const auto mid = static_cast<std::ptrdiff_t>(a.size());
  a.insert(a.end(), b.begin(), b.end());
  std::inplace_merge(a.begin(), a.begin() + mid, a.end(),
                     [](const Entry& x, const Entry& y) { return EntryTime(x) < EntryTime(y); });
  return a;
}

}  // namespace draco::rawlog
