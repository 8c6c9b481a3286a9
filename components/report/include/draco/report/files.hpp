// Small file helpers of the report: atomic writes and the point-cloud reader.
#pragma once

#include <string>
#include <vector>

#include "draco/report/figures.hpp"

namespace draco::report {

// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a
// reader never sees a half-written file. On failure the temporary file is removed and
// std::runtime_error is thrown.
void WriteFileAtomically(const std::string& path, const std::string& bytes);

// x, y of every vertex of an ASCII PLY file whose first two vertex properties are x and y
// (the local map written by slam.LocalSlam). Throws std::runtime_error naming the file.
std::vector<Xy> ReadPlyXy(const std::string& path);

}  // namespace draco::report
