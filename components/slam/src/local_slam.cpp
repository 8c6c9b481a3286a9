#include "draco/slam/local_slam.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "draco/consistency/filter.hpp"
#include "draco/consistency/se2.hpp"
#include "draco/icp/icp.hpp"
#include "draco/pose_graph/g2o.hpp"
#include "draco/pose_graph/pose_graph_2d.hpp"

namespace draco::slam {
namespace {

namespace pg = draco::pose_graph;

pg::Pose2 ToPg(const msgs::Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }
msgs::Pose2 FromPg(const pg::Pose2& p) { return {p.x_m, p.y_m, p.yaw_rad}; }

// Covariance with its diagonal raised to at least the given sigmas (off-diagonals kept).
Eigen::Matrix3d Floored(const msgs::Covariance3& c, double sigma_xy, double sigma_yaw) {
  Eigen::Matrix3d m = consistency::ToMatrix(c);
  if (!m.allFinite()) m.setZero();
  const double floors[3] = {sigma_xy * sigma_xy, sigma_xy * sigma_xy, sigma_yaw * sigma_yaw};
  for (int i = 0; i < 3; ++i) m(i, i) = std::max(m(i, i), floors[i]);
  return 0.5 * (m + m.transpose());
}

// The pose graph's window and full solves. Full solves on one thread: Ceres sums each
// thread's share of the cost and gradient in an order that depends on scheduling, so with two
// the last bits of a cost could differ between two runs of the same input and flip a step's
// acceptance; on one they cannot (the replay is deterministic by construction).
pg::IncrementalOptions SolveSettings(const LocalSlamOptions& o) {
  pg::IncrementalOptions inc;
  inc.window_size = o.heading_bias_sigma_rad > 0 ? 2 * o.window_size : o.window_size;
  inc.full_solve_min_poses = o.full_solve_min_keyframes;
  inc.full_solve_max_boundary_chi2 = o.full_solve_max_boundary_chi2;
  inc.full.num_threads = 1;
  if (!o.bounds_line_search) {
    inc.full.bounded_line_search_iterations = 0;
    inc.local.bounded_line_search_iterations = 0;
  }
  return inc;
}

pg::Matrix3 Information(const Eigen::Matrix3d& covariance) {
  const Eigen::Matrix3d info = covariance.inverse();
  pg::Matrix3 out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      out[static_cast<std::size_t>(3 * r + c)] = 0.5 * (info(r, c) + info(c, r));
  }
  return out;
}

// LocalSlamOptions::loop_icp_ambiguity_ratio: the places other than the answer (more than
// 1 m or 5 deg away) where ICP from the answer moved by each offset in 8 directions lands with
// nearly its overlap, as translations from the answer in the source keyframe's frame.
std::vector<Eigen::Vector2d> IcpAlternatives(const icp::Cloud2& source, icp::IcpTarget& target,
                                             const icp::IcpResult& answer,
                                             const LocalSlamOptions& o) {
  icp::IcpOptions again;
  again.covariance = false;
  const msgs::Pose2& best = answer.T_target_source;
  const double needed = o.loop_icp_ambiguity_ratio * answer.overlap_ratio;
  const Eigen::Rotation2Dd R_source_target(-best.yaw_rad);
  std::vector<Eigen::Vector2d> out;
  for (const double offset_m : o.loop_icp_ambiguity_offsets_m) {
    for (int d = 0; d < 8; ++d) {
      const double a = M_PI / 4.0 * d;
      const msgs::Pose2 seed{best.x_m + offset_m * std::cos(a), best.y_m + offset_m * std::sin(a),
                             best.yaw_rad};
      const icp::IcpResult r = icp::AlignIcp(source, target, seed, again);
      if (!r.valid || r.overlap_ratio < needed) continue;
      const Eigen::Vector2d shift(r.T_target_source.x_m - best.x_m,
                                  r.T_target_source.y_m - best.y_m);
      if (shift.norm() > 1.0 ||
          std::abs(std::remainder(r.T_target_source.yaw_rad - best.yaw_rad, 2.0 * M_PI)) > 0.0873) {
        out.push_back(R_source_target * shift);
        if (!o.loop_icp_ambiguity_inflate) return out;  // one is enough to drop the loop
      }
    }
  }
  return out;
}

// Correlative search for an ICP seed (as in real-time correlative scan matching): see
// CorrelativeSeedSearch in local_slam.hpp.
SeedSearch CorrelativeSeed(const icp::Cloud2& source, const icp::Cloud2& target,
                           const msgs::Pose2& guess, const LocalSlamOptions& o) {
  SeedSearch out;
  out.best = guess;
  if (source.empty() || target.empty()) return out;
  const double res = o.seed_resolution_m;
  double min_x = target[0].x(), max_x = min_x, min_y = target[0].y(), max_y = min_y;
  for (const auto& p : target) {
    min_x = std::min(min_x, p.x());
    max_x = std::max(max_x, p.x());
    min_y = std::min(min_y, p.y());
    max_y = std::max(max_y, p.y());
  }
  const int w = static_cast<int>((max_x - min_x) / res) + 3;
  const int h = static_cast<int>((max_y - min_y) / res) + 3;
  std::vector<std::uint8_t> grid(static_cast<std::size_t>(w) * h, 0);
  const double ox = min_x - res, oy = min_y - res;
  for (const auto& p : target) {
    const int cx = static_cast<int>((p.x() - ox) / res), cy = static_cast<int>((p.y() - oy) / res);
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int x = cx + dx, y = cy + dy;
        if (x >= 0 && y >= 0 && x < w && y < h) grid[static_cast<std::size_t>(y) * w + x] = 1;
      }
    }
  }
  const int nt = static_cast<int>(std::round(o.seed_search_m / res));
  const int nr = static_cast<int>(std::round(o.seed_search_rad / o.seed_angle_step_rad));
  const int side = 2 * nt + 1;
  // Per translation of the lattice, the best score over the rotations (for the runner-up).
  std::vector<int> best_over_rotations(static_cast<std::size_t>(side) * side, 0);
  int best_score = -1, best_ix = 0, best_iy = 0;
  std::vector<double> rx(source.size()), ry(source.size());
  for (int ir = -nr; ir <= nr; ++ir) {
    const double yaw = guess.yaw_rad + ir * o.seed_angle_step_rad;
    const double c = std::cos(yaw), s = std::sin(yaw);
    for (std::size_t i = 0; i < source.size(); ++i) {
      rx[i] = c * source[i].x() - s * source[i].y() + guess.x_m - ox;
      ry[i] = s * source[i].x() + c * source[i].y() + guess.y_m - oy;
    }
    for (int iy = -nt; iy <= nt; ++iy) {
      for (int ix = -nt; ix <= nt; ++ix) {
        int score = 0;
        for (std::size_t i = 0; i < source.size(); ++i) {
          const int x = static_cast<int>(std::floor((rx[i] + ix * res) / res));
          const int y = static_cast<int>(std::floor((ry[i] + iy * res) / res));
          if (x >= 0 && y >= 0 && x < w && y < h)
            score += grid[static_cast<std::size_t>(y) * w + x];
        }
        int& cell = best_over_rotations[static_cast<std::size_t>(iy + nt) * side + (ix + nt)];
        cell = std::max(cell, score);
        // Ties keep the pose closest to the guess (visited first from the centre is not
        // guaranteed, so compare the offset explicitly).
        const bool closer =
            score == best_score &&
            (std::abs(ix) + std::abs(iy) + std::abs(ir)) <
                (std::abs(static_cast<int>(std::round((out.best.x_m - guess.x_m) / res))) +
                 std::abs(static_cast<int>(std::round((out.best.y_m - guess.y_m) / res))) +
                 std::abs(static_cast<int>(
                     std::round((out.best.yaw_rad - guess.yaw_rad) / o.seed_angle_step_rad))));
        if (score > best_score || closer) {
          best_score = score;
          best_ix = ix;
          best_iy = iy;
          out.best = {guess.x_m + ix * res, guess.y_m + iy * res, yaw};
        }
      }
    }
  }
  out.best_score = std::max(best_score, 0);
  // The runner-up is measured from the centre of the translations that reach the best score
  // (the dilated grid gives a right match a plateau 3-4 cells wide, and `best` may lie on
  // its edge): the best-scoring translation nearest to their mean.
  double mx = 0.0, my = 0.0;
  int count = 0;
  const auto score_at = [&](int ix, int iy) {
    return best_over_rotations[static_cast<std::size_t>(iy + nt) * side + (ix + nt)];
  };
  for (int iy = -nt; iy <= nt; ++iy) {
    for (int ix = -nt; ix <= nt; ++ix) {
      if (score_at(ix, iy) < best_score) continue;
      mx += ix;
      my += iy;
      ++count;
    }
  }
  if (count > 0) {
    mx /= count;
    my /= count;
    double nearest = std::numeric_limits<double>::infinity();
    for (int iy = -nt; iy <= nt; ++iy) {
      for (int ix = -nt; ix <= nt; ++ix) {
        const double d = std::hypot(ix - mx, iy - my);
        if (score_at(ix, iy) < best_score || d >= nearest) continue;
        nearest = d;
        best_ix = ix;
        best_iy = iy;
      }
    }
  }
  // Spread (second moment about their mean) of the translations scoring at least
  // loop_ambiguity_ratio of the best.
  if (o.loop_ambiguity_ratio > 0 && best_score > 0) {
    double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0, syy = 0.0;
    int n = 0;
    for (int iy = -nt; iy <= nt; ++iy) {
      for (int ix = -nt; ix <= nt; ++ix) {
        if (score_at(ix, iy) < o.loop_ambiguity_ratio * best_score) continue;
        const double x = ix * res, y = iy * res;
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
        ++n;
      }
    }
    if (n > 0) {
      sx /= n;
      sy /= n;
      out.spread_xx_m2 = sxx / n - sx * sx;
      out.spread_xy_m2 = sxy / n - sx * sy;
      out.spread_yy_m2 = syy / n - sy * sy;
    }
  }
  for (int iy = -nt; iy <= nt; ++iy) {
    for (int ix = -nt; ix <= nt; ++ix) {
      if (std::hypot(ix - best_ix, iy - best_iy) * res < o.loop_ambiguity_offset_m) continue;
      out.runner_up_score =
          std::max(out.runner_up_score,
                   best_over_rotations[static_cast<std::size_t>(iy + nt) * side + (ix + nt)]);
    }
  }
  return out;
}

}  // namespace

SeedSearch CorrelativeSeedSearch(const std::vector<msgs::Point2>& source_kf,
                                 const std::vector<msgs::Point2>& target_kf,
                                 const msgs::Pose2& guess, const LocalSlamOptions& options) {
  icp::Cloud2 source, target;
  for (const auto& p : source_kf) source.emplace_back(p.x_m, p.y_m);
  for (const auto& p : target_kf) target.emplace_back(p.x_m, p.y_m);
  return CorrelativeSeed(source, target, guess, options);
}

std::vector<LandmarkObservation> ExtractLandmarkObservations(
    const std::vector<msgs::Point2>& points_kf, const LocalSlamOptions& o) {
  const std::size_t n = points_kf.size();
  // Single linkage: union-find over the pairs within the radius (tens to a few hundred
  // points per keyframe, so all pairs).
  std::vector<std::size_t> parent(n);
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  auto find = [&](std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  const double r2 = o.landmark_cluster_radius_m * o.landmark_cluster_radius_m;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const double dx = points_kf[i].x_m - points_kf[j].x_m;
      const double dy = points_kf[i].y_m - points_kf[j].y_m;
      if (dx * dx + dy * dy <= r2) parent[find(i)] = find(j);
    }
  }
  std::map<std::size_t, std::vector<std::size_t>> clusters;  // ordered: deterministic output
  for (std::size_t i = 0; i < n; ++i) clusters[find(i)].push_back(i);

  std::vector<LandmarkObservation> out;
  const double floor2 = o.landmark_min_sigma_m * o.landmark_min_sigma_m;
  for (const auto& [root, members] : clusters) {
    const int m = static_cast<int>(members.size());
    if (m < o.landmark_min_points) continue;
    double cx = 0.0, cy = 0.0;
    for (const std::size_t i : members) {
      cx += points_kf[i].x_m;
      cy += points_kf[i].y_m;
    }
    cx /= m;
    cy /= m;
    double extent2 = 0.0;
    for (std::size_t a = 0; a < members.size(); ++a) {
      for (std::size_t b = a + 1; b < members.size(); ++b) {
        const double dx = points_kf[members[a]].x_m - points_kf[members[b]].x_m;
        const double dy = points_kf[members[a]].y_m - points_kf[members[b]].y_m;
        extent2 = std::max(extent2, dx * dx + dy * dy);
      }
    }
    if (extent2 > o.landmark_max_extent_m * o.landmark_max_extent_m) continue;
    if (o.landmark_max_range_m > 0 && std::hypot(cx, cy) > o.landmark_max_range_m) continue;
    // Isolated: no point of another cluster near the centroid (rows of piles, debris fields
    // and wreck parts alias; a lone boulder does not).
    bool isolated = true;
    const double iso2 = o.landmark_isolation_m * o.landmark_isolation_m;
    for (std::size_t i = 0; i < n && isolated; ++i) {
      if (find(i) == root) continue;
      const double dx = points_kf[i].x_m - cx, dy = points_kf[i].y_m - cy;
      isolated = dx * dx + dy * dy > iso2;
    }
    if (!isolated) continue;
    LandmarkObservation z;
    z.p_kf = {cx, cy};
    z.num_points = m;
    z.extent_m = std::sqrt(extent2);
    for (const std::size_t i : members) {
      const double dx = points_kf[i].x_m - cx, dy = points_kf[i].y_m - cy;
      z.cov_xx += dx * dx / m;
      z.cov_xy += dx * dy / m;
      z.cov_yy += dy * dy / m;
    }
    z.cov_xx += floor2;
    z.cov_yy += floor2;
    // Near-face bias: the object's centre lies behind the centroid, along the ray.
    const double range = std::hypot(cx, cy);
    if (range > 1e-6) {
      const double ux = cx / range, uy = cy / range, half = 0.5 * z.extent_m;
      z.p_kf.x_m += o.landmark_center_offset_ratio * half * ux;
      z.p_kf.y_m += o.landmark_center_offset_ratio * half * uy;
      const double var = std::pow(o.landmark_range_sigma_ratio * half, 2);
      z.cov_xx += var * ux * ux;
      z.cov_xy += var * ux * uy;
      z.cov_yy += var * uy * uy;
    }
    out.push_back(z);
  }
  return out;
}

msgs::Covariance3 LoopCovariance(const msgs::Covariance3& icp_covariance, double rmse_m,
                                 double overlap_ratio, const LocalSlamOptions& o) {
  Eigen::Matrix3d cov = Floored(icp_covariance, o.loop_min_sigma_xy_m, o.loop_min_sigma_yaw_rad);
  if (o.loop_rmse_cov_scale > 0) {
    // Scale the whole covariance (keeping its shape) until the xy variance reaches
    // loop_rmse_cov_scale * rmse^2.
    const double xy = 0.5 * (cov(0, 0) + cov(1, 1));
    cov *= std::max(1.0, o.loop_rmse_cov_scale * rmse_m * rmse_m / xy);
  }
  if (o.loop_overlap_cov_power > 0 && overlap_ratio > 0) {
    cov *= std::pow(1.0 / std::min(1.0, overlap_ratio), o.loop_overlap_cov_power);
  }
  return consistency::FromMatrix(cov);
}

double LoopChainChi2(const msgs::Pose2& T_j_k_estimate, const msgs::Pose2& T_j_k_loop,
                     const msgs::Covariance3& chain_covariance,
                     const msgs::Covariance3& loop_covariance) {
  // Both covariances are of (x, y, yaw) of T_j_k in keyframe j's frame: so is the difference.
  const Eigen::Vector3d e(T_j_k_loop.x_m - T_j_k_estimate.x_m, T_j_k_loop.y_m - T_j_k_estimate.y_m,
                          consistency::WrapAngle(T_j_k_loop.yaw_rad - T_j_k_estimate.yaw_rad));
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(consistency::ToMatrix(chain_covariance) +
                                          consistency::ToMatrix(loop_covariance));
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || ldlt.vectorD().minCoeff() <= 0.0) {
    return std::numeric_limits<double>::infinity();
  }
  return e.dot(ldlt.solve(e));
}

struct LocalSlam::Impl {
  LocalSlamOptions options;
  pg::PoseGraph2d graph;
  std::vector<msgs::Keyframe> keyframes;
  std::vector<icp::Cloud2> clouds;     // keyframe points, body frame
  consistency::ChainPoseSource chain;  // the odometry chain, for PCM
  consistency::ConsistencyFilter pcm;
  std::vector<LoopRecord> loops;
  std::map<std::uint64_t, std::size_t> loop_by_id;
  // Loops whose factor gets a wider covariance than PCM tested (loop_icp_ambiguity_inflate).
  std::map<std::uint64_t, msgs::Covariance3> factor_covariance;
  std::uint64_t next_loop_id = 0;
  int ambiguous_loops = 0;       // candidates dropped by the ambiguity test, this step
  int chain_rejected_loops = 0;  // candidates the chain test dropped, this step
  int icp_ambiguous_loops = 0;   // candidates the ICP ambiguity test found, this step

  // Point landmarks; the index is the graph's point id.
  struct LandmarkSighting {
    int keyframe = 0;
    LandmarkObservation z;
  };
  struct Landmark {
    std::vector<LandmarkSighting> sightings;
    bool in_graph = false;
    bool unstable = false;
  };
  std::vector<Landmark> landmarks;

  explicit Impl(const LocalSlamOptions& o)
      : options(o), pcm([&] {
          consistency::FilterOptions f;
          f.method = consistency::Method::kPcm;
          f.min_clique_size = o.pcm_min_clique_size;
          f.pairwise.chi2_threshold = o.pcm_chi2_threshold;
          f.max_clique_nodes = o.pcm_max_clique_nodes;
          // No wall-clock budget: it would make replay depend on machine load; the node
          // budget (pcm_max_clique_nodes) bounds a keyframe's latency instead.
          f.time_budget_ms = 0.0;
          return f;
        }()) {}

  msgs::Pose2 Estimate(int index) const { return FromPg(graph.Pose(index)); }

  // Heading-bias node of keyframe k (negative ids; only its yaw is used: its x, y are pinned
  // by a prior and tied to nothing else).
  static pg::PoseId BiasId(int k) { return -2 - static_cast<pg::PoseId>(k); }
  static constexpr pg::PoseId kBiasMeanId = -1;
  void AddHeadingBias(int k) {
    const auto& o = options;
    const msgs::Keyframe& kf = keyframes[static_cast<std::size_t>(k)];
    const pg::Pose2 anchor{kf.T_odom_body.x_m, kf.T_odom_body.y_m, 0.0};
    const double tiny = 1e-9;
    const double sb = o.heading_bias_sigma_rad;
    if (k == 0) {
      // The mean of the heading error: free (the AHRS error at keyframe 0, which the graph
      // frame absorbs, is unknown too), so only deviations from it are penalised.
      graph.AddPose(kBiasMeanId, anchor);
      graph.AddPrior(kBiasMeanId, anchor, pg::Diagonal3(1.0, 1.0, 1e-6));
    }
    graph.AddPose(BiasId(k), anchor);
    graph.AddPrior(BiasId(k), anchor, pg::Diagonal3(1.0, 1.0, tiny));
    const msgs::Keyframe& first = keyframes.front();
    if (k == 0 || !o.heading_bias_gauss_markov) {
      // Gauss-Markov model: beta_0 - mean ~ N(0, sb^2) only (the stationary distribution).
      graph.AddBetween(kBiasMeanId, BiasId(k),
                       {kf.T_odom_body.x_m - first.T_odom_body.x_m,
                        kf.T_odom_body.y_m - first.T_odom_body.y_m, 0.0},
                       pg::Diagonal3(tiny, tiny, 1.0 / (sb * sb)), pg::FactorKind::kOdometry);
    }
    const double sm = o.heading_meas_sigma_rad;
    graph.AddBetween(BiasId(k), k, {0.0, 0.0, kf.T_odom_body.yaw_rad},
                     pg::Diagonal3(tiny, tiny, 1.0 / (sm * sm)), pg::FactorKind::kOdometry,
                     o.heading_meas_cauchy_scale > 0
                         ? pg::RobustLoss{pg::LossKind::kCauchy, o.heading_meas_cauchy_scale}
                         : pg::RobustLoss{});
    if (k > 0) {
      const msgs::Keyframe& prev = keyframes[static_cast<std::size_t>(k - 1)];
      const double dt = std::max(1e-3, kf.time_s - prev.time_s);
      const double tau = std::max(1e-3, o.heading_bias_tau_s);
      if (o.heading_bias_gauss_markov) {
        // Exact AR(1): (beta_k - mean) - phi (beta_k-1 - mean), sigma sb sqrt(1 - phi^2).
        const double phi = std::exp(-dt / tau);
        const double sw = sb * std::sqrt(std::max(1e-12, 1.0 - phi * phi));
        graph.AddYawGaussMarkov(kBiasMeanId, BiasId(k - 1), BiasId(k), phi, sw);
        return;
      }
      const double sw = sb * std::sqrt(2.0 * dt / tau);
      graph.AddBetween(BiasId(k - 1), BiasId(k),
                       {kf.T_odom_body.x_m - prev.T_odom_body.x_m,
                        kf.T_odom_body.y_m - prev.T_odom_body.y_m, 0.0},
                       pg::Diagonal3(tiny, tiny, 1.0 / (sw * sw)), pg::FactorKind::kOdometry);
    }
  }

  msgs::Point2 LandmarkPosition(std::size_t id) const {
    const Landmark& l = landmarks[id];
    if (l.in_graph) {
      const pg::Point2 p = graph.Point(static_cast<pg::PointId>(id));
      return {p.x_m, p.y_m};
    }
    double x = 0.0, y = 0.0;
    for (const auto& s : l.sightings) {
      const pg::Point2 p = pg::Transform(graph.Pose(s.keyframe), {s.z.p_kf.x_m, s.z.p_kf.y_m});
      x += p.x_m;
      y += p.y_m;
    }
    const double n = static_cast<double>(l.sightings.size());
    return {x / n, y / n};
  }

  void AddLandmarkFactor(std::size_t id, const LandmarkSighting& s) {
    const auto& z = s.z;
    const double det = z.cov_xx * z.cov_yy - z.cov_xy * z.cov_xy;
    const pg::Matrix2 information = {z.cov_yy / det, -z.cov_xy / det, -z.cov_xy / det,
                                     z.cov_xx / det};
    graph.AddPointObservation(
        s.keyframe, static_cast<pg::PointId>(id), {z.p_kf.x_m, z.p_kf.y_m}, information,
        options.landmark_cauchy_scale > 0
            ? pg::RobustLoss{pg::LossKind::kCauchy, options.landmark_cauchy_scale}
            : pg::RobustLoss{});
  }

  // Whether sighting s agrees with the earlier sightings of its pass (see the options).
  bool StableInPass(const Landmark& l, const LandmarkSighting& s) const {
    double x = 0.0, y = 0.0;
    int n = 0, next = s.keyframe;
    for (auto it = l.sightings.rbegin(); it != l.sightings.rend(); ++it) {
      if (next - it->keyframe > options.landmark_pass_gap) break;
      const pg::Point2 p =
          pg::Transform(graph.Pose(it->keyframe), {it->z.p_kf.x_m, it->z.p_kf.y_m});
      x += p.x_m;
      y += p.y_m;
      ++n;
      next = it->keyframe;
    }
    if (n == 0) return true;  // the first sighting of a pass
    const pg::Point2 p = pg::Transform(graph.Pose(s.keyframe), {s.z.p_kf.x_m, s.z.p_kf.y_m});
    return std::hypot(p.x_m - x / n, p.y_m - y / n) <= options.landmark_max_pass_spread_m;
  }

  // Associates keyframe k's landmark observations (see LocalSlamOptions) by the current
  // estimate and adds the constraints of landmarks that are informative enough.
  void ObserveLandmarks(int k) {
    const auto& o = options;
    const auto observed =
        ExtractLandmarkObservations(keyframes[static_cast<std::size_t>(k)].points_body, o);
    if (observed.empty()) return;
    const pg::Pose2 T_map_k = graph.Pose(k);
    std::vector<msgs::Point2> known(landmarks.size());
    for (std::size_t id = 0; id < landmarks.size(); ++id) {
      known[id] = LandmarkPosition(id);
      // With a radius state the graph point is the centre: predict the near face from here.
      const auto rho =
          landmarks[id].in_graph ? graph.PointRadius(static_cast<pg::PointId>(id)) : std::nullopt;
      if (rho) {
        const double dx = known[id].x_m - T_map_k.x_m, dy = known[id].y_m - T_map_k.y_m;
        const double d = std::hypot(dx, dy);
        if (d > *rho) {
          known[id].x_m -= *rho * dx / d;
          known[id].y_m -= *rho * dy / d;
        }
      }
    }
    constexpr int kDropped = -2, kNew = -1;
    std::vector<int> match(observed.size(), kDropped);
    for (std::size_t b = 0; b < observed.size(); ++b) {
      const pg::Point2 p = pg::Transform(T_map_k, {observed[b].p_kf.x_m, observed[b].p_kf.y_m});
      int in_gate = 0, near = 0, nearest = kDropped;
      for (std::size_t id = 0; id < known.size(); ++id) {
        const double d = std::hypot(known[id].x_m - p.x_m, known[id].y_m - p.y_m);
        if (d <= o.landmark_gate_m) {
          ++in_gate;
          nearest = static_cast<int>(id);
        }
        if (d <= o.landmark_new_min_distance_m) ++near;
      }
      if (in_gate == 1) {
        match[b] = nearest;
      } else if (near == 0) {
        match[b] = kNew;
      }
    }
    // Two clusters onto one landmark: neither is trusted.
    for (std::size_t a = 0; a < match.size(); ++a) {
      for (std::size_t b = a + 1; b < match.size(); ++b) {
        if (match[a] >= 0 && match[a] == match[b]) match[a] = match[b] = kDropped;
      }
    }
    for (std::size_t b = 0; b < observed.size(); ++b) {
      if (match[b] == kDropped) continue;
      const LandmarkSighting sighting{k, observed[b]};
      if (match[b] == kNew) {
        landmarks.push_back({{sighting}, false});
        continue;
      }
      const std::size_t id = static_cast<std::size_t>(match[b]);
      Landmark& l = landmarks[id];
      if (l.unstable) continue;
      if (o.landmark_max_pass_spread_m > 0 && !StableInPass(l, sighting)) {
        l.unstable = true;
        continue;
      }
      l.sightings.push_back(sighting);
      if (l.in_graph) {
        AddLandmarkFactor(id, sighting);
      } else if (static_cast<int>(l.sightings.size()) >= o.landmark_min_observations &&
                 l.sightings.back().keyframe - l.sightings.front().keyframe >=
                     o.landmark_min_index_gap) {
        const msgs::Point2 p = LandmarkPosition(id);
        std::optional<pg::PointRadiusPrior> radius;
        if (o.landmark_radius_sigma_m > 0) {
          double extent = 0.0;
          for (const auto& s : l.sightings) extent += s.z.extent_m;
          extent /= static_cast<double>(l.sightings.size());
          radius = pg::PointRadiusPrior{
              std::min(o.landmark_radius_prior_ratio * 0.5 * extent, o.landmark_radius_max_m),
              o.landmark_radius_sigma_m, o.landmark_radius_max_m};
        }
        graph.AddPoint(static_cast<pg::PointId>(id), {p.x_m, p.y_m}, radius);
        l.in_graph = true;
        for (const auto& s : l.sightings) AddLandmarkFactor(id, s);
      }
    }
  }

  // Registers keyframe k against the submaps around older keyframes near its estimate.
  std::vector<msgs::InterRobotLoop> ProposeLoops(int k) {
    std::vector<msgs::InterRobotLoop> out;
    const auto& o = options;
    if (!o.loop_closure || static_cast<int>(clouds[k].size()) < o.loop_min_points) return out;
    const msgs::Pose2 T_map_k = Estimate(k);
    std::vector<std::pair<double, int>> candidates;
    for (int j = 0; j + o.loop_min_index_gap <= k; ++j) {
      if (static_cast<int>(clouds[j].size()) < o.loop_min_points) continue;
      const msgs::Pose2 T_j_k = consistency::Between(Estimate(j), T_map_k);
      const double d = std::hypot(T_j_k.x_m, T_j_k.y_m);
      if (d <= o.loop_max_distance_m && std::abs(T_j_k.yaw_rad) <= o.loop_max_yaw_rad) {
        candidates.push_back({d, j});
      }
    }
    std::sort(candidates.begin(), candidates.end());
    // Source: keyframe k and up to loop_source_half_width keyframes before it, in k's frame.
    icp::Cloud2 source = clouds[k];
    for (int i = std::max(0, k - o.loop_source_half_width); i < k; ++i) {
      const msgs::Pose2 T_k_i = consistency::Between(T_map_k, Estimate(i));
      const double c = std::cos(T_k_i.yaw_rad), s = std::sin(T_k_i.yaw_rad);
      for (const auto& p : clouds[i]) {
        source.emplace_back(c * p.x() - s * p.y() + T_k_i.x_m, s * p.x() + c * p.y() + T_k_i.y_m);
      }
    }
    // Skip candidates next to one already tried: their submaps overlap.
    std::vector<int> tried;
    for (const auto& [d, j] : candidates) {
      if (static_cast<int>(tried.size()) >= o.loop_max_candidates) break;
      bool near_tried = false;
      for (int t : tried) near_tried |= std::abs(t - j) <= o.loop_submap_half_width;
      if (near_tried) continue;
      tried.push_back(j);
      // Target: keyframes j-w .. j+w (never within the gap of k) in j's frame.
      icp::Cloud2 target;
      const msgs::Pose2 T_map_j = Estimate(j);
      for (int i = std::max(0, j - o.loop_submap_half_width);
           i <= std::min(k - o.loop_min_index_gap, j + o.loop_submap_half_width); ++i) {
        const msgs::Pose2 T_j_i = consistency::Between(T_map_j, Estimate(i));
        const double c = std::cos(T_j_i.yaw_rad), s = std::sin(T_j_i.yaw_rad);
        for (const auto& p : clouds[i]) {
          target.emplace_back(c * p.x() - s * p.y() + T_j_i.x_m, s * p.x() + c * p.y() + T_j_i.y_m);
        }
      }
      const msgs::Pose2 guess = consistency::Between(T_map_j, T_map_k);
      msgs::Pose2 seed = guess;
      SeedSearch search;
      if (o.seed_search_m > 0) {
        search = CorrelativeSeed(source, target, guess, o);
        if (o.loop_ambiguity_ratio > 0 && !o.loop_ambiguity_inflate &&
            search.AmbiguityRatio() >= o.loop_ambiguity_ratio) {
          ++ambiguous_loops;
          continue;
        }
        seed = search.best;
      }
      icp::IcpTarget prepared(std::move(target));
      const icp::IcpResult r = icp::AlignIcp(source, prepared, seed);
      if (!r.valid || r.overlap_ratio < o.loop_min_overlap) continue;
      if (o.loop_max_rmse_m > 0 && r.rmse_m > o.loop_max_rmse_m) continue;
      const msgs::Pose2 correction = consistency::Between(guess, r.T_target_source);
      if (std::hypot(correction.x_m, correction.y_m) > o.loop_max_correction_m ||
          std::abs(correction.yaw_rad) > o.loop_max_correction_rad) {
        continue;
      }
      std::vector<Eigen::Vector2d> alternatives;
      if (o.loop_icp_ambiguity_ratio > 0) {
        alternatives = IcpAlternatives(source, prepared, r, o);
        if (!alternatives.empty()) ++icp_ambiguous_loops;
        if (!alternatives.empty() && !o.loop_icp_ambiguity_inflate) continue;
      }
      const msgs::Covariance3 loop_covariance =
          LoopCovariance(r.covariance, r.rmse_m, r.overlap_ratio, o);
      if (o.loop_chain_chi2 > 0) {
        const auto chain_j_k = chain.Relative(0, j, k);
        if (chain_j_k &&
            LoopChainChi2(guess, r.T_target_source, consistency::FromMatrix(chain_j_k->covariance),
                          loop_covariance) > o.loop_chain_chi2) {
          ++chain_rejected_loops;
          continue;
        }
      }
      msgs::InterRobotLoop loop;
      loop.id = next_loop_id++;
      // As a PCM candidate: own keyframe j, "teammate" keyframe k of the same robot.
      loop.own_robot = 0;
      loop.teammate_robot = 0;
      loop.own_keyframe = j;
      loop.teammate_keyframe = k;
      loop.T_ownkf_teammatekf = r.T_target_source;
      loop.covariance = loop_covariance;
      if (o.loop_ambiguity_ratio > 0 && o.loop_ambiguity_inflate) {
        // The plateau's elongation (its spread beyond the isotropic part) is added to the
        // translation covariance (target frame, as the lattice): along a wall the loop then
        // constrains the distance to the wall and the heading, not the slide.
        const double sxx = search.spread_xx_m2, sxy = search.spread_xy_m2,
                     syy = search.spread_yy_m2;
        const double min_eig =
            0.5 * (sxx + syy) - std::sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
        if (sxx + syy - 2 * min_eig > 0.25) {  // more than 0.5 m of slide
          loop.covariance[0] += sxx - min_eig;
          loop.covariance[1] += sxy;
          loop.covariance[3] += sxy;
          loop.covariance[4] += syy - min_eig;
          ++ambiguous_loops;
        }
      }
      // Each other place the scan fits adds its shift's outer product to the translation
      // covariance of the loop's factor (source frame, as the ICP covariance): along a row of
      // piles the loop then holds the distance to the row and the heading, not the position
      // along it. PCM still tests the loop with its own covariance, which a wider one would
      // only make easier to pass.
      if (!alternatives.empty()) {
        msgs::Covariance3 wide = loop.covariance;
        for (const Eigen::Vector2d& shift : alternatives) {
          wide[0] += shift.x() * shift.x();
          wide[1] += shift.x() * shift.y();
          wide[3] += shift.x() * shift.y();
          wide[4] += shift.y() * shift.y();
        }
        factor_covariance[loop.id] = wide;
      }
      loop.overlap = r.overlap_ratio;
      loop_by_id[loop.id] = loops.size();
      loops.push_back(LoopRecord{j, k, r.T_target_source, r.overlap_ratio, r.rmse_m, false});
      out.push_back(loop);
    }
    return out;
  }
};

LocalSlam::LocalSlam(const LocalSlamOptions& options) : impl_(std::make_unique<Impl>(options)) {}
LocalSlam::~LocalSlam() = default;
LocalSlam::LocalSlam(LocalSlam&&) noexcept = default;
LocalSlam& LocalSlam::operator=(LocalSlam&&) noexcept = default;

int LocalSlam::NumKeyframes() const { return static_cast<int>(impl_->keyframes.size()); }

StepResult LocalSlam::AddKeyframe(const msgs::Keyframe& keyframe,
                                  const msgs::SequentialFactor* factor) {
  Impl& m = *impl_;
  const auto& o = m.options;
  const int k = static_cast<int>(m.keyframes.size());
  if (keyframe.index != k) {
    throw std::invalid_argument("LocalSlam: keyframe " + std::to_string(keyframe.index) +
                                " arrived, expected " + std::to_string(k));
  }
  if (factor != nullptr && (factor->to_index != k || factor->from_index != k - 1)) {
    throw std::invalid_argument("LocalSlam: factor " + std::to_string(factor->from_index) + "->" +
                                std::to_string(factor->to_index) + " does not lead to keyframe " +
                                std::to_string(k));
  }
  m.keyframes.push_back(keyframe);
  m.clouds.push_back(icp::ToCloud(keyframe.points_body));

  StepResult result;
  if (k == 0) {
    m.graph.AddPose(0, ToPg(keyframe.T_odom_body));
    m.graph.AddPrior(
        0, ToPg(keyframe.T_odom_body),
        pg::InformationFromSigmas(o.prior_sigma_xy_m, o.prior_sigma_xy_m, o.prior_sigma_yaw_rad));
    m.chain.AddKeyframe(0, keyframe.T_odom_body, Eigen::Matrix3d::Zero());
    if (o.heading_bias_sigma_rad > 0) m.AddHeadingBias(0);
    if (o.landmarks) m.ObserveLandmarks(0);
    return result;
  }
  const msgs::Pose2 T_prev_k = factor != nullptr ? factor->T_from_to : keyframe.T_prevkf_kf;
  const Eigen::Matrix3d cov =
      Floored(factor != nullptr ? factor->covariance : keyframe.covariance_prevkf_kf,
              o.min_factor_sigma_xy_m, o.min_factor_sigma_yaw_rad);
  const msgs::Pose2 initial = consistency::Compose(m.Estimate(k - 1), T_prev_k);
  m.graph.AddPose(k, ToPg(initial));
  const bool scan_matched = factor != nullptr && factor->scan_matched;
  if (o.heading_prior_sigma_rad > 0) {
    // The AHRS heading is absolute, its error bounded: a yaw-only prior (negligible weight on
    // x, y) keeps the graph from rotating whole segments to satisfy a loop.
    const double w = 1.0 / (o.heading_prior_sigma_rad * o.heading_prior_sigma_rad);
    m.graph.AddPrior(k, ToPg(keyframe.T_odom_body), pg::Diagonal3(1e-9, 1e-9, w),
                     o.heading_prior_cauchy_scale > 0
                         ? pg::RobustLoss{pg::LossKind::kCauchy, o.heading_prior_cauchy_scale}
                         : pg::RobustLoss{});
  }
  if (o.heading_bias_sigma_rad > 0) m.AddHeadingBias(k);
  const pg::RobustLoss sequential_loss =
      scan_matched && o.scan_match_cauchy_scale > 0
          ? pg::RobustLoss{pg::LossKind::kCauchy, o.scan_match_cauchy_scale}
          : pg::RobustLoss{};
  const Eigen::Matrix3d graph_cov =
      scan_matched && o.min_scan_match_sigma_xy_m >= 0
          ? Floored(factor->covariance, o.min_scan_match_sigma_xy_m, o.min_factor_sigma_yaw_rad)
          : cov;
  m.graph.AddBetween(k - 1, k, ToPg(T_prev_k), Information(graph_cov),
                     scan_matched ? pg::FactorKind::kScanMatch : pg::FactorKind::kOdometry,
                     sequential_loss);
  if (scan_matched && o.keep_dead_reckoning_factor) {
    // Dead reckoning stays in the graph beside the scan match: a scan match that slid along
    // a row of piles is outvoted instead of trusted.
    m.graph.AddBetween(
        k - 1, k, ToPg(keyframe.T_prevkf_kf),
        Information(Floored(
            keyframe.covariance_prevkf_kf,
            o.min_dr_sigma_xy_m >= 0 ? o.min_dr_sigma_xy_m : o.min_factor_sigma_xy_m,
            o.min_dr_sigma_yaw_rad >= 0 ? o.min_dr_sigma_yaw_rad : o.min_factor_sigma_yaw_rad)),
        pg::FactorKind::kOdometry);
  }
  const int chain_size = m.chain.NumKeyframes(0);
  m.chain.AddKeyframe(0, consistency::Compose(m.chain.KeyframePose(0, chain_size - 1), T_prev_k),
                      cov);

  const auto proposed = m.ProposeLoops(k);
  result.loops_registered = static_cast<int>(proposed.size());
  result.loops_ambiguous = m.ambiguous_loops;
  m.ambiguous_loops = 0;
  result.loops_chain_rejected = m.chain_rejected_loops;
  m.chain_rejected_loops = 0;
  result.loops_icp_ambiguous = m.icp_ambiguous_loops;
  m.icp_ambiguous_loops = 0;
  if (!proposed.empty()) {
    const consistency::Decision d = m.pcm.Add(proposed, m.chain);
    result.pcm_search_capped = !d.exact;
    for (std::uint64_t id : d.newly_accepted) {
      LoopRecord& rec = m.loops[m.loop_by_id.at(id)];
      if (rec.accepted) continue;
      rec.accepted = true;
      Eigen::Matrix3d loop_cov = Eigen::Matrix3d::Zero();
      for (const auto& p : proposed) {
        if (p.id == id) loop_cov = consistency::ToMatrix(p.covariance);
      }
      if (const auto wide = m.factor_covariance.find(id); wide != m.factor_covariance.end()) {
        loop_cov = consistency::ToMatrix(wide->second);
      }
      if (loop_cov.isZero()) {
        loop_cov.diagonal() << o.loop_min_sigma_xy_m * o.loop_min_sigma_xy_m,
            o.loop_min_sigma_xy_m * o.loop_min_sigma_xy_m,
            o.loop_min_sigma_yaw_rad * o.loop_min_sigma_yaw_rad;
      }
      m.graph.AddBetween(rec.from_index, rec.to_index, ToPg(rec.T_from_to), Information(loop_cov),
                         pg::FactorKind::kLoop, {pg::LossKind::kCauchy, o.loop_cauchy_scale});
      ++result.loops_accepted;
    }
  }
  if (o.landmarks) m.ObserveLandmarks(k);
  const pg::SolveSummary s = m.graph.Update(SolveSettings(o));
  result.full_solve = s.full;
  result.full_solve_avoided = s.full_avoided;
  result.solve_time_s = s.time_s;
  result.solve_iterations = s.iterations;
  return result;
}

bool LocalSlam::Flush() {
  if (!impl_->graph.FullSolvePending()) return false;
  impl_->graph.Optimize(SolveSettings(impl_->options).full);
  return true;
}

std::vector<KeyframeEstimate> LocalSlam::Trajectory() const {
  std::vector<KeyframeEstimate> out;
  for (const auto& kf : impl_->keyframes) {
    out.push_back(KeyframeEstimate{kf.index, kf.time_s, impl_->Estimate(kf.index), kf.T_odom_body,
                                   static_cast<int>(kf.points_body.size())});
  }
  return out;
}

const std::vector<LoopRecord>& LocalSlam::Loops() const { return impl_->loops; }

std::vector<LandmarkRecord> LocalSlam::Landmarks() const {
  std::vector<LandmarkRecord> out;
  for (std::size_t id = 0; id < impl_->landmarks.size(); ++id) {
    const auto& l = impl_->landmarks[id];
    LandmarkRecord r{static_cast<int>(id),
                     impl_->LandmarkPosition(id),
                     static_cast<int>(l.sightings.size()),
                     l.sightings.front().keyframe,
                     l.sightings.back().keyframe,
                     l.in_graph,
                     l.unstable};
    if (l.in_graph)
      r.radius_m = impl_->graph.PointRadius(static_cast<pg::PointId>(id)).value_or(0.0);
    for (const auto& s : l.sightings) r.keyframes.push_back(s.keyframe);
    out.push_back(std::move(r));
  }
  return out;
}

std::vector<msgs::Point2> LocalSlam::MapPoints() const {
  std::vector<msgs::Point2> out;
  for (const auto& kf : impl_->keyframes) {
    const msgs::Pose2 T = impl_->Estimate(kf.index);
    const double c = std::cos(T.yaw_rad), s = std::sin(T.yaw_rad);
    for (const auto& p : kf.points_body) {
      out.push_back({c * p.x_m - s * p.y_m + T.x_m, s * p.x_m + c * p.y_m + T.y_m});
    }
  }
  return out;
}

std::string LocalSlam::ToG2oText() const {
  std::ostringstream os;
  pg::WriteG2o(os, pg::ToG2o(impl_->graph));
  return os.str();
}

}  // namespace draco::slam
