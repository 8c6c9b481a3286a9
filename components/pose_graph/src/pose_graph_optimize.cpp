// Solving a PoseGraph2d (pose_graph_2d.hpp): SolverOptions as Ceres', the initial guess from a
// spanning tree, full and windowed solves and the incremental choice between them, chi2.
#include <algorithm>
#include <chrono>
#include <deque>
#include <vector>

#include <ceres/problem.h>
#include <ceres/solver.h>

#include "draco/pose_graph/pose_graph_2d.hpp"
#include "pose_graph_impl.hpp"

namespace draco::pose_graph {
namespace {

using Clock = std::chrono::steady_clock;
using internal::BorrowingProblemOptions;
using internal::ToPose;

}  // namespace

namespace internal {

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
  options.max_num_line_search_step_size_iterations = o.bounded_line_search_iterations;
  options.initial_trust_region_radius = o.initial_trust_region_radius;
  options.minimizer_progress_to_stdout = o.log_progress;
  options.logging_type = o.log_progress ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  return options;
}

}  // namespace internal

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
      if (f.kind == FactorKind::kPrior || f.yaw_gauss_markov) continue;
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
  m.full_pending = false;
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
      // Count a factor at its newest window end only, so it is listed once.
      if (m.NewestNode(m.factors[k]) == u) window_factors.push_back(k);
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
  const bool forced = full;
  if (!full && options.full_solve_on_loop) {
    const std::size_t first = n - w;
    for (std::size_t k = m.factors_at_last_solve; k < m.factors.size() && !full; ++k) {
      if (m.OldestNode(m.factors[k]) < first) full = true;
    }
    // A point re-observed after it left the window closes a loop through the point.
    for (std::size_t k = m.observations_at_last_solve; k < m.observations.size() && !full; ++k) {
      for (const std::size_t o : m.points[m.point_index.at(m.observations[k].point)].observations) {
        if (m.index.at(m.observations[o].pose) < first) full = true;
      }
    }
  }
  if (full && m.nodes_at_last_full > 0 && !(n <= w) && options.full_solve_min_poses > 1 &&
      n - m.nodes_at_last_full < static_cast<std::size_t>(options.full_solve_min_poses)) {
    m.full_pending = true;  // OptimizeWindow forgets the trigger: remembered here
    full = false;
  } else if (!full && m.full_pending &&
             n - m.nodes_at_last_full >= static_cast<std::size_t>(options.full_solve_min_poses)) {
    full = true;
  }
  if (full && !forced && options.full_solve_max_boundary_chi2 > 0.0) {
    // Try the window first (not forced, so n > w): a loop that agrees with the older graph
    // needs no full solve.
    SolveSummary local = OptimizeWindow(options.window_size, options.local);
    if (local.usable && m.MaxBoundaryChi2(n - w) <= options.full_solve_max_boundary_chi2) {
      m.full_pending = false;
      local.full_avoided = true;
      return local;
    }
    SolveSummary out = Optimize(options.full);
    out.time_s += local.time_s;
    return out;
  }
  return full ? Optimize(options.full) : OptimizeWindow(options.window_size, options.local);
}

bool PoseGraph2d::FullSolvePending() const { return impl_->full_pending; }

double PoseGraph2d::Chi2() const { return impl_->TotalChi2(); }

double PoseGraph2d::FactorChi2(std::size_t factor_index) const {
  return impl_->FactorChi2(impl_->factors.at(factor_index));
}

}  // namespace draco::pose_graph
