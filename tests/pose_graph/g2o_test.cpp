// g2o import/export: round trip, graph conversion, and errors that name file and line.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>

#include "draco/pose_graph/g2o.hpp"

namespace draco::pose_graph {
namespace {

const char* kSmall =
    "# a comment\n"
    "VERTEX_SE2 0 0 0 0\n"
    "VERTEX_SE2 1 1.0 0.1 0.05\n"
    "\n"
    "VERTEX_SE2 2 2.0 0.2 3.1\r\n"
    "FIX 0\n"
    "EDGE_SE2 0 1 1.0 0.1 0.05 50 1 2 40 3 100\n"
    "EDGE_SE2 1 2 1.0 0.05 3.05 50 0 0 50 0 100\n"
    "EDGE_SE2_PRIOR 2 2.0 0.2 3.1 10 0 0 10 0 20\n";

TEST(G2o, ParsesVerticesEdgesPriorsAndFix) {
  std::istringstream in(kSmall);
  const G2oGraph g = ParseG2o(in, "small.g2o");
  ASSERT_EQ(g.vertices.size(), 3u);
  ASSERT_EQ(g.edges.size(), 2u);
  ASSERT_EQ(g.priors.size(), 1u);
  ASSERT_EQ(g.fixed.size(), 1u);
  EXPECT_DOUBLE_EQ(g.vertices[2].T_world_pose.yaw_rad, 3.1);
  const Matrix3& info = g.edges[0].information;
  const Matrix3 expected{50, 1, 2, 1, 40, 3, 2, 3, 100};
  EXPECT_EQ(info, expected);
  EXPECT_EQ(g.edges[1].i, 1);
  EXPECT_EQ(g.edges[1].j, 2);
}

TEST(G2o, RoundTripIsExact) {
  std::istringstream in(kSmall);
  const G2oGraph g = ParseG2o(in, "small.g2o");
  const auto path = std::filesystem::temp_directory_path() / "draco_pose_graph_roundtrip.g2o";
  WriteG2o(path, g);
  const G2oGraph back = ReadG2o(path);
  {
    // Priors under g2o's own tag (EdgeSE2Prior), so g2o's tools open the file; the input's
    // older spelling EDGE_SE2_PRIOR is read but not written.
    std::ifstream written(path);
    const std::string text((std::istreambuf_iterator<char>(written)), {});
    EXPECT_NE(text.find("EDGE_PRIOR_SE2 2 "), std::string::npos);
    EXPECT_EQ(text.find("EDGE_SE2_PRIOR"), std::string::npos);
  }
  std::filesystem::remove(path);
  ASSERT_EQ(back.vertices.size(), g.vertices.size());
  ASSERT_EQ(back.edges.size(), g.edges.size());
  for (std::size_t k = 0; k < g.vertices.size(); ++k) {
    EXPECT_EQ(back.vertices[k].id, g.vertices[k].id);
    EXPECT_EQ(back.vertices[k].T_world_pose.x_m, g.vertices[k].T_world_pose.x_m);
    EXPECT_EQ(back.vertices[k].T_world_pose.yaw_rad, g.vertices[k].T_world_pose.yaw_rad);
  }
  for (std::size_t k = 0; k < g.edges.size(); ++k) {
    EXPECT_EQ(back.edges[k].T_i_j.y_m, g.edges[k].T_i_j.y_m);
    EXPECT_EQ(back.edges[k].information, g.edges[k].information);
  }
  EXPECT_EQ(back.priors[0].information, g.priors[0].information);
  EXPECT_EQ(back.fixed, g.fixed);
}

TEST(G2o, PoseGraphRoundTripKeepsFactorsAndEstimates) {
  std::istringstream in(kSmall);
  PoseGraph2d graph = ToPoseGraph(ParseG2o(in, "small.g2o"), FactorKind::kScanMatch);
  EXPECT_EQ(graph.NumPoses(), 3u);
  EXPECT_EQ(graph.NumFactors(), 3u);
  EXPECT_EQ(graph.Factors()[0].kind, FactorKind::kScanMatch);
  ASSERT_TRUE(graph.Optimize().usable);
  const G2oGraph out = ToG2o(graph);
  std::ostringstream text;
  WriteG2o(text, out);
  std::istringstream again(text.str());
  PoseGraph2d back = ToPoseGraph(ParseG2o(again, "again.g2o"));
  for (const PoseId id : graph.PoseIds()) {
    EXPECT_EQ(back.Pose(id).x_m, graph.Pose(id).x_m);
    EXPECT_EQ(back.Pose(id).yaw_rad, graph.Pose(id).yaw_rad);
  }
  EXPECT_NEAR(back.Chi2(), graph.Chi2(), 1e-12);
}

// The tags g2o registers for 2D SLAM (g2o/types/slam2d/types_slam2d.cpp, G2O_REGISTER_TYPE)
// and the FIX keyword of its loader: every line draco writes must use one of them.
const std::set<std::string> kG2oTags = {"VERTEX_SE2",
                                        "VERTEX_XY",
                                        "PARAMS_SE2OFFSET",
                                        "CACHE_SE2_OFFSET",
                                        "EDGE_PRIOR_SE2",
                                        "EDGE_PRIOR_SE2_XY",
                                        "EDGE_SE2",
                                        "EDGE_SE2_XY",
                                        "EDGE_BEARING_SE2_XY",
                                        "EDGE_SE2_XY_CALIB",
                                        "EDGE_SE2_OFFSET",
                                        "EDGE_SE2_POINTXY_OFFSET",
                                        "EDGE_POINTXY",
                                        "EDGE_SE2_TWOPOINTSXY",
                                        "EDGE_SE2_LOTSOFXY",
                                        "FIX"};

TEST(G2o, EveryTagWrittenIsOneG2oRegisters) {
  // Poses, a prior, odometry, points with observations (one with a radius state) and an
  // auxiliary node with a negative id, as local SLAM's heading-bias states are.
  PoseGraph2d graph;
  graph.AddPose(0, {0, 0, 0});
  graph.AddPose(1, {1, 0, 0.1});
  graph.AddPose(2, {2, 0.2, 0.2});
  graph.AddPose(-2, {0, 0, 0});
  graph.AddPrior(0, {0, 0, 0}, Diagonal3(100, 100, 100));
  graph.AddBetween(0, 1, {1, 0, 0.1}, Diagonal3(10, 10, 50));
  graph.AddBetween(1, 2, {1, 0.1, 0.1}, Diagonal3(10, 10, 50));
  graph.AddPrior(-2, {0, 0, 0}, Diagonal3(1, 1, 1));
  graph.AddBetween(-2, 1, {0, 0, 0.1}, Diagonal3(1e-9, 1e-9, 100));
  graph.AddPoint(7, {3, 1});
  graph.AddPoint(9, {4, -1}, PointRadiusPrior{});
  graph.AddPointObservation(0, 7, {3, 1}, {4, 0.5, 0.5, 4});
  graph.AddPointObservation(2, 7, {0.9, 0.98}, {4, 0, 0, 4});
  graph.AddPointObservation(1, 9, {3, -1}, {4, 0, 0, 4});
  std::ostringstream out;
  WriteG2o(out, ToG2o(graph));
  const std::string text = out.str();
  std::istringstream lines(text);
  std::set<PoseId> vertex_ids;
  int comments = 0, vertices = 0;
  for (std::string line; std::getline(lines, line);) {
    std::istringstream tokens(line);
    std::string tag;
    tokens >> tag;
    if (tag == "#") {
      ++comments;
      continue;
    }
    EXPECT_TRUE(kG2oTags.count(tag)) << "not a g2o tag: " << line;
    if (tag == "VERTEX_SE2" || tag == "VERTEX_XY") {
      PoseId id = -1;
      tokens >> id;
      EXPECT_GE(id, 0) << line;
      vertex_ids.insert(id);  // one id space for poses and points, as g2o has
      ++vertices;
    }
  }
  EXPECT_EQ(vertices, 5);
  EXPECT_EQ(vertex_ids.size(), 5u);
  EXPECT_EQ(comments, 2);  // the left-out auxiliary node, the radius state
  EXPECT_NE(text.find("# left out: 1 auxiliary nodes"), std::string::npos);
  EXPECT_NE(text.find("and the 2 factors that name them"), std::string::npos);
  EXPECT_NE(text.find("EDGE_SE2_XY 0 3 3 1 4 0.5 4\n"), std::string::npos) << text;

  // Read back: the same poses, points (renumbered) and observations; the graph without the
  // auxiliary node.
  std::istringstream again(text);
  const G2oGraph g = ParseG2o(again, "written.g2o");
  ASSERT_EQ(g.points.size(), 2u);
  EXPECT_EQ(g.points[0].id, 3);
  EXPECT_EQ(g.points[1].id, 4);
  EXPECT_EQ(g.points[1].p_world.x_m, 4.0);
  ASSERT_EQ(g.point_edges.size(), 3u);
  EXPECT_EQ(g.point_edges[1].pose, 2);
  EXPECT_EQ(g.point_edges[1].p_pose.y_m, 0.98);
  EXPECT_EQ(g.point_edges[0].information, (Matrix2{4, 0.5, 0.5, 4}));
  const PoseGraph2d back = ToPoseGraph(g);
  EXPECT_EQ(back.NumPoses(), 3u);
  EXPECT_EQ(back.NumFactors(), 3u);
  EXPECT_EQ(back.NumPoints(), 2u);
  EXPECT_EQ(back.PointObservations().size(), 3u);
  std::istringstream orphan("VERTEX_SE2 0 0 0 0\nEDGE_SE2_XY 0 5 1 2 1 0 1\n");
  EXPECT_THROW(ToPoseGraph(ParseG2o(orphan, "orphan.g2o")), std::invalid_argument);
}

TEST(G2o, EdgesWithoutVerticesCreatePosesAtTheOrigin) {
  std::istringstream in("EDGE_SE2 3 7 1 0 0 1 0 0 1 0 1\n");
  PoseGraph2d graph = ToPoseGraph(ParseG2o(in, "edges.g2o"));
  ASSERT_EQ(graph.NumPoses(), 2u);
  EXPECT_EQ(graph.InitializeFromSpanningTree(3), 1u);
  EXPECT_DOUBLE_EQ(graph.Pose(7).x_m, 1.0);
}

std::string ParseError(const std::string& text) {
  std::istringstream in(text);
  try {
    ParseG2o(in, "bad.g2o");
  } catch (const G2oParseError& e) {
    return e.what();
  }
  return "no error";
}

TEST(G2o, MalformedLinesNameFileAndLine) {
  EXPECT_EQ(ParseError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0\n"),
            "bad.g2o:2: VERTEX_SE2 needs 4 values, found 3: 'VERTEX_SE2 1 0 0'");
  EXPECT_EQ(ParseError("\n\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 abc\n"),
            "bad.g2o:3: value 11 ('abc') is not a finite number: "
            "'EDGE_SE2 0 1 1 0 0 1 0 0 1 0 abc'");
  EXPECT_EQ(ParseError("VERTEX_SE2 1.5 0 0 0\n"),
            "bad.g2o:1: value 1 ('1.5') is not an integer id: 'VERTEX_SE2 1.5 0 0 0'");
  EXPECT_EQ(ParseError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"),
            "bad.g2o:1: unsupported tag 'VERTEX_SE3:QUAT' (expected VERTEX_SE2, EDGE_SE2, "
            "EDGE_PRIOR_SE2, VERTEX_XY, EDGE_SE2_XY, FIX): 'VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1'");
  EXPECT_EQ(ParseError("EDGE_SE2_XY 0 5 1 2 3 0\n"),
            "bad.g2o:1: EDGE_SE2_XY needs 7 values, found 6: 'EDGE_SE2_XY 0 5 1 2 3 0'");
  EXPECT_EQ(ParseError("VERTEX_SE2 0 nan 0 0\n"),
            "bad.g2o:1: value 2 ('nan') is not a finite number: 'VERTEX_SE2 0 nan 0 0'");
  std::istringstream in("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0\n");
  try {
    ParseG2o(in, "x.g2o");
    FAIL();
  } catch (const G2oParseError& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_EQ(e.source(), "x.g2o");
  }
  EXPECT_THROW(ReadG2o("/nonexistent/file.g2o"), std::runtime_error);
}

}  // namespace
}  // namespace draco::pose_graph
