#include "draco/report/files.hpp"

#include <filesystem>

#include "draco/graph/executor.hpp"
#include "draco/pointcloud_io/pointcloud_io.hpp"

namespace draco::report {

void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  graph::WriteFileAtomicallyOrThrow(path, bytes);
}

std::vector<Xy> ReadMapXy(const std::string& path) {
  std::vector<Xy> out;
  for (const auto& p : pointcloud_io::ReadMap(path)) out.push_back({p.x_m, p.y_m});
  return out;
}

void WriteTeamCloud(const TeamMap& map, const std::string& path) {
  std::vector<msgs::Point2> points;
  for (const auto& robot : map.robots) {
    for (const auto& p : robot.cloud) points.push_back({p.x, p.y});
  }
  pointcloud_io::WritePcd(path, points);
}

std::string MapCloudPath(const std::string& dir, const std::string& robot) {
  for (const char* ext : {".map.pcd", ".map.ply"}) {
    const std::filesystem::path path = std::filesystem::path(dir) / (robot + ext);
    if (std::filesystem::exists(path)) return path.string();
  }
  return "";
}

}  // namespace draco::report
