// Static 2D kd-tree (see kdtree2.hpp). The tree is implicit in the position array: a range
// [lo, hi) longer than a leaf is split at mid = (lo + hi) / 2, and the points are stored in
// that order, so a leaf is a contiguous run of memory.
#include "draco/icp/kdtree2.hpp"

#include <algorithm>
#include <utility>

namespace draco::icp {
namespace {
constexpr int kLeaf = 8;
}

void KdTree2::Build(const Cloud2& points) {
  // The median splits move (point, index) records, so the comparisons read memory in order;
  // std::nth_element sees the same comparisons as on an index array and so leaves the same
  // arrangement.
  std::vector<Node> nodes(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) nodes[i] = {points[i], static_cast<int>(i)};
  dim_.assign(points.size(), 0);
  BuildRange(&nodes, 0, static_cast<int>(points.size()));
  sorted_.resize(points.size());
  index_.resize(points.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    sorted_[i] = nodes[i].p;
    index_[i] = nodes[i].index;
  }
}

void KdTree2::BuildRange(std::vector<Node>* nodes, int lo, int hi) {
  if (hi - lo <= kLeaf) return;
  Node* n = nodes->data();
  Eigen::Vector2d mn = n[lo].p, mx = mn;
  for (int i = lo + 1; i < hi; ++i) {
    mn = mn.cwiseMin(n[i].p);
    mx = mx.cwiseMax(n[i].p);
  }
  const int d = (mx.x() - mn.x()) >= (mx.y() - mn.y()) ? 0 : 1;
  const int mid = (lo + hi) / 2;
  std::nth_element(n + lo, n + mid, n + hi,
                   [d](const Node& a, const Node& b) { return a.p[d] < b.p[d]; });
  dim_[static_cast<std::size_t>(mid)] = static_cast<std::uint8_t>(d);
  BuildRange(nodes, lo, mid);
  BuildRange(nodes, mid + 1, hi);
}

namespace {

// The fixed visiting order of every search: each node's median, then the child on q's side,
// then the other one if enter(its splitting line's squared distance) still holds when the
// near side is done. Depth first with an explicit stack of far sides, the order a recursion
// would take without its calls. visit(pos) is called for each point visited (tree order
// positions).
template <class Visit, class Enter>
[[gnu::always_inline]] inline void Traverse(const Eigen::Vector2d* p, const std::uint8_t* dim,
                                            int lo, int hi, const Eigen::Vector2d& q, Visit visit,
                                            Enter enter) {
  struct Pending {
    int lo, hi;
    double line2;
  };
  Pending stack[64];  // one entry per level: 2^64 points are not held
  int top = 0;
  for (;;) {
    while (hi - lo > kLeaf) {
      const int mid = (lo + hi) / 2;
      const int d = dim[mid];
      const double diff = q[d] - p[mid][d];
      visit(mid);
      if (diff < 0.0) {
        stack[top++] = Pending{mid + 1, hi, diff * diff};
        hi = mid;
      } else {
        stack[top++] = Pending{lo, mid, diff * diff};
        lo = mid + 1;
      }
    }
    for (int i = lo; i < hi; ++i) visit(i);
    do {
      if (top == 0) return;
      --top;
    } while (!enter(stack[top].line2));
    lo = stack[top].lo;
    hi = stack[top].hi;
  }
}

}  // namespace

// Enters a far side when its line is within the best so far and keeps the last point at the
// smallest distance.
void KdTree2::NearestRange(int lo, int hi, const Eigen::Vector2d& q, double* best2,
                           int* best) const {
  const Eigen::Vector2d* p = sorted_.data();
  const Eigen::Vector2d query = q;
  double b2 = *best2;  // locals, so that the lambdas keep them in registers
  int b = *best;
  Traverse(
      p, dim_.data(), lo, hi, query,
      [&](int pos) {
        const double d2 = (p[pos] - query).squaredNorm();
        if (d2 <= b2) {
          b2 = d2;
          b = pos;
        }
      },
      [&](double line2) { return line2 <= b2; });
  *best2 = b2;
  *best = b;
}

int KdTree2::Nearest(const Eigen::Vector2d& q, double max_distance2, double* distance2) const {
  int best = -1;
  double best2 = max_distance2;
  if (!index_.empty()) NearestRange(0, static_cast<int>(index_.size()), q, &best2, &best);
  if (distance2 != nullptr) *distance2 = best2;
  return best < 0 ? -1 : index_[static_cast<std::size_t>(best)];
}

// Enters a far side while its line is strictly closer than the list's worst; a point is taken
// when the list is not full or it is strictly closer than the list's worst (the first of equal
// points visited stays).
void KdTree2::KNearestRange(int lo, int hi, const Eigen::Vector2d& q, KBest* best) const {
  const Eigen::Vector2d* p = sorted_.data();
  auto offer = [&](int pos) {
    const double d2 = (p[pos] - q).squaredNorm();
    if (best->size == best->k && d2 >= best->slots[best->size - 1].first) return;
    const std::pair<double, int> entry{d2, index_[static_cast<std::size_t>(pos)]};
    std::pair<double, int>* end = best->slots + best->size;
    std::pair<double, int>* it = std::upper_bound(best->slots, end, entry);
    std::move_backward(it, end, end + 1);
    *it = entry;
    if (best->size < best->k) ++best->size;
  };
  auto worst = [&] { return best->size < best->k ? 1e300 : best->slots[best->size - 1].first; };
  Traverse(p, dim_.data(), lo, hi, q, offer, [&](double line2) { return line2 < worst(); });
}

void KdTree2::KNearest(const Eigen::Vector2d& q, int k, std::vector<int>* indices) const {
  indices->clear();
  if (k <= 0 || index_.empty()) return;
  // Small k (normals: 6 neighbours) on the stack; the list needs one slot beyond k.
  constexpr int kInline = 32;
  std::pair<double, int> inline_slots[kInline + 1];
  std::vector<std::pair<double, int>> heap_slots;
  std::pair<double, int>* slots = inline_slots;
  if (k > kInline) {
    heap_slots.resize(static_cast<std::size_t>(k) + 1);
    slots = heap_slots.data();
  }
  KBest best{slots, 0, k};
  KNearestRange(0, static_cast<int>(index_.size()), q, &best);
  for (int i = 0; i < best.size; ++i) indices->push_back(slots[i].second);
}

}  // namespace draco::icp
