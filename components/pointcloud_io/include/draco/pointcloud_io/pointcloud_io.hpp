// Point-cloud files of draco maps and scans, written and read by PCL (pcl::io), so that
// pcl_viewer, CloudCompare and MeshLab open them exactly as PCL writes them.
//
// On disk a point is PCL's PointXYZ: x, y, z as float32, metres, z = 0 (draco's maps are
// planar). Writing rounds each coordinate to the nearest float; reading gives back exactly
// those floats. Files are written atomically (a temporary `*.partial.<pid>` beside the file,
// then a rename). Every error is a std::runtime_error whose message starts with the path.
// PCL stays in the .cpp files: this header is plain C++.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::pointcloud_io {

// PCD v0.7 DATA section: binary (the default), binary_compressed (PCL's LZF of the fields
// one after another), or ascii (PCL's text form, 9 significant digits: exact floats too).
enum class PcdEncoding { kBinary, kBinaryCompressed, kAscii };
const char* PcdEncodingName(PcdEncoding encoding);  // "binary", "binary_compressed", "ascii"
// Parses a name of PcdEncodingName; throws std::invalid_argument listing the choices.
PcdEncoding ParsePcdEncoding(std::string_view name);

// PCD through pcl::io (PCDWriter).
void WritePcd(const std::string& path, const std::vector<msgs::Point2>& points,
              PcdEncoding encoding = PcdEncoding::kBinary);
// Binary little-endian PLY through pcl::io::savePLYFileBinary (a vertex element x y z and
// PCL's camera element).
void WritePly(const std::string& path, const std::vector<msgs::Point2>& points);

// x, y of every point of a PCD file (any encoding PCL reads: ascii, binary,
// binary_compressed), e.g. a map as a prior. The file must have float x and y fields; z and
// other fields are ignored. Truncated or corrupt files are refused with a message naming the
// file and what is wrong, never read past their end.
std::vector<msgs::Point2> ReadMapPcd(const std::string& path);
// The same for a PLY file (ascii or binary) with vertex properties x and y.
std::vector<msgs::Point2> ReadMapPly(const std::string& path);
// ReadMapPcd or ReadMapPly by the file's extension (.pcd, .ply).
std::vector<msgs::Point2> ReadMap(const std::string& path);

}  // namespace draco::pointcloud_io
