// Small file helpers of the report: atomic writes and the point-cloud map reader.
#pragma once

#include <string>
#include <vector>

#include "draco/report/figures.hpp"

namespace draco::report {

// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a
// reader never sees a half-written file. On failure the temporary file is removed and
// std::runtime_error is thrown.
void WriteFileAtomically(const std::string& path, const std::string& bytes);

// x, y of every point of a point-cloud file, PCD or PLY by its extension, in any encoding
// PCL reads (the local map slam.LocalSlam writes: pointcloud_io.hpp). Throws
// std::runtime_error naming the file.
std::vector<Xy> ReadMapXy(const std::string& path);

// Every robot's point cloud of a team map, in the map's frame (as drawn), as one binary PCD
// (pcl::io). Throws std::runtime_error naming the file.
void WriteTeamCloud(const TeamMap& map, const std::string& path);

// The point-cloud map of `robot` in a run folder: <robot>.map.pcd, else <robot>.map.ply; ""
// when neither exists.
std::string MapCloudPath(const std::string& dir, const std::string& robot);

}  // namespace draco::report
