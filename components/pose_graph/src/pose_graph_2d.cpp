// Building a PoseGraph2d (pose_graph_2d.hpp): poses, priors and between factors, points with
// their optional radius, point observations, and reading them back. The state is in
// pose_graph_impl.hpp; solves are in pose_graph_optimize.cpp, covariances in
// pose_graph_covariance.cpp.
#include "draco/pose_graph/pose_graph_2d.hpp"

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <ceres/loss_function.h>

#include "pose_graph_impl.hpp"
#include "se2_cost.hpp"

namespace draco::pose_graph {

std::string_view ToString(FactorKind kind) {
  switch (kind) {
    case FactorKind::kPrior:
      return "prior";
    case FactorKind::kOdometry:
      return "odometry";
    case FactorKind::kScanMatch:
      return "scan_match";
    case FactorKind::kLoop:
      return "loop";
    case FactorKind::kInterRobot:
      return "inter_robot";
  }
  return "unknown";
}

namespace {

using internal::ToPose;

std::unique_ptr<ceres::LossFunction> MakeLoss(const RobustLoss& loss) {
  switch (loss.kind) {
    case LossKind::kNone:
      return nullptr;
    case LossKind::kHuber:
      return std::make_unique<ceres::HuberLoss>(loss.scale);
    case LossKind::kCauchy:
      return std::make_unique<ceres::CauchyLoss>(loss.scale);
  }
  return nullptr;
}

}  // namespace

PoseGraph2d::PoseGraph2d(ErrorConvention convention) : impl_(std::make_unique<Impl>()) {
  impl_->convention = convention;
}
PoseGraph2d::~PoseGraph2d() = default;
PoseGraph2d::PoseGraph2d(PoseGraph2d&&) noexcept = default;
PoseGraph2d& PoseGraph2d::operator=(PoseGraph2d&&) noexcept = default;

void PoseGraph2d::AddPose(PoseId id, const Pose2& T_world_pose) {
  auto& m = *impl_;
  if (m.index.count(id) != 0) {
    throw std::invalid_argument("pose " + std::to_string(id) + " already in graph");
  }
  m.index.emplace(id, m.nodes.size());
  Impl::Node& n = m.nodes.emplace_back();
  n.id = id;
  n.x = {T_world_pose.x_m, T_world_pose.y_m, NormalizeAngle(T_world_pose.yaw_rad)};
}

bool PoseGraph2d::HasPose(PoseId id) const { return impl_->index.count(id) != 0; }
std::size_t PoseGraph2d::NumPoses() const { return impl_->nodes.size(); }

std::vector<PoseId> PoseGraph2d::PoseIds() const {
  std::vector<PoseId> ids;
  ids.reserve(impl_->nodes.size());
  for (const auto& n : impl_->nodes) ids.push_back(n.id);
  return ids;
}

Pose2 PoseGraph2d::Pose(PoseId id) const { return ToPose(impl_->nodes[impl_->Index(id)].x); }

void PoseGraph2d::SetPose(PoseId id, const Pose2& T_world_pose) {
  impl_->nodes[impl_->Index(id)].x = {T_world_pose.x_m, T_world_pose.y_m,
                                      NormalizeAngle(T_world_pose.yaw_rad)};
}

void PoseGraph2d::SetPoseConstant(PoseId id, bool constant) {
  auto& n = impl_->nodes[impl_->Index(id)];
  if (n.constant == constant) return;
  n.constant = constant;
  if (constant) {
    ++impl_->num_constant;
  } else {
    --impl_->num_constant;
  }
}

std::size_t PoseGraph2d::AddPrior(PoseId id, const Pose2& T_world_pose, const Matrix3& information,
                                  RobustLoss loss) {
  auto& m = *impl_;
  const std::size_t node = m.Index(id);
  Impl::FactorTerms t;
  t.cost =
      std::make_unique<internal::PriorCost>(T_world_pose, information, m.convention);  // validates
  t.loss = MakeLoss(loss);
  const std::size_t k = m.factors.size();
  m.factors.push_back({FactorKind::kPrior, id, id, T_world_pose, information, loss, std::nullopt});
  m.terms.push_back(std::move(t));
  m.nodes[node].factors.push_back(k);
  ++m.num_priors;
  return k;
}

std::size_t PoseGraph2d::AddBetween(PoseId i, PoseId j, const Pose2& T_i_j,
                                    const Matrix3& information, FactorKind kind, RobustLoss loss) {
  auto& m = *impl_;
  if (kind == FactorKind::kPrior) throw std::invalid_argument("use AddPrior for a prior");
  if (i == j)
    throw std::invalid_argument("between factor from pose " + std::to_string(i) + " to itself");
  const std::size_t ni = m.Index(i), nj = m.Index(j);
  Impl::FactorTerms t;
  t.cost = std::make_unique<internal::BetweenCost>(T_i_j, information, m.convention);
  t.loss = MakeLoss(loss);
  const std::size_t k = m.factors.size();
  m.factors.push_back({kind, i, j, T_i_j, information, loss, std::nullopt});
  m.terms.push_back(std::move(t));
  m.nodes[ni].factors.push_back(k);
  m.nodes[nj].factors.push_back(k);
  return k;
}

std::size_t PoseGraph2d::AddYawGaussMarkov(PoseId mean, PoseId previous, PoseId current, double phi,
                                           double sigma_rad, RobustLoss loss) {
  auto& m = *impl_;
  if (mean == previous || mean == current || previous == current) {
    throw std::invalid_argument("yaw Gauss-Markov factor: the three poses must differ");
  }
  const std::size_t nm = m.Index(mean), nb = m.Index(previous), nc = m.Index(current);
  Impl::FactorTerms t;
  t.cost = std::make_unique<internal::YawGaussMarkovCost>(phi, sigma_rad);  // validates
  t.loss = MakeLoss(loss);
  const std::size_t k = m.factors.size();
  m.factors.push_back({FactorKind::kOdometry, previous, current, Pose2{},
                       Diagonal3(0.0, 0.0, 1.0 / (sigma_rad * sigma_rad)), loss,
                       YawGaussMarkov{mean, phi, sigma_rad}});
  m.terms.push_back(std::move(t));
  m.nodes[nm].factors.push_back(k);
  m.nodes[nb].factors.push_back(k);
  m.nodes[nc].factors.push_back(k);
  return k;
}

const std::vector<Factor>& PoseGraph2d::Factors() const { return impl_->factors; }

void PoseGraph2d::AddPoint(PointId id, const Point2& p_world,
                           std::optional<PointRadiusPrior> radius) {
  auto& m = *impl_;
  if (m.point_index.count(id) != 0) {
    throw std::invalid_argument("point " + std::to_string(id) + " already in graph");
  }
  std::unique_ptr<ceres::CostFunction> radius_cost;
  if (radius) {
    if (!(radius->max_m > 0.0) || !(radius->prior_m >= 0.0) || radius->prior_m > radius->max_m) {
      throw std::invalid_argument("point " + std::to_string(id) +
                                  ": radius prior must lie in [0, max_m], max_m > 0");
    }
    radius_cost.reset(internal::NewRadiusPriorCost(radius->prior_m, radius->sigma_m));
  }
  m.point_index.emplace(id, m.points.size());
  Impl::PointNode& n = m.points.emplace_back();
  n.id = id;
  n.x = {p_world.x_m, p_world.y_m};
  n.radius = radius;
  n.radius_cost = std::move(radius_cost);
  if (radius) n.rho[0] = radius->prior_m;
}

std::optional<double> PoseGraph2d::PointRadius(PointId id) const {
  const auto& q = impl_->points[impl_->PointIndex(id)];
  if (!q.radius) return std::nullopt;
  return q.rho[0];
}

bool PoseGraph2d::HasPoint(PointId id) const { return impl_->point_index.count(id) != 0; }
std::size_t PoseGraph2d::NumPoints() const { return impl_->points.size(); }

Point2 PoseGraph2d::Point(PointId id) const {
  const auto& x = impl_->points[impl_->PointIndex(id)].x;
  return {x[0], x[1]};
}

void PoseGraph2d::SetPoint(PointId id, const Point2& p_world) {
  impl_->points[impl_->PointIndex(id)].x = {p_world.x_m, p_world.y_m};
}

std::size_t PoseGraph2d::AddPointObservation(PoseId pose, PointId point, const Point2& p_pose,
                                             const Matrix2& information, RobustLoss loss) {
  auto& m = *impl_;
  const std::size_t ni = m.Index(pose), np = m.PointIndex(point);
  std::unique_ptr<ceres::CostFunction> cost;  // both validate the information
  if (m.points[np].radius) {
    cost.reset(internal::NewPointRadiusObservationCost(p_pose, information));
  } else {
    cost = std::make_unique<internal::PointObservationCost>(p_pose, information);
  }
  const std::size_t k = m.observations.size();
  m.observations.push_back({pose, point, p_pose, information, loss});
  m.observation_costs.push_back(std::move(cost));
  m.observation_losses.push_back(MakeLoss(loss));
  m.nodes[ni].observations.push_back(k);
  m.points[np].observations.push_back(k);
  return k;
}

const std::vector<PointObservation>& PoseGraph2d::PointObservations() const {
  return impl_->observations;
}

double PoseGraph2d::PointObservationChi2(std::size_t observation_index) const {
  return impl_->ObservationChi2(impl_->observations.at(observation_index));
}
std::size_t PoseGraph2d::NumFactors() const { return impl_->factors.size(); }
ErrorConvention PoseGraph2d::Convention() const { return impl_->convention; }

}  // namespace draco::pose_graph
