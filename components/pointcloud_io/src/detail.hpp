// Helpers shared by the format files (no PCL here).
#pragma once

#include <functional>
#include <string>

namespace draco::pointcloud_io::detail {

// Runs write(tmp) on a temporary path beside `path` (`path.partial.<pid>`), then renames it
// into place. write returns PCL's status (< 0: failed) or throws; either way the temporary
// file is removed and std::runtime_error names `path` and `what` (e.g. "PCD").
void WriteThroughTemporary(const std::string& path, const std::string& what,
                           const std::function<int(const std::string& tmp)>& write);

// Size of the file at `path` (std::runtime_error naming it when it cannot be read).
std::size_t FileSize(const std::string& path, const std::string& what);

}  // namespace draco::pointcloud_io::detail
