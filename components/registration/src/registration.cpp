#include "draco/registration/registration.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <unordered_set>

namespace draco::registration {

double WrapAngle(double a) {
  a = std::remainder(a, 2.0 * std::numbers::pi);
  if (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

Pose2 Compose(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
  return {a.x_m + c * b.x_m - s * b.y_m, a.y_m + s * b.x_m + c * b.y_m,
          WrapAngle(a.yaw_rad + b.yaw_rad)};
}

Pose2 Inverse(const Pose2& a) {
  const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
  return {-(c * a.x_m + s * a.y_m), -(-s * a.x_m + c * a.y_m), WrapAngle(-a.yaw_rad)};
}

Pose2 Between(const Pose2& T_w_a, const Pose2& T_w_b) { return Compose(Inverse(T_w_a), T_w_b); }

Point2 Apply(const Pose2& T, const Point2& p) {
  const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
  return {T.x_m + c * p.x_m - s * p.y_m, T.y_m + s * p.x_m + c * p.y_m};
}

std::vector<ScanRequest> SelectScanRequests(const msgs::ObjectMap& /*own*/,
                                            const msgs::ObjectMap& teammate,
                                            const msgs::ObjectMatch& match,
                                            const std::vector<KeyframeInfo>& own_keyframes,
                                            const std::vector<KeyframeInfo>& teammate_keyframes,
                                            const SelectionOptions& options,
                                            const std::vector<int>& exclude) {
  std::vector<ScanRequest> out;
  if (match.status != msgs::MatchStatus::kMatched) return out;
  std::unordered_map<std::uint32_t, const msgs::Object*> by_id;
  for (const auto& o : teammate.objects) by_id[o.id] = &o;
  // Matched objects observed per teammate keyframe (each object counted once per keyframe).
  std::unordered_map<int, int> count;
  for (const auto& pair : match.pairs) {
    const auto it = by_id.find(pair.id_b);
    if (it == by_id.end()) continue;
    std::vector<int> kfs = it->second->keyframes;
    std::sort(kfs.begin(), kfs.end());
    kfs.erase(std::unique(kfs.begin(), kfs.end()), kfs.end());
    for (const int k : kfs) ++count[k];
  }
  const std::unordered_set<int> excluded(exclude.begin(), exclude.end());
  std::vector<const KeyframeInfo*> chosen;
  std::unordered_map<int, int> matched_of;
  for (const auto& kf : teammate_keyframes) {
    const auto it = count.find(kf.index);
    if (it == count.end() || excluded.count(kf.index) || kf.num_points < options.min_points) {
      continue;
    }
    chosen.push_back(&kf);
    matched_of[kf.index] = it->second;
  }
  std::sort(chosen.begin(), chosen.end(), [&](const KeyframeInfo* x, const KeyframeInfo* y) {
    const int cx = matched_of[x->index], cy = matched_of[y->index];
    if (cx != cy) return cx > cy;
    return x->index > y->index;
  });
  const double r2 = options.candidate_radius_m * options.candidate_radius_m;
  for (const KeyframeInfo* kf : chosen) {
    if (static_cast<int>(out.size()) >= options.max_requests) break;
    ScanRequest req;
    req.teammate_keyframe = kf->index;
    req.matched_objects = matched_of[kf->index];
    req.T_own_teammatekf = Compose(match.T_a_b, kf->T_map_kf);
    std::vector<std::pair<double, int>> near;
    for (const auto& own : own_keyframes) {
      const double dx = own.T_map_kf.x_m - req.T_own_teammatekf.x_m;
      const double dy = own.T_map_kf.y_m - req.T_own_teammatekf.y_m;
      const double d2 = dx * dx + dy * dy;
      if (d2 > r2) continue;
      if (std::abs(WrapAngle(own.T_map_kf.yaw_rad - req.T_own_teammatekf.yaw_rad)) >
          options.candidate_max_yaw_rad) {
        continue;
      }
      near.emplace_back(d2, own.index);
    }
    if (near.empty()) continue;
    std::sort(near.begin(), near.end());
    if (options.max_candidates_per_request > 0 &&
        static_cast<int>(near.size()) > options.max_candidates_per_request) {
      near.resize(options.max_candidates_per_request);
    }
    for (const auto& [d2, index] : near) {
      req.candidates.push_back(index);
      req.distances_m.push_back(std::sqrt(d2));
    }
    out.push_back(std::move(req));
  }
  return out;
}

const char* RegistrationStatusName(RegistrationStatus status) {
  switch (status) {
    case RegistrationStatus::kAccepted:
      return "accepted";
    case RegistrationStatus::kTooFewSourcePoints:
      return "too few source points";
    case RegistrationStatus::kEmptyTarget:
      return "empty target";
    case RegistrationStatus::kIcpFailed:
      return "ICP failed";
    case RegistrationStatus::kLowOverlap:
      return "low overlap";
    case RegistrationStatus::kLargeCorrection:
      return "large correction";
    case RegistrationStatus::kAmbiguous:
      return "ambiguous";
    case RegistrationStatus::kHeadingMismatch:
      return "heading mismatch";
  }
  return "unknown";
}

std::vector<int> WindowPositions(int n, int k, int window, bool reference_window) {
  std::vector<int> out;
  if (k < 0 || k >= n) return out;
  const int hi = reference_window && window > 0 ? k + window - 1 : k + window;
  for (int j = k - window; j <= hi; ++j) {
    if (j >= 0 && j < n) out.push_back(j);
  }
  if (reference_window && window > 0) out.push_back(k);  // keyframe k a second time
  return out;
}

icp::Cloud2 BuildWindowTarget(const std::vector<KeyframeScan>& own, int k, int window,
                              bool reference_window, int* num_keyframes) {
  icp::Cloud2 cloud;
  const auto positions = WindowPositions(static_cast<int>(own.size()), k, window, reference_window);
  if (num_keyframes) *num_keyframes = static_cast<int>(positions.size());
  if (positions.empty()) return cloud;
  std::size_t total = 0;
  for (const int j : positions) total += own[j].points_kf.size();
  cloud.reserve(total);
  const Pose2 T_kf_map = Inverse(own[k].T_map_kf);
  for (const int j : positions) {
    const Pose2 T_k_j = Compose(T_kf_map, own[j].T_map_kf);
    const double c = std::cos(T_k_j.yaw_rad), s = std::sin(T_k_j.yaw_rad);
    for (const auto& p : own[j].points_kf) {
      cloud.emplace_back(T_k_j.x_m + c * p.x_m - s * p.y_m, T_k_j.y_m + s * p.x_m + c * p.y_m);
    }
  }
  return cloud;
}

Pose2 SeedPose(const Pose2& T_ownmap_ownkf, const Pose2& T_own_teammate,
               const Pose2& T_teammatemap_teammatekf) {
  return Compose(Inverse(T_ownmap_ownkf), Compose(T_own_teammate, T_teammatemap_teammatekf));
}

msgs::Covariance3 LoopCovariance(const icp::IcpResult& r, const RegistrationOptions& o) {
  msgs::Covariance3 out{};
  if (o.covariance == CovarianceModel::kReferenceResidual) {
    const double v = o.residual_scale * r.rmse_m * r.rmse_m;
    out[0] = out[4] = out[8] = v;
    return out;
  }
  // ICP covariance: right perturbation (source frame); additive x, y rotate by R(yaw).
  Eigen::Matrix3d C;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) C(i, j) = r.covariance[3 * i + j];
  }
  Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
  const double c = std::cos(r.T_target_source.yaw_rad), s = std::sin(r.T_target_source.yaw_rad);
  J(0, 0) = c;
  J(0, 1) = -s;
  J(1, 0) = s;
  J(1, 1) = c;
  Eigen::Matrix3d A = J * C * J.transpose();
  A = 0.5 * (A + A.transpose());
  // Floor: add to each diagonal what it lacks of the floor (keeps it positive definite).
  const double fxy = o.min_sigma_xy_m * o.min_sigma_xy_m;
  const double fyaw = o.min_sigma_yaw_rad * o.min_sigma_yaw_rad;
  A(0, 0) = std::max(A(0, 0), fxy);
  A(1, 1) = std::max(A(1, 1), fxy);
  A(2, 2) = std::max(A(2, 2), fyaw);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out[3 * i + j] = A(i, j);
  }
  return out;
}

namespace {

// The ambiguity test of RegistrationOptions: true when a re-alignment from a displaced seed
// ends distinct from the answer with nearly its overlap. Fills the runner-up fields.
bool Ambiguous(const icp::Cloud2& source, icp::IcpTarget& target, const RegistrationOptions& o,
               RegistrationResult* result) {
  const Pose2 best = result->icp.T_target_source;
  std::vector<Pose2> seeds;
  for (const double offset_m : o.ambiguity_offsets_m) {
    for (int d = 0; d < o.ambiguity_directions; ++d) {
      const double a = 2.0 * std::numbers::pi * d / o.ambiguity_directions;
      seeds.push_back(
          {best.x_m + offset_m * std::cos(a), best.y_m + offset_m * std::sin(a), best.yaw_rad});
    }
  }
  if (!o.ambiguity_turns_deg.empty() && !source.empty()) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& p : source) c += p;
    c /= static_cast<double>(source.size());
    for (const double turn_deg : o.ambiguity_turns_deg) {
      // The source turned about its own centroid c: T * Trans(c) * Rot(turn) * Trans(-c).
      const Pose2 about = Compose(Pose2{c.x(), c.y(), turn_deg * std::numbers::pi / 180.0},
                                  Pose2{-c.x(), -c.y(), 0.0});
      seeds.push_back(Compose(best, about));
    }
  }
  const double d = o.ambiguity_overlap_distance_m;
  // The re-runs need the pose, validity and overlap only; at the ICP's own overlap distance
  // (the default) its overlap is the one asked for.
  icp::IcpOptions again = o.icp;
  again.covariance = false;
  const bool same_distance = d == o.icp.overlap_distance_m;
  const double needed =
      o.ambiguity_ratio * (same_distance ? result->icp.overlap_ratio
                                         : icp::OverlapRatio(source, target.tree(), best, d));
  for (const Pose2& seed : seeds) {
    icp::IcpResult r = icp::AlignIcp(source, target, seed, again);
    if (!r.valid) continue;
    if (!same_distance) {
      r.overlap_ratio = icp::OverlapRatio(source, target.tree(), r.T_target_source, d);
    }
    const bool distinct =
        std::hypot(r.T_target_source.x_m - best.x_m, r.T_target_source.y_m - best.y_m) >
            o.ambiguity_distinct_m ||
        std::abs(WrapAngle(r.T_target_source.yaw_rad - best.yaw_rad)) > o.ambiguity_distinct_rad;
    if (!distinct || r.overlap_ratio <= result->runner_up_overlap) continue;
    result->runner_up_overlap = r.overlap_ratio;
    result->runner_up_T = r.T_target_source;
    if (r.overlap_ratio >= needed) return true;
  }
  return false;
}

}  // namespace

RegistrationResult RegisterScan(icp::IcpTarget& target, const std::vector<Point2>& source_kf,
                                const Pose2& seed, const RegistrationOptions& options) {
  RegistrationResult result;
  result.target_points = static_cast<int>(target.points().size());
  result.loop.T_ownkf_teammatekf = seed;
  if (static_cast<int>(source_kf.size()) < options.min_source_points) {
    result.status = RegistrationStatus::kTooFewSourcePoints;
    return result;
  }
  if (target.points().empty()) {
    result.status = RegistrationStatus::kEmptyTarget;
    return result;
  }
  const icp::Cloud2 source = icp::ToCloud(source_kf);
  result.icp = icp::AlignIcp(source, target, seed, options.icp);
  result.loop.T_ownkf_teammatekf = result.icp.T_target_source;
  result.loop.overlap = result.icp.overlap_ratio;
  result.loop.covariance = LoopCovariance(result.icp, options);
  if (!result.icp.valid) {
    result.status = RegistrationStatus::kIcpFailed;
  } else if (result.icp.overlap_ratio < options.min_overlap) {
    result.status = RegistrationStatus::kLowOverlap;
  } else if (options.max_correction_m > 0.0 &&
             std::hypot(result.icp.T_target_source.x_m - seed.x_m,
                        result.icp.T_target_source.y_m - seed.y_m) > options.max_correction_m) {
    result.status = RegistrationStatus::kLargeCorrection;
  } else {
    result.status = RegistrationStatus::kAccepted;
    if (Ambiguous(source, target, options, &result)) result.status = RegistrationStatus::kAmbiguous;
  }
  return result;
}

RegistrationResult RegisterScan(const std::vector<KeyframeScan>& own, int k,
                                const std::vector<Point2>& teammate_points_kf, const Pose2& seed,
                                const RegistrationOptions& options, int own_robot,
                                int teammate_robot, int teammate_keyframe) {
  int num_kfs = 0;
  RegistrationResult result;
  if (static_cast<int>(teammate_points_kf.size()) < options.min_source_points) {
    result.status = RegistrationStatus::kTooFewSourcePoints;
    result.loop.T_ownkf_teammatekf = seed;
  } else {
    icp::IcpTarget target(
        BuildWindowTarget(own, k, options.window, options.reference_window, &num_kfs));
    result = RegisterScan(target, teammate_points_kf, seed, options);
  }
  result.target_keyframes = num_kfs;
  result.loop.own_robot = own_robot;
  result.loop.own_keyframe = k >= 0 && k < static_cast<int>(own.size()) ? own[k].index : k;
  result.loop.teammate_robot = teammate_robot;
  result.loop.teammate_keyframe = teammate_keyframe;
  return result;
}

}  // namespace draco::registration
