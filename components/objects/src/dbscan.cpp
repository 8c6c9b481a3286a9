// Batch and incremental DBSCAN (see dbscan.hpp).
#include "draco/objects/dbscan.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <stdexcept>
#include <tuple>

namespace draco::objects {
namespace {

double Dist2(const Point2& a, const Point2& b) {
  const double dx = a.x_m - b.x_m, dy = a.y_m - b.y_m;
  return dx * dx + dy * dy;
}

void CheckOptions(const DbscanOptions& options) {
  if (!(options.eps_m > 0.0)) throw std::invalid_argument("DBSCAN: eps_m must be > 0");
  if (options.min_points < 1) throw std::invalid_argument("DBSCAN: min_points must be >= 1");
}

// Nearest-core rule shared by both forms: smaller distance, then lower index.
bool Closer(double d2, std::int64_t index, double best_d2, std::int64_t best_index) {
  return best_index < 0 || d2 < best_d2 || (d2 == best_d2 && index < best_index);
}

}  // namespace

void PointGrid::Insert(const Point2& p, std::uint32_t index) {
  cells_[Key(Cell(p.x_m), Cell(p.y_m))].push_back(index);
}

std::vector<int> DbscanBatch(const std::vector<Point2>& points, const DbscanOptions& options) {
  CheckOptions(options);
  const std::size_t n = points.size();
  PointGrid grid(options.eps_m);
  for (std::size_t i = 0; i < n; ++i) grid.Insert(points[i], static_cast<std::uint32_t>(i));
  std::vector<std::uint8_t> core(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    int count = 0;
    grid.ForNeighbours(points, points[i], options.eps_m, [&](std::uint32_t) { ++count; });
    core[i] = count >= options.min_points;
  }
  std::vector<int> labels(n, kNoise);
  int next = 0;
  std::vector<std::uint32_t> stack;
  for (std::size_t seed = 0; seed < n; ++seed) {  // components of core points
    if (!core[seed] || labels[seed] != kNoise) continue;
    labels[seed] = next;
    stack.assign(1, static_cast<std::uint32_t>(seed));
    while (!stack.empty()) {
      const std::uint32_t i = stack.back();
      stack.pop_back();
      grid.ForNeighbours(points, points[i], options.eps_m, [&](std::uint32_t j) {
        if (core[j] && labels[j] == kNoise) {
          labels[j] = next;
          stack.push_back(j);
        }
      });
    }
    ++next;
  }
  for (std::size_t i = 0; i < n; ++i) {  // border points: nearest core point
    if (core[i]) continue;
    std::int64_t best = -1;
    double best_d2 = 0.0;
    grid.ForNeighbours(points, points[i], options.eps_m, [&](std::uint32_t j) {
      const double d2 = Dist2(points[i], points[j]);
      if (core[j] && Closer(d2, j, best_d2, best)) best = j, best_d2 = d2;
    });
    if (best >= 0) labels[i] = labels[static_cast<std::size_t>(best)];
  }
  return labels;
}

IncrementalDbscan::IncrementalDbscan(const DbscanOptions& options)
    : options_(options), grid_(options.eps_m) {
  CheckOptions(options);
}

void IncrementalDbscan::Clear() {
  grid_.Clear();
  points_.clear();
  count_.clear();
  core_.clear();
  parent_.clear();
  component_id_.clear();
  nearest_core_.clear();
  nearest_d2_.clear();
}

std::uint32_t IncrementalDbscan::Find(std::uint32_t i) const {
  while (parent_[i] != i) {
    parent_[i] = parent_[parent_[i]];  // path halving
    i = parent_[i];
  }
  return i;
}

void IncrementalDbscan::Union(std::uint32_t a, std::uint32_t b) {
  a = Find(a);
  b = Find(b);
  if (a == b) return;
  if (a > b) std::swap(a, b);  // deterministic root: the lower index
  const int ia = component_id_[a], ib = component_id_[b];
  parent_[b] = a;
  // The merged cluster keeps the oldest id (ids of newly core points are unset, -1).
  component_id_[a] = ia < 0 ? ib : (ib < 0 ? ia : std::min(ia, ib));
}

void IncrementalDbscan::OfferCore(std::uint32_t border, std::uint32_t core) {
  const double d2 = Dist2(points_[border], points_[core]);
  if (Closer(d2, core, nearest_d2_[border], nearest_core_[border])) {
    nearest_core_[border] = core;
    nearest_d2_[border] = d2;
  }
}

void IncrementalDbscan::Add(const std::vector<Point2>& points) {
  const std::size_t start = points_.size();
  const std::size_t n = start + points.size();
  if (n > std::numeric_limits<std::uint32_t>::max()) {
    throw std::length_error("DBSCAN: too many points");
  }
  points_.insert(points_.end(), points.begin(), points.end());
  count_.resize(n, 0);
  core_.resize(n, 0);
  parent_.resize(n);
  component_id_.resize(n, -1);
  nearest_core_.resize(n, -1);
  nearest_d2_.resize(n, 0.0);

  // 1. Neighbour counts: each new point against the points inserted before it.
  std::vector<std::uint32_t> touched;
  for (std::size_t i = start; i < n; ++i) {
    const auto ii = static_cast<std::uint32_t>(i);
    parent_[i] = ii;
    int found = 0;
    grid_.ForNeighbours(points_, points_[i], options_.eps_m, [&](std::uint32_t j) {
      ++found;
      ++count_[j];
      if (j < start && !core_[j] && count_[j] == options_.min_points) touched.push_back(j);
    });
    count_[i] = found + 1;
    grid_.Insert(points_[i], ii);
  }
  // 2. Points that became core: old points that crossed the threshold, and new points.
  std::vector<std::uint32_t> new_core = std::move(touched);
  for (std::size_t i = start; i < n; ++i) {
    if (count_[i] >= options_.min_points) new_core.push_back(static_cast<std::uint32_t>(i));
  }
  std::sort(new_core.begin(), new_core.end());
  for (const std::uint32_t p : new_core) {
    core_[p] = 1;
    parent_[p] = p;
    component_id_[p] = -1;
    nearest_core_[p] = -1;
  }
  // 3. Core-core edges with a newly core end, and border candidates around new cores.
  for (const std::uint32_t p : new_core) {
    grid_.ForNeighbours(points_, points_[p], options_.eps_m, [&](std::uint32_t q) {
      if (q == p) return;
      if (core_[q]) {
        Union(p, q);
      } else {
        OfferCore(q, p);
      }
    });
  }
  for (const std::uint32_t p : new_core) {  // new components: fresh ids, in index order
    const std::uint32_t r = Find(p);
    if (component_id_[r] < 0) component_id_[r] = next_id_++;
  }
  // 4. New non-core points: nearest core among all neighbours (old cores included).
  for (std::size_t i = start; i < n; ++i) {
    if (core_[i]) continue;
    const auto ii = static_cast<std::uint32_t>(i);
    grid_.ForNeighbours(points_, points_[i], options_.eps_m, [&](std::uint32_t q) {
      if (core_[q]) OfferCore(ii, q);
    });
  }
}

int IncrementalDbscan::Label(std::size_t i) const {
  if (core_[i]) return component_id_[Find(static_cast<std::uint32_t>(i))];
  if (nearest_core_[i] < 0) return kNoise;
  return component_id_[Find(static_cast<std::uint32_t>(nearest_core_[i]))];
}

std::vector<int> IncrementalDbscan::Labels() const {
  std::vector<int> labels(points_.size());
  for (std::size_t i = 0; i < points_.size(); ++i) labels[i] = Label(i);
  return labels;
}

void IncrementalDbscan::RemapIds(const std::vector<int>& previous_labels) {
  if (previous_labels.size() != points_.size()) {
    throw std::invalid_argument("DBSCAN: RemapIds needs one previous label per point");
  }
  // Overlap between current components (by root) and previous ids.
  std::map<std::pair<int, std::uint32_t>, int> overlap;  // (old id, root) -> points
  std::vector<std::uint32_t> roots;
  for (std::size_t i = 0; i < points_.size(); ++i) {
    std::int64_t c = core_[i] ? static_cast<std::int64_t>(i) : nearest_core_[i];
    if (c < 0) continue;
    const std::uint32_t r = Find(static_cast<std::uint32_t>(c));
    if (core_[i] && r == i) roots.push_back(r);
    if (previous_labels[i] != kNoise) ++overlap[{previous_labels[i], r}];
  }
  std::vector<std::tuple<int, int, std::uint32_t>> claims;  // (old id, -points, root)
  for (const auto& [key, points] : overlap) claims.emplace_back(key.first, -points, key.second);
  std::sort(claims.begin(), claims.end());
  std::map<std::uint32_t, int> assigned;
  std::map<int, bool> used;
  for (const auto& [old_id, neg_points, root] : claims) {
    if (assigned.count(root) || used.count(old_id)) continue;
    assigned[root] = old_id;
    used[old_id] = true;
    next_id_ = std::max(next_id_, old_id + 1);
  }
  std::sort(roots.begin(), roots.end());
  for (const std::uint32_t r : roots) {
    const auto it = assigned.find(r);
    component_id_[r] = it != assigned.end() ? it->second : next_id_++;
  }
}

}  // namespace draco::objects
