// Constant false alarm rate (CFAR) detection along range for a forward-looking sonar, and
// the feature-point pipeline of the reference (Bruce-SLAM): CFAR, absolute intensity
// threshold, polar to Cartesian through the ping's bearing table, voxel downsampling and a
// radius outlier filter. No runtime dependency; see docs/local-slam.md.
//
// Detector (square-law / exponential noise model): each column (one beam) is tested along
// its rows (range bins). A cell under test at row r has guard_cells/2 guard cells and
// train_cells/2 training cells on each side (lead: smaller ranges, lag: larger ranges), n =
// train_cells/2 cells per side, N = train_cells in all. With S_lead and S_lag the training
// sums, a cell is a detection when its value exceeds
//   CA:   tau * (S_lead + S_lag) / N
//   SOCA: tau * min(S_lead, S_lag) / n     (reference default)
//   GOCA: tau * max(S_lead, S_lag) / n
//   OS:   tau * X_(k), the k-th smallest of the N training cells, k = os_rank
// where tau is computed exactly from the false-alarm probability (ThresholdFactor).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "draco/msgs/sensors.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::cfar {

enum class Method { kCa, kSoca, kGoca, kOs };

// Cells whose training windows run past either end of the column.
enum class EdgeMode {
  kNone,      // never detections (the reference)
  kOneSided,  // tested against the complete side alone, CA with n cells at the same Pfa;
              // cells with neither side complete are never detections
};

const char* MethodName(Method method);
bool ParseMethod(const std::string& name, Method* method);  // "CA", "SOCA", "GOCA", "OS"

struct CfarOptions {
  Method method = Method::kSoca;
  int train_cells = 40;  // both sides together; must be even and >= 2
  int guard_cells = 20;  // both sides together; must be even and >= 0
  double false_alarm_probability = 0.1;
  int os_rank = 0;  // OS only: rank k in 1..train_cells; 0 means 3/4 of train_cells
  EdgeMode edge_mode = EdgeMode::kNone;
};

// Exact false-alarm probability of `method` with threshold factor tau on i.i.d.
// exponential noise (square-law detector). train_cells = N (both sides).
double FalseAlarmProbability(Method method, int train_cells, double tau, int os_rank = 0);

// The tau that gives false_alarm_probability (closed form for CA, bisection on the exact
// series for SOCA, GOCA and on the product formula for OS). Throws std::invalid_argument
// on bad options.
double ThresholdFactor(Method method, int train_cells, double false_alarm_probability,
                       int os_rank = 0);

struct Cell {
  int range_bin = 0;
  int beam = 0;
};

// Runs CFAR on many images with the same options (thresholds computed once, scratch reused).
class CfarDetector {
 public:
  explicit CfarDetector(const CfarOptions& options);

  // image: rows x cols, row-major (row = range bin, column = beam). Appends to `detections`
  // (cleared first) every cell that passes CFAR and has value > min_value, in row-major order.
  void Detect(const float* image, int rows, int cols, float min_value,
              std::vector<Cell>* detections);

  const CfarOptions& options() const { return options_; }
  double tau() const { return tau_; }
  double edge_tau() const { return edge_tau_; }
  int os_rank() const { return os_rank_; }

 private:
  CfarOptions options_;
  double tau_ = 0.0;
  double edge_tau_ = 0.0;
  int os_rank_ = 0;
  std::vector<double> lead_, lag_;
  std::vector<float> window_;
};

enum class Downsample { kNone, kMedoid, kCentroid };

struct FeatureOptions {
  CfarOptions cfar;
  double min_intensity = 85.0;  // absolute threshold on the detector's input (0..255 scale)
  // Linearise the driver's gamma-encoded intensity: v = 255 * (u / 255)^(255 / gamma).
  bool linearize_gamma = false;
  double gamma = 255.0;  // the ping's gamma byte (255 = linear)
  double min_range_m = 0.0;
  double max_range_m = 1e9;
  Downsample downsample = Downsample::kMedoid;
  double voxel_size_m = 0.5;
  double outlier_radius_m = 1.0;  // 0 disables the radius filter
  int outlier_min_neighbors = 5;  // other points within the radius needed to keep a point
};

struct FeatureStats {
  int detections = 0;   // CFAR and intensity
  int downsampled = 0;  // after the voxel grid
  int kept = 0;         // after the outlier filter
};

// The whole per-ping pipeline; keeps scratch buffers between pings.
class FeatureExtractor {
 public:
  explicit FeatureExtractor(const FeatureOptions& options);
  // Feature points in the sensor frame (x = r cos(bearing), y = r sin(bearing), range of
  // row i = (i + 1) * range_resolution_m).
  std::vector<msgs::Point2> Extract(const msgs::SonarPing& ping, FeatureStats* stats = nullptr);
  const FeatureOptions& options() const { return options_; }

 private:
  FeatureOptions options_;
  CfarDetector detector_;
  float lut_[256];
  std::vector<float> image_;
  std::vector<Cell> cells_;
};

// One representative per voxel_size_m square: the medoid (the member with the smallest sum
// of distances to the others, so an actual detection, as the reference) or the centroid.
// Output order: by cell (x index, then y index).
std::vector<msgs::Point2> VoxelDownsample(const std::vector<msgs::Point2>& points,
                                          double voxel_size_m, Downsample mode);

// Keeps the points that have at least min_neighbors other points within radius_m.
std::vector<msgs::Point2> RadiusOutlierFilter(const std::vector<msgs::Point2>& points,
                                              double radius_m, int min_neighbors);

}  // namespace draco::cfar
