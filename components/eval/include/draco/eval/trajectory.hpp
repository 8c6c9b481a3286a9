// Trajectory evaluation as the paper does it (evo-compatible): TUM files, association by
// time stamp, SE(2) Umeyama alignment (rotation + translation, no scale), ATE RMSE and RPE.
#pragma once

#include <string>
#include <vector>

namespace draco::eval {

struct StampedPose2 {
  double time_s = 0.0;
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};
using Trajectory = std::vector<StampedPose2>;

// TUM format: "t x y z qx qy qz qw" per line, '#' comments. Reading keeps x, y and the yaw of
// the quaternion. Throws std::runtime_error naming file and line on malformed input.
Trajectory ReadTum(const std::string& path);
// Writes atomically (temporary file + rename); z = 0, quaternion from yaw.
void WriteTum(const std::string& path, const Trajectory& trajectory);

// Pairs each pose of `estimate` with the ground-truth pose interpolated at its time (linear in
// position, shortest-arc in yaw). Estimates outside the ground truth's time span, or further
// than max_gap_s from a ground-truth sample, are skipped.
struct Association {
  Trajectory estimate;
  Trajectory truth;
};
Association Associate(const Trajectory& estimate, const Trajectory& truth, double max_gap_s = 0.5);

// T_truth_estimate minimising sum |p_truth - (R p_est + t)|^2 (Umeyama, 2D, no scale).
struct Se2 {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};
Se2 AlignUmeyama(const Trajectory& estimate, const Trajectory& truth);
Trajectory Transform(const Se2& T, const Trajectory& trajectory);

struct AteResult {
  std::size_t pairs = 0;
  double rmse_m = 0.0;
  double mean_m = 0.0;
  double max_m = 0.0;
  Se2 T_truth_estimate;
};
// Associates, aligns (unless align is false) and measures the absolute trajectory error.
AteResult Ate(const Trajectory& estimate, const Trajectory& truth, bool align = true,
              double max_gap_s = 0.5);

// Relative pose error over pose pairs `delta` samples apart (after association).
struct RpeResult {
  std::size_t pairs = 0;
  double trans_rmse_m = 0.0;
  double rot_rmse_rad = 0.0;
};
RpeResult Rpe(const Trajectory& estimate, const Trajectory& truth, std::size_t delta = 1,
              double max_gap_s = 0.5);

// Path length of a trajectory (sum of position steps).
double PathLengthM(const Trajectory& trajectory);

double WrapAngle(double a);

}  // namespace draco::eval
