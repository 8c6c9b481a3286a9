#include "draco/consistency/pairwise.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include <Eigen/Cholesky>

namespace draco::consistency {

const char* CovarianceModelName(CovarianceModel model) {
  return model == CovarianceModel::kFirstLoop ? "first-loop" : "propagated";
}

void ChainPoseSource::AddKeyframe(int robot, const Pose2& T_map_kf,
                                  const Eigen::Matrix3d& step_covariance) {
  Chain& chain = chains_[robot];
  if (chain.poses.empty()) {
    chain.cumulative.push_back(Eigen::Matrix3d::Zero());
  } else {
    // T_0_k = T_0_{k-1} * step: the step's covariance in the first keyframe's frame.
    const Pose2 T_0_prev = Between(chain.poses.front(), chain.poses.back());
    const Pose2 step = Between(chain.poses.back(), T_map_kf);
    Eigen::Matrix3d J_a;
    Eigen::Matrix3d J_b;
    Compose(T_0_prev, step, &J_a, &J_b);
    chain.cumulative.push_back(J_a * chain.cumulative.back() * J_a.transpose() +
                               J_b * step_covariance * J_b.transpose());
  }
  chain.from_first.push_back(chain.poses.empty() ? Pose2{}
                                                 : Between(chain.poses.front(), T_map_kf));
  chain.poses.push_back(T_map_kf);
}

void ChainPoseSource::SetMapTransform(int own_robot, int teammate,
                                      const UncertainPose& T_own_teammate) {
  map_transforms_[{own_robot, teammate}] = T_own_teammate;
}

int ChainPoseSource::NumKeyframes(int robot) const {
  const auto it = chains_.find(robot);
  return it == chains_.end() ? 0 : static_cast<int>(it->second.poses.size());
}

const Pose2& ChainPoseSource::KeyframePose(int robot, int keyframe) const {
  return chains_.at(robot).poses.at(static_cast<std::size_t>(keyframe));
}

std::optional<UncertainPose> ChainPoseSource::Relative(int robot, int from_keyframe,
                                                       int to_keyframe) const {
  const auto it = chains_.find(robot);
  if (it == chains_.end()) return std::nullopt;
  const Chain& chain = it->second;
  const int n = static_cast<int>(chain.poses.size());
  if (from_keyframe < 0 || to_keyframe < 0 || from_keyframe >= n || to_keyframe >= n) {
    return std::nullopt;
  }
  const bool forward = from_keyframe <= to_keyframe;
  const int lo = forward ? from_keyframe : to_keyframe;
  const int hi = forward ? to_keyframe : from_keyframe;
  // T_0_hi = T_0_lo * T_lo_hi with T_lo_hi independent of T_0_lo: solve for Cov(T_lo_hi).
  const Pose2& T_0_lo = chain.from_first[static_cast<std::size_t>(lo)];
  UncertainPose rel;
  rel.pose =
      Between(chain.poses[static_cast<std::size_t>(lo)], chain.poses[static_cast<std::size_t>(hi)]);
  Eigen::Matrix3d J_a;
  Eigen::Matrix3d J_b;
  Compose(T_0_lo, rel.pose, &J_a, &J_b);
  const Eigen::Matrix3d rest =
      chain.cumulative[static_cast<std::size_t>(hi)] -
      J_a * chain.cumulative[static_cast<std::size_t>(lo)] * J_a.transpose();
  // J_b is a rotation (block): its inverse is its transpose.
  rel.covariance = J_b.transpose() * rest * J_b;
  rel.covariance = 0.5 * (rel.covariance + rel.covariance.transpose()).eval();
  if (forward) return rel;
  return Inverse(rel);
}

std::optional<UncertainPose> ChainPoseSource::MapTransform(int own_robot, int teammate) const {
  const auto it = map_transforms_.find({own_robot, teammate});
  if (it == map_transforms_.end()) return std::nullopt;
  return it->second;
}

std::optional<UncertainPose> ChainPoseSource::InMap(int robot, int keyframe) const {
  const auto it = chains_.find(robot);
  if (it == chains_.end()) return std::nullopt;
  const Chain& chain = it->second;
  if (keyframe < 0 || keyframe >= static_cast<int>(chain.poses.size())) return std::nullopt;
  // T_map_k = T_map_0 * T_0_k with T_map_0 fixed: the covariance rotated into the map frame.
  Eigen::Matrix3d J_b;
  Compose(chain.poses.front(), chain.from_first[static_cast<std::size_t>(keyframe)], nullptr, &J_b);
  UncertainPose p;
  p.pose = chain.poses[static_cast<std::size_t>(keyframe)];
  p.covariance = J_b * chain.cumulative[static_cast<std::size_t>(keyframe)] * J_b.transpose();
  return p;
}

PoseSource::Chain ChainPoseSource::OpenChain(int robot) const {
  const auto it = chains_.find(robot);
  if (it == chains_.end()) return {};
  return {&it->second.from_first, &it->second.cumulative};
}

PreparedLoop Prepare(const msgs::InterRobotLoop& loop, const PoseSource& poses) {
  PreparedLoop p;
  p.loop = loop;
  p.z = {loop.T_ownkf_teammatekf, ToMatrix(loop.covariance)};
  p.z_inverse = Inverse(p.z);
  // Positive definiteness by Cholesky (scale-free; a determinant threshold would reject
  // tight but valid covariances).
  const Eigen::LLT<Eigen::Matrix3d> llt(p.z.covariance);
  p.information_valid = llt.info() == Eigen::Success;
  if (p.information_valid) p.information = llt.solve(Eigen::Matrix3d::Identity());
  const auto T_a_b = poses.MapTransform(loop.own_robot, loop.teammate_robot);
  const auto x_b = poses.InMap(loop.teammate_robot, loop.teammate_keyframe);
  if (T_a_b && x_b) {
    p.in_own_map = true;
    p.teammate_in_own_map = Compose(*T_a_b, *x_b);
  }
  return p;
}

PairwiseResult TestPair(const PreparedLoop& p1, const PreparedLoop& p2, const PoseSource& poses,
                        const PairwiseOptions& options) {
  const msgs::InterRobotLoop& z1 = p1.loop;
  const msgs::InterRobotLoop& z2 = p2.loop;
  if (z1.own_robot != z2.own_robot) {
    throw std::invalid_argument("TestPair: loops of different own robots");
  }
  PairwiseResult result;
  const auto x_own = poses.Relative(z1.own_robot, z1.own_keyframe, z2.own_keyframe);
  if (!x_own) return result;

  // x_{c_l b_k}: the second loop's teammate keyframe to the first's.
  std::optional<UncertainPose> x_team;
  if (z1.teammate_robot == z2.teammate_robot) {
    x_team = poses.Relative(z1.teammate_robot, z2.teammate_keyframe, z1.teammate_keyframe);
  } else if (p1.in_own_map && p2.in_own_map) {
    // inv(T_{a_0 c_l}) * T_{a_0 b_k}, the map transforms of the two teammates independent.
    x_team = Compose(Inverse(p2.teammate_in_own_map), p1.teammate_in_own_map);
  }
  if (!x_team) return result;
  result.evaluated = true;

  if (options.covariance == CovarianceModel::kFirstLoop) {
    const Pose2 e =
        Compose(Compose(p1.z_inverse.pose, x_own->pose), Compose(p2.z.pose, x_team->pose));
    result.error = ErrorVector(e);
    if (!p1.information_valid) return result;
    result.mahalanobis_squared = result.error.dot(p1.information * result.error);
  } else {
    const UncertainPose e = Compose(Compose(p1.z_inverse, *x_own), Compose(p2.z, *x_team));
    result.error = ErrorVector(e.pose);
    const Eigen::LLT<Eigen::Matrix3d> llt(e.covariance);
    if (llt.info() != Eigen::Success) return result;  // evaluated, inconsistent
    result.mahalanobis_squared = llt.matrixL().solve(result.error).squaredNorm();
  }
  result.consistent = result.mahalanobis_squared < options.chi2_threshold;
  return result;
}

PairwiseResult TestMapPrior(const PreparedLoop& z, const PoseSource& poses,
                            const PairwiseOptions& options) {
  PairwiseResult result;
  if (!z.in_own_map) return result;
  const auto own = poses.InMap(z.loop.own_robot, z.loop.own_keyframe);
  if (!own) return result;
  result.evaluated = true;
  const UncertainPose e = Compose(Compose(*own, z.z), Inverse(z.teammate_in_own_map));
  result.error = ErrorVector(e.pose);
  const Eigen::LLT<Eigen::Matrix3d> llt(e.covariance);
  if (llt.info() != Eigen::Success) return result;
  result.mahalanobis_squared = llt.matrixL().solve(result.error).squaredNorm();
  result.consistent = result.mahalanobis_squared < options.chi2_threshold;
  return result;
}

PairwiseResult TestPair(const msgs::InterRobotLoop& z1, const msgs::InterRobotLoop& z2,
                        const PoseSource& poses, const PairwiseOptions& options) {
  return TestPair(Prepare(z1, poses), Prepare(z2, poses), poses, options);
}

namespace {

// Covariances as left perturbations: a pose T with additive-parameter covariance C has
// T' = Exp(xi) * T with xi = L(t) d, L(t) = [1 0 t_y; 0 1 -t_x; 0 0 1]; an SE(2) adjoint is
// Ad(T) = L(t) * diag(R, 1). In these terms a chain's relative covariance is a difference of
// the keyframes' covariances in the chain's first frame, and the cycle error's covariance is
// a sum of per-loop terms with one transport by the adjoint of a per-loop transform.

Sym3 ToSym3(const Eigen::Matrix3d& m) {
  return {m(0, 0), 0.5 * (m(0, 1) + m(1, 0)), 0.5 * (m(0, 2) + m(2, 0)),
          m(1, 1), 0.5 * (m(1, 2) + m(2, 1)), m(2, 2)};
}

Sym3 operator+(const Sym3& a, const Sym3& b) {
  return {a.xx + b.xx, a.xy + b.xy, a.xt + b.xt, a.yy + b.yy, a.yt + b.yt, a.tt + b.tt};
}
Sym3 operator-(const Sym3& a, const Sym3& b) {
  return {a.xx - b.xx, a.xy - b.xy, a.xt - b.xt, a.yy - b.yy, a.yt - b.yt, a.tt - b.tt};
}

// diag(R, 1) * S * diag(R, 1)^T, R = [c -s; s c].
Sym3 Rotate(const Sym3& m, double c, double s) {
  const double cc = c * c;
  const double ss = s * s;
  const double cs = c * s;
  return {cc * m.xx - 2.0 * cs * m.xy + ss * m.yy,
          cs * (m.xx - m.yy) + (cc - ss) * m.xy,
          c * m.xt - s * m.yt,
          ss * m.xx + 2.0 * cs * m.xy + cc * m.yy,
          s * m.xt + c * m.yt,
          m.tt};
}

// L(t) * S * L(t)^T.
Sym3 Shift(const Sym3& m, double tx, double ty) {
  const double a = ty;
  const double b = -tx;
  return {m.xx + 2.0 * a * m.xt + a * a * m.tt,
          m.xy + a * m.yt + b * m.xt + a * b * m.tt,
          m.xt + a * m.tt,
          m.yy + 2.0 * b * m.yt + b * b * m.tt,
          m.yt + b * m.tt,
          m.tt};
}

double FastWrap(double a) {
  constexpr double kPi = std::numbers::pi;
  while (a > kPi) a -= 2.0 * kPi;
  while (a <= -kPi) a += 2.0 * kPi;
  return a;
}

constexpr double kMargin = 1e-6;  // relative band around the threshold handed to TestPair

}  // namespace

bool PairTester::Reset(const std::vector<PreparedLoop>& loops, const PoseSource& poses,
                       const PairwiseOptions& options) {
  loops_ = &loops;
  poses_ = &poses;
  options_ = options;
  placed_.assign(loops.size(), Placed{});
  std::map<int, PoseSource::Chain> chains;
  auto chain = [&](int robot) {
    auto it = chains.find(robot);
    if (it == chains.end()) it = chains.emplace(robot, poses.OpenChain(robot)).first;
    return it->second;
  };
  for (std::size_t n = 0; n < loops.size(); ++n) {
    const PreparedLoop& l = loops[n];
    Placed& p = placed_[n];
    const PoseSource::Chain own = chain(l.loop.own_robot);
    const PoseSource::Chain team = chain(l.loop.teammate_robot);
    if (own.from_first == nullptr || team.from_first == nullptr) return false;
    p.teammate = l.loop.teammate_robot;
    p.own_keyframe = l.loop.own_keyframe;
    p.teammate_keyframe = l.loop.teammate_keyframe;
    p.information = ToSym3(l.information);
    p.information_valid = l.information_valid;
    const int i = l.loop.own_keyframe;
    p.own_ok = i >= 0 && i < static_cast<int>(own.from_first->size());
    if (!p.own_ok) continue;
    const Pose2& F = (*own.from_first)[static_cast<std::size_t>(i)];
    p.own = Shift(ToSym3((*own.covariance)[static_cast<std::size_t>(i)]), F.x_m, F.y_m);
    const Pose2 A = Compose(F, l.z.pose);
    p.ax = A.x_m;
    p.ay = A.y_m;
    p.ayaw = A.yaw_rad;
    p.ac = std::cos(A.yaw_rad);
    p.as = std::sin(A.yaw_rad);
    p.loop = Shift(Rotate(ToSym3(l.z.covariance), std::cos(F.yaw_rad), std::sin(F.yaw_rad)), A.x_m,
                   A.y_m);
    const int k = l.loop.teammate_keyframe;
    p.teammate_ok = k >= 0 && k < static_cast<int>(team.from_first->size());
    if (p.teammate_ok) {
      const Pose2& H = (*team.from_first)[static_cast<std::size_t>(k)];
      p.hx = H.x_m;
      p.hy = H.y_m;
      p.hyaw = H.yaw_rad;
      const Sym3 c = ToSym3((*team.covariance)[static_cast<std::size_t>(k)]);
      p.team = Shift(c, H.x_m, H.y_m);
      const Pose2 M = Compose(A, Inverse(H));
      p.mx = M.x_m;
      p.my = M.y_m;
      p.myaw = M.yaw_rad;
      p.mc = std::cos(M.yaw_rad);
      p.ms = std::sin(M.yaw_rad);
    }
    p.cross_ok = l.in_own_map;
    if (p.cross_ok) {
      const Pose2& Q = l.teammate_in_own_map.pose;
      p.qx = Q.x_m;
      p.qy = Q.y_m;
      p.qyaw = Q.yaw_rad;
      p.in_own = Shift(ToSym3(l.teammate_in_own_map.covariance), Q.x_m, Q.y_m);
      const Pose2 N = Compose(A, Inverse(Q));
      p.nx = N.x_m;
      p.ny = N.y_m;
      p.nyaw = N.yaw_rad;
      p.nc = std::cos(N.yaw_rad);
      p.ns = std::sin(N.yaw_rad);
    }
  }
  return true;
}

bool PairTester::Consistent(int a, int b) const {
  const Placed& p = placed_[static_cast<std::size_t>(a)];
  const Placed& q = placed_[static_cast<std::size_t>(b)];
  if (!p.own_ok || !q.own_ok) return false;
  // e = inv(A_p) * T * X: T = M_q, X = T_{b_0 b_k} (one teammate) or T = N_q, X = T_{a_0 b_k}.
  const bool same = p.teammate == q.teammate;
  double tx, ty, tyaw, tc, ts, xx, xy, xyaw;
  if (same) {
    if (!p.teammate_ok || !q.teammate_ok) return false;
    tx = q.mx, ty = q.my, tyaw = q.myaw, tc = q.mc, ts = q.ms;
    xx = p.hx, xy = p.hy, xyaw = p.hyaw;
  } else {
    if (!p.cross_ok || !q.cross_ok) return false;
    tx = q.nx, ty = q.ny, tyaw = q.nyaw, tc = q.nc, ts = q.ns;
    xx = p.qx, xy = p.qy, xyaw = p.qyaw;
  }
  const double yx = tx + tc * xx - ts * xy - p.ax;
  const double yy = ty + ts * xx + tc * xy - p.ay;
  const double ex = p.ac * yx + p.as * yy;
  const double ey = -p.as * yx + p.ac * yy;
  const double et = FastWrap(tyaw + xyaw - p.ayaw);
  const double threshold = options_.chi2_threshold;
  auto exact = [&]() {
    ++fallbacks_;
    return TestPair((*loops_)[static_cast<std::size_t>(a)], (*loops_)[static_cast<std::size_t>(b)],
                    *poses_, options_)
        .consistent;
  };

  if (options_.covariance == CovarianceModel::kFirstLoop) {
    if (!p.information_valid) return false;
    const Sym3& I = p.information;
    const double d2 = I.xx * ex * ex + I.yy * ey * ey + I.tt * et * et +
                      2.0 * (I.xy * ex * ey + I.xt * ex * et + I.yt * ey * et);
    if (std::abs(d2 - threshold) <= kMargin * threshold) return exact();
    return d2 < threshold;
  }

  // Covariance of the cycle as a left perturbation in the own map frame.
  const Sym3 own = p.own_keyframe <= q.own_keyframe ? q.own - p.own : p.own - q.own;
  Sym3 team;
  if (same) {
    team = p.teammate_keyframe <= q.teammate_keyframe ? q.team - p.team : p.team - q.team;
  } else {
    team = p.in_own + q.in_own;
  }
  // Bound from the yaw alone (the transport leaves the yaw variance unchanged): d2 >=
  // e_yaw^2 / S_yaw,yaw.
  const double tt = own.tt + p.loop.tt + q.loop.tt + team.tt;
  if (tt > 0.0 && et * et > (1.0 + kMargin) * threshold * tt) {
    ++early_outs_;
    return false;
  }
  const Sym3 S = own + p.loop + q.loop + Shift(Rotate(team, tc, ts), tx, ty);
  // The error as the same left perturbation: u = Ad(A_p) * L(t_e) * e.
  const double vx = ex + ey * et;
  const double vy = ey - ex * et;
  const double u0 = p.ac * vx - p.as * vy + et * p.ay;
  const double u1 = p.as * vx + p.ac * vy - et * p.ax;
  const double u2 = et;
  // LDL^T of S.
  const double d1 = S.xx;
  if (!(d1 > 0.0)) return exact();
  const double l10 = S.xy / d1;
  const double l20 = S.xt / d1;
  const double d2p = S.yy - l10 * S.xy;
  if (!(d2p > 1e-9 * S.yy)) return exact();
  const double r21 = S.yt - l20 * S.xy;
  const double l21 = r21 / d2p;
  const double d3 = S.tt - l20 * S.xt - l21 * r21;
  if (!(d3 > 1e-9 * S.tt)) return exact();
  const double y0 = u0;
  const double y1 = u1 - l10 * y0;
  const double y2 = u2 - l20 * y0 - l21 * y1;
  const double d2 = y0 * y0 / d1 + y1 * y1 / d2p + y2 * y2 / d3;
  if (std::abs(d2 - threshold) <= kMargin * threshold) return exact();
  return d2 < threshold;
}

}  // namespace draco::consistency
