// SE(2) pose graph: poses T_world_pose, priors and between factors with information
// matrices and optional robust losses, solved with Ceres (kept out of this header).
//
// Error of a between factor with measurement Z = T_i_j (g2o's EDGE_SE2 definition):
//   E = Z^-1 * (T_w_i^-1 * T_w_j),  e = (E.x, E.y, E.yaw) in Z's frame,
// chi2 = e^T * Omega * e (ErrorConvention::kG2o, the default). ErrorConvention::kCeresExample
// keeps the translation error in frame i instead, e_t = R_w_i^T (t_w_j - t_w_i) - Z.t, as Ceres'
// pose_graph_2d example does; the two agree when Omega's x-y block is isotropic. The solver
// minimises sum over factors of rho(chi2) / 2, where rho is the robust loss (identity for none). A
// prior on pose i with measurement Z = T_w_i is the same with T_w_i in place of T_i_j.
//
// Yaw Gauss-Markov factor (AddYawGaussMarkov): yaw only, on three poses, for a time-correlated
// heading-error state: with the deviations d = wrap(yaw - mean.yaw) of the previous and the
// current pose, r = (d_current - phi * d_previous) / sigma (chi2 = r^2). With phi = exp(-dt / tau)
// and sigma = s * sqrt(1 - phi^2) it is the exact discretisation of a stationary first-order
// Gauss-Markov process of sigma s and correlation time tau about the mean pose's yaw. x and y
// of the three poses do not enter; it is not an SE(2) relation (the spanning-tree
// initialisation and the g2o export skip it).
//
// Gauge: when the graph has neither a prior nor a pose held constant, the first pose added
// is held constant during solves (the problem is otherwise rank-deficient).
//
// Point landmarks: 2D point nodes l (world frame) observed from poses; a point observation z
// (the landmark in the pose's frame) has the error e = R_w_i^T (l - t_w_i) - z and a 2x2
// information matrix (chi2 = e^T Omega e). Points are not poses: they do not count in the
// incremental window, the g2o export or the spanning-tree initialisation.
//
// Incremental use: the Ceres problem is kept between solves and grows with the graph; pose
// values are solved in place, so every solve starts warm. Update() optimises only the newest
// poses (the rest held constant) unless a new factor reaches older poses (a loop closure) or
// a full solve is due.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "draco/pose_graph/pose2.hpp"

namespace draco::pose_graph {

using PoseId = std::int64_t;
using PointId = std::int64_t;

enum class FactorKind { kPrior, kOdometry, kScanMatch, kLoop, kInterRobot };
std::string_view ToString(FactorKind kind);

// Frame of the translation error (see the top of this file).
enum class ErrorConvention { kG2o, kCeresExample };

enum class LossKind { kNone, kHuber, kCauchy };

// Robust loss on the whitened error: scale is in sigmas (sqrt(chi2) units), e.g. Huber with
// scale 1 is quadratic up to one sigma and linear beyond.
struct RobustLoss {
  LossKind kind = LossKind::kNone;
  double scale = 1.0;
};

// The third pose and the parameters of a yaw Gauss-Markov factor (see the top of this file).
struct YawGaussMarkov {
  PoseId mean = 0;
  double phi = 1.0;
  double sigma_rad = 1.0;
};

struct Factor {
  FactorKind kind = FactorKind::kOdometry;
  PoseId i = 0;       // the pose of a prior, the from-pose of a between factor, or the
                      // previous pose of a yaw Gauss-Markov factor
  PoseId j = 0;       // the to-pose of a between factor or the current pose of a yaw
                      // Gauss-Markov factor (== i for a prior)
  Pose2 measurement;  // T_i_j for a between factor, T_world_i for a prior (zero otherwise)
  Matrix3 information = Diagonal3(1.0, 1.0, 1.0);  // (0, 0, 1 / sigma^2) for yaw Gauss-Markov
  RobustLoss loss;
  std::optional<YawGaussMarkov> yaw_gauss_markov;  // set for a yaw Gauss-Markov factor only
};

// Optional radius state of a point landmark. A sonar sees a round object's near face, so the
// centroid of its returns lies between the object's centre and the observer, by about 0.64
// radii for a lit half circle. With a radius state rho (m) the point is the object's centre l
// and an observation z predicts c (1 - rho / |c|), c = R_w_i^T (l - t_w_i): the centre moved
// toward the observer by rho. rho has a Gaussian prior and stays within [0, max_m]; it is
// observable once the point is seen from different sides.
struct PointRadiusPrior {
  double prior_m = 0.0;
  double sigma_m = 0.5;
  double max_m = 5.0;
};

struct PointObservation {
  PoseId pose = 0;
  PointId point = 0;
  Point2 p_pose;  // the landmark in the pose's frame
  Matrix2 information = {1.0, 0.0, 0.0, 1.0};
  RobustLoss loss;
};

enum class Algorithm { kLevenbergMarquardt, kDogleg };
enum class LinearSolver { kSparseNormalCholesky, kDenseNormalCholesky, kDenseQr };
enum class SparseBackend { kSuiteSparse, kEigenSparse, kCxSparse };

// Defaults were chosen by tests/pose_graph/pose_graph_bench.cpp (see docs/pose-graph.md).
struct SolverOptions {
  Algorithm algorithm = Algorithm::kLevenbergMarquardt;
  LinearSolver linear_solver = LinearSolver::kSparseNormalCholesky;
  SparseBackend sparse_backend = SparseBackend::kEigenSparse;
  int max_iterations = 100;
  int num_threads = 2;
  double function_tolerance = 1e-6;  // relative decrease of the cost
  double gradient_tolerance = 1e-10;
  double parameter_tolerance = 1e-8;
  bool jacobi_scaling = true;
  bool nonmonotonic_steps = false;
  bool mixed_precision = false;  // factorise in float, refine in double (Ceres option)
  // Large: the first Levenberg-Marquardt steps are nearly Gauss-Newton (3 iterations instead
  // of 9-21 on the g2o datasets); rejected steps still shrink the region.
  double initial_trust_region_radius = 1e12;
  // Step-size iterations of the projected line search Ceres runs after every trust-region
  // step of a problem with bounds (landmark radius states); 0: none, the step is only
  // projected onto the bounds.
  int bounded_line_search_iterations = 20;
  bool log_progress = false;  // Ceres' per-iteration log to stderr
  bool full_report = false;   // SolveSummary::report gets Ceres' full report (timings)
};

struct SolveSummary {
  bool usable = false;     // Ceres left a usable solution (converged or hit the iteration cap)
  bool converged = false;  // a tolerance was met
  bool full = true;        // false for a local window solve
  // A triggered full solve the window's answer made unnecessary
  // (IncrementalOptions::full_solve_max_boundary_chi2).
  bool full_avoided = false;
  int iterations = 0;
  int variable_poses = 0;
  int factors = 0;            // factors in the solved problem
  double initial_cost = 0.0;  // Ceres cost, 0.5 * sum rho(chi2) over the solved factors
  double final_cost = 0.0;
  double initial_chi2 = 0.0;  // sum of chi2 over the solved factors (no robust loss), as g2o
  double final_chi2 = 0.0;
  double time_s = 0.0;  // wall time of the whole call
  std::string report;   // Ceres' one-line report, or the full one (SolverOptions::full_report)
};

struct IncrementalOptions {
  int window_size = 20;      // newest poses (insertion order) free in a local solve
  int full_solve_every = 0;  // poses added between forced full solves; 0: only when triggered
  // A new factor touching a pose older than the window triggers a full solve.
  bool full_solve_on_loop = true;
  // A triggered full solve waits until this many poses were added since the last one (window
  // solves meanwhile; 0 or 1: at once): on repeated passes nearly every pose re-observes an old
  // landmark or closes a loop, and a full solve per pose makes each step cost the whole graph.
  int full_solve_min_poses = 0;
  // A triggered full solve first tries the window: when, after the window solve, every factor
  // and point observation that ties a window pose to a pose outside it (held constant) has
  // chi2 at most this, the new loop or sighting agrees with the older graph and the window's
  // answer stands; otherwise the full solve runs from it. Forced full solves (the first
  // window, full_solve_every) are not tried. 0: off (every triggered full solve runs).
  double full_solve_max_boundary_chi2 = 0.0;
  SolverOptions local{
      .linear_solver = LinearSolver::kDenseNormalCholesky, .max_iterations = 10, .num_threads = 1};
  SolverOptions full{};
};

class PoseGraph2d {
 public:
  explicit PoseGraph2d(ErrorConvention convention = ErrorConvention::kG2o);
  ~PoseGraph2d();
  PoseGraph2d(PoseGraph2d&&) noexcept;
  PoseGraph2d& operator=(PoseGraph2d&&) noexcept;
  PoseGraph2d(const PoseGraph2d&) = delete;
  PoseGraph2d& operator=(const PoseGraph2d&) = delete;

  // Poses. Throws std::invalid_argument on a duplicate id, std::out_of_range on an unknown one.
  void AddPose(PoseId id, const Pose2& T_world_pose);
  bool HasPose(PoseId id) const;
  std::size_t NumPoses() const;
  std::vector<PoseId> PoseIds() const;  // insertion order
  Pose2 Pose(PoseId id) const;
  void SetPose(PoseId id, const Pose2& T_world_pose);
  // A pose held constant fixes the gauge instead of the automatic first-pose rule.
  void SetPoseConstant(PoseId id, bool constant = true);

  // Factors; both return the factor's index. Information must be symmetric positive definite
  // (std::invalid_argument otherwise); ids must exist.
  std::size_t AddPrior(PoseId id, const Pose2& T_world_pose, const Matrix3& information,
                       RobustLoss loss = {});
  std::size_t AddBetween(PoseId i, PoseId j, const Pose2& T_i_j, const Matrix3& information,
                         FactorKind kind = FactorKind::kOdometry, RobustLoss loss = {});
  // Yaw Gauss-Markov factor (see the top of this file); kind kOdometry. Throws
  // std::invalid_argument unless the three ids differ, |phi| <= 1 and sigma_rad > 0;
  // std::out_of_range on an unknown id.
  std::size_t AddYawGaussMarkov(PoseId mean, PoseId previous, PoseId current, double phi,
                                double sigma_rad, RobustLoss loss = {});
  const std::vector<Factor>& Factors() const;

  // Point landmarks (their own id space). AddPoint throws std::invalid_argument on a duplicate
  // id; AddPointObservation returns the observation's index and validates the information
  // (symmetric positive definite) and both ids (std::out_of_range).
  void AddPoint(PointId id, const Point2& p_world,
                std::optional<PointRadiusPrior> radius = std::nullopt);
  bool HasPoint(PointId id) const;
  std::size_t NumPoints() const;
  Point2 Point(PointId id) const;
  void SetPoint(PointId id, const Point2& p_world);
  // The radius estimate of a point added with a PointRadiusPrior (nullopt otherwise).
  std::optional<double> PointRadius(PointId id) const;
  std::size_t AddPointObservation(PoseId pose, PointId point, const Point2& p_pose,
                                  const Matrix2& information, RobustLoss loss = {});
  const std::vector<PointObservation>& PointObservations() const;
  double PointObservationChi2(std::size_t observation_index) const;

  std::size_t NumFactors() const;
  ErrorConvention Convention() const;

  // Breadth-first over the between factors from root (default: the first pose), setting each
  // newly reached pose to parent * measurement (or its inverse against the edge). Poses not
  // reached keep their values. Returns the number of poses set (root excluded).
  std::size_t InitializeFromSpanningTree(std::optional<PoseId> root = std::nullopt);

  // Full solve of every pose, warm-started from the current values.
  SolveSummary Optimize(const SolverOptions& options = {});
  // Solves the newest window_size poses with every other pose held constant, and the points
  // they observe (with all of those points' observations).
  SolveSummary OptimizeWindow(int window_size, const SolverOptions& options = {});
  // Per-keyframe entry point: a window solve, or a full one when a new factor reaches older
  // than the window (a new point observation counts when its point was observed from a pose
  // older than the window) or a periodic full solve is due.
  SolveSummary Update(const IncrementalOptions& options = {});
  // A full solve was triggered and deferred (IncrementalOptions::full_solve_min_poses).
  bool FullSolvePending() const;

  // chi2 of the whole graph, point observations included (robust losses not applied), and
  // of one factor.
  double Chi2() const;
  double FactorChi2(std::size_t factor_index) const;

  // Marginal covariance of T_i_j = T_w_i^-1 * T_w_j at the current estimate, as a right
  // perturbation: T_true = T_i_j * Exp(d), d = (dx, dy, dyaw) in frame j. Uses Ceres'
  // covariance (SuiteSparse sparse QR) over the whole graph; throws std::runtime_error if
  // the graph is rank-deficient. Ask for many pairs at once: one factorisation serves all.
  Matrix3 RelativeCovariance(PoseId i, PoseId j);
  std::vector<Matrix3> RelativeCovariances(std::span<const std::pair<PoseId, PoseId>> pairs);
  // Marginal covariance of (x, y, yaw) of T_w_i in the world frame.
  Matrix3 MarginalCovariance(PoseId id);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace draco::pose_graph
