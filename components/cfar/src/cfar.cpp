// CFAR detection and the sonar feature-point pipeline (see cfar.hpp).
#include "draco/cfar/cfar.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>

namespace draco::cfar {
namespace {

void CheckWindow(int train_cells, double pfa) {
  if (train_cells < 2 || train_cells % 2 != 0) {
    throw std::invalid_argument("CFAR: train_cells must be even and >= 2");
  }
  if (!(pfa > 0.0 && pfa < 1.0)) {
    throw std::invalid_argument("CFAR: false_alarm_probability must be in (0, 1)");
  }
}

int ResolveOsRank(int train_cells, int os_rank) {
  const int k = os_rank > 0 ? os_rank : (3 * train_cells + 2) / 4;
  if (k < 1 || k > train_cells) throw std::invalid_argument("CFAR: os_rank out of 1..train_cells");
  return k;
}

// One side, n cells, CA: P(x > tau * S / n) = (1 + tau / n)^-n.
double OneSidedPfa(int n, double tau) { return std::pow(1.0 + tau / n, -n); }

// SOCA with n cells per side (Gandhi and Kassam's series):
// Pfa = 2 * sum_{k=0}^{n-1} C(n-1+k, k) * (2 + tau/n)^-(n+k).
double SocaPfa(int n, double tau) {
  const double log_base = std::log(2.0 + tau / n);
  double sum = 0.0;
  for (int k = 0; k < n; ++k) {
    const double log_term =
        std::lgamma(n + k) - std::lgamma(k + 1.0) - std::lgamma(n) - (n + k) * log_base;
    sum += std::exp(log_term);
  }
  return 2.0 * sum;
}

// Bisection on a decreasing Pfa(tau) for the tau with Pfa(tau) = target.
template <class F>
double SolveDecreasing(F pfa_of_tau, double target) {
  double lo = 0.0;
  double hi = 1.0;
  while (pfa_of_tau(hi) > target) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e12) throw std::invalid_argument("CFAR: no threshold factor for this Pfa");
  }
  for (int i = 0; i < 200 && hi - lo > 1e-13 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (pfa_of_tau(mid) > target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

const char* MethodName(Method method) {
  switch (method) {
    case Method::kCa:
      return "CA";
    case Method::kSoca:
      return "SOCA";
    case Method::kGoca:
      return "GOCA";
    case Method::kOs:
      return "OS";
  }
  return "?";
}

bool ParseMethod(const std::string& name, Method* method) {
  for (Method m : {Method::kCa, Method::kSoca, Method::kGoca, Method::kOs}) {
    if (name == MethodName(m)) {
      *method = m;
      return true;
    }
  }
  return false;
}

double FalseAlarmProbability(Method method, int train_cells, double tau, int os_rank) {
  CheckWindow(train_cells, 0.5);
  const int n = train_cells / 2;
  switch (method) {
    case Method::kCa:
      return OneSidedPfa(train_cells, tau);
    case Method::kSoca:
      return SocaPfa(n, tau);
    case Method::kGoca:
      // P(x > tau max/n) + P(x > tau min/n) = P(x > tau S1/n) + P(x > tau S2/n).
      return 2.0 * OneSidedPfa(n, tau) - SocaPfa(n, tau);
    case Method::kOs: {
      // Rohling: Pfa = prod_{i=0}^{k-1} (N - i) / (N - i + tau).
      const int k = ResolveOsRank(train_cells, os_rank);
      double log_p = 0.0;
      for (int i = 0; i < k; ++i) {
        log_p += std::log((train_cells - i) / (train_cells - i + tau));
      }
      return std::exp(log_p);
    }
  }
  return 1.0;
}

double ThresholdFactor(Method method, int train_cells, double pfa, int os_rank) {
  CheckWindow(train_cells, pfa);
  if (method == Method::kCa) {
    return train_cells * (std::pow(pfa, -1.0 / train_cells) - 1.0);
  }
  if (method == Method::kOs) os_rank = ResolveOsRank(train_cells, os_rank);
  return SolveDecreasing(
      [&](double tau) { return FalseAlarmProbability(method, train_cells, tau, os_rank); }, pfa);
}

CfarDetector::CfarDetector(const CfarOptions& options) : options_(options) {
  if (options.guard_cells < 0 || options.guard_cells % 2 != 0) {
    throw std::invalid_argument("CFAR: guard_cells must be even and >= 0");
  }
  if (options.method == Method::kOs) {
    os_rank_ = ResolveOsRank(options.train_cells, options.os_rank);
  }
  tau_ = ThresholdFactor(options.method, options.train_cells, options.false_alarm_probability,
                         os_rank_);
  // The one-sided edge test: CA with n cells.
  edge_tau_ =
      ThresholdFactor(Method::kCa, options.train_cells / 2, options.false_alarm_probability);
}

namespace {

// Tests one row whose two training windows are complete. lead/lag hold the window sums.
template <Method M>
void TestRow(const float* row, const double* lead, const double* lag, int cols, int r, double tau,
             int n, float min_value, std::vector<Cell>* out) {
  const double scale = M == Method::kCa ? tau / (2.0 * n) : tau / n;
  for (int b = 0; b < cols; ++b) {
    double noise;
    if constexpr (M == Method::kCa) {
      noise = lead[b] + lag[b];
    } else if constexpr (M == Method::kSoca) {
      noise = std::min(lead[b], lag[b]);
    } else {
      noise = std::max(lead[b], lag[b]);
    }
    const double v = row[b];
    if (v > min_value && v > scale * noise) out->push_back(Cell{r, b});
  }
}

}  // namespace

void CfarDetector::Detect(const float* image, int rows, int cols, float min_value,
                          std::vector<Cell>* detections) {
  detections->clear();
  const int n = options_.train_cells / 2;
  const int g = options_.guard_cells / 2;
  const int reach = n + g;  // farthest training cell from the cell under test
  const bool one_sided = options_.edge_mode == EdgeMode::kOneSided;
  lead_.assign(cols, 0.0);
  lag_.assign(cols, 0.0);
  auto add_row = [&](std::vector<double>& sums, int row, double sign) {
    const float* p = image + static_cast<std::size_t>(row) * cols;
    for (int b = 0; b < cols; ++b) sums[b] += sign * p[b];
  };
  // lag(r) = rows [r + g + 1, r + g + n]; lead(r) = rows [r - g - n, r - g - 1].
  if (reach < rows) {
    for (int k = g + 1; k <= reach; ++k) add_row(lag_, k, 1.0);
  }
  const Method method = options_.method;
  for (int r = 0; r < rows; ++r) {
    if (r == reach) {
      for (int k = 0; k < n; ++k) add_row(lead_, k, 1.0);
    } else if (r > reach) {
      add_row(lead_, r - g - 1, 1.0);
      add_row(lead_, r - reach - 1, -1.0);
    }
    const bool lag_ok = r + reach < rows;
    if (r > 0 && lag_ok) {
      add_row(lag_, r + reach, 1.0);
      add_row(lag_, r + g, -1.0);
    }
    const bool lead_ok = r >= reach;
    const float* row = image + static_cast<std::size_t>(r) * cols;
    if (lead_ok && lag_ok) {
      switch (method) {
        case Method::kCa:
          TestRow<Method::kCa>(row, lead_.data(), lag_.data(), cols, r, tau_, n, min_value,
                               detections);
          break;
        case Method::kSoca:
          TestRow<Method::kSoca>(row, lead_.data(), lag_.data(), cols, r, tau_, n, min_value,
                                 detections);
          break;
        case Method::kGoca:
          TestRow<Method::kGoca>(row, lead_.data(), lag_.data(), cols, r, tau_, n, min_value,
                                 detections);
          break;
        case Method::kOs: {
          window_.resize(2 * n);
          for (int b = 0; b < cols; ++b) {
            const float v = row[b];
            if (!(v > min_value)) continue;  // cheap test first: most cells stop here
            int w = 0;
            for (int k = r - reach; k < r - g; ++k) window_[w++] = image[std::size_t(k) * cols + b];
            for (int k = r + g + 1; k <= r + reach; ++k) {
              window_[w++] = image[std::size_t(k) * cols + b];
            }
            std::nth_element(window_.begin(), window_.begin() + (os_rank_ - 1), window_.end());
            if (v > tau_ * window_[os_rank_ - 1]) detections->push_back(Cell{r, b});
          }
          break;
        }
      }
    } else if (one_sided && (lead_ok || lag_ok)) {
      const double* sums = lead_ok ? lead_.data() : lag_.data();
      const double scale = edge_tau_ / n;
      for (int b = 0; b < cols; ++b) {
        const double v = row[b];
        if (v > min_value && v > scale * sums[b]) detections->push_back(Cell{r, b});
      }
    }
  }
}

namespace {

struct Keyed {
  std::int64_t key;
  int index;
};

std::int64_t CellKey(double x, double y, double inv_size) {
  const auto ix = static_cast<std::int64_t>(std::floor(x * inv_size));
  const auto iy = static_cast<std::int64_t>(std::floor(y * inv_size));
  return (ix << 32) + (iy + (std::int64_t{1} << 31));
}

std::vector<Keyed> SortedKeys(const std::vector<msgs::Point2>& points, double cell_size) {
  std::vector<Keyed> keyed(points.size());
  const double inv = 1.0 / cell_size;
  for (std::size_t i = 0; i < points.size(); ++i) {
    keyed[i] = Keyed{CellKey(points[i].x_m, points[i].y_m, inv), static_cast<int>(i)};
  }
  std::sort(keyed.begin(), keyed.end(), [](const Keyed& a, const Keyed& b) {
    return a.key != b.key ? a.key < b.key : a.index < b.index;
  });
  return keyed;
}

}  // namespace

std::vector<msgs::Point2> VoxelDownsample(const std::vector<msgs::Point2>& points,
                                          double voxel_size_m, Downsample mode) {
  if (mode == Downsample::kNone || voxel_size_m <= 0.0 || points.empty()) return points;
  const std::vector<Keyed> keyed = SortedKeys(points, voxel_size_m);
  std::vector<msgs::Point2> out;
  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin + 1;
    while (end < keyed.size() && keyed[end].key == keyed[begin].key) ++end;
    if (mode == Downsample::kCentroid) {
      double sx = 0.0, sy = 0.0;
      for (std::size_t i = begin; i < end; ++i) {
        sx += points[keyed[i].index].x_m;
        sy += points[keyed[i].index].y_m;
      }
      const double m = static_cast<double>(end - begin);
      out.push_back(msgs::Point2{sx / m, sy / m});
    } else {
      std::size_t best = begin;
      double best_cost = INFINITY;
      for (std::size_t i = begin; i < end; ++i) {
        const msgs::Point2& p = points[keyed[i].index];
        double cost = 0.0;
        for (std::size_t j = begin; j < end; ++j) {
          const msgs::Point2& q = points[keyed[j].index];
          cost += std::hypot(p.x_m - q.x_m, p.y_m - q.y_m);
        }
        if (cost < best_cost) {
          best_cost = cost;
          best = i;
        }
      }
      out.push_back(points[keyed[best].index]);
    }
    begin = end;
  }
  return out;
}

std::vector<msgs::Point2> RadiusOutlierFilter(const std::vector<msgs::Point2>& points,
                                              double radius_m, int min_neighbors) {
  if (radius_m <= 0.0 || min_neighbors <= 0 || points.empty()) return points;
  // Grid of radius-sized cells: every neighbour is in the 3 x 3 block around a point's cell.
  const std::vector<Keyed> keyed = SortedKeys(points, radius_m);
  const double inv = 1.0 / radius_m;
  const double r2 = radius_m * radius_m;
  auto cell_range = [&](std::int64_t key) {
    auto lo = std::lower_bound(keyed.begin(), keyed.end(), key,
                               [](const Keyed& k, std::int64_t v) { return k.key < v; });
    auto hi = lo;
    while (hi != keyed.end() && hi->key == key) ++hi;
    return std::make_pair(lo, hi);
  };
  std::vector<msgs::Point2> out;
  for (const msgs::Point2& p : points) {
    const auto ix = static_cast<std::int64_t>(std::floor(p.x_m * inv));
    const auto iy = static_cast<std::int64_t>(std::floor(p.y_m * inv));
    int count = -1;  // the point itself is counted below
    for (std::int64_t dx = -1; dx <= 1 && count < min_neighbors; ++dx) {
      for (std::int64_t dy = -1; dy <= 1 && count < min_neighbors; ++dy) {
        const std::int64_t key = ((ix + dx) << 32) + (iy + dy + (std::int64_t{1} << 31));
        auto [lo, hi] = cell_range(key);
        for (auto it = lo; it != hi; ++it) {
          const msgs::Point2& q = points[it->index];
          const double ddx = q.x_m - p.x_m, ddy = q.y_m - p.y_m;
          if (ddx * ddx + ddy * ddy <= r2) ++count;
        }
      }
    }
    if (count >= min_neighbors) out.push_back(p);
  }
  return out;
}

FeatureExtractor::FeatureExtractor(const FeatureOptions& options)
    : options_(options), detector_(options.cfar) {
  for (int u = 0; u < 256; ++u) {
    double v = u;
    if (options.linearize_gamma && options.gamma > 0.0) {
      v = 255.0 * std::pow(u / 255.0, 255.0 / options.gamma);
    }
    lut_[u] = static_cast<float>(v);
  }
}

std::vector<msgs::Point2> FeatureExtractor::Extract(const msgs::SonarPing& ping,
                                                    FeatureStats* stats) {
  const int rows = ping.num_ranges;
  const int cols = ping.num_beams;
  const std::size_t size = static_cast<std::size_t>(rows) * cols;
  if (rows <= 0 || cols <= 0 || ping.intensity.size() != size ||
      ping.bearings_rad.size() != static_cast<std::size_t>(cols)) {
    throw std::invalid_argument("FeatureExtractor: ping sizes do not match");
  }
  image_.resize(size);
  for (std::size_t i = 0; i < size; ++i) image_[i] = lut_[ping.intensity[i]];
  detector_.Detect(image_.data(), rows, cols, static_cast<float>(options_.min_intensity), &cells_);
  std::vector<msgs::Point2> points;
  points.reserve(cells_.size());
  for (const Cell& c : cells_) {
    const double range = (c.range_bin + 1) * ping.range_resolution_m;
    if (range < options_.min_range_m || range > options_.max_range_m) continue;
    const double bearing = ping.bearings_rad[c.beam];
    points.push_back(msgs::Point2{range * std::cos(bearing), range * std::sin(bearing)});
  }
  const int detections = static_cast<int>(points.size());
  points = VoxelDownsample(points, options_.voxel_size_m, options_.downsample);
  const int downsampled = static_cast<int>(points.size());
  points = RadiusOutlierFilter(points, options_.outlier_radius_m, options_.outlier_min_neighbors);
  if (stats != nullptr)
    *stats = FeatureStats{detections, downsampled, static_cast<int>(points.size())};
  return points;
}

}  // namespace draco::cfar
