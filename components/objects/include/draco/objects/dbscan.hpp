// DBSCAN over a growing 2D point set (DRACo-SLAM2 section III-A; Ester et al. 1996), kept
// up to date point batch by point batch instead of re-clustering the whole map each step.
//
// Definition (the same for the batch and the incremental form, so both give the same
// partition): a point is core when at least min_points points (itself included) lie within
// eps_m (distance <= eps_m). Clusters are the connected components of core points under
// the eps_m neighbourhood. A non-core point within eps_m of a core point is a border point
// and joins the cluster of its nearest core point (ties: the lower point index); other
// points are noise. The reference (scikit-learn) gives a border point to whichever cluster
// reaches it first; fixing the rule makes the partition unique.
//
// Incremental update: inserting points only ever raises neighbour counts, so points only
// become core and components only merge (union-find). Only the neighbourhoods of the new
// points and of the newly core points are visited.
//
// Ids: a new component gets the next id (0, 1, 2, ...); a merge keeps the oldest (lowest)
// id, so an id survives growth and merges. RemapIds carries ids over a rebuild.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "draco/msgs/slam.hpp"

namespace draco::objects {

using msgs::Point2;

struct DbscanOptions {
  double eps_m = 1.5;   // neighbourhood radius (reference: 1.5 m)
  int min_points = 20;  // core when >= min_points neighbours, itself included (reference: 20)
};

inline constexpr int kNoise = -1;

// From-scratch reference: label per point, clusters numbered 0, 1, ... in the order of
// their lowest core point index; kNoise for noise.
std::vector<int> DbscanBatch(const std::vector<Point2>& points, const DbscanOptions& options);

// Uniform grid with cell size eps: neighbours within eps lie in the 3 x 3 cells around.
class PointGrid {
 public:
  explicit PointGrid(double cell_m) : cell_m_(cell_m) {}
  void Insert(const Point2& p, std::uint32_t index);
  void Clear() { cells_.clear(); }
  // Calls f(index) for every inserted point within radius_m (<= cell size) of p.
  template <class F>
  void ForNeighbours(const std::vector<Point2>& points, const Point2& p, double radius_m,
                     F&& f) const;

 private:
  static std::uint64_t Key(std::int64_t cx, std::int64_t cy) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(cx)) << 32) |
           static_cast<std::uint32_t>(cy);
  }
  std::int64_t Cell(double v) const;
  double cell_m_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
};

class IncrementalDbscan {
 public:
  explicit IncrementalDbscan(const DbscanOptions& options = {});

  // Appends points (indices continue from size()) and updates the clustering.
  void Add(const std::vector<Point2>& points);
  // Forgets all points; ids continue from where they were (no id is ever reused).
  void Clear();
  // Clear() then Add(points), computed in batch (DbscanBatch's cell grid, several times
  // faster): the same clustering and state, so later Adds continue as after Add(points).
  // Ids: fresh ones in the order of each cluster's lowest core point (RemapIds carries them).
  void Rebuild(std::vector<Point2> points);
  // After Clear() and re-adding the same number of points: gives each cluster the oldest
  // id it held in previous_labels (one label per point, as returned by Labels() before),
  // each old id to at most one cluster (the one with most of its points on a tie of age);
  // clusters left without an old id get new ids.
  void RemapIds(const std::vector<int>& previous_labels);

  std::size_t size() const { return points_.size(); }
  const std::vector<Point2>& points() const { return points_; }
  bool IsCore(std::size_t i) const { return core_[i] != 0; }
  int Label(std::size_t i) const;  // cluster id or kNoise
  std::vector<int> Labels() const;
  const DbscanOptions& options() const { return options_; }

 private:
  std::uint32_t Find(std::uint32_t i) const;
  void Union(std::uint32_t a, std::uint32_t b);
  void OfferCore(std::uint32_t border, std::uint32_t core);

  DbscanOptions options_;
  PointGrid grid_;
  std::vector<Point2> points_;
  std::vector<std::int32_t> count_;  // neighbours within eps, itself included
  std::vector<std::uint8_t> core_;
  mutable std::vector<std::uint32_t> parent_;  // union-find over core points
  std::vector<int> component_id_;              // at union-find roots
  std::vector<std::int64_t> nearest_core_;     // border points: nearest core point or -1
  std::vector<double> nearest_d2_;
  int next_id_ = 0;
};

// ---------------------------------------------------------------------------------------

inline std::int64_t PointGrid::Cell(double v) const {
  return static_cast<std::int64_t>(std::floor(v / cell_m_));
}

template <class F>
void PointGrid::ForNeighbours(const std::vector<Point2>& points, const Point2& p, double radius_m,
                              F&& f) const {
  const double r2 = radius_m * radius_m;
  const std::int64_t cx = Cell(p.x_m), cy = Cell(p.y_m);
  for (std::int64_t dx = -1; dx <= 1; ++dx) {
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      const auto it = cells_.find(Key(cx + dx, cy + dy));
      if (it == cells_.end()) continue;
      for (const std::uint32_t j : it->second) {
        const double ex = points[j].x_m - p.x_m, ey = points[j].y_m - p.y_m;
        if (ex * ex + ey * ey <= r2) f(j);
      }
    }
  }
}

}  // namespace draco::objects
