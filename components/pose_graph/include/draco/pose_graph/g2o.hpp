// g2o text format for 2D pose graphs:
//   VERTEX_SE2 id x y theta
//   EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33     (measurement T_i_j, upper-triangular
//                                                          information, order x y theta)
//   EDGE_PRIOR_SE2 i x y theta I11 I12 I13 I22 I23 I33    (prior on T_w_i; g2o's
//                                                          EdgeSE2Prior; EDGE_SE2_PRIOR read too)
//   VERTEX_XY id x y                                      (a point landmark, world frame)
//   EDGE_SE2_XY i l x y I11 I12 I22                       (point l seen from pose i, in pose
//                                                          i's frame; g2o's EdgeSE2PointXY)
//   FIX id
// Blank lines and lines starting with '#' are skipped; any other tag is an error. Every tag
// written is one g2o registers (g2o/types/slam2d/types_slam2d.cpp), so g2o_viewer and g2o's
// tools open the files; g2o keeps vertices of both kinds in one id space.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "draco/pose_graph/pose_graph_2d.hpp"

namespace draco::pose_graph {

struct G2oVertex {
  PoseId id = 0;
  Pose2 T_world_pose;
};

struct G2oEdge {
  PoseId i = 0;
  PoseId j = 0;
  Pose2 T_i_j;
  Matrix3 information = Diagonal3(1.0, 1.0, 1.0);
};

struct G2oPrior {
  PoseId id = 0;
  Pose2 T_world_pose;
  Matrix3 information = Diagonal3(1.0, 1.0, 1.0);
};

struct G2oPoint {
  PointId id = 0;  // a vertex id: never also a VERTEX_SE2's
  Point2 p_world;
};

struct G2oPointEdge {
  PoseId pose = 0;
  PointId point = 0;
  Point2 p_pose;
  Matrix2 information = {1.0, 0.0, 0.0, 1.0};
};

struct G2oGraph {
  std::vector<G2oVertex> vertices;
  std::vector<G2oEdge> edges;
  std::vector<G2oPrior> priors;
  std::vector<PoseId> fixed;
  std::vector<G2oPoint> points;
  std::vector<G2oPointEdge> point_edges;
  // Written as '#' lines at the top (what the file leaves out, and why); not read back.
  std::vector<std::string> comments;
};

// Thrown on a malformed line; what() is "<source>:<line>: <problem>: '<line text>'".
class G2oParseError : public std::runtime_error {
 public:
  G2oParseError(const std::string& source, int line, const std::string& problem,
                std::string_view text);
  const std::string& source() const { return source_; }
  int line() const { return line_; }

 private:
  std::string source_;
  int line_;
};

// Throws G2oParseError on a malformed line, std::runtime_error when the file cannot be read.
G2oGraph ReadG2o(const std::filesystem::path& path);
G2oGraph ParseG2o(std::istream& in, const std::string& source_name);

// Writes with round-trip precision (max_digits10). Throws std::runtime_error on I/O failure.
void WriteG2o(const std::filesystem::path& path, const G2oGraph& graph);
void WriteG2o(std::ostream& out, const G2oGraph& graph);

// Graph from a g2o file: vertices in file order, then any id only named by an edge (at the
// origin, ascending id); every edge as a between factor of `kind`; priors; FIX as constant;
// points and their observations (a point only named by an EDGE_SE2_XY is an error).
PoseGraph2d ToPoseGraph(const G2oGraph& graph, FactorKind kind = FactorKind::kOdometry,
                        ErrorConvention convention = ErrorConvention::kG2o);
// Current estimates and all factors of a pose graph (priors as EDGE_PRIOR_SE2), points as
// VERTEX_XY with ids after the largest pose id (g2o has one vertex id space) and their
// observations as EDGE_SE2_XY. Poses with negative ids are auxiliary states g2o's SE2 types do
// not model (local SLAM's heading-bias nodes: yaw-only random walks): they and every factor
// that names one are left out, counted in a comment. Point radius states (PointRadiusPrior)
// are not g2o's either: such points are written at their centre estimate and noted.
G2oGraph ToG2o(const PoseGraph2d& graph);

}  // namespace draco::pose_graph
