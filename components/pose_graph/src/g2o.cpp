#include "draco/pose_graph/g2o.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

namespace draco::pose_graph {

G2oParseError::G2oParseError(const std::string& source, int line, const std::string& problem,
                             std::string_view text)
    : std::runtime_error(source + ":" + std::to_string(line) + ": " + problem + ": '" +
                         std::string(text) + "'"),
      source_(source),
      line_(line) {}

namespace {

std::vector<std::string_view> Tokens(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t k = 0;
  while (k < line.size()) {
    while (k < line.size() && std::isspace(static_cast<unsigned char>(line[k]))) ++k;
    const std::size_t begin = k;
    while (k < line.size() && !std::isspace(static_cast<unsigned char>(line[k]))) ++k;
    if (k > begin) out.push_back(line.substr(begin, k - begin));
  }
  return out;
}

class LineParser {
 public:
  LineParser(const std::string& source, int line, std::string_view text,
             std::vector<std::string_view> tokens)
      : source_(source), line_(line), text_(text), tokens_(std::move(tokens)) {}

  void ExpectCount(std::size_t n) const {
    if (tokens_.size() != n) {
      Fail(std::string(tokens_[0]) + " needs " + std::to_string(n - 1) + " values, found " +
           std::to_string(tokens_.size() - 1));
    }
  }
  PoseId Id(std::size_t k) const {
    PoseId v = 0;
    const auto t = tokens_[k];
    const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    if (ec != std::errc() || ptr != t.data() + t.size()) {
      Fail("value " + std::to_string(k) + " ('" + std::string(t) + "') is not an integer id");
    }
    return v;
  }
  double Number(std::size_t k) const {
    double v = 0.0;
    const auto t = tokens_[k];
    const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    if (ec != std::errc() || ptr != t.data() + t.size() || !std::isfinite(v)) {
      Fail("value " + std::to_string(k) + " ('" + std::string(t) + "') is not a finite number");
    }
    return v;
  }
  Pose2 Pose(std::size_t k) const { return {Number(k), Number(k + 1), Number(k + 2)}; }
  Matrix3 UpperInformation(std::size_t k) const {
    const double xx = Number(k), xy = Number(k + 1), xt = Number(k + 2), yy = Number(k + 3),
                 yt = Number(k + 4), tt = Number(k + 5);
    return {xx, xy, xt, xy, yy, yt, xt, yt, tt};
  }
  Matrix2 UpperInformation2(std::size_t k) const {
    const double xx = Number(k), xy = Number(k + 1), yy = Number(k + 2);
    return {xx, xy, xy, yy};
  }
  [[noreturn]] void Fail(const std::string& problem) const {
    throw G2oParseError(source_, line_, problem, text_);
  }

 private:
  const std::string& source_;
  int line_;
  std::string_view text_;
  std::vector<std::string_view> tokens_;
};

void WritePose(std::ostream& out, const Pose2& p) {
  out << ' ' << p.x_m << ' ' << p.y_m << ' ' << p.yaw_rad;
}

void WriteInformation(std::ostream& out, const Matrix3& m) {
  out << ' ' << m[0] << ' ' << m[1] << ' ' << m[2] << ' ' << m[4] << ' ' << m[5] << ' ' << m[8];
}

}  // namespace

G2oGraph ParseG2o(std::istream& in, const std::string& source_name) {
  G2oGraph graph;
  std::string text;
  int line = 0;
  while (std::getline(in, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    auto tokens = Tokens(text);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    const std::string tag(tokens[0]);
    const LineParser p(source_name, line, text, std::move(tokens));
    if (tag == "VERTEX_SE2") {
      p.ExpectCount(5);
      graph.vertices.push_back({p.Id(1), p.Pose(2)});
    } else if (tag == "EDGE_SE2") {
      p.ExpectCount(12);
      graph.edges.push_back({p.Id(1), p.Id(2), p.Pose(3), p.UpperInformation(6)});
    } else if (tag == "EDGE_PRIOR_SE2" || tag == "EDGE_SE2_PRIOR") {  // g2o's name; draco's old
      p.ExpectCount(11);
      graph.priors.push_back({p.Id(1), p.Pose(2), p.UpperInformation(5)});
    } else if (tag == "VERTEX_XY") {
      p.ExpectCount(4);
      graph.points.push_back({p.Id(1), {p.Number(2), p.Number(3)}});
    } else if (tag == "EDGE_SE2_XY") {
      p.ExpectCount(8);
      graph.point_edges.push_back(
          {p.Id(1), p.Id(2), {p.Number(3), p.Number(4)}, p.UpperInformation2(5)});
    } else if (tag == "FIX") {
      p.ExpectCount(2);
      graph.fixed.push_back(p.Id(1));
    } else {
      p.Fail("unsupported tag '" + tag +
             "' (expected VERTEX_SE2, EDGE_SE2, EDGE_PRIOR_SE2, VERTEX_XY, EDGE_SE2_XY, FIX)");
    }
  }
  if (in.bad()) throw std::runtime_error(source_name + ": read error");
  return graph;
}

G2oGraph ReadG2o(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open for reading");
  return ParseG2o(in, path.string());
}

void WriteG2o(std::ostream& out, const G2oGraph& graph) {
  out.precision(std::numeric_limits<double>::max_digits10);
  for (const auto& c : graph.comments) out << "# " << c << '\n';
  for (const auto& v : graph.vertices) {
    out << "VERTEX_SE2 " << v.id;
    WritePose(out, v.T_world_pose);
    out << '\n';
  }
  for (const PoseId id : graph.fixed) out << "FIX " << id << '\n';
  for (const auto& e : graph.edges) {
    out << "EDGE_SE2 " << e.i << ' ' << e.j;
    WritePose(out, e.T_i_j);
    WriteInformation(out, e.information);
    out << '\n';
  }
  for (const auto& p : graph.priors) {
    out << "EDGE_PRIOR_SE2 " << p.id;
    WritePose(out, p.T_world_pose);
    WriteInformation(out, p.information);
    out << '\n';
  }
  for (const auto& p : graph.points) {
    out << "VERTEX_XY " << p.id << ' ' << p.p_world.x_m << ' ' << p.p_world.y_m << '\n';
  }
  for (const auto& e : graph.point_edges) {
    out << "EDGE_SE2_XY " << e.pose << ' ' << e.point << ' ' << e.p_pose.x_m << ' ' << e.p_pose.y_m
        << ' ' << e.information[0] << ' ' << e.information[1] << ' ' << e.information[3] << '\n';
  }
}

void WriteG2o(const std::filesystem::path& path, const G2oGraph& graph) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path.string() + ": cannot open for writing");
  WriteG2o(out, graph);
  out.flush();
  if (!out) throw std::runtime_error(path.string() + ": write error");
}

PoseGraph2d ToPoseGraph(const G2oGraph& g, FactorKind kind, ErrorConvention convention) {
  PoseGraph2d graph(convention);
  for (const auto& v : g.vertices) graph.AddPose(v.id, v.T_world_pose);
  std::set<PoseId> missing;
  for (const auto& e : g.edges) {
    if (!graph.HasPose(e.i)) missing.insert(e.i);
    if (!graph.HasPose(e.j)) missing.insert(e.j);
  }
  for (const auto& p : g.priors) {
    if (!graph.HasPose(p.id)) missing.insert(p.id);
  }
  for (const PoseId id : missing) graph.AddPose(id, Pose2{});
  for (const auto& e : g.edges) graph.AddBetween(e.i, e.j, e.T_i_j, e.information, kind);
  for (const auto& p : g.priors) graph.AddPrior(p.id, p.T_world_pose, p.information);
  for (const PoseId id : g.fixed) graph.SetPoseConstant(id);
  for (const auto& p : g.points) graph.AddPoint(p.id, p.p_world);
  for (const auto& e : g.point_edges) {
    if (!graph.HasPoint(e.point)) {
      throw std::invalid_argument("g2o: EDGE_SE2_XY names point " + std::to_string(e.point) +
                                  ", which has no VERTEX_XY");
    }
    if (!graph.HasPose(e.pose)) graph.AddPose(e.pose, Pose2{});
    graph.AddPointObservation(e.pose, e.point, e.p_pose, e.information);
  }
  return graph;
}

G2oGraph ToG2o(const PoseGraph2d& graph) {
  G2oGraph g;
  PoseId max_id = -1;
  std::size_t aux_poses = 0, aux_factors = 0, yaw_gauss_markov = 0;
  for (const PoseId id : graph.PoseIds()) {
    if (id < 0) {
      ++aux_poses;
      continue;
    }
    g.vertices.push_back({id, graph.Pose(id)});
    max_id = std::max(max_id, id);
  }
  for (const Factor& f : graph.Factors()) {
    if (f.i < 0 || f.j < 0 || (f.yaw_gauss_markov && f.yaw_gauss_markov->mean < 0)) {
      ++aux_factors;
    } else if (f.yaw_gauss_markov) {
      ++yaw_gauss_markov;  // not an SE(2) relation
    } else if (f.kind == FactorKind::kPrior) {
      g.priors.push_back({f.i, f.measurement, f.information});
    } else {
      g.edges.push_back({f.i, f.j, f.measurement, f.information});
    }
  }
  // Points after the poses in g2o's one vertex id space, in observation order.
  std::map<PointId, PointId> vertex_of;
  std::size_t with_radius = 0, aux_observations = 0;
  for (const auto& o : graph.PointObservations()) {
    if (o.pose < 0) {
      ++aux_observations;
      continue;
    }
    auto it = vertex_of.find(o.point);
    if (it == vertex_of.end()) {
      const PointId vid = max_id + 1 + static_cast<PointId>(vertex_of.size());
      it = vertex_of.emplace(o.point, vid).first;
      g.points.push_back({vid, graph.Point(o.point)});
      if (graph.PointRadius(o.point)) ++with_radius;
    }
    g.point_edges.push_back({o.pose, it->second, o.p_pose, o.information});
  }
  if (aux_poses > 0 || aux_observations > 0) {
    g.comments.push_back("left out: " + std::to_string(aux_poses) + " auxiliary nodes (ids < 0: " +
                         "heading-bias states, yaw-only random walks g2o's SE2 types do not " +
                         "model) and the " + std::to_string(aux_factors + aux_observations) +
                         " factors that name them; the poses hold their effect");
  }
  if (yaw_gauss_markov > 0) {
    g.comments.push_back("left out: " + std::to_string(yaw_gauss_markov) +
                         " yaw Gauss-Markov factors (three poses' yaws, no g2o SE2 type)");
  }
  if (with_radius > 0) {
    g.comments.push_back(std::to_string(with_radius) +
                         " points carry a radius state (observations of an object's near " +
                         "face); written at their centre estimate with the raw observations, " +
                         "which g2o reads as EdgeSE2PointXY without the radius");
  }
  return g;
}

}  // namespace draco::pose_graph
