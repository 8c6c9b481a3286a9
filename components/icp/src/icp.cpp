// 2D ICP (see icp.hpp).
#include "draco/icp/icp.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "backends.hpp"

namespace draco::icp {
namespace {

struct Rigid {
  Eigen::Matrix2d R = Eigen::Matrix2d::Identity();
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  double yaw = 0.0;
};

Rigid FromPose(const msgs::Pose2& p) {
  Rigid r;
  r.yaw = p.yaw_rad;
  r.R = Eigen::Rotation2Dd(p.yaw_rad).toRotationMatrix();
  r.t = {p.x_m, p.y_m};
  return r;
}

msgs::Pose2 ToPose(const Rigid& r) {
  return msgs::Pose2{r.t.x(), r.t.y(), std::remainder(r.yaw, 2.0 * M_PI)};
}

// delta * current.
Rigid ComposeLeft(const Rigid& delta, const Rigid& current) {
  Rigid r;
  r.yaw = delta.yaw + current.yaw;
  r.R = Eigen::Rotation2Dd(r.yaw).toRotationMatrix();
  r.t = delta.R * current.t + delta.t;
  return r;
}

struct Pair {
  int source;
  int target;
  double distance2;
};

// Closed-form rigid alignment of paired points (2D Kabsch / Horn).
Rigid SolvePointToPoint(const Cloud2& moved, const Cloud2& target, const std::vector<Pair>& pairs) {
  Eigen::Vector2d ms = Eigen::Vector2d::Zero(), mt = Eigen::Vector2d::Zero();
  for (const Pair& p : pairs) {
    ms += moved[p.source];
    mt += target[p.target];
  }
  ms /= static_cast<double>(pairs.size());
  mt /= static_cast<double>(pairs.size());
  double sc = 0.0, ss = 0.0;  // sum of dot and cross products of centred pairs
  for (const Pair& p : pairs) {
    const Eigen::Vector2d a = moved[p.source] - ms, b = target[p.target] - mt;
    sc += a.dot(b);
    ss += a.x() * b.y() - a.y() * b.x();
  }
  Rigid d;
  d.yaw = std::atan2(ss, sc);
  d.R = Eigen::Rotation2Dd(d.yaw).toRotationMatrix();
  d.t = mt - d.R * ms;
  return d;
}

// One Gauss-Newton step of sum (n_i . (p_i + t + theta S p_i - q_i))^2, small-angle
// linearised about the identity (left perturbation).
Rigid SolvePointToLine(const Cloud2& moved, IcpTarget& target, const std::vector<Pair>& pairs,
                       int neighbors) {
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  for (const Pair& p : pairs) {
    const Eigen::Vector2d& n = target.Normal(p.target, neighbors);
    const Eigen::Vector2d& s = moved[p.source];
    const Eigen::Vector3d J(n.x(), n.y(), n.x() * -s.y() + n.y() * s.x());
    const double r = n.dot(s - target.points()[p.target]);
    H += J * J.transpose();
    g += J * r;
  }
  H.diagonal().array() += 1e-9 * (1.0 + H.trace());
  const Eigen::Vector3d x = -H.ldlt().solve(g);
  Rigid d;
  d.yaw = x.z();
  d.R = Eigen::Rotation2Dd(d.yaw).toRotationMatrix();
  d.t = x.head<2>();
  return d;
}

}  // namespace

IcpTarget::IcpTarget(Cloud2 points) : points_(std::move(points)) {
  tree_.Build(points_);
  normals_.resize(points_.size());
  has_normal_.assign(points_.size(), 0);
}

const Eigen::Vector2d& IcpTarget::Normal(int i, int neighbors) {
  if (!has_normal_[i]) {
    tree_.KNearest(points_[i], std::max(neighbors, 2), &scratch_);
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (int j : scratch_) mean += points_[j];
    mean /= static_cast<double>(scratch_.size());
    Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
    for (int j : scratch_) C += (points_[j] - mean) * (points_[j] - mean).transpose();
    // Normal = eigenvector of the smallest eigenvalue (closed form for 2x2).
    const double a = C(0, 0), b = C(0, 1), c = C(1, 1);
    const double major = 0.5 * std::atan2(2.0 * b, a - c);  // direction of the largest spread
    normals_[i] = Eigen::Vector2d(-std::sin(major), std::cos(major));
    has_normal_[i] = 1;
  }
  return normals_[i];
}

double OverlapRatio(const Cloud2& source, const KdTree2& target, const msgs::Pose2& T_target_source,
                    double max_distance_m) {
  if (source.empty()) return 0.0;
  const Rigid T = FromPose(T_target_source);
  const double max2 = max_distance_m * max_distance_m;
  int hits = 0;
  for (const Eigen::Vector2d& p : source) {
    hits += target.Nearest(T.R * p + T.t, max2, nullptr) >= 0;
  }
  return static_cast<double>(hits) / static_cast<double>(source.size());
}

namespace {

// Correspondences of the source moved by T: the nearest target point within the maximum
// distance, then the closest trim_fraction of them. False when fewer than
// min_correspondences remain. With `within` set, *within counts the source points whose
// nearest target point is within sqrt(within2) (no more than the maximum distance): the
// overlap's count, from the same queries.
bool Match(const Cloud2& source, const Rigid& T, const KdTree2& tree, const IcpOptions& o,
           Cloud2* moved, std::vector<Pair>* pairs, double within2 = 0.0, int* within = nullptr) {
  const double max2 = o.max_correspondence_distance_m * o.max_correspondence_distance_m;
  for (std::size_t i = 0; i < source.size(); ++i) (*moved)[i] = T.R * source[i] + T.t;
  pairs->clear();
  int hits = 0;
  for (std::size_t i = 0; i < source.size(); ++i) {
    double d2;
    const int j = tree.Nearest((*moved)[i], max2, &d2);
    if (j >= 0) {
      pairs->push_back(Pair{static_cast<int>(i), j, d2});
      hits += d2 <= within2;
    }
  }
  if (within != nullptr) *within = hits;
  const auto keep = static_cast<std::size_t>(std::ceil(o.trim_fraction * pairs->size()));
  if (keep < pairs->size()) {
    std::nth_element(pairs->begin(), pairs->begin() + keep, pairs->end(),
                     [](const Pair& a, const Pair& b) { return a.distance2 < b.distance2; });
    pairs->resize(keep);
  }
  return static_cast<int>(pairs->size()) >= o.min_correspondences;
}

// draco's ICP iterations from T; fills valid, converged, iterations.
Rigid IterateDraco(const Cloud2& source, IcpTarget& target, Rigid T, const IcpOptions& o,
                   Cloud2* moved, std::vector<Pair>* pairs, IcpResult* result) {
  std::vector<double> dt_hist, dr_hist;
  result->valid = true;
  for (int it = 0; it < o.max_iterations; ++it) {
    if (!Match(source, T, target.tree(), o, moved, pairs)) {
      result->valid = false;
      break;
    }
    const Rigid d = o.metric == Metric::kPointToPoint
                        ? SolvePointToPoint(*moved, target.points(), *pairs)
                        : SolvePointToLine(*moved, target, *pairs, o.normal_neighbors);
    T = ComposeLeft(d, T);
    result->iterations = it + 1;
    // Size of the change of T (the translation change includes the rotation's effect on t).
    dt_hist.push_back((d.R * Eigen::Vector2d::Zero() + d.t).norm());
    dr_hist.push_back(std::abs(d.yaw));
    const int w = std::max(o.convergence_window, 1);
    if (static_cast<int>(dt_hist.size()) >= w) {
      double mt = 0.0, mr = 0.0;
      for (int k = 0; k < w; ++k) {
        mt += dt_hist[dt_hist.size() - 1 - k];
        mr += dr_hist[dr_hist.size() - 1 - k];
      }
      if (mt / w < o.convergence_translation_m && mr / w < o.convergence_rotation_rad) {
        result->converged = true;
        break;
      }
    }
  }
  return T;
}

}  // namespace

IcpResult AlignIcp(const Cloud2& source, IcpTarget& target,
                   const msgs::Pose2& initial_T_target_source, const IcpOptions& o) {
  IcpResult result;
  const Cloud2& tp = target.points();
  if (source.empty() || tp.empty()) {
    result.T_target_source = initial_T_target_source;
    return result;
  }
  Cloud2 moved(source.size());
  std::vector<Pair> pairs;
  pairs.reserve(source.size());
  Rigid T;
  if (o.backend == Backend::kDraco) {
    T = IterateDraco(source, target, FromPose(initial_T_target_source), o, &moved, &pairs, &result);
  } else {
    detail::BackendAnswer a;
    switch (o.backend) {
      case Backend::kPclIcp:
        a = detail::AlignPclIcp(source, target, initial_T_target_source, o);
        break;
      case Backend::kPclGicp:
        a = detail::AlignPclGicp(source, target, initial_T_target_source, o);
        break;
      case Backend::kMrptIcp:
        a = detail::AlignMrptIcp(source, target, initial_T_target_source, o);
        break;
      case Backend::kPclNdt:
      default:
        a = detail::AlignPclNdt(source, target, initial_T_target_source, o);
        break;
    }
    result.valid = a.valid;
    result.converged = a.converged;
    result.iterations = a.iterations;
    T = FromPose(a.valid ? a.T_target_source : initial_T_target_source);
  }
  result.T_target_source = ToPose(T);
  // The overlap comes from the final correspondences' queries when its distance is within
  // theirs (the defaults: 0.5 against 3 m), otherwise from its own queries below. Either way
  // it is the share of source points with a target point within overlap_distance_m, moved
  // by T (FromPose(ToPose(T)) is T itself for a yaw in [-pi, pi]).
  const bool overlap_in_match = o.overlap_distance_m <= o.max_correspondence_distance_m;
  int overlap_hits = 0;
  if (!result.valid || !Match(source, T, target.tree(), o, &moved, &pairs,
                              overlap_in_match ? o.overlap_distance_m * o.overlap_distance_m : 0.0,
                              overlap_in_match ? &overlap_hits : nullptr)) {
    result.valid = false;
    return result;
  }

  // Residuals and covariance on the final correspondences (IcpOptions::covariance).
  double sum2 = 0.0, line2 = 0.0;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (const Pair& p : pairs) {
    const Eigen::Vector2d e = moved[p.source] - tp[p.target];
    sum2 += e.squaredNorm();
    if (!o.covariance) continue;
    const Eigen::Vector2d& n = target.Normal(p.target, o.normal_neighbors);
    const double r = n.dot(e);
    line2 += r * r;
    // d(moved)/d(right perturbation): [R, R S p] with S p = (-p_y, p_x).
    const Eigen::Vector2d& s = source[p.source];
    const Eigen::Vector2d rsp = T.R * Eigen::Vector2d(-s.y(), s.x());
    const Eigen::Vector2d nr = T.R.transpose() * n;
    const Eigen::Vector3d J(nr.x(), nr.y(), n.dot(rsp));
    H += J * J.transpose();
  }
  const double m = static_cast<double>(pairs.size());
  result.correspondences = static_cast<int>(pairs.size());
  result.rmse_m = std::sqrt(sum2 / m);
  if (o.covariance) {
    const double sigma2 =
        std::max(line2 / std::max(m - 3.0, 1.0), o.min_residual_sigma_m * o.min_residual_sigma_m);
    H.diagonal().array() += o.information_regularization;
    const Eigen::Matrix3d cov = sigma2 * H.inverse();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) result.covariance[i * 3 + j] = 0.5 * (cov(i, j) + cov(j, i));
    }
  }
  result.overlap_ratio =
      overlap_in_match
          ? static_cast<double>(overlap_hits) / static_cast<double>(source.size())
          : OverlapRatio(source, target.tree(), result.T_target_source, o.overlap_distance_m);
  return result;
}

IcpResult AlignIcp(const Cloud2& source, const Cloud2& target,
                   const msgs::Pose2& initial_T_target_source, const IcpOptions& options) {
  IcpTarget prepared(target);
  return AlignIcp(source, prepared, initial_T_target_source, options);
}

const std::vector<std::string>& BackendNames() {
  static const std::vector<std::string> names{"draco", "pcl_icp", "pcl_gicp", "pcl_ndt",
                                              "mrpt_icp"};
  return names;
}

const char* BackendName(Backend backend) {
  return BackendNames()[static_cast<std::size_t>(backend)].c_str();
}

Backend ParseBackend(std::string_view name) {
  const auto& names = BackendNames();
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (name == names[i]) return static_cast<Backend>(i);
  }
  std::string choices;
  for (const auto& n : names) choices += (choices.empty() ? "" : ", ") + n;
  throw std::invalid_argument("registration back end '" + std::string(name) +
                              "' is not one of: " + choices);
}

Cloud2 ToCloud(const std::vector<msgs::Point2>& points) {
  Cloud2 out;
  out.reserve(points.size());
  for (const auto& p : points) out.emplace_back(p.x_m, p.y_m);
  return out;
}

}  // namespace draco::icp
