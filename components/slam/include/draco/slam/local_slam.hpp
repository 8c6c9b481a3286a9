// Local SLAM back end of one robot (Bruce-SLAM's scheme, DRACo-SLAM2 section III-A):
// keyframes and sequential scan-matching factors go into a Ceres SE(2) pose graph; intra-robot
// loop closures are proposed from the current estimate, registered by ICP against a submap,
// checked for pairwise consistency (PCM over the odometry chain) and added with a robust loss.
// Compact isolated clusters of keyframe points (boulders, debris) become point landmarks in
// the graph (docs/local-slam.md, "Sparse point landmarks").
// No runtime dependency.
#pragma once

#include <cstdint>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::slam {

struct LocalSlamOptions {
  // Gauge prior on the first keyframe (sigmas as the reference's prior).
  double prior_sigma_xy_m = 0.1;
  double prior_sigma_yaw_rad = 0.01;
  // Floors on factor sigmas (the reference's ICP sigmas): ICP covariances from hundreds of
  // points are overconfident. Measured on the marina mission (docs/local-slam.md).
  double min_factor_sigma_xy_m = 0.1;
  double min_factor_sigma_yaw_rad = 0.01;
  // Floors on the dead-reckoning factor kept beside a scan match (negative: the floors above).
  double min_dr_sigma_xy_m = -1.0;
  double min_dr_sigma_yaw_rad = -1.0;
  // Floor on the translation sigma of a scan-matching factor in the graph (negative: as
  // min_factor_sigma_xy_m). The keyframe chain that PCM tests loops against keeps the floor
  // above, so this changes how the graph weighs sequential ICP against dead reckoning only.
  double min_scan_match_sigma_xy_m = -1.0;
  // Keep the dead-reckoning increment as a factor beside each scan-matching factor, and put
  // a Cauchy loss (scale in sigmas; 0: none) on scan-matching factors.
  bool keep_dead_reckoning_factor = true;
  // Yaw-only prior from the dead-reckoning heading (AHRS: absolute, bounded error) on every
  // keyframe; 0 disables.
  double heading_prior_sigma_rad = 0.0;
  // Cauchy loss on the heading prior, in sigmas (0: none): local heading anomalies near steel
  // objects (several sigmas) are down-weighted instead of bending the graph.
  double heading_prior_cauchy_scale = 0.0;
  // AHRS heading as a measurement with a time-correlated error state (off when sigma is 0):
  // per keyframe a bias node b_k (yaw only used), the factor yaw_k + beta_k = DR yaw_k
  // (sigma heading_meas_sigma_rad), a zero prior on beta_k (sigma heading_bias_sigma_rad:
  // the AHRS Gauss-Markov drift and the steel anomaly, relative to keyframe 0) and a random
  // walk beta_k - beta_k-1 (sigma heading_bias_sigma_rad * sqrt(2 dt / tau)).
  double heading_bias_sigma_rad = 0.0;
  double heading_bias_tau_s = 120.0;
  double heading_meas_sigma_rad = 0.01;
  // Exact Gauss-Markov model of the bias instead (needs heading_bias_sigma_rad > 0): with
  // m the free mean node and s = heading_bias_sigma_rad, beta_0 - m ~ N(0, s^2) and for k > 0
  // (beta_k - m) - phi (beta_k-1 - m) ~ N(0, s^2 (1 - phi^2)), phi = exp(-dt / tau): the
  // stationary process, with no per-keyframe prior (which over-counts the information of a
  // process correlated over many keyframes).
  bool heading_bias_gauss_markov = false;
  // Cauchy loss on the heading measurement yaw_k + beta_k = DR yaw_k, in sigmas (0: none): the
  // steel anomaly (local, a few degrees) is down-weighted instead of followed by the bias.
  double heading_meas_cauchy_scale = 0.0;
  double scan_match_cauchy_scale = 1.0;

  // Ceres' projected line search after every trust-region step (the landmark radius states
  // have bounds, which makes each solve a bounded problem; Ceres' own comment calls it "not
  // terribly effective"). false (default): the step is only projected onto the bounds, and a
  // step that does not lower the cost is rejected as always. Off, the marina's local SLAM
  // solves take about half the time (docs/local-slam.md, "Limits").
  bool bounds_line_search = false;

  bool loop_closure = true;
  int loop_min_index_gap = 8;  // keyframes at least this far apart
  // Candidates within 20 m at any heading, keyframes of at least 20 points (docs/local-slam.md,
  // "Loop candidates": 10 m, 60 deg, 50 points lost the loops across the lobes).
  double loop_max_distance_m = 20.0;
  double loop_max_yaw_rad = std::numbers::pi;  // any heading difference
  int loop_min_points = 20;
  int loop_submap_half_width = 2;  // target: the candidate keyframe and this many each side
  int loop_max_candidates = 3;     // nearest candidates registered per keyframe
  double loop_min_overlap = 0.5;
  // Correlative search around the estimate seeds loop-closure ICP (0 m: ICP from the estimate).
  double seed_search_m = 2.5;
  double seed_search_rad = 15.0 * std::numbers::pi / 180.0;
  double seed_resolution_m = 0.5;
  double seed_angle_step_rad = 2.0 * std::numbers::pi / 180.0;
  double loop_max_correction_m = 3.0;  // seed + ICP may move the estimate by at most this
  double loop_max_correction_rad = 30.0 * std::numbers::pi / 180.0;
  // A loop's correction of the estimate (seed + ICP result against the estimate's relative
  // pose) must be explained by the drift the keyframe chain between its ends allows: its
  // squared Mahalanobis distance under the chain's relative covariance plus the loop's own
  // must stay below this (3 dof; 0: off). A row of piles aliases by one spacing whatever the
  // gap; the chain's covariance tells a 2 m slip over 8 keyframes from 2 m of drift over 80.
  double loop_chain_chi2 = 0.0;
  // Loop covariance floor (the reference's ICP sigmas 0.1 m, 0.01 rad) and the PCM test.
  double loop_min_sigma_xy_m = 0.1;
  double loop_min_sigma_yaw_rad = 0.01;
  double pcm_chi2_threshold = 11.34;
  int pcm_min_clique_size = 2;
  // Branch-and-bound nodes the PCM clique search may take per keyframe (deterministic). A
  // robot that repeats one pattern makes a dense consistency graph (hundreds of loops, each
  // consistent with most others) where proving that no larger clique holds a new loop takes
  // millions of nodes (docs/local-slam.md, step 4). At the budget the greedy clique answers:
  // a larger clique than the current one replaces it, and a loop left out stays a candidate.
  int pcm_max_clique_nodes = 10'000;
  double loop_cauchy_scale = 1.0;  // robust loss on loop factors, in sigmas
  // Loop covariance from the registration residual (the reference: 20 * mean squared residual
  // * I): the floored covariance is scaled up so that its xy variance is at least
  // loop_rmse_cov_scale * rmse^2 (0: off).
  double loop_rmse_cov_scale = 0.0;
  // Loop covariance scaled by (1 / overlap)^loop_overlap_cov_power (0: off).
  double loop_overlap_cov_power = 0.0;
  double loop_max_rmse_m = 0.0;  // reject loops whose ICP rmse exceeds this (0: no gate)
  // Source: keyframe k and this many keyframes before it, in k's frame (0: keyframe k only).
  int loop_source_half_width = 0;
  // Loop ambiguity (0: off). The correlative seed search scores every lattice pose; the
  // runner-up is the best score of a pose at least loop_ambiguity_offset_m from the best ones
  // (any rotation; CorrelativeSeedSearch). A loop whose runner-up reaches loop_ambiguity_ratio of
  // the best score is dropped: along one straight wall the scan slides, and a row of piles matches
  // itself shifted by its spacing, so ICP converges to wherever the seed lands and the floored loop
  // covariance (0.1 m) pins the map there.
  double loop_ambiguity_ratio = 0.0;
  double loop_ambiguity_offset_m = 2.0;
  // Instead of dropping an ambiguous loop, keep it and add the elongation of the search's
  // near-best plateau (translations scoring >= loop_ambiguity_ratio of the best: their spread
  // minus its isotropic part) to the loop's translation covariance.
  bool loop_ambiguity_inflate = false;
  // ICP ambiguity (0: off), the inter-robot registration's test (registration::
  // RegistrationOptions::ambiguity_*) on intra-robot loops: a loop that passed the gates is
  // aligned again by ICP from its answer moved by each of loop_icp_ambiguity_offsets_m in 8
  // directions (in the target keyframe's frame); when one lands more than 1 m or 5 deg from the
  // answer with at least loop_icp_ambiguity_ratio of its overlap, the scan fits two places and
  // the loop is dropped.
  double loop_icp_ambiguity_ratio = 0.0;
  std::vector<double> loop_icp_ambiguity_offsets_m{2.5, 5.0};
  // Instead of dropping the loop, keep it with each other place's shift (in the source
  // keyframe's frame) added to its translation covariance as its outer product.
  bool loop_icp_ambiguity_inflate = false;

  // Sparse point landmarks (on by default since docs/local-slam.md "Sparse point landmarks":
  // every robot of both default missions better): small isolated objects (boulders, debris) give a
  // few CFAR points per keyframe, too few for ICP, but their centroid is a point landmark
  // seen from many keyframes and from opposite lanes. Per keyframe, points are clustered by
  // single linkage (landmark_cluster_radius_m); a cluster with at least landmark_min_points
  // points, extent (largest distance between two of its points) at most
  // landmark_max_extent_m and no point of another cluster within landmark_isolation_m of its
  // centroid is an observation: centroid in the keyframe frame, covariance = point spread +
  // landmark_min_sigma_m^2 I (a compact object is seen from one side: its centroid moves
  // with the view point). Association by the current estimate: the one landmark within
  // landmark_gate_m; none within landmark_new_min_distance_m: a new landmark; otherwise (two
  // within the gate, or one between the gate and the new-landmark distance, or two clusters
  // onto one landmark) the cluster is dropped. A landmark enters the graph (point node,
  // observations with a Cauchy loss) once its observations span landmark_min_index_gap
  // keyframes and number landmark_min_observations.
  bool landmarks = true;
  double landmark_cluster_radius_m = 1.0;
  int landmark_min_points = 3;
  double landmark_max_extent_m = 2.5;
  double landmark_isolation_m = 3.0;  // 2 m lets the airplane's debris field alias
  double landmark_min_sigma_m = 0.5;
  double landmark_max_range_m = 0.0;  // ignore clusters farther from the sonar (0: no limit)
  double landmark_gate_m = 3.0;
  double landmark_new_min_distance_m = 6.0;
  int landmark_min_index_gap = 8;
  int landmark_min_observations = 3;
  double landmark_cauchy_scale = 2.0;  // in sigmas; 0: no robust loss
  // The sonar sees the near face of an object, so a cluster's centroid lies in front of the
  // object's centre by up to its radius (about extent / 2), towards the sonar: from opposite
  // lanes the two centroids differ by up to the diameter. The centroid is moved along the
  // ray away from the sonar by landmark_center_offset_ratio * extent / 2 (the centroid of a
  // lit half circle is 2/pi = 0.64 radii in front of the centre), and
  // (landmark_range_sigma_ratio * extent / 2)^2 is added to the variance along the ray
  // (0: off, both).
  double landmark_center_offset_ratio = 0.0;
  double landmark_range_sigma_ratio = 0.0;
  // Viewpoint stability: within one pass (sightings at most landmark_pass_gap keyframes
  // apart) the relative poses are good, so the sightings of a point-like object agree; a
  // sighting farther than landmark_max_pass_spread_m from the mean of the earlier sightings of
  // its pass (map frame, current estimates) marks the landmark unstable (an extended or
  // partly seen object, or two objects): it takes no further part (0: no test).
  // Radius state (pose_graph::PointRadiusPrior): a landmark's graph point is the object's
  // centre and each sighting predicts the centroid of its near face, moved toward the sonar by
  // rho; rho's prior is landmark_radius_prior_ratio * (mean extent of the sightings) / 2 with
  // sigma landmark_radius_sigma_m (0: no radius state), at most landmark_radius_max_m.
  double landmark_radius_sigma_m = 0.3;
  double landmark_radius_prior_ratio = 0.64;
  double landmark_radius_max_m = 2.0;
  double landmark_max_pass_spread_m = 0.0;
  int landmark_pass_gap = 3;

  int window_size = 20;  // incremental solve window (newest keyframes)
  // A full solve (a loop closed, an old landmark seen again) waits until this many keyframes
  // were added since the last one; window solves meanwhile (pose_graph::IncrementalOptions::
  // full_solve_min_poses; 0: at once).
  int full_solve_min_keyframes = 0;
  // A triggered full solve is tried as a window solve first, and the window's answer stands
  // when every factor and landmark sighting tying the window to older keyframes then has chi2
  // at most this (pose_graph::IncrementalOptions::full_solve_max_boundary_chi2; 0: off).
  double full_solve_max_boundary_chi2 = 0.0;
};

// One point landmark candidate of a keyframe: a compact isolated cluster of its points.
struct LandmarkObservation {
  msgs::Point2 p_kf;                                // centroid, keyframe frame
  double cov_xx = 0.0, cov_xy = 0.0, cov_yy = 0.0;  // m^2, floor included
  int num_points = 0;
  double extent_m = 0.0;
};

// Clusters a keyframe's points (body frame) into landmark observations (see the options).
std::vector<LandmarkObservation> ExtractLandmarkObservations(
    const std::vector<msgs::Point2>& points_kf, const LocalSlamOptions& options);

struct LandmarkRecord {
  int id = 0;
  msgs::Point2 p_map;  // graph estimate, or the mean of the observations at the current poses
  int num_observations = 0;
  int first_keyframe = 0;
  int last_keyframe = 0;
  bool in_graph = false;
  bool unstable = false;       // failed the viewpoint-stability test
  double radius_m = 0.0;       // radius state (0 without one)
  std::vector<int> keyframes;  // the keyframes that saw it, ascending
};

struct KeyframeEstimate {
  int index = 0;
  double time_s = 0.0;
  msgs::Pose2 T_map_kf;   // optimised
  msgs::Pose2 T_odom_kf;  // dead reckoning at the keyframe time
  int num_points = 0;
};

struct LoopRecord {
  int from_index = 0;  // older keyframe (target)
  int to_index = 0;    // newer keyframe (source)
  msgs::Pose2 T_from_to;
  double overlap_ratio = 0.0;
  double rmse_m = 0.0;
  bool accepted = false;
};

struct StepResult {
  int loops_registered = 0;  // candidates that passed ICP and the gates
  int loops_accepted = 0;    // newly accepted by PCM and added to the graph
  // Candidates the ambiguity test dropped, or (loop_ambiguity_inflate) kept with more than
  // 0.5 m of slide added to their covariance.
  int loops_ambiguous = 0;
  int loops_chain_rejected = 0;  // candidates whose correction the chain test refused
  // Candidates the ICP ambiguity test found (dropped, or kept with a wider factor covariance).
  int loops_icp_ambiguous = 0;
  // The PCM clique search ran out of pcm_max_clique_nodes and a greedy clique answered.
  bool pcm_search_capped = false;
  bool full_solve = false;
  bool full_solve_avoided = false;  // triggered, but the window's answer agreed (see options)
  double solve_time_s = 0.0;
  int solve_iterations = 0;  // the solver's iterations in this step's solve
};

// Covariance given to a registered loop: the ICP covariance floored at the loop sigmas, then
// inflated by the residual (rmse) and overlap terms of the options.
msgs::Covariance3 LoopCovariance(const msgs::Covariance3& icp_covariance, double rmse_m,
                                 double overlap_ratio, const LocalSlamOptions& options);

// Squared Mahalanobis distance between a loop's registration T_j_k_loop (keyframe k in the
// older keyframe j's frame) and the estimate's T_j_k_estimate, under the keyframe chain's
// covariance of T_j_k plus the loop's own: the drift the chain allows between j and k.
// Infinity when the summed covariance is not positive definite.
double LoopChainChi2(const msgs::Pose2& T_j_k_estimate, const msgs::Pose2& T_j_k_loop,
                     const msgs::Covariance3& chain_covariance,
                     const msgs::Covariance3& loop_covariance);

// Correlative search for a loop's ICP seed: the target rasterised at seed_resolution_m
// (occupied cells dilated by one), every pose of the lattice around `guess` (translations
// within seed_search_m, rotations within seed_search_rad) scored by the source points that land
// on occupied cells. `best` is the top pose (ties: the one nearest the guess); runner_up_score
// the top score of a pose at least loop_ambiguity_offset_m from the centre of the top-scoring
// translations (a right match scores its best on a plateau 3-4 cells wide: the dilation).
struct SeedSearch {
  msgs::Pose2 best;
  int best_score = 0;
  int runner_up_score = 0;
  // Spread of the translations scoring at least loop_ambiguity_ratio of the best (m^2, lattice
  // frame = the target's; 0 when the ratio is 0).
  double spread_xx_m2 = 0.0, spread_xy_m2 = 0.0, spread_yy_m2 = 0.0;
  // runner_up_score / best_score (0 when nothing scored).
  double AmbiguityRatio() const {
    return best_score > 0 ? static_cast<double>(runner_up_score) / best_score : 0.0;
  }
};
SeedSearch CorrelativeSeedSearch(const std::vector<msgs::Point2>& source_kf,
                                 const std::vector<msgs::Point2>& target_kf,
                                 const msgs::Pose2& guess, const LocalSlamOptions& options);

class LocalSlam {
 public:
  explicit LocalSlam(const LocalSlamOptions& options = {});
  ~LocalSlam();
  LocalSlam(LocalSlam&&) noexcept;
  LocalSlam& operator=(LocalSlam&&) noexcept;

  // Adds keyframe k with the factor from k-1 (nullptr for the first keyframe, or to use the
  // dead-reckoning increment carried by the keyframe). Keyframes must arrive in index order.
  StepResult AddKeyframe(const msgs::Keyframe& keyframe, const msgs::SequentialFactor* factor);
  // Runs the full solve still waiting (full_solve_min_keyframes), if any: at the end of a
  // mission. Returns whether one ran.
  bool Flush();

  std::vector<KeyframeEstimate> Trajectory() const;
  const std::vector<LoopRecord>& Loops() const;
  std::vector<LandmarkRecord> Landmarks() const;
  // Every keyframe's points in the map frame.
  std::vector<msgs::Point2> MapPoints() const;
  // The pose graph as g2o text (VERTEX_SE2 / EDGE_SE2).
  std::string ToG2oText() const;
  int NumKeyframes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace draco::slam
