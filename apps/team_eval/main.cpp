// draco-team-eval MISSION_DIR [--out DIR] [--experiment FILE] [--exp-set section.key=value]:
// the paper's Table III on a recorded mission. The front end of draco-frontend-eval
// (components/frontend: local SLAM per robot in-process, object maps, object-graph matching,
// scan selection, window registration) gives, for each own robot, the candidate inter-robot
// loops (accepted registrations at the experiment's window and overlap threshold, with every
// teammate). They are filtered by PCM and by GCM (ConsistencyFilter, propagated covariance, no
// time budget) and given, with the map-to-map guesses of graph matching (or the oracle's), to
// TwoStepPgo and FullPgo. The knobs of this protocol are the experiment (experiment.hpp,
// config/experiments/*.yaml); the run folder records it resolved as OUT/experiment.yaml, the
// local-SLAM graph each robot ran as OUT/slam/<robot>.graph.yaml, and the commit and command
// line in OUT/run_info.json.
//
// ATE as the paper: for each robot, its own trajectory then the teammates' in mission order,
// concatenated, in the own frame, against the ground truth concatenated the same way, one
// SE(2) alignment. The concatenation is written as TUM files with each segment shifted in
// time (segment s by s * 1e5 s), so draco-eval on the out folder reports the same table:
//   OUT/<robot>.{dead_reckoning,trajectory,ground_truth}.tum and
//   OUT/<robot>.trajectory.{two-step-pcm,two-step-gcm,full-pcm,full-gcm}.tum.
//
//   draco-team-eval /tmp/marina --out runs/team-marina --experiment
//       config/experiments/oracle-matching.yaml
#include <CLI/CLI.hpp>

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <numbers>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "app_version.hpp"
#include "data_path.hpp"
#include "draco/consistency/filter.hpp"
#include "draco/consistency/graph_pose_source.hpp"
#include "draco/consistency/pairwise.hpp"
#include "draco/eval/trajectory.hpp"
#include "draco/frontend/outliers.hpp"
#include "draco/frontend/pipeline.hpp"
#include "draco/graph/executor.hpp"
#include "draco/graph/graph.hpp"
#include "draco/pose_graph/g2o.hpp"
#include "draco/recording/recording.hpp"
#include "draco/registration/registration.hpp"
#include "draco/team/team_pgo.hpp"
#include "experiment.hpp"
#include "log_option.hpp"
#include "run_info.hpp"

namespace {

using draco::msgs::Pose2;
namespace fe = draco::frontend;
namespace reg = draco::registration;
namespace cons = draco::consistency;
namespace team = draco::team;
namespace pg = draco::pose_graph;
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kSegmentOffsetS = 1e5;

pg::Pose2 ToPg(const Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }
Pose2 FromPg(const pg::Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }

// One robot's local pose graph from the local-SLAM run (OUT/slam/<robot>.pose_graph.g2o),
// poses replaced by the captured final keyframes, and the per-step covariance of the chain
// (the summed information of the factors between consecutive keyframes, inverted).
struct LocalGraph {
  team::RobotGraph graph;
  std::vector<Eigen::Matrix3d> step_covariance;  // [k]: from k-1 to k ([0] unused)
  std::vector<cons::RelativeFactor> factors;     // every factor of the g2o, loops included
};

LocalGraph LoadLocalGraph(const std::string& path, const fe::Robot& r, bool full_graph,
                          double chain_sigma_m, double chain_sigma_rad) {
  const auto g2o = pg::ReadG2o(path);
  const std::size_t n = r.kfs.size();
  if (g2o.vertices.size() != n) {
    throw std::runtime_error(path + ": " + std::to_string(g2o.vertices.size()) +
                             " vertices, captured keyframes " + std::to_string(n));
  }
  for (std::size_t k = 0; k < n; ++k) {
    if (g2o.vertices[k].id != static_cast<pg::PoseId>(k) || r.kfs[k].index != static_cast<int>(k)) {
      throw std::runtime_error(path + ": keyframe ids are not 0..n-1 in order");
    }
  }
  LocalGraph out;
  const auto graph = pg::ToPoseGraph(g2o);
  out.graph = team::FromPoseGraph(graph);
  for (std::size_t k = 0; k < n; ++k) out.graph.poses[k] = ToPg(r.kfs[k].T_map_kf);
  if (!full_graph) out.graph.factors.clear();  // replaced by the chain below
  std::vector<Eigen::Matrix3d> info(n, Eigen::Matrix3d::Zero());
  for (const auto& e : g2o.edges) {
    if (e.i < static_cast<pg::PoseId>(n) && e.j < static_cast<pg::PoseId>(n)) {
      cons::RelativeFactor f;
      f.from = static_cast<int>(e.i);
      f.to = static_cast<int>(e.j);
      f.T_from_to = {e.T_i_j.x_m, e.T_i_j.y_m, e.T_i_j.yaw_rad};
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) f.information(a, b) = e.information[3 * a + b];
      }
      out.factors.push_back(f);
    }
    if (e.j == e.i + 1 && e.j < static_cast<pg::PoseId>(n)) {
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) info[e.j](a, b) += e.information[3 * a + b];
      }
    }
  }
  out.step_covariance.resize(n, Eigen::Matrix3d::Identity());
  for (std::size_t k = 1; k < n; ++k) {
    if (info[k].determinant() > 1e-12) {
      out.step_covariance[k] = info[k].inverse();
    } else {  // no factor (should not happen): the local SLAM's floors
      out.step_covariance[k] = Eigen::Vector3d(0.01, 0.01, 1e-4).asDiagonal();
    }
    if (!full_graph) {
      // The local SLAM's optimised trajectory as a chain: zero residual at the input, so
      // without loops the team problem returns the local result.
      team::ChainFactor f;
      f.from = static_cast<int>(k - 1);
      f.to = static_cast<int>(k);
      f.T_from_to = ToPg(reg::Between(r.kfs[k - 1].T_map_kf, r.kfs[k].T_map_kf));
      // The optimised local trajectory holds together better than one step's odometry says
      // (its intra-robot loops): a fixed chain sigma when given, as the running team's own
      // chain (OptimizerStage, own_chain_sigma_*).
      const Eigen::Matrix3d I =
          chain_sigma_m > 0
              ? Eigen::Matrix3d(Eigen::Vector3d(1.0 / (chain_sigma_m * chain_sigma_m),
                                                1.0 / (chain_sigma_m * chain_sigma_m),
                                                1.0 / (chain_sigma_rad * chain_sigma_rad))
                                    .asDiagonal())
              : Eigen::Matrix3d(out.step_covariance[k].inverse());
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) f.information[3 * a + b] = I(a, b);
      }
      out.graph.factors.push_back(f);
    }
  }
  return out;
}

// A trajectory (poses at the robot's keyframe times) shifted into segment `segment`.
void AppendSegment(const fe::Robot& r, const std::vector<Pose2>& poses, const Pose2& T_own_map,
                   int segment, draco::eval::Trajectory* out) {
  for (std::size_t k = 0; k < r.kfs.size() && k < poses.size(); ++k) {
    const Pose2 p = reg::Compose(T_own_map, poses[k]);
    out->push_back({r.kfs[k].time_s + segment * kSegmentOffsetS, p.x_m, p.y_m, p.yaw_rad});
  }
}

const char* kRowNames[] = {"dead reckoning", "local only", "two-step + PCM",
                           "two-step + GCM", "full + PCM", "full + GCM"};
const char* kRowTags[] = {"dead_reckoning",          "trajectory",
                          "trajectory.two-step-pcm", "trajectory.two-step-gcm",
                          "trajectory.full-pcm",     "trajectory.full-gcm"};
constexpr int kRows = 6;

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-team-eval: ATE of two-step / full PGO with PCM / GCM (paper Table III)"};
  draco::app::AddLogLevelOption(app);
  std::string mission;
  std::string out_dir;
  fe::SlamRunOptions slam;
  std::string experiment_path;
  std::vector<std::string> experiment_sets;
  bool print_experiment = false;
  app.add_option("mission", mission, "recorded mission folder");
  app.add_option("--out", out_dir, "output folder (default runs/team-<mission>)");
  app.add_option("--graph", slam.graph_path,
                 "local-SLAM graph YAML (default: graphs/local-slam.yaml)");
  app.add_option("--set", slam.overrides, "local-SLAM graph override component.param=value");
  app.add_flag("--reuse", slam.reuse, "reuse the keyframes cached in OUT/slam");
  app.add_option("--experiment", experiment_path,
                 "experiment YAML file, or the name of a shipped one (config/experiments/): the "
                 "protocol's knobs (--print-experiment lists them); default: every default");
  app.add_option("--exp-set", experiment_sets,
                 "experiment override section.key=value, after --experiment (e.g. "
                 "inject.fraction=0.9)");
  app.add_flag("--print-experiment", print_experiment,
               "print the resolved experiment (every key, its value and meaning) and exit");
  app.set_version_flag("--version", draco::app::VersionLine("draco-team-eval"));
  CLI11_PARSE(app, argc, argv);

  draco::team_eval::Experiment experiment;
  try {
    // A shipped experiment by name: `--experiment oracle-matching` is
    // experiments/oracle-matching.yaml on the data search path (config/experiments/).
    if (!experiment_path.empty() && experiment_path.find('/') == std::string::npos &&
        !experiment_path.ends_with(".yaml")) {
      experiment_path =
          draco::app::ResolveDataFile("experiments/" + experiment_path + ".yaml").path.string();
    }
    experiment = draco::team_eval::LoadExperiment(experiment_path, experiment_sets);
  } catch (const draco::app::DataFileError& e) {
    draco::log::Error(std::string("draco-team-eval: ") + e.what());
    return 1;
  } catch (const draco::team_eval::ExperimentError& e) {
    draco::log::Error(e.what());
    return 1;
  }
  if (print_experiment) {
    std::printf("%s", draco::team_eval::ExperimentYaml(experiment).c_str());
    return 0;
  }
  if (mission.empty()) {
    draco::log::Error("draco-team-eval: the mission folder is required (--help)");
    return 2;
  }

  // The experiment's knobs as the libraries take them.
  const bool oracle = experiment.matching.oracle;
  const bool shared_transforms = experiment.matching.shared_transforms;
  const double threshold = experiment.candidates.min_overlap;
  const int window = experiment.candidates.window;
  const int min_clique = experiment.filter.min_clique_size;
  const double map_sigma_m = experiment.filter.map_sigma_m;
  const double map_sigma_deg = experiment.filter.map_sigma_deg;
  const bool graph_covariance = experiment.filter.pose_covariance == "graph";
  const bool map_frame_drift = experiment.filter.map_frame_drift;
  const bool full_local_graph = experiment.optimizer.local_graph == "full";
  const double chain_sigma_m = experiment.optimizer.local_chain_sigma_xy_m;  // 0: from the graph
  const double chain_sigma_deg = experiment.optimizer.local_chain_sigma_yaw_deg;
  const auto& opt = experiment.optimizer;
  team::TwoStepOptions two_step;
  team::FullOptions full_options;
  two_step.anchor = opt.global_anchor == "rigid"        ? team::GlobalAnchor::kRigid
                    : opt.global_anchor == "first_loop" ? team::GlobalAnchor::kFirstLoop
                                                        : team::GlobalAnchor::kTouchedPoses;
  two_step.teammate_chain_from_factors = opt.chain_from_factors;
  if (opt.loop_sigma_xy_m > 0) {  // and the yaw sigma (LoadExperiment checks)
    two_step.loop_information_from_covariance = full_options.loop_information_from_covariance =
        false;
    two_step.loop_sigma_xy_m = full_options.loop_sigma_xy_m = opt.loop_sigma_xy_m;
    two_step.loop_sigma_yaw_rad = full_options.loop_sigma_yaw_rad = opt.loop_sigma_yaw_deg * kDeg;
  }
  fe::OutlierOptions inject;
  inject.fraction = experiment.inject.fraction;
  inject.kind =
      experiment.inject.kind == "random" ? fe::OutlierKind::kRandom : fe::OutlierKind::kCorrelated;
  inject.group_size = experiment.inject.group_size;
  inject.offset_m = experiment.inject.offset_m;
  inject.directions = experiment.inject.directions;
  inject.seed = experiment.inject.seed;
  reg::SelectionOptions sel;
  reg::RegistrationOptions ro;
  ro.min_overlap = 0.0;  // the threshold is applied below
  const double tp_m = 1.5, tp_deg = 15.0;

  try {
    const auto info = draco::recording::LoadMissionInfo(mission);
    slam.graph_path = draco::app::ResolveDataFile("graphs/local-slam.yaml", slam.graph_path).path;
    if (out_dir.empty()) out_dir = "runs/team-" + info.name;
    std::filesystem::create_directories(out_dir);
    auto run_info = draco::app::MakeRunInfo("draco-team-eval", argc, argv);
    run_info.AddFile("graph", slam.graph_path);
    if (!experiment_path.empty()) run_info.AddFile("experiment", experiment_path);
    draco::app::WriteRunInfo(out_dir, run_info);
    // What runs, every key resolved: --experiment OUT/experiment.yaml runs it again.
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/experiment.yaml",
                                             draco::team_eval::ExperimentYaml(experiment));
    const bool airplane = info.world.find("airplane") != std::string::npos ||
                          info.name.find("airplane") != std::string::npos;
    if (airplane) {
      const auto a = reg::AirplaneSelectionOptions();
      sel.candidate_radius_m = a.candidate_radius_m;
      sel.candidate_max_yaw_rad = a.candidate_max_yaw_rad;
    }
    double slam_s = 0.0;
    const auto robots = fe::RunRobots(mission, info, out_dir, slam, &slam_s);
    const int n = static_cast<int>(robots.size());
    if (n > 16)
      throw std::runtime_error("at most 16 robots (the mission has " + std::to_string(n) + ")");

    // Local graphs, dead reckoning at the keyframes, dense ground truth.
    std::vector<LocalGraph> graphs;
    std::vector<std::vector<Pose2>> dr(robots.size()), local(robots.size());
    std::vector<draco::eval::Trajectory> truth(robots.size());
    for (int i = 0; i < n; ++i) {
      const auto& r = robots[i];
      graphs.push_back(LoadLocalGraph(out_dir + "/slam/" + r.name + ".pose_graph.g2o", r,
                                      full_local_graph, chain_sigma_m, chain_sigma_deg * kDeg));
      const auto d = draco::eval::ReadTum(out_dir + "/slam/" + r.name + ".dead_reckoning.tum");
      if (d.size() != r.kfs.size()) throw std::runtime_error(r.name + ": dead reckoning size");
      for (const auto& p : d) dr[i].push_back({p.x_m, p.y_m, p.yaw_rad});
      for (const auto& k : r.kfs) local[i].push_back(k.T_map_kf);
      truth[i] = draco::eval::ReadTum(mission + "/" + r.name + "/groundtruth.tum");
    }

    // Front end per ordered pair: candidate loops of own a with teammate b, map guesses.
    fe::PairOptions po;
    po.selection = sel;
    po.registration = ro;
    po.windows = {window};
    po.oracle = oracle;
    po.tp_m = tp_m;
    po.tp_deg = tp_deg;
    std::map<std::pair<int, int>, fe::PairResult> pairs;
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) {
        if (a != b) pairs[{a, b}] = fe::MatchAndRegister(robots[a], robots[b], po);
      }
    }

    std::printf("\nmission %s (%s): %d robots, local SLAM %.1f s wall; %s\n", info.name.c_str(),
                info.world.c_str(), n, slam_s,
                oracle ? "ORACLE MATCHING (ground-truth map-to-map transforms where matching "
                         "was not right)"
                       : "object-graph matching only (no oracle)");
    std::printf("candidate loops: window %d, overlap >= %.2f; true positive <= %.1f m, %.0f deg\n",
                window, threshold, tp_m, tp_deg);

    // Pose sources of every robot for the consistency filters (the graph one inverts each
    // robot's information once, O(n^3)).
    cons::ChainPoseSource chain_poses_all;
    cons::GraphPoseSource graph_poses_all({map_frame_drift
                                               ? cons::MapFrameCovariance::kFromFirstKeyframe
                                               : cons::MapFrameCovariance::kNone});
    for (int i = 0; i < n; ++i) {
      std::vector<Pose2> kf_poses;
      for (std::size_t k = 0; k < robots[i].kfs.size(); ++k) {
        chain_poses_all.AddKeyframe(robots[i].id, robots[i].kfs[k].T_map_kf,
                                    graphs[i].step_covariance[k]);
        kf_poses.push_back(robots[i].kfs[k].T_map_kf);
      }
      if (graph_covariance) graph_poses_all.SetRobot(robots[i].id, kf_poses, graphs[i].factors);
    }

    double ate[kRows][16] = {};
    int loop_accepted[2][16] = {}, loop_tp[2][16] = {};
    std::string loops_csv =
        "robot,teammates_placed_by,candidates,candidate_tp,pcm_accepted,pcm_tp,gcm_accepted,"
        "gcm_tp,pcm_exact,gcm_exact\n";
    std::string placement_lines, segment_lines;
    for (int a = 0; a < n; ++a) {
      const auto& A = robots[a];
      // Candidates and their truth.
      std::vector<draco::msgs::InterRobotLoop> candidates;
      std::map<std::uint64_t, bool> is_tp;
      team::TeamProblem problem;
      for (int i = 0; i < n; ++i) problem.robots[robots[i].id] = graphs[i].graph;
      // The robots' poses are the same for every own robot; only the map transforms differ.
      cons::ChainPoseSource chain_poses = chain_poses_all;
      cons::GraphPoseSource graph_poses = graph_poses_all;
      const cons::PoseSource& poses =
          graph_covariance ? static_cast<const cons::PoseSource&>(graph_poses) : chain_poses;
      std::vector<Pose2> T_own(robots.size());  // T_a_i guess (identity when none)
      std::string placed_by;
      // Teammates' own matches, as the map-to-map transforms they would share.
      team::TeamProblem others;
      if (shared_transforms) {
        // The own matches first, then the teammates' (one transform per robot pair).
        for (int j = 0; j < n; ++j) {
          if (j == a) continue;
          const auto& pr = pairs.at({a, j});
          if (pr.match.status == draco::msgs::MatchStatus::kMatched)
            others.maps[{A.id, robots[j].id}] = ToPg(pr.match.T_a_b);
        }
        for (int i = 0; i < n; ++i) {
          for (int j = 0; j < n; ++j) {
            if (i == a || j == i) continue;
            const auto& pr = pairs.at({i, j});
            if (pr.match.status != draco::msgs::MatchStatus::kMatched || pr.oracle_used) continue;
            if (others.maps.count({robots[j].id, robots[i].id})) continue;
            others.maps[{robots[i].id, robots[j].id}] = ToPg(pr.match.T_a_b);
          }
        }
      }
      for (int b = 0; b < n; ++b) {
        if (b == a) continue;
        const fe::PairResult* pr_ptr = &pairs.at({a, b});
        const bool have = pr_ptr->match.status == draco::msgs::MatchStatus::kMatched;
        team::Pose2 chained;
        const bool via = shared_transforms && !have && !oracle &&
                         team::MapGuess(others, A.id, robots[b].id, &chained);
        fe::PairResult chained_result;
        if (via) {  // scans around the objects the shared transform overlays
          chained_result = fe::RegisterWithTransform(
              A, robots[b], Pose2{chained.x_m, chained.y_m, chained.yaw_rad}, po);
          pr_ptr = &chained_result;
        }
        const fe::PairResult& pr = *pr_ptr;
        std::string how = pr.oracle_used
                              ? "oracle"
                              : (have ? (pr.correct ? "matching" : "matching(wrong)")
                                      : std::string("nothing(") +
                                            draco::msgs::MatchStatusName(pr.match.status) + ")");
        // The oracle also places teammates with no true shared object (no scans requested).
        const bool oracle_guess = oracle && !have;
        if (oracle_guess) how = "oracle(no-scans)";
        if (via) how = "shared-transforms";
        T_own[b] = have
                       ? pr.match.T_a_b
                       : (oracle_guess
                              ? pr.T_true
                              : (via ? Pose2{chained.x_m, chained.y_m, chained.yaw_rad} : Pose2{}));
        placed_by += (placed_by.empty() ? "" : " ") + robots[b].name + ":" + how;
        problem.maps[{A.id, robots[b].id}] = ToPg(T_own[b]);
        cons::UncertainPose m;
        m.pose = T_own[b];
        m.covariance = Eigen::Vector3d(map_sigma_m * map_sigma_m, map_sigma_m * map_sigma_m,
                                       std::pow(map_sigma_deg * kDeg, 2))
                           .asDiagonal();
        if (have || oracle_guess || via) {
          chain_poses.SetMapTransform(A.id, robots[b].id, m);
          graph_poses.SetMapTransform(A.id, robots[b].id, m);
        }
        for (const auto& r : pr.registrations) {
          if (!r.valid || r.overlap < threshold - 1e-9) continue;
          auto loop = r.loop;
          loop.id = candidates.size();
          is_tp[loop.id] = r.tp;
          candidates.push_back(loop);
        }
      }
      if (inject.fraction > 0.0) {
        auto o = inject;
        o.seed = inject.seed * 1000 + static_cast<std::uint64_t>(a);
        const auto wrong = fe::InjectOutliers(candidates, local[a], o, candidates.size());
        for (const auto& w : wrong) {
          is_tp[w.id] = false;
          candidates.push_back(w);
        }
      }
      std::sort(candidates.begin(), candidates.end(), [](const auto& x, const auto& y) {
        return std::tie(x.own_keyframe, x.teammate_robot, x.teammate_keyframe) <
               std::tie(y.own_keyframe, y.teammate_robot, y.teammate_keyframe);
      });

      // PCM and GCM, one batch decision each, exact (no time budget).
      std::vector<draco::msgs::InterRobotLoop> accepted[2];
      int tp_acc[2] = {0, 0};
      bool exact[2] = {true, true};
      for (int m = 0; m < 2; ++m) {
        cons::FilterOptions fo;
        fo.method = m == 0 ? cons::Method::kPcm : cons::Method::kGcm;
        fo.time_budget_ms = 0.0;
        fo.min_clique_size = min_clique;
        cons::ConsistencyFilter filter(fo);
        const auto d = filter.Add(candidates, poses);
        exact[m] = d.exact;
        const std::set<std::uint64_t> ids(d.accepted.begin(), d.accepted.end());
        for (const auto& l : candidates) {
          if (!ids.count(l.id)) continue;
          accepted[m].push_back(l);
          tp_acc[m] += is_tp[l.id];
        }
      }
      int cand_tp = 0;
      for (const auto& [id, t] : is_tp) cand_tp += t;
      for (int m = 0; m < 2; ++m) {
        loop_accepted[m][a] = static_cast<int>(accepted[m].size());
        loop_tp[m][a] = tp_acc[m];
      }

      // Trajectories of every row, concatenated: own first, then teammates in order.
      std::vector<std::vector<std::vector<Pose2>>> rows(kRows);  // [row][robot] in own frame
      rows[0] = dr;
      rows[1] = local;
      for (int row = 0; row < 2; ++row) {
        for (int b = 0; b < n; ++b) {
          for (auto& p : rows[row][b]) p = reg::Compose(T_own[b], p);
        }
      }
      for (int m = 0; m < 2; ++m) {
        problem.loops = accepted[m];
        const auto two = team::TwoStepPgo(problem, A.id, two_step);
        const auto full = team::FullPgo(problem, A.id, full_options);
        for (int v = 0; v < 2; ++v) {
          const auto& est = v == 0 ? two : full;
          auto& out = rows[2 + 2 * v + m];
          out.resize(robots.size());
          for (int b = 0; b < n; ++b) {
            for (const auto& p : est.trajectories.at(robots[b].id)) out[b].push_back(FromPg(p));
          }
        }
      }
      std::vector<int> order{a};
      for (int b = 0; b < n; ++b) {
        if (b != a) order.push_back(b);
      }
      draco::eval::Trajectory truth_cat;
      for (std::size_t s = 0; s < order.size(); ++s) {
        for (const auto& p : truth[order[s]]) {
          truth_cat.push_back(
              {p.time_s + static_cast<double>(s) * kSegmentOffsetS, p.x_m, p.y_m, p.yaw_rad});
        }
      }
      draco::eval::WriteTum(out_dir + "/" + A.name + ".ground_truth.tum", truth_cat);
      for (int row = 0; row < kRows; ++row) {
        draco::eval::Trajectory cat;
        for (std::size_t s = 0; s < order.size(); ++s) {
          AppendSegment(robots[order[s]], rows[row][order[s]], Pose2{}, static_cast<int>(s), &cat);
        }
        draco::eval::WriteTum(out_dir + "/" + A.name + "." + kRowTags[row] + ".tum", cat);
        const auto res = draco::eval::Ate(cat, truth_cat);
        ate[row][a] = res.rmse_m;
        // Per segment after the one alignment (diagnostic).
        const auto as =
            draco::eval::Associate(draco::eval::Transform(res.T_truth_estimate, cat), truth_cat);
        std::vector<double> se(order.size(), 0.0), sn(order.size(), 0.0);
        for (std::size_t k = 0; k < as.estimate.size(); ++k) {
          const auto s = static_cast<std::size_t>(as.estimate[k].time_s / kSegmentOffsetS);
          if (s >= order.size()) continue;
          se[s] += std::pow(as.estimate[k].x_m - as.truth[k].x_m, 2) +
                   std::pow(as.estimate[k].y_m - as.truth[k].y_m, 2);
          sn[s] += 1.0;
        }
        segment_lines += "  " + A.name + " " + kRowNames[row] + ":";
        for (std::size_t s = 0; s < order.size(); ++s) {
          char v[64];
          std::snprintf(v, sizeof(v), " %s %.2f", robots[order[s]].name.c_str(),
                        sn[s] > 0 ? std::sqrt(se[s] / sn[s]) : -1.0);
          segment_lines += v;
        }
        segment_lines += "\n";
      }
      char line[512];
      std::snprintf(line, sizeof(line), "%s,%s,%zu,%d,%zu,%d,%zu,%d,%d,%d\n", A.name.c_str(),
                    placed_by.c_str(), candidates.size(), cand_tp, accepted[0].size(), tp_acc[0],
                    accepted[1].size(), tp_acc[1], exact[0] ? 1 : 0, exact[1] ? 1 : 0);
      loops_csv += line;
      placement_lines += "  " + A.name + ": teammates placed by " + placed_by + "\n";
    }

    // Table.
    std::printf("%s", placement_lines.c_str());
    std::string table_csv = "row";
    std::printf("\nATE RMSE (m), own + teammates concatenated in the own frame, SE(2) aligned\n");
    std::printf("%-16s", "row");
    for (const auto& r : robots) {
      std::printf(" %9s", r.name.c_str());
      table_csv += "," + r.name;
    }
    std::printf(" %9s\n", "mean");
    table_csv += ",mean,oracle_matching\n";
    for (int row = 0; row < kRows; ++row) {
      std::printf("%-16s", kRowNames[row]);
      table_csv += kRowNames[row];
      double sum = 0.0;
      for (int a = 0; a < n; ++a) {
        std::printf(" %9.2f", ate[row][a]);
        char v[32];
        std::snprintf(v, sizeof(v), ",%.3f", ate[row][a]);
        table_csv += v;
        sum += ate[row][a];
      }
      char v[48];
      std::snprintf(v, sizeof(v), ",%.3f,%d\n", sum / n, oracle ? 1 : 0);
      table_csv += v;
      std::printf(" %9.2f\n", sum / n);
    }
    std::printf("\ntwo-step + GCM / dead reckoning:");
    for (int a = 0; a < n; ++a) {
      std::printf(" %s %.0f %%", robots[a].name.c_str(),
                  ate[0][a] > 0 ? 100.0 * ate[3][a] / ate[0][a] : 0.0);
    }
    std::printf("\n\nper segment (RMSE m after the one alignment):\n%s", segment_lines.c_str());
    std::printf("\ninter-robot loops (accepted / true positives):\n%s", loops_csv.c_str());
    if (inject.fraction > 0.0) {
      std::printf("injected: %s outliers, %.0f %% of each robot's stream (seed %llu)\n",
                  experiment.inject.kind.c_str(), 100.0 * inject.fraction,
                  static_cast<unsigned long long>(inject.seed));
    }
    for (int m = 0; m < 2; ++m) {
      std::printf("%s precision (accepted true / accepted):", m == 0 ? "PCM" : "GCM");
      int acc_all = 0, tp_all = 0;
      for (int a = 0; a < n; ++a) {
        std::printf(" %s %d/%d", robots[a].name.c_str(), loop_tp[m][a], loop_accepted[m][a]);
        acc_all += loop_accepted[m][a];
        tp_all += loop_tp[m][a];
      }
      std::printf("; all %.3f\n", acc_all ? static_cast<double>(tp_all) / acc_all : 1.0);
    }
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/table3.csv", table_csv);
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/team_loops.csv", loops_csv);
    std::printf("TUM files and table3.csv, team_loops.csv in %s (draco-eval %s reports them)\n",
                out_dir.c_str(), out_dir.c_str());
    return 0;
  } catch (const draco::graph::GraphError& e) {
    draco::log::Error(e.what());
    return 1;
  } catch (const std::exception& e) {
    draco::log::Error(std::string("draco-team-eval: ") + e.what());
    return 1;
  }
}
