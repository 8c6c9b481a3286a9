#include "draco/pose_graph/pose_graph_2d.hpp"

#include <algorithm>
#include <chrono>
#include <deque>
#include <stdexcept>
#include <unordered_map>

#include <ceres/covariance.h>
#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <Eigen/Core>

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

using Clock = std::chrono::steady_clock;
using Mat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

Pose2 ToPose(const std::array<double, 3>& x) { return {x[0], x[1], x[2]}; }

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

ceres::Problem::Options BorrowingProblemOptions() {
  ceres::Problem::Options options;
  options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

ceres::Solver::Options ToCeres(const SolverOptions& o) {
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type =
      o.algorithm == Algorithm::kDogleg ? ceres::DOGLEG : ceres::LEVENBERG_MARQUARDT;
  switch (o.linear_solver) {
    case LinearSolver::kSparseNormalCholesky:
      options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
      break;
    case LinearSolver::kDenseNormalCholesky:
      options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
      break;
    case LinearSolver::kDenseQr:
      options.linear_solver_type = ceres::DENSE_QR;
      break;
  }
  switch (o.sparse_backend) {
    case SparseBackend::kSuiteSparse:
      options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
      break;
    case SparseBackend::kEigenSparse:
      options.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
      break;
    case SparseBackend::kCxSparse:
      options.sparse_linear_algebra_library_type = ceres::CX_SPARSE;
      break;
  }
  options.use_mixed_precision_solves = o.mixed_precision;
  if (o.mixed_precision) options.max_num_refinement_iterations = 2;
  options.max_num_iterations = o.max_iterations;
  options.num_threads = o.num_threads;
  options.function_tolerance = o.function_tolerance;
  options.gradient_tolerance = o.gradient_tolerance;
  options.parameter_tolerance = o.parameter_tolerance;
  options.jacobi_scaling = o.jacobi_scaling;
  options.use_nonmonotonic_steps = o.nonmonotonic_steps;
  options.initial_trust_region_radius = o.initial_trust_region_radius;
  options.minimizer_progress_to_stdout = o.log_progress;
  options.logging_type = o.log_progress ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  return options;
}

}  // namespace

struct PoseGraph2d::Impl {
  struct Node {
    PoseId id = 0;
    std::array<double, 3> x{};  // Ceres parameter block; the deque keeps its address stable
    std::vector<std::size_t> factors;
    std::vector<std::size_t> observations;  // point observations made from this pose
    bool constant = false;
    bool in_problem = false;
  };
  struct PointNode {
    PointId id = 0;
    std::array<double, 2> x{};  // Ceres parameter block (world frame)
    std::vector<std::size_t> observations;
    bool in_problem = false;
    // Optional radius state (PointRadiusPrior) and its prior's cost.
    std::array<double, 1> rho{};
    std::optional<PointRadiusPrior> radius;
    std::unique_ptr<ceres::CostFunction> radius_cost;
  };
  struct FactorTerms {
    std::unique_ptr<ceres::CostFunction> cost;
    std::unique_ptr<ceres::LossFunction> loss;
  };

  std::deque<Node> nodes;
  std::unordered_map<PoseId, std::size_t> index;
  std::vector<Factor> factors;
  std::vector<FactorTerms> terms;
  std::deque<PointNode> points;
  std::unordered_map<PointId, std::size_t> point_index;
  std::vector<PointObservation> observations;
  std::vector<std::unique_ptr<ceres::CostFunction>> observation_costs;
  std::vector<std::unique_ptr<ceres::LossFunction>> observation_losses;
  std::size_t num_priors = 0;
  std::size_t num_constant = 0;
  ErrorConvention convention = ErrorConvention::kG2o;
  internal::Pose2Manifold manifold;

  // The persistent problem holds every node and the first factors_in_problem factors.
  std::unique_ptr<ceres::Problem> problem;
  std::size_t factors_in_problem = 0;
  std::size_t observations_in_problem = 0;
  std::size_t gauge_node_in_problem = SIZE_MAX;  // node the problem holds constant for gauge

  // Bookkeeping for Update().
  std::size_t factors_at_last_solve = 0;
  std::size_t observations_at_last_solve = 0;
  std::size_t nodes_at_last_full = 0;

  std::size_t Index(PoseId id) const {
    const auto it = index.find(id);
    if (it == index.end()) throw std::out_of_range("pose " + std::to_string(id) + " not in graph");
    return it->second;
  }

  // Ceres' covariance silently ignores a parameter block without residuals.
  void RequireFactors(PoseId id) const {
    const std::size_t k = Index(id);
    const Node& node = nodes[k];
    if (node.factors.empty() && node.observations.empty() && !node.constant &&
        !(NeedsAutoGauge() && k == 0)) {
      throw std::runtime_error("covariance: pose " + std::to_string(id) + " has no factor");
    }
  }

  bool NeedsAutoGauge() const { return num_priors == 0 && num_constant == 0 && !nodes.empty(); }

  double FactorChi2(const Factor& f) const {
    const Pose2 a = ToPose(nodes[Index(f.i)].x);
    if (f.kind == FactorKind::kPrior) {
      return internal::Chi2(internal::PriorError(a, f.measurement, convention), f.information);
    }
    const Pose2 b = ToPose(nodes[Index(f.j)].x);
    return internal::Chi2(internal::BetweenError(a, b, f.measurement, convention), f.information);
  }

  std::size_t PointIndex(PointId id) const {
    const auto it = point_index.find(id);
    if (it == point_index.end()) {
      throw std::out_of_range("point " + std::to_string(id) + " not in graph");
    }
    return it->second;
  }

  double ObservationChi2(const PointObservation& o) const {
    const Pose2 a = ToPose(nodes[Index(o.pose)].x);
    const PointNode& q = points[PointIndex(o.point)];
    const Point2 l{q.x[0], q.x[1]};
    return internal::Chi2(q.radius ? internal::PointRadiusError(a, l, q.rho[0], o.p_pose)
                                   : internal::PointError(a, l, o.p_pose),
                          o.information);
  }

  static double RadiusPriorChi2(const PointNode& q) {
    if (!q.radius) return 0.0;
    const double r = (q.rho[0] - q.radius->prior_m) / q.radius->sigma_m;
    return r * r;
  }

  // The radius block of point q with its prior and bounds (once per problem).
  static void AddRadiusBlock(ceres::Problem& p, PointNode& q) {
    if (!q.radius || p.HasParameterBlock(q.rho.data())) return;
    p.AddParameterBlock(q.rho.data(), 1);
    p.SetParameterLowerBound(q.rho.data(), 0, 0.0);
    p.SetParameterUpperBound(q.rho.data(), 0, q.radius->max_m);
    p.AddResidualBlock(q.radius_cost.get(), nullptr, q.rho.data());
  }

  template <typename Range>
  double SumChi2(const Range& factor_indices) const {
    double sum = 0.0;
    for (const std::size_t k : factor_indices) sum += FactorChi2(factors[k]);
    return sum;
  }

  double TotalChi2() const {
    double sum = 0.0;
    for (const Factor& f : factors) sum += FactorChi2(f);
    for (const PointObservation& o : observations) sum += ObservationChi2(o);
    for (const PointNode& q : points) sum += RadiusPriorChi2(q);
    return sum;
  }

  void AddObservationResidual(ceres::Problem& p, std::size_t k) {
    const PointObservation& o = observations[k];
    PointNode& q = points[point_index.at(o.point)];
    if (q.radius) {
      AddRadiusBlock(p, q);
      p.AddResidualBlock(observation_costs[k].get(), observation_losses[k].get(),
                         nodes[index.at(o.pose)].x.data(), q.x.data(), q.rho.data());
    } else {
      p.AddResidualBlock(observation_costs[k].get(), observation_losses[k].get(),
                         nodes[index.at(o.pose)].x.data(), q.x.data());
    }
  }

  void AddResidual(ceres::Problem& p, std::size_t k) {
    const Factor& f = factors[k];
    Node& a = nodes[index.at(f.i)];
    if (f.kind == FactorKind::kPrior) {
      p.AddResidualBlock(terms[k].cost.get(), terms[k].loss.get(), a.x.data());
    } else {
      Node& b = nodes[index.at(f.j)];
      p.AddResidualBlock(terms[k].cost.get(), terms[k].loss.get(), a.x.data(), b.x.data());
    }
  }

  // Brings the persistent problem up to date with the graph (new nodes, factors, constants).
  void SyncProblem() {
    if (!problem) problem = std::make_unique<ceres::Problem>(BorrowingProblemOptions());
    for (Node& n : nodes) {
      if (!n.in_problem) {
        problem->AddParameterBlock(n.x.data(), 3, &manifold);
        n.in_problem = true;
      }
    }
    for (PointNode& n : points) {
      if (!n.in_problem) {
        problem->AddParameterBlock(n.x.data(), 2);
        n.in_problem = true;
      }
    }
    for (; factors_in_problem < factors.size(); ++factors_in_problem) {
      AddResidual(*problem, factors_in_problem);
    }
    for (; observations_in_problem < observations.size(); ++observations_in_problem) {
      AddObservationResidual(*problem, observations_in_problem);
    }
    const std::size_t gauge = NeedsAutoGauge() ? 0 : SIZE_MAX;
    for (Node& n : nodes) {
      const std::size_t k = index.at(n.id);
      const bool want_constant = n.constant || k == gauge;
      if (want_constant != problem->IsParameterBlockConstant(n.x.data())) {
        if (want_constant) {
          problem->SetParameterBlockConstant(n.x.data());
        } else {
          problem->SetParameterBlockVariable(n.x.data());
        }
      }
    }
    gauge_node_in_problem = gauge;
  }

  SolveSummary Run(ceres::Problem& p, const SolverOptions& o) {
    ceres::Solver::Summary s;
    ceres::Solve(ToCeres(o), &p, &s);
    SolveSummary out;
    out.usable = s.IsSolutionUsable();
    out.converged = s.termination_type == ceres::CONVERGENCE;
    out.iterations = static_cast<int>(s.iterations.size()) - 1;
    out.initial_cost = s.initial_cost;
    out.final_cost = s.final_cost;
    out.report = o.full_report ? s.FullReport() : s.BriefReport();
    return out;
  }
};

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
  m.factors.push_back({FactorKind::kPrior, id, id, T_world_pose, information, loss});
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
  m.factors.push_back({kind, i, j, T_i_j, information, loss});
  m.terms.push_back(std::move(t));
  m.nodes[ni].factors.push_back(k);
  m.nodes[nj].factors.push_back(k);
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

std::size_t PoseGraph2d::InitializeFromSpanningTree(std::optional<PoseId> root) {
  auto& m = *impl_;
  if (m.nodes.empty()) return 0;
  const std::size_t r = root ? m.Index(*root) : 0;
  std::vector<char> seen(m.nodes.size(), 0);
  std::deque<std::size_t> queue{r};
  seen[r] = 1;
  std::size_t set = 0;
  while (!queue.empty()) {
    const std::size_t u = queue.front();
    queue.pop_front();
    const Pose2 T_w_u = ToPose(m.nodes[u].x);
    for (const std::size_t k : m.nodes[u].factors) {
      const Factor& f = m.factors[k];
      if (f.kind == FactorKind::kPrior) continue;
      const bool forward = m.index.at(f.i) == u;
      const std::size_t v = m.index.at(forward ? f.j : f.i);
      if (seen[v]) continue;
      seen[v] = 1;
      const Pose2 T_w_v = Compose(T_w_u, forward ? f.measurement : Inverse(f.measurement));
      m.nodes[v].x = {T_w_v.x_m, T_w_v.y_m, T_w_v.yaw_rad};
      ++set;
      queue.push_back(v);
    }
  }
  return set;
}

SolveSummary PoseGraph2d::Optimize(const SolverOptions& options) {
  auto& m = *impl_;
  const auto start = Clock::now();
  m.SyncProblem();
  const double chi2_before = m.TotalChi2();
  SolveSummary out = m.Run(*m.problem, options);
  out.full = true;
  out.factors = static_cast<int>(m.factors.size() + m.observations.size());
  out.variable_poses = 0;
  for (const auto& n : m.nodes) {
    if (!m.problem->IsParameterBlockConstant(n.x.data())) ++out.variable_poses;
  }
  out.initial_chi2 = chi2_before;
  out.final_chi2 = m.TotalChi2();
  m.factors_at_last_solve = m.factors.size();
  m.observations_at_last_solve = m.observations.size();
  m.nodes_at_last_full = m.nodes.size();
  out.time_s = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

SolveSummary PoseGraph2d::OptimizeWindow(int window_size, const SolverOptions& options) {
  auto& m = *impl_;
  const auto start = Clock::now();
  const std::size_t n = m.nodes.size();
  const std::size_t w =
      std::min<std::size_t>(n, static_cast<std::size_t>(std::max(window_size, 1)));
  const std::size_t first = n - w;
  // Factors touching the window, each once.
  std::vector<std::size_t> window_factors;
  for (std::size_t u = first; u < n; ++u) {
    for (const std::size_t k : m.nodes[u].factors) {
      const Factor& f = m.factors[k];
      // Count a factor at its newest window end only, so it is listed once.
      const std::size_t a = m.index.at(f.i), b = m.index.at(f.j);
      if (std::max(a, b) == u) window_factors.push_back(k);
    }
  }
  // Points observed from the window are free, with every observation of them (poses outside
  // the window held constant), so an old observation anchors them.
  std::vector<std::size_t> window_points;
  for (std::size_t u = first; u < n; ++u) {
    for (const std::size_t k : m.nodes[u].observations) {
      window_points.push_back(m.point_index.at(m.observations[k].point));
    }
  }
  std::sort(window_points.begin(), window_points.end());
  window_points.erase(std::unique(window_points.begin(), window_points.end()), window_points.end());
  std::vector<std::size_t> window_observations;
  for (const std::size_t q : window_points) {
    for (const std::size_t k : m.points[q].observations) window_observations.push_back(k);
  }
  ceres::Problem p(BorrowingProblemOptions());
  for (std::size_t u = first; u < n; ++u) p.AddParameterBlock(m.nodes[u].x.data(), 3, &m.manifold);
  for (const std::size_t k : window_factors) m.AddResidual(p, k);
  for (const std::size_t k : window_observations) m.AddObservationResidual(p, k);
  int variable = 0;
  for (std::size_t u = 0; u < n; ++u) {
    double* x = m.nodes[u].x.data();
    if (!p.HasParameterBlock(x)) continue;
    const bool outside = u < first;
    const bool gauge = u == 0 && m.NeedsAutoGauge();
    if (outside || gauge || m.nodes[u].constant) {
      p.SetParameterBlockConstant(x);
    } else {
      ++variable;
    }
  }
  auto observation_chi2 = [&] {
    double sum = 0.0;
    for (const std::size_t k : window_observations) sum += m.ObservationChi2(m.observations[k]);
    return sum;
  };
  const double chi2_before = m.SumChi2(window_factors) + observation_chi2();
  SolveSummary out;
  if (variable > 0 && !window_factors.empty()) {
    out = m.Run(p, options);
  } else {
    out.usable = out.converged = true;
  }
  out.initial_chi2 = chi2_before;
  out.full = false;
  out.variable_poses = variable;
  out.factors = static_cast<int>(window_factors.size() + window_observations.size());
  out.final_chi2 = m.SumChi2(window_factors) + observation_chi2();
  m.factors_at_last_solve = m.factors.size();
  m.observations_at_last_solve = m.observations.size();
  out.time_s = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

SolveSummary PoseGraph2d::Update(const IncrementalOptions& options) {
  auto& m = *impl_;
  const std::size_t n = m.nodes.size();
  const std::size_t w = static_cast<std::size_t>(std::max(options.window_size, 1));
  bool full = n <= w || m.nodes_at_last_full == 0;
  if (options.full_solve_every > 0 &&
      n - m.nodes_at_last_full >= static_cast<std::size_t>(options.full_solve_every)) {
    full = true;
  }
  if (!full && options.full_solve_on_loop) {
    const std::size_t first = n - w;
    for (std::size_t k = m.factors_at_last_solve; k < m.factors.size() && !full; ++k) {
      const Factor& f = m.factors[k];
      if (std::min(m.index.at(f.i), m.index.at(f.j)) < first) full = true;
    }
    // A point re-observed after it left the window closes a loop through the point.
    for (std::size_t k = m.observations_at_last_solve; k < m.observations.size() && !full; ++k) {
      for (const std::size_t o : m.points[m.point_index.at(m.observations[k].point)].observations) {
        if (m.index.at(m.observations[o].pose) < first) full = true;
      }
    }
  }
  return full ? Optimize(options.full) : OptimizeWindow(options.window_size, options.local);
}

double PoseGraph2d::Chi2() const { return impl_->TotalChi2(); }

double PoseGraph2d::FactorChi2(std::size_t factor_index) const {
  return impl_->FactorChi2(impl_->factors.at(factor_index));
}

std::vector<Matrix3> PoseGraph2d::RelativeCovariances(
    std::span<const std::pair<PoseId, PoseId>> pairs) {
  auto& m = *impl_;
  m.SyncProblem();
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::SPARSE_QR;
  co.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  co.num_threads = 2;
  ceres::Covariance covariance(co);
  std::vector<std::pair<const double*, const double*>> blocks;
  auto add_block = [&](const double* a, const double* b) {
    const std::pair<const double*, const double*> key = a <= b ? std::pair{a, b} : std::pair{b, a};
    if (std::find(blocks.begin(), blocks.end(), key) == blocks.end()) blocks.push_back(key);
  };
  for (const auto& [i, j] : pairs) {
    m.RequireFactors(i);
    m.RequireFactors(j);
    const double* a = m.nodes[m.Index(i)].x.data();
    const double* b = m.nodes[m.Index(j)].x.data();
    add_block(a, a);
    add_block(b, b);
    if (a != b) add_block(a, b);
  }
  if (!covariance.Compute(blocks, m.problem.get())) {
    throw std::runtime_error("covariance: the pose graph is rank-deficient (unconstrained poses?)");
  }
  std::vector<Matrix3> result;
  result.reserve(pairs.size());
  for (const auto& [i, j] : pairs) {
    const double* a = m.nodes[m.Index(i)].x.data();
    const double* b = m.nodes[m.Index(j)].x.data();
    Mat3 saa, sbb, sab;
    covariance.GetCovarianceBlock(a, a, saa.data());
    covariance.GetCovarianceBlock(b, b, sbb.data());
    covariance.GetCovarianceBlock(a, b, sab.data());
    // T_i_j = (R_a^T (p_b - p_a), yaw_b - yaw_a); local frame: rotate by R_b^T = R_ij^T R_a^T.
    const double ca = std::cos(a[2]), sa = std::sin(a[2]);
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    // Jacobians of the parameters of T_i_j w.r.t. a and b.
    Mat3 Ja, Jb;
    Ja << -ca, -sa, -sa * dx + ca * dy,  //
        sa, -ca, -ca * dx - sa * dy,     //
        0, 0, -1;
    Jb << ca, sa, 0,  //
        -sa, ca, 0,   //
        0, 0, 1;
    // Right perturbation of T_i_j: d_t = R_ij^T * (change of its translation).
    const double yij = b[2] - a[2];
    const double cij = std::cos(yij), sij = std::sin(yij);
    Mat3 G;
    G << cij, sij, 0, -sij, cij, 0, 0, 0, 1;
    const Mat3 A = G * Ja, B = G * Jb;
    const Mat3 cov = A * saa * A.transpose() + A * sab * B.transpose() +
                     B * sab.transpose() * A.transpose() + B * sbb * B.transpose();
    Matrix3 out;
    for (int k = 0; k < 9; ++k) out[k] = 0.5 * (cov(k / 3, k % 3) + cov(k % 3, k / 3));
    result.push_back(out);
  }
  return result;
}

Matrix3 PoseGraph2d::RelativeCovariance(PoseId i, PoseId j) {
  const std::pair<PoseId, PoseId> pair{i, j};
  return RelativeCovariances(std::span(&pair, 1)).front();
}

Matrix3 PoseGraph2d::MarginalCovariance(PoseId id) {
  auto& m = *impl_;
  m.RequireFactors(id);
  m.SyncProblem();
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::SPARSE_QR;
  co.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  ceres::Covariance covariance(co);
  const double* x = m.nodes[m.Index(id)].x.data();
  const std::vector<std::pair<const double*, const double*>> blocks{{x, x}};
  if (!covariance.Compute(blocks, m.problem.get())) {
    throw std::runtime_error("covariance: the pose graph is rank-deficient (unconstrained poses?)");
  }
  Matrix3 out;
  covariance.GetCovarianceBlock(x, x, out.data());
  return out;
}

}  // namespace draco::pose_graph
