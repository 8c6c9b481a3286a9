// A small static 2D kd-tree over a point array (median splits on the wider axis, leaves of
// up to 8 points): nearest neighbour within a radius and k nearest neighbours.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

namespace draco::icp {

using Cloud2 = std::vector<Eigen::Vector2d>;

class KdTree2 {
 public:
  KdTree2() = default;
  explicit KdTree2(const Cloud2& points) { Build(points); }
  // Copies the points (in tree order): `points` may change or go afterwards.
  void Build(const Cloud2& points);

  // Index of the nearest point with squared distance <= max_distance2 (and the squared
  // distance), or -1. Among points at the same distance the answer is fixed by the tree.
  int Nearest(const Eigen::Vector2d& q, double max_distance2, double* distance2) const;
  // Up to k nearest indices, closest first.
  void KNearest(const Eigen::Vector2d& q, int k, std::vector<int>* indices) const;
  std::size_t size() const { return index_.size(); }

 private:
  struct Node {
    Eigen::Vector2d p;
    int index;
  };
  void BuildRange(std::vector<Node>* nodes, int lo, int hi);
  void NearestRange(int lo, int hi, const Eigen::Vector2d& q, double* best2, int* best) const;
  // The k best so far, sorted by (distance2, index): a caller's buffer of k + 1 slots.
  struct KBest {
    std::pair<double, int>* slots;
    int size;
    int k;
  };
  void KNearestRange(int lo, int hi, const Eigen::Vector2d& q, KBest* best) const;
  Cloud2 sorted_;                  // the points in tree order
  std::vector<int> index_;         // tree position -> index in the cloud
  std::vector<std::uint8_t> dim_;  // split axis of the node whose median sits at position i
};

}  // namespace draco::icp
