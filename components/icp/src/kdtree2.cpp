// Static 2D kd-tree (see kdtree2.hpp). The tree is implicit in the index array: a range
// [lo, hi) longer than a leaf is split at mid = (lo + hi) / 2.
#include "draco/icp/kdtree2.hpp"

#include <algorithm>
#include <numeric>
#include <utility>

namespace draco::icp {
namespace {
constexpr int kLeaf = 8;
}

void KdTree2::Build(const Cloud2& points) {
  points_ = &points;
  index_.resize(points.size());
  std::iota(index_.begin(), index_.end(), 0);
  dim_.assign(points.size(), 0);
  BuildRange(0, static_cast<int>(points.size()));
}

void KdTree2::BuildRange(int lo, int hi) {
  if (hi - lo <= kLeaf) return;
  const Cloud2& p = *points_;
  Eigen::Vector2d mn = p[index_[lo]], mx = mn;
  for (int i = lo + 1; i < hi; ++i) {
    mn = mn.cwiseMin(p[index_[i]]);
    mx = mx.cwiseMax(p[index_[i]]);
  }
  const int d = (mx.x() - mn.x()) >= (mx.y() - mn.y()) ? 0 : 1;
  const int mid = (lo + hi) / 2;
  std::nth_element(index_.begin() + lo, index_.begin() + mid, index_.begin() + hi,
                   [&](int a, int b) { return p[a][d] < p[b][d]; });
  dim_[mid] = static_cast<std::uint8_t>(d);
  BuildRange(lo, mid);
  BuildRange(mid + 1, hi);
}

void KdTree2::NearestRange(int lo, int hi, const Eigen::Vector2d& q, double* best2,
                           int* best) const {
  const Cloud2& p = *points_;
  if (hi - lo <= kLeaf) {
    for (int i = lo; i < hi; ++i) {
      const double d2 = (p[index_[i]] - q).squaredNorm();
      if (d2 <= *best2) {
        *best2 = d2;
        *best = index_[i];
      }
    }
    return;
  }
  const int mid = (lo + hi) / 2;
  const int d = dim_[mid];
  const Eigen::Vector2d& m = p[index_[mid]];
  const double diff = q[d] - m[d];
  const double d2 = (m - q).squaredNorm();
  if (d2 <= *best2) {
    *best2 = d2;
    *best = index_[mid];
  }
  if (diff < 0.0) {
    NearestRange(lo, mid, q, best2, best);
    if (diff * diff <= *best2) NearestRange(mid + 1, hi, q, best2, best);
  } else {
    NearestRange(mid + 1, hi, q, best2, best);
    if (diff * diff <= *best2) NearestRange(lo, mid, q, best2, best);
  }
}

int KdTree2::Nearest(const Eigen::Vector2d& q, double max_distance2, double* distance2) const {
  int best = -1;
  double best2 = max_distance2;
  if (!index_.empty()) NearestRange(0, static_cast<int>(index_.size()), q, &best2, &best);
  if (distance2 != nullptr) *distance2 = best2;
  return best;
}

void KdTree2::KNearest(const Eigen::Vector2d& q, int k, std::vector<int>* indices) const {
  // Small k: a sorted list of (distance2, index), pruned against its worst member.
  std::vector<std::pair<double, int>> best;
  best.reserve(k + 1);
  const Cloud2& p = *points_;
  auto offer = [&](int idx) {
    const double d2 = (p[idx] - q).squaredNorm();
    if (static_cast<int>(best.size()) == k && d2 >= best.back().first) return;
    auto it = std::upper_bound(best.begin(), best.end(), std::make_pair(d2, idx));
    best.insert(it, {d2, idx});
    if (static_cast<int>(best.size()) > k) best.pop_back();
  };
  auto worst = [&] { return static_cast<int>(best.size()) < k ? 1e300 : best.back().first; };
  auto rec = [&](auto&& self, int lo, int hi) -> void {
    if (hi - lo <= kLeaf) {
      for (int i = lo; i < hi; ++i) offer(index_[i]);
      return;
    }
    const int mid = (lo + hi) / 2;
    const int d = dim_[mid];
    const double diff = q[d] - p[index_[mid]][d];
    offer(index_[mid]);
    if (diff < 0.0) {
      self(self, lo, mid);
      if (diff * diff < worst()) self(self, mid + 1, hi);
    } else {
      self(self, mid + 1, hi);
      if (diff * diff < worst()) self(self, lo, mid);
    }
  };
  if (k > 0 && !index_.empty()) rec(rec, 0, static_cast<int>(index_.size()));
  indices->clear();
  for (const auto& b : best) indices->push_back(b.second);
}

}  // namespace draco::icp
