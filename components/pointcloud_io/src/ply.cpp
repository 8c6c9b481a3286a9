// PLY files through pcl::io (pointcloud_io.hpp).
#include <pcl/io/ply_io.h>

#include <fstream>
#include <stdexcept>

#include "cloud.hpp"
#include "detail.hpp"
#include "draco/pointcloud_io/pointcloud_io.hpp"

namespace draco::pointcloud_io {

void WritePly(const std::string& path, const std::vector<msgs::Point2>& points) {
  const auto cloud = detail::ToPcl(points);
  detail::WriteThroughTemporary(path, "PLY", [&](const std::string& tmp) {
    if (!cloud.empty()) return pcl::io::savePLYFileBinary(tmp, cloud);
    // PCL 1.13 writes no file for an empty cloud; this is the header it writes otherwise,
    // with no vertices (its own reader and CloudCompare read it).
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f << "ply\nformat binary_little_endian 1.0\ncomment PCL generated\nelement vertex 0\n"
         "property float x\nproperty float y\nproperty float z\nend_header\n";
    f.flush();
    return f ? 0 : -1;
  });
}

std::vector<msgs::Point2> ReadMapPly(const std::string& path) {
  detail::FileSize(path, "PLY");  // a clear message for a missing file
  pcl::PCLPointCloud2 blob;
  try {
    if (pcl::io::loadPLYFile(path, blob) < 0) {
      throw std::runtime_error(path +
                               ": not a readable PLY file (PCL's reader refused it: truncated or "
                               "corrupt)");
    }
  } catch (const pcl::PCLException& e) {
    throw std::runtime_error(path + ": not a readable PLY file: " + e.what());
  }
  return detail::FromBlob(blob, path, "PLY");
}

}  // namespace draco::pointcloud_io
