// Runtime adapters: slam.LocalSlam (the pose-graph back end of one robot) and
// eval.TrajectoryRecorder (ground truth to TUM). Outputs are written on Stop().
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <map>
#include <numbers>
#include <string>

#include "draco/eval/trajectory.hpp"
#include "draco/graph/component.hpp"
#include "draco/graph/executor.hpp"
#include "draco/log/log.hpp"
#include "draco/msgs/map.hpp"
#include "draco/msgs/sensors.hpp"
#include "draco/pointcloud_io/pointcloud_io.hpp"
#include "draco/slam/local_slam.hpp"

namespace draco::slam {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;

std::string OutPath(const Context& ctx, const std::string& prefix, const std::string& name) {
  return (std::filesystem::path(ctx.output_dir()) / (prefix + name)).string();
}

class LocalSlamComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "Local SLAM back end: keyframes and sequential factors into a Ceres SE(2) pose graph, "
        "intra-robot loop closures (ICP + PCM), sparse point landmarks; writes trajectory, "
        "graph, loops, landmarks and map.");
    keyframe_ = spec.Input<msgs::Keyframe>("keyframe", {.depth = 256, .doc = "keyframes"});
    factor_ = spec.Input<msgs::SequentialFactor>(
        "factor", {.depth = 256,
                   .required = false,
                   .doc = "scan-matching factors (k-1 -> k); unconnected: dead reckoning"});
    trajectory_ = spec.Output<msgs::KeyframeTrajectory>("trajectory", "after every keyframe");
    spec.Param("prefix", &prefix_, {.doc = "output file name prefix, e.g. the robot name"});
    spec.Param("loop_closure", &o_.loop_closure, {.doc = "search intra-robot loop closures"});
    spec.Param("loop_min_index_gap", &o_.loop_min_index_gap,
               {.doc = "keyframes at least this far apart", .min = 1});
    spec.Param("loop_max_distance_m", &o_.loop_max_distance_m,
               {.doc = "candidate search radius", .unit = "m", .min = 0});
    spec.Param("loop_min_overlap", &o_.loop_min_overlap,
               {.doc = "ICP overlap ratio needed", .min = 0, .max = 1});
    spec.Param("full_solve_min_keyframes", &o_.full_solve_min_keyframes,
               {.doc = "a triggered full pose-graph solve waits until this many keyframes were "
                       "added since the last one (0: at once)"});
    spec.Param("full_solve_max_boundary_chi2", &o_.full_solve_max_boundary_chi2,
               {.doc = "a triggered full solve is tried as a window solve first; its answer "
                       "stands when every factor tying the window to older keyframes has chi2 "
                       "at most this (0: off)",
                .min = 0});
    spec.Param("loop_max_candidates", &o_.loop_max_candidates,
               {.doc = "candidates registered per keyframe", .min = 0});
    spec.Param("pcm_chi2_threshold", &o_.pcm_chi2_threshold,
               {.doc = "pairwise consistency threshold (3 dof)", .min = 0});
    spec.Param("pcm_min_clique_size", &o_.pcm_min_clique_size,
               {.doc = "consistent loops needed before any is accepted", .min = 1});
    spec.Param("pcm_max_clique_nodes", &o_.pcm_max_clique_nodes,
               {.doc = "branch-and-bound nodes of the PCM clique search per keyframe; at the "
                       "budget a greedy clique answers",
                .min = 1});
    spec.Param("keep_dead_reckoning_factor", &o_.keep_dead_reckoning_factor,
               {.doc = "dead-reckoning factor beside every scan-matching factor"});
    spec.Param("heading_prior_sigma_rad", &o_.heading_prior_sigma_rad,
               {.doc = "yaw prior from the AHRS heading on every keyframe (0: none)",
                .unit = "rad",
                .min = 0});
    spec.Param("heading_bias_sigma_rad", &o_.heading_bias_sigma_rad,
               {.doc = "AHRS heading with a correlated error state: its sigma (0: off)",
                .unit = "rad",
                .min = 0});
    spec.Param("heading_bias_tau_s", &o_.heading_bias_tau_s,
               {.doc = "correlation time of the AHRS heading error", .unit = "s", .min = 1e-3});
    spec.Param("heading_meas_sigma_rad", &o_.heading_meas_sigma_rad,
               {.doc = "white noise of the AHRS heading", .unit = "rad", .min = 1e-6});
    spec.Param("heading_bias_gauss_markov", &o_.heading_bias_gauss_markov,
               {.doc = "exact Gauss-Markov (AR(1)) heading-error model, no per-keyframe prior"});
    spec.Param("heading_meas_cauchy_scale", &o_.heading_meas_cauchy_scale,
               {.doc = "Cauchy loss on the AHRS heading measurement (0: none)",
                .unit = "sigma",
                .min = 0});
    spec.Param("heading_prior_cauchy_scale", &o_.heading_prior_cauchy_scale,
               {.doc = "Cauchy loss on the heading prior (0: none)", .unit = "sigma", .min = 0});
    spec.Param(
        "scan_match_cauchy_scale", &o_.scan_match_cauchy_scale,
        {.doc = "Cauchy loss on scan-matching factors (0: none)", .unit = "sigma", .min = 0});
    spec.Param("min_factor_sigma_xy_m", &o_.min_factor_sigma_xy_m,
               {.doc = "floor on factor sigmas", .unit = "m", .min = 1e-6});
    spec.Param("min_factor_sigma_yaw_rad", &o_.min_factor_sigma_yaw_rad,
               {.doc = "floor on factor sigmas", .unit = "rad", .min = 1e-7});
    spec.Param("bounds_line_search", &o_.bounds_line_search,
               {.doc = "Ceres' projected line search after each step of a solve with bounds "
                       "(landmark radii); false: steps only projected onto the bounds"});
    spec.Param("min_scan_match_sigma_xy_m", &o_.min_scan_match_sigma_xy_m,
               {.doc = "floor on a scan-matching factor's translation sigma in the graph (<0: "
                       "min_factor_sigma_xy_m; the loop test's chain keeps that floor)",
                .unit = "m"});
    spec.Param("min_dr_sigma_xy_m", &o_.min_dr_sigma_xy_m,
               {.doc = "floor on the dead-reckoning factor beside a scan match (<0: as above)",
                .unit = "m"});
    spec.Param("min_dr_sigma_yaw_rad", &o_.min_dr_sigma_yaw_rad,
               {.doc = "floor on the dead-reckoning factor beside a scan match (<0: as above, "
                       "the library's default)",
                .unit = "rad",
                .origin = "0.02: dead reckoning's heading error per keyframe is ~0.02 rad, twice "
                          "the 0.01 floor; calibrated against ground truth on the marina and "
                          "airplane missions: docs/local-slam.md, \"Factor calibration\""});
    spec.Param("loop_rmse_cov_scale", &o_.loop_rmse_cov_scale,
               {.doc = "loop xy variance at least this times the ICP rmse^2 (0: off)", .min = 0});
    spec.Param("loop_overlap_cov_power", &o_.loop_overlap_cov_power,
               {.doc = "loop covariance times (1/overlap)^power (0: off)", .min = 0});
    spec.Param("loop_max_correction_m", &o_.loop_max_correction_m,
               {.doc = "reject loops that move the estimate by more (seed search + ICP)",
                .unit = "m",
                .min = 0});
    spec.Param("loop_max_correction_rad", &o_.loop_max_correction_rad,
               {.doc = "reject loops that turn the estimate by more", .unit = "rad", .min = 0});
    spec.Param("loop_chain_chi2", &o_.loop_chain_chi2,
               {.doc = "refuse a loop whose correction of the estimate has a larger squared "
                       "Mahalanobis distance under the keyframe chain's covariance (0: off)",
                .min = 0});
    spec.Param("loop_max_rmse_m", &o_.loop_max_rmse_m,
               {.doc = "reject loops with a larger ICP rmse (0: no gate)", .unit = "m", .min = 0});
    spec.Param("loop_ambiguity_ratio", &o_.loop_ambiguity_ratio,
               {.doc = "drop a loop whose correlative runner-up (a pose at least "
                       "loop_ambiguity_offset_m away) scores this fraction of the best (0: off)",
                .min = 0,
                .max = 1});
    spec.Param("loop_ambiguity_inflate", &o_.loop_ambiguity_inflate,
               {.doc = "keep ambiguous loops with the search plateau's elongation added to "
                       "their covariance instead of dropping them"});
    spec.Param("loop_icp_ambiguity_ratio", &o_.loop_icp_ambiguity_ratio,
               {.doc = "drop a loop when ICP from its answer moved by loop_icp_ambiguity_offsets_m "
                       "(8 directions) lands more than 1 m or 5 deg away with this fraction of "
                       "its overlap (0: off)",
                .min = 0,
                .max = 1});
    spec.Param("loop_icp_ambiguity_offsets_m", &o_.loop_icp_ambiguity_offsets_m,
               {.doc = "seed offsets of the ICP ambiguity test", .unit = "m"});
    spec.Param("loop_icp_ambiguity_inflate", &o_.loop_icp_ambiguity_inflate,
               {.doc = "keep an ICP-ambiguous loop with each other place's shift added to its "
                       "translation covariance instead of dropping it"});
    spec.Param("loop_ambiguity_offset_m", &o_.loop_ambiguity_offset_m,
               {.doc = "how far from the best pose a runner-up must be", .unit = "m", .min = 0});
    spec.Param("loop_max_yaw_rad", &o_.loop_max_yaw_rad,
               {.doc = "candidate heading difference", .unit = "rad", .min = 0});
    spec.Param("loop_min_points", &o_.loop_min_points,
               {.doc = "points a keyframe needs to take part in a loop", .min = 0});
    spec.Param("loop_submap_half_width", &o_.loop_submap_half_width,
               {.doc = "loop target: candidate keyframe and this many each side", .min = 0});
    spec.Param("loop_source_half_width", &o_.loop_source_half_width,
               {.doc = "loop source: keyframe k and this many before it", .min = 0});
    spec.Param("loop_min_sigma_xy_m", &o_.loop_min_sigma_xy_m,
               {.doc = "floor on loop sigmas", .unit = "m", .min = 1e-6});
    spec.Param("loop_min_sigma_yaw_rad", &o_.loop_min_sigma_yaw_rad,
               {.doc = "floor on loop sigmas", .unit = "rad", .min = 1e-7});
    spec.Param("landmarks", &o_.landmarks,
               {.doc = "point landmarks from compact isolated clusters of keyframe points"});
    spec.Param("landmark_cluster_radius_m", &o_.landmark_cluster_radius_m,
               {.doc = "single-linkage radius of landmark clusters", .unit = "m", .min = 1e-3});
    spec.Param("landmark_min_points", &o_.landmark_min_points,
               {.doc = "points a landmark cluster needs", .min = 1});
    spec.Param("landmark_max_extent_m", &o_.landmark_max_extent_m,
               {.doc = "largest extent of a landmark cluster", .unit = "m", .min = 0});
    spec.Param("landmark_isolation_m", &o_.landmark_isolation_m,
               {.doc = "no other point this close to a landmark cluster's centroid",
                .unit = "m",
                .min = 0});
    spec.Param("landmark_min_sigma_m", &o_.landmark_min_sigma_m,
               {.doc = "sigma added to a landmark observation's spread", .unit = "m", .min = 1e-3});
    spec.Param(
        "landmark_max_range_m", &o_.landmark_max_range_m,
        {.doc = "ignore landmark clusters farther away (0: no limit)", .unit = "m", .min = 0});
    spec.Param("landmark_gate_m", &o_.landmark_gate_m,
               {.doc = "association distance to a landmark's estimate", .unit = "m", .min = 0});
    spec.Param("landmark_new_min_distance_m", &o_.landmark_new_min_distance_m,
               {.doc = "no landmark within this distance for a new one", .unit = "m", .min = 0});
    spec.Param(
        "landmark_min_index_gap", &o_.landmark_min_index_gap,
        {.doc = "keyframes a landmark's sightings must span before it constrains", .min = 0});
    spec.Param("landmark_min_observations", &o_.landmark_min_observations,
               {.doc = "sightings a landmark needs before it constrains", .min = 1});
    spec.Param(
        "landmark_center_offset_ratio", &o_.landmark_center_offset_ratio,
        {.doc = "landmark centroid moved away from the sonar by this * extent / 2", .min = 0});
    spec.Param("landmark_range_sigma_ratio", &o_.landmark_range_sigma_ratio,
               {.doc = "landmark sigma along the ray: this * extent / 2", .min = 0});
    spec.Param("landmark_radius_sigma_m", &o_.landmark_radius_sigma_m,
               {.doc = "sigma of a landmark's radius-state prior (0: no radius state)",
                .unit = "m",
                .min = 0});
    spec.Param("landmark_radius_prior_ratio", &o_.landmark_radius_prior_ratio,
               {.doc = "radius prior = this * mean sighting extent / 2", .min = 0});
    spec.Param("landmark_radius_max_m", &o_.landmark_radius_max_m,
               {.doc = "upper bound of a landmark's radius", .unit = "m", .min = 0.01});
    spec.Param("landmark_max_pass_spread_m", &o_.landmark_max_pass_spread_m,
               {.doc = "landmark unstable when a sighting strays this far within a pass (0: off)",
                .unit = "m",
                .min = 0});
    spec.Param("landmark_pass_gap", &o_.landmark_pass_gap,
               {.doc = "sightings at most this many keyframes apart form one pass", .min = 1});
    spec.Param(
        "landmark_cauchy_scale", &o_.landmark_cauchy_scale,
        {.doc = "Cauchy loss on landmark observations (0: none)", .unit = "sigma", .min = 0});
    spec.Param("pcd_encoding", &pcd_encoding_name_,
               {.doc = "DATA of the map.pcd written on Stop (PCL's writer)",
                .choices = {"binary", "binary_compressed", "ascii"}});
  }
  Status Start(Context&) override {
    pcd_encoding_ = pointcloud_io::ParsePcdEncoding(pcd_encoding_name_);
    slam_ = LocalSlam(o_);
    return Status::Ok();
  }
  Status Process(Context& ctx) override {
    for (auto& k : keyframe_.TakeAll()) pending_keyframes_.push_back(k);
    for (auto& f : factor_.TakeAll()) pending_factors_[f->to_index] = f;
    bool added = false;
    while (!pending_keyframes_.empty()) {
      const auto& kf = pending_keyframes_.front();
      const msgs::SequentialFactor* factor = nullptr;
      if (kf->index > 0 && factor_.connected()) {
        auto it = pending_factors_.find(kf->index);
        if (it == pending_factors_.end()) break;  // wait for its factor
        factor = it->second.value.get();
      }
      try {
        const StepResult r = slam_.AddKeyframe(*kf, factor);
        loops_accepted_ += r.loops_accepted;
        loops_ambiguous_ += r.loops_ambiguous;
        loops_chain_rejected_ += r.loops_chain_rejected;
        loops_icp_ambiguous_ += r.loops_icp_ambiguous;
        pcm_searches_capped_ += r.pcm_search_capped ? 1 : 0;
        (r.full_solve ? full_solves_ : window_solves_) += 1;
        (r.full_solve ? full_solve_s_ : window_solve_s_) += r.solve_time_s;
        if (r.full_solve) full_solve_iterations_ += r.solve_iterations;
        full_solves_avoided_ += r.full_solve_avoided ? 1 : 0;
      } catch (const std::exception& e) {
        pending_keyframes_.pop_front();
        return Status::Error(e.what());
      }
      pending_factors_.erase(kf->index);
      pending_keyframes_.pop_front();
      added = true;
    }
    if (added) Publish(ctx);
    return Status::Ok();
  }
  Status Stop(Context& ctx) override {
    if (slam_.Flush()) ++full_solves_;  // the files below hold the last full solve
    if (full_solves_ + window_solves_ > 0) {
      char line[256];
      std::snprintf(line, sizeof(line),
                    "local SLAM: %d full solves (%.2f s, %d iterations), %d window solves "
                    "(%.2f s; %d of them instead of a full solve)",
                    full_solves_, full_solve_s_, full_solve_iterations_, window_solves_,
                    window_solve_s_, full_solves_avoided_);
      log::Info(prefix_ + line);
    }
    const auto count = [&](int n, const std::string& what) {
      if (n > 0) log::Info(prefix_ + "local SLAM: " + std::to_string(n) + what);
    };
    count(loops_ambiguous_,
          std::string(o_.loop_ambiguity_inflate ? " ambiguous loops kept with their slide added to "
                                                  "the covariance"
                                                : " loop candidates dropped as ambiguous") +
              " (loop_ambiguity_ratio)");
    count(loops_chain_rejected_,
          " loop candidates refused: a correction the keyframe chain cannot explain "
          "(loop_chain_chi2)");
    count(loops_icp_ambiguous_,
          std::string(o_.loop_icp_ambiguity_inflate
                          ? " loops kept with their other fits added to the covariance"
                          : " loop candidates dropped") +
              ": ICP from a shifted seed fits them elsewhere as well (loop_icp_ambiguity_ratio)");
    count(pcm_searches_capped_,
          " keyframes whose PCM clique search reached its budget; a greedy clique answered "
          "(pcm_max_clique_nodes)");
    if (ctx.output_dir().empty()) return Status::Ok();
    eval::Trajectory est, dr;
    for (const auto& k : slam_.Trajectory()) {
      est.push_back({k.time_s, k.T_map_kf.x_m, k.T_map_kf.y_m, k.T_map_kf.yaw_rad});
      dr.push_back({k.time_s, k.T_odom_kf.x_m, k.T_odom_kf.y_m, k.T_odom_kf.yaw_rad});
    }
    std::string loops = "from_index,to_index,x_m,y_m,yaw_rad,overlap_ratio,accepted\n";
    for (const auto& l : slam_.Loops()) {
      char line[160];
      std::snprintf(line, sizeof(line), "%d,%d,%.4f,%.4f,%.5f,%.3f,%d\n", l.from_index, l.to_index,
                    l.T_from_to.x_m, l.T_from_to.y_m, l.T_from_to.yaw_rad, l.overlap_ratio,
                    l.accepted ? 1 : 0);
      loops += line;
    }
    const auto points = slam_.MapPoints();
    if (o_.landmarks) {
      std::string csv =
          "id,x_m,y_m,observations,first_keyframe,last_keyframe,in_graph,unstable,radius_m,"
          "keyframes\n";
      for (const auto& l : slam_.Landmarks()) {
        char line[200];
        std::snprintf(line, sizeof(line), "%d,%.3f,%.3f,%d,%d,%d,%d,%d,%.3f,", l.id, l.p_map.x_m,
                      l.p_map.y_m, l.num_observations, l.first_keyframe, l.last_keyframe,
                      l.in_graph ? 1 : 0, l.unstable ? 1 : 0, l.radius_m);
        csv += line;
        for (std::size_t i = 0; i < l.keyframes.size(); ++i) {
          csv += (i ? ";" : "") + std::to_string(l.keyframes[i]);
        }
        csv += "\n";
      }
      if (!graph::WriteFileAtomically(OutPath(ctx, prefix_, "landmarks.csv"), csv)) {
        return Status::Fatal("cannot write " + OutPath(ctx, prefix_, "landmarks.csv"));
      }
    }
    try {
      eval::WriteTum(OutPath(ctx, prefix_, "trajectory.tum"), est);
      eval::WriteTum(OutPath(ctx, prefix_, "dead_reckoning.tum"), dr);
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    for (const auto& [name, text] :
         {std::pair<std::string, std::string>{"pose_graph.g2o", slam_.ToG2oText()},
          {"intra_loops.csv", loops}}) {
      if (!graph::WriteFileAtomically(OutPath(ctx, prefix_, name), text)) {
        return Status::Fatal("cannot write " + OutPath(ctx, prefix_, name));
      }
    }
    // The point-cloud map, as PCL writes it (binary PCD and binary PLY: docs/results.md).
    try {
      pointcloud_io::WritePcd(OutPath(ctx, prefix_, "map.pcd"), points, pcd_encoding_);
      pointcloud_io::WritePly(OutPath(ctx, prefix_, "map.ply"), points);
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    return Status::Ok();
  }

 private:
  void Publish(Context& ctx) {
    msgs::KeyframeTrajectory t;
    for (const auto& k : slam_.Trajectory()) {
      t.keyframes.push_back({k.index, k.time_s, k.T_map_kf});
    }
    t.time_s = t.keyframes.empty() ? 0.0 : t.keyframes.back().time_s;
    t.loops_accepted = loops_accepted_;
    if (o_.landmarks) {
      for (auto& l : slam_.Landmarks()) {
        if (l.unstable) continue;
        t.landmarks.push_back({l.id, l.p_map, l.radius_m, std::move(l.keyframes)});
      }
    }
    trajectory_.PublishAt(ctx.Now(), std::move(t));
  }

  // The runtime's defaults are the calibrated ones (see their origin); the library keeps the
  // reference's.
  LocalSlamOptions o_ = [] {
    LocalSlamOptions o;
    o.min_dr_sigma_yaw_rad = 0.02;
    return o;
  }();
  std::string prefix_;
  std::string pcd_encoding_name_ = "binary";
  pointcloud_io::PcdEncoding pcd_encoding_ = pointcloud_io::PcdEncoding::kBinary;
  LocalSlam slam_;
  int loops_accepted_ = 0;
  int loops_ambiguous_ = 0;
  int loops_chain_rejected_ = 0;
  int loops_icp_ambiguous_ = 0;
  int pcm_searches_capped_ = 0;
  int full_solves_avoided_ = 0;
  int full_solves_ = 0, window_solves_ = 0;  // pose-graph solves, and their time
  int full_solve_iterations_ = 0;
  double full_solve_s_ = 0.0, window_solve_s_ = 0.0;
  std::deque<graph::Stamped<msgs::Keyframe>> pending_keyframes_;
  std::map<int, graph::Stamped<msgs::SequentialFactor>> pending_factors_;
  graph::In<msgs::Keyframe> keyframe_;
  graph::In<msgs::SequentialFactor> factor_;
  graph::Out<msgs::KeyframeTrajectory> trajectory_;
};
DRACO_REGISTER_COMPONENT(LocalSlamComponent, "slam.LocalSlam")

class TrajectoryRecorder final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc("Records ground-truth poses and writes them as TUM (yaw only) on Stop.");
    truth_ = spec.Input<msgs::GroundTruthPose>("ground_truth", {.depth = 1024, .doc = "poses"});
    spec.Param("file", &file_, {.doc = "TUM file name in the run folder"});
    spec.Param("min_interval_s", &min_interval_s_,
               {.doc = "keep at most one pose per interval", .unit = "s", .min = 0});
  }
  Status Process(Context&) override {
    for (const auto& m : truth_.TakeAll()) {
      if (!poses_.empty() && m->time_s - poses_.back().time_s < min_interval_s_) continue;
      poses_.push_back({m->time_s, m->position_m[0], m->position_m[1], m->yaw_rad});
    }
    return Status::Ok();
  }
  Status Stop(Context& ctx) override {
    if (ctx.output_dir().empty()) return Status::Ok();
    try {
      eval::WriteTum((std::filesystem::path(ctx.output_dir()) / file_).string(), poses_);
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    return Status::Ok();
  }

 private:
  std::string file_ = "ground_truth.tum";
  double min_interval_s_ = 0.0;
  eval::Trajectory poses_;
  graph::In<msgs::GroundTruthPose> truth_;
};
DRACO_REGISTER_COMPONENT(TrajectoryRecorder, "eval.TrajectoryRecorder")

}  // namespace
}  // namespace draco::slam
