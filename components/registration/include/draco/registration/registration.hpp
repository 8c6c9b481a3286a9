// Inter-robot scan exchange and registration (DRACo-SLAM2 section III-C).
//
// 1. Scan requests: after object-graph matching gave T_own_teammate and matched object
//    pairs, the teammate keyframes that observed matched objects are requested (at most
//    max_requests per exchange, none with fewer than min_points points). For each, the own
//    keyframes near the teammate keyframe placed by the transform are the candidates.
// 2. Sliding-window registration: the target is own keyframes k-w .. k+w in keyframe k's
//    frame (own optimised poses); the source is one teammate scan pre-placed by the
//    graph-matching transform; ICP, then the overlap ratio decides.
//
// Frames: "map" is a robot's local SLAM frame; T_a_b maps frame b to frame a. No runtime
// dependency.
#pragma once

#include <cstdint>
#include <numbers>
#include <vector>

#include "draco/icp/icp.hpp"
#include "draco/msgs/loops.hpp"
#include "draco/msgs/objects.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::registration {

using msgs::Point2;
using msgs::Pose2;

// Planar rigid transforms (p_a = T_a_b * p_b).
Pose2 Compose(const Pose2& T_a_b, const Pose2& T_b_c);
Pose2 Inverse(const Pose2& T_a_b);
Pose2 Between(const Pose2& T_w_a, const Pose2& T_w_b);  // T_a_b = inv(T_w_a) T_w_b
Point2 Apply(const Pose2& T_a_b, const Point2& p_b);
double WrapAngle(double angle_rad);  // to (-pi, pi]

// A keyframe as registration sees it: its optimised pose in the robot's map frame and its
// points in the keyframe (body) frame.
struct KeyframeScan {
  int index = 0;
  double time_s = 0.0;
  Pose2 T_map_kf;
  std::vector<Point2> points_kf;
};

// Only what selection needs from a keyframe (no points).
struct KeyframeInfo {
  int index = 0;
  Pose2 T_map_kf;
  int num_points = 0;
};

// ---------------------------------------------------------------------------------------
// Scan-request selection

struct SelectionOptions {
  int max_requests = 20;  // teammate scans per exchange
  int min_points = 30;    // a teammate scan with fewer points is never requested
  // Own candidate keyframes: within this distance and heading difference of the teammate
  // keyframe placed by the graph-matching transform (reference: 40 m / 180 deg; airplane
  // 20 m / 90 deg: AirplaneSelectionOptions).
  double candidate_radius_m = 40.0;
  double candidate_max_yaw_rad = std::numbers::pi;
  // Nearest candidates kept per request (0: all within the radius, as the reference).
  // Measured (docs/front-end.md): all candidates give 10x the true positives of the nearest
  // 1 or 3 at the same precision (window 3, overlap 0.85).
  int max_candidates_per_request = 0;
};

inline SelectionOptions AirplaneSelectionOptions() {
  SelectionOptions o;
  o.candidate_radius_m = 20.0;
  o.candidate_max_yaw_rad = std::numbers::pi / 2.0;
  return o;
}

struct ScanRequest {
  int teammate_keyframe = 0;
  int matched_objects = 0;          // matched objects this keyframe observed
  Pose2 T_own_teammatekf;           // the teammate keyframe placed in the own map frame
  std::vector<int> candidates;      // own keyframe indices, nearest first
  std::vector<double> distances_m;  // of the candidates to the placed teammate keyframe
};

// Teammate keyframes observing matched objects (pairs' id_b in `teammate`), ordered by the
// number of matched objects observed (most first), then by index (newest first); keyframes
// in `exclude` (already requested) and those under min_points are skipped; at most
// max_requests. A match whose status is not kMatched gives no requests. `own` is not needed
// for the decision beyond the match; it is taken for symmetry with the reference's
// interface and ignored. Requests without candidates are dropped.
std::vector<ScanRequest> SelectScanRequests(const msgs::ObjectMap& own,
                                            const msgs::ObjectMap& teammate,
                                            const msgs::ObjectMatch& match,
                                            const std::vector<KeyframeInfo>& own_keyframes,
                                            const std::vector<KeyframeInfo>& teammate_keyframes,
                                            const SelectionOptions& options = {},
                                            const std::vector<int>& exclude = {});

// ---------------------------------------------------------------------------------------
// Sliding-window registration

enum class CovarianceModel {
  kIcpFloored,         // the ICP's own covariance, sigmas floored (default)
  kReferenceResidual,  // the reference's 20 * mean squared residual * I
};

struct RegistrationOptions {
  int window = 3;  // target = own keyframes k-w .. k+w (clipped to the trajectory)
  // The reference's window: k-w .. k+w-1 plus keyframe k a second time (off by one).
  bool reference_window = false;
  icp::IcpOptions icp;        // point-to-point by default
  double min_overlap = 0.85;  // the reference code's 0.85 (the paper: 0.9)
  int min_source_points = 30;
  CovarianceModel covariance = CovarianceModel::kIcpFloored;
  double min_sigma_xy_m = 0.1;  // floors on the ICP covariance (the reference's ICP sigmas)
  double min_sigma_yaw_rad = 0.01;
  double residual_scale = 20.0;  // kReferenceResidual: this * mean squared residual
  // Reject when ICP moved the seed by more than this (0: no gate; the reference has none).
  double max_correction_m = 0.0;
  // Ambiguity (a row or grid of identical piles, a wall seen along its length): an accepted
  // registration is aligned again by ICP from its answer moved by each of ambiguity_offsets_m
  // in ambiguity_directions directions (in the own keyframe frame); when one of these lands
  // more than ambiguity_distinct_m (or ambiguity_distinct_rad) away from the answer with an
  // overlap of at least ambiguity_ratio x the answer's, the scan fits two places and the
  // registration is kAmbiguous. A loop from it would be as likely one period off as right, and
  // the wrong ones agree with each other (the same offset repeats along the row). Both lists
  // empty: off.
  std::vector<double> ambiguity_offsets_m{2.5, 5.0};
  int ambiguity_directions = 8;
  // ... and from the answer turned by each of these about the scan's centroid (a square grid
  // of piles matches itself turned by 90 deg, any grid by 180 deg).
  std::vector<double> ambiguity_turns_deg{90.0, 180.0, 270.0};
  double ambiguity_ratio = 0.9;
  // Overlaps compared by the test are counted within this distance. At 1 m (robots that see a
  // pile row from opposite sides image opposite faces, a pile diameter apart) the test also
  // rejects true registrations in clutter: on tuning seeds 1-20 plus the default missions
  // 0.5 m places more pairs right (19 vs 17; airplane 5 vs 3) with fewer placed 40 m or more
  // off (3 vs 5) (docs/safe-merges.md).
  double ambiguity_overlap_distance_m = 0.5;
  double ambiguity_distinct_m = 1.0;
  double ambiguity_distinct_rad = 0.0873;  // 5 deg
};

enum class RegistrationStatus : std::uint8_t {
  kAccepted = 0,
  kTooFewSourcePoints,
  kEmptyTarget,
  kIcpFailed,  // too few correspondences
  kLowOverlap,
  kLargeCorrection,
  kAmbiguous,  // another pose, distinct from the answer, fits about as well
  // Set by the caller (team.ScanExchange): the map-to-map rotation the answer implies is
  // further from the maps' absolute headings' difference than allowed.
  kHeadingMismatch,
};
const char* RegistrationStatusName(RegistrationStatus status);

struct RegistrationResult {
  RegistrationStatus status = RegistrationStatus::kEmptyTarget;
  bool accepted() const { return status == RegistrationStatus::kAccepted; }
  // Filled whenever ICP ran (also when rejected): pose, covariance, overlap.
  msgs::InterRobotLoop loop;
  icp::IcpResult icp;
  int target_points = 0;
  int target_keyframes = 0;
  // Ambiguity test (accepted ICP answers only): the best overlap (at
  // ambiguity_overlap_distance_m) among the re-alignments that
  // ended distinct from the answer (0: none), and where it ended.
  double runner_up_overlap = 0.0;
  Pose2 runner_up_T;
};

// Indices (positions in own_keyframes, which must be sorted by index without gaps beyond
// what clipping handles) of the window around position k.
std::vector<int> WindowPositions(int num_keyframes, int k, int window, bool reference_window);

// Target cloud: the window's points in keyframe k's frame (own optimised poses). `k` is a
// position in own_keyframes.
icp::Cloud2 BuildWindowTarget(const std::vector<KeyframeScan>& own_keyframes, int k, int window,
                              bool reference_window, int* num_keyframes = nullptr);

// Registers one teammate scan (points in its keyframe frame) against the window around own
// keyframe position k, seeded by T_ownkf_teammatekf_seed (the graph-matching placement
// expressed in own keyframe k's frame). The loop's robots and keyframe indices are filled
// from the arguments; id and flags are left 0.
RegistrationResult RegisterScan(const std::vector<KeyframeScan>& own_keyframes, int k,
                                const std::vector<Point2>& teammate_points_kf,
                                const Pose2& T_ownkf_teammatekf_seed,
                                const RegistrationOptions& options = {}, int own_robot = 0,
                                int teammate_robot = 0, int teammate_keyframe = 0);

// The same with a prepared target (for many sources against one window).
RegistrationResult RegisterScan(icp::IcpTarget& target,
                                const std::vector<Point2>& teammate_points_kf,
                                const Pose2& T_ownkf_teammatekf_seed,
                                const RegistrationOptions& options);

// Seed of a registration: the teammate keyframe placed by T_own_teammate, in own keyframe
// k's frame: inv(T_own_kf) * T_own_teammate * T_teammate_kf.
Pose2 SeedPose(const Pose2& T_ownmap_ownkf, const Pose2& T_own_teammate,
               const Pose2& T_teammatemap_teammatekf);

// Loop covariance (additive x, y, yaw) from an ICP result, as the options say.
msgs::Covariance3 LoopCovariance(const icp::IcpResult& icp, const RegistrationOptions& options);

}  // namespace draco::registration
