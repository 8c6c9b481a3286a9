// The state behind PoseGraph2d (pose_graph_2d.hpp), private to draco_pose_graph: poses,
// points, factors and point observations with their Ceres terms, and the persistent Ceres
// problem. Building the graph is in pose_graph_2d.cpp, the solves in pose_graph_optimize.cpp,
// the covariances in pose_graph_covariance.cpp.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include "draco/pose_graph/pose_graph_2d.hpp"
#include "se2_cost.hpp"

namespace draco::pose_graph {
namespace internal {

inline Pose2 ToPose(const std::array<double, 3>& x) { return {x[0], x[1], x[2]}; }

// A problem that borrows the graph's costs, losses and manifold (pose_graph_optimize.cpp).
ceres::Problem::Options BorrowingProblemOptions();

// SolverOptions as Ceres' (pose_graph_optimize.cpp).
ceres::Solver::Options ToCeres(const SolverOptions& o);

}  // namespace internal

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
  bool full_pending = false;  // a full solve was triggered and deferred (full_solve_min_poses)

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
    const Pose2 a = internal::ToPose(nodes[Index(f.i)].x);
    if (f.yaw_gauss_markov) {
      const auto& g = *f.yaw_gauss_markov;
      const double r = internal::YawGaussMarkovError(internal::ToPose(nodes[Index(g.mean)].x), a,
                                                     internal::ToPose(nodes[Index(f.j)].x), g.phi) /
                       g.sigma_rad;
      return r * r;
    }
    if (f.kind == FactorKind::kPrior) {
      return internal::Chi2(internal::PriorError(a, f.measurement, convention), f.information);
    }
    const Pose2 b = internal::ToPose(nodes[Index(f.j)].x);
    return internal::Chi2(internal::BetweenError(a, b, f.measurement, convention), f.information);
  }

  // Node indices of a factor's poses, newest and oldest (a yaw Gauss-Markov factor has three).
  std::size_t NewestNode(const Factor& f) const {
    std::size_t n = std::max(index.at(f.i), index.at(f.j));
    if (f.yaw_gauss_markov) n = std::max(n, index.at(f.yaw_gauss_markov->mean));
    return n;
  }
  std::size_t OldestNode(const Factor& f) const {
    std::size_t n = std::min(index.at(f.i), index.at(f.j));
    if (f.yaw_gauss_markov) n = std::min(n, index.at(f.yaw_gauss_markov->mean));
    return n;
  }

  // The largest chi2 of the factors and point observations that tie a pose at index >= first
  // (or a point observed from one) to a pose before first.
  double MaxBoundaryChi2(std::size_t first) const {
    double worst = 0.0;
    for (std::size_t u = first; u < nodes.size(); ++u) {
      for (const std::size_t k : nodes[u].factors) {
        const Factor& f = factors[k];
        if (NewestNode(f) == u && OldestNode(f) < first) worst = std::max(worst, FactorChi2(f));
      }
      for (const std::size_t k : nodes[u].observations) {
        for (const std::size_t o : points[PointIndex(observations[k].point)].observations) {
          if (index.at(observations[o].pose) < first)
            worst = std::max(worst, ObservationChi2(observations[o]));
        }
      }
    }
    return worst;
  }

  std::size_t PointIndex(PointId id) const {
    const auto it = point_index.find(id);
    if (it == point_index.end()) {
      throw std::out_of_range("point " + std::to_string(id) + " not in graph");
    }
    return it->second;
  }

  double ObservationChi2(const PointObservation& o) const {
    const Pose2 a = internal::ToPose(nodes[Index(o.pose)].x);
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
    } else if (f.yaw_gauss_markov) {
      Node& mean = nodes[index.at(f.yaw_gauss_markov->mean)];
      Node& b = nodes[index.at(f.j)];
      p.AddResidualBlock(terms[k].cost.get(), terms[k].loss.get(), mean.x.data(), a.x.data(),
                         b.x.data());
    } else {
      Node& b = nodes[index.at(f.j)];
      p.AddResidualBlock(terms[k].cost.get(), terms[k].loss.get(), a.x.data(), b.x.data());
    }
  }

  // Brings the persistent problem up to date with the graph (new nodes, factors, constants).
  void SyncProblem() {
    if (!problem) problem = std::make_unique<ceres::Problem>(internal::BorrowingProblemOptions());
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

  // The radius blocks of p that sit on a bound and are free in p.
  std::vector<double*> RadiiAtBounds(const ceres::Problem& p) {
    std::vector<double*> out;
    for (PointNode& q : points) {
      if (!q.radius || !p.HasParameterBlock(q.rho.data()) ||
          p.IsParameterBlockConstant(q.rho.data())) {
        continue;
      }
      if (q.rho[0] <= 0.0 || q.rho[0] >= q.radius->max_m) out.push_back(q.rho.data());
    }
    return out;
  }

  // Solves p. A radius on its bound is held there (an active set): Ceres projects a step onto
  // the bounds after computing it without them, so a radius the evidence pushes past its
  // bound takes the rest of the step with it, and the solve is rejected step after step (on
  // the marina repeated, 21 iterations a full solve against 5). After the solve, a held radius
  // whose gradient points into its range is freed and the problem solved again from there.
  static constexpr int kMaxActiveSetPasses = 4;
  SolveSummary Run(ceres::Problem& p, const SolverOptions& o) {
    const ceres::Solver::Options options = internal::ToCeres(o);
    std::vector<double*> held = RadiiAtBounds(p);
    SolveSummary out;
    out.initial_cost = -1.0;
    for (int pass = 0; pass < kMaxActiveSetPasses; ++pass) {
      for (double* r : held) p.SetParameterBlockConstant(r);
      ceres::Solver::Summary s;
      ceres::Solve(options, &p, &s);
      for (double* r : held) p.SetParameterBlockVariable(r);
      out.usable = s.IsSolutionUsable();
      out.converged = s.termination_type == ceres::CONVERGENCE;
      out.iterations += static_cast<int>(s.iterations.size()) - 1;
      if (out.initial_cost < 0.0) out.initial_cost = s.initial_cost;
      out.final_cost = s.final_cost;
      out.report = o.full_report ? s.FullReport() : s.BriefReport();
      if (held.empty() || !out.usable) break;
      // Gradient of the whole cost with respect to the held radii.
      ceres::Problem::EvaluateOptions eval;
      eval.parameter_blocks = held;
      std::vector<double> gradient;
      double cost = 0.0;
      if (!p.Evaluate(eval, &cost, nullptr, &gradient, nullptr)) break;
      std::vector<double*> still;
      for (std::size_t i = 0; i < held.size(); ++i) {
        const bool at_lower = *held[i] <= 0.0;
        const bool inward = at_lower ? gradient[i] < 0.0 : gradient[i] > 0.0;
        if (!inward) still.push_back(held[i]);
      }
      if (still.size() == held.size()) break;
      held = std::move(still);
    }
    return out;
  }
};

}  // namespace draco::pose_graph
