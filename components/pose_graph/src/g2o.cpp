#include "draco/pose_graph/g2o.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

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
    } else if (tag == "FIX") {
      p.ExpectCount(2);
      graph.fixed.push_back(p.Id(1));
    } else {
      p.Fail("unsupported tag '" + tag + "' (expected VERTEX_SE2, EDGE_SE2, EDGE_PRIOR_SE2, FIX)");
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
  return graph;
}

G2oGraph ToG2o(const PoseGraph2d& graph) {
  G2oGraph g;
  for (const PoseId id : graph.PoseIds()) g.vertices.push_back({id, graph.Pose(id)});
  for (const Factor& f : graph.Factors()) {
    if (f.kind == FactorKind::kPrior) {
      g.priors.push_back({f.i, f.measurement, f.information});
    } else {
      g.edges.push_back({f.i, f.j, f.measurement, f.information});
    }
  }
  return g;
}

}  // namespace draco::pose_graph
