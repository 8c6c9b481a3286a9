// draco points <-> pcl::PointCloud<pcl::PointXYZ> (z = 0). Included by the PCL .cpp files only.
#pragma once

#include <pcl/PCLPointCloud2.h>
#include <pcl/console/print.h>
#include <pcl/conversions.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::pointcloud_io::detail {

// draco says what is wrong with a file itself, naming it; PCL's console lines beside that
// ("Input point cloud has no data!" for every empty map a robot writes, "Failed to find match
// for field" on foreign files) are noise in a daemon's log. Process-wide, as the PCL
// registration back ends set it.
inline void QuietPcl() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }

inline pcl::PointCloud<pcl::PointXYZ> ToPcl(const std::vector<msgs::Point2>& points) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.reserve(points.size());
  for (const auto& p : points) {
    cloud.push_back(pcl::PointXYZ(static_cast<float>(p.x_m), static_cast<float>(p.y_m), 0.0f));
  }
  return cloud;  // width = size, height = 1 (unorganised), dense
}

inline std::vector<msgs::Point2> FromPcl(const pcl::PointCloud<pcl::PointXYZ>& cloud) {
  std::vector<msgs::Point2> out;
  out.reserve(cloud.size());
  for (const auto& p : cloud) out.push_back({p.x, p.y});
  return out;
}

// x, y of a cloud PCL's reader produced, after checking that its size fields agree with its
// data (PCL's PLY reader takes the height from the camera element's viewport, so a damaged
// file can announce more points than were read: converting it would read past the data).
inline std::vector<msgs::Point2> FromBlob(const pcl::PCLPointCloud2& blob, const std::string& path,
                                          const std::string& what) {
  const auto fail = [&](const std::string& why) {
    throw std::runtime_error(path + ": not a readable " + what + " file: " + why);
  };
  const unsigned long long points = 1ull * blob.width * blob.height;
  if (points * blob.point_step != blob.data.size() ||
      1ull * blob.row_step * blob.height != blob.data.size()) {
    fail(std::to_string(blob.width) + " x " + std::to_string(blob.height) + " points announced, " +
         std::to_string(blob.data.size()) + " bytes read");
  }
  int xy = 0;
  for (const auto& field : blob.fields) {
    if (field.name != "x" && field.name != "y") continue;
    if (field.datatype != pcl::PCLPointField::FLOAT32 &&
        field.datatype != pcl::PCLPointField::FLOAT64) {
      fail("field " + field.name + " is not a float");
    }
    if (1ull * field.offset + (field.datatype == pcl::PCLPointField::FLOAT32 ? 4 : 8) >
        blob.point_step) {
      fail("field " + field.name + " lies outside the point");
    }
    ++xy;
  }
  if (points == 0) return {};  // (PCL's conversion indexes an empty vector)
  if (xy != 2) fail("no x and y fields");
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl::fromPCLPointCloud2(blob, cloud);
  return FromPcl(cloud);
}

}  // namespace draco::pointcloud_io::detail
