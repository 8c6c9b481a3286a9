// Batch and incremental DBSCAN (see dbscan.hpp).
#include "draco/objects/dbscan.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <stdexcept>
#include <tuple>
#include <unordered_map>
#include <utility>

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

namespace {

// The points sorted into square cells of side eps / sqrt(2) (a hair less): any two points of
// a cell are within eps of each other, and a point's neighbours within eps lie in the 5 x 5
// cells around its own. Cells hold their points contiguously (coordinates copied in cell
// order) and know their non-empty neighbour cells.
struct CellGrid {
  std::vector<double> x, y;              // in cell order
  std::vector<std::uint32_t> index;      // cell order -> point index
  std::vector<std::uint32_t> begin;      // cell -> first position; begin[cells] = n
  std::vector<std::uint32_t> nbr_begin;  // cell -> first entry of nbr
  std::vector<std::uint32_t> nbr;        // non-empty cells of the 5 x 5 around, itself included

  std::size_t Cells() const { return begin.size() - 1; }

  CellGrid(const std::vector<Point2>& points, double eps_m) {
    const std::size_t n = points.size();
    const double side = eps_m / std::sqrt(2.0) * (1.0 - 1e-9);
    std::vector<std::pair<std::int64_t, std::int64_t>> cell(n);
    for (std::size_t i = 0; i < n; ++i) {
      cell[i] = {static_cast<std::int64_t>(std::floor(points[i].x_m / side)),
                 static_cast<std::int64_t>(std::floor(points[i].y_m / side))};
    }
    index.resize(n);
    for (std::size_t i = 0; i < n; ++i) index[i] = static_cast<std::uint32_t>(i);
    std::sort(index.begin(), index.end(), [&](std::uint32_t a, std::uint32_t b) {
      return cell[a] < cell[b] || (cell[a] == cell[b] && a < b);
    });
    x.resize(n);
    y.resize(n);
    const auto key = [](std::int64_t cx, std::int64_t cy) {
      return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(cx)) << 32) |
             static_cast<std::uint32_t>(cy);
    };
    std::unordered_map<std::uint64_t, std::uint32_t> id;
    for (std::size_t s = 0; s < n; ++s) {
      const std::uint32_t i = index[s];
      x[s] = points[i].x_m;
      y[s] = points[i].y_m;
      if (s == 0 || cell[i] != cell[index[s - 1]]) {
        id.emplace(key(cell[i].first, cell[i].second), static_cast<std::uint32_t>(begin.size()));
        begin.push_back(static_cast<std::uint32_t>(s));
      }
    }
    begin.push_back(static_cast<std::uint32_t>(n));
    nbr_begin.reserve(begin.size());
    for (std::size_t c = 0; c + 1 < begin.size(); ++c) {
      nbr_begin.push_back(static_cast<std::uint32_t>(nbr.size()));
      const auto [cx, cy] = cell[index[begin[c]]];
      for (std::int64_t dx = -2; dx <= 2; ++dx) {
        for (std::int64_t dy = -2; dy <= 2; ++dy) {
          const auto it = id.find(key(cx + dx, cy + dy));
          if (it != id.end()) nbr.push_back(it->second);
        }
      }
    }
    nbr_begin.push_back(static_cast<std::uint32_t>(nbr.size()));
  }
};

// The batch clustering in the incremental form's terms: per point core or not, its neighbour
// count (exact below min_points, min_points at or above), its cluster's lowest core point
// index (core points), its nearest core point and squared distance (border points; -1 noise).
struct BatchState {
  std::vector<std::uint8_t> core;
  std::vector<std::int32_t> count;
  std::vector<std::uint32_t> root;
  std::vector<std::int64_t> nearest;
  std::vector<double> nearest_d2;
};

BatchState ClusterBatch(const std::vector<Point2>& points, const DbscanOptions& options) {
  const std::size_t n = points.size();
  BatchState out;
  out.core.assign(n, 0);
  out.count.assign(n, 0);
  out.root.resize(n);
  for (std::size_t i = 0; i < n; ++i) out.root[i] = static_cast<std::uint32_t>(i);
  out.nearest.assign(n, -1);
  out.nearest_d2.assign(n, 0.0);
  if (n == 0) return out;
  const double r2 = options.eps_m * options.eps_m;
  const auto min_points = static_cast<std::size_t>(options.min_points);
  const CellGrid g(points, options.eps_m);
  const std::size_t cells = g.Cells();
  const auto within = [&](std::uint32_t s, std::uint32_t t) {
    const double ex = g.x[t] - g.x[s], ey = g.y[t] - g.y[s];
    return ex * ex + ey * ey <= r2;
  };
  // 1. Core points (cell order): a cell of min_points is all core; otherwise count the
  // neighbours (itself included) until min_points.
  std::vector<std::uint8_t> core(n, 0);
  for (std::size_t c = 0; c < cells; ++c) {
    if (g.begin[c + 1] - g.begin[c] >= min_points) {
      std::fill(core.begin() + g.begin[c], core.begin() + g.begin[c + 1], 1);
      for (std::uint32_t s = g.begin[c]; s < g.begin[c + 1]; ++s) {
        out.count[g.index[s]] = options.min_points;
      }
      continue;
    }
    for (std::uint32_t s = g.begin[c]; s < g.begin[c + 1]; ++s) {
      std::size_t count = 0;
      for (std::uint32_t e = g.nbr_begin[c]; e < g.nbr_begin[c + 1] && count < min_points; ++e) {
        const std::uint32_t d = g.nbr[e];
        for (std::uint32_t t = g.begin[d]; t < g.begin[d + 1] && count < min_points; ++t) {
          count += within(s, t) ? 1 : 0;
        }
      }
      core[s] = count >= min_points;
      out.count[g.index[s]] = static_cast<std::int32_t>(count);
    }
  }
  // 2. Clusters: the core points of a cell are one another's neighbours; two cells join when
  // any core point of one lies within eps of one of the other (union-find over cells).
  std::vector<std::uint32_t> parent(cells);
  std::vector<std::uint8_t> core_cell(cells, 0);
  for (std::size_t c = 0; c < cells; ++c) {
    parent[c] = static_cast<std::uint32_t>(c);
    for (std::uint32_t s = g.begin[c]; s < g.begin[c + 1] && !core_cell[c]; ++s) {
      core_cell[c] = core[s];
    }
  }
  const auto find = [&](std::uint32_t c) {
    while (parent[c] != c) c = parent[c] = parent[parent[c]];
    return c;
  };
  for (std::uint32_t c = 0; c < cells; ++c) {
    if (!core_cell[c]) continue;
    for (std::uint32_t e = g.nbr_begin[c]; e < g.nbr_begin[c + 1]; ++e) {
      const std::uint32_t d = g.nbr[e];
      if (d <= c || !core_cell[d] || find(c) == find(d)) continue;
      bool joined = false;
      for (std::uint32_t s = g.begin[c]; s < g.begin[c + 1] && !joined; ++s) {
        if (!core[s]) continue;
        for (std::uint32_t t = g.begin[d]; t < g.begin[d + 1] && !joined; ++t) {
          joined = core[t] && within(s, t);
        }
      }
      if (joined) {
        const std::uint32_t a = find(c), b = find(d);
        parent[std::max(a, b)] = std::min(a, b);
      }
    }
  }
  // Each cluster's lowest core point index.
  std::vector<std::uint32_t> lowest(cells, std::numeric_limits<std::uint32_t>::max());
  for (std::uint32_t c = 0; c < cells; ++c) {
    for (std::uint32_t s = g.begin[c]; s < g.begin[c + 1]; ++s) {
      if (!core[s]) continue;
      std::uint32_t& low = lowest[find(c)];
      low = std::min(low, g.index[s]);
    }
  }
  // 3. Core points: their cluster's root; border points: their nearest core point.
  for (std::uint32_t c = 0; c < cells; ++c) {
    for (std::uint32_t s = g.begin[c]; s < g.begin[c + 1]; ++s) {
      const std::uint32_t i = g.index[s];
      if (core[s]) {
        out.core[i] = 1;
        out.root[i] = lowest[find(c)];
        continue;
      }
      for (std::uint32_t e = g.nbr_begin[c]; e < g.nbr_begin[c + 1]; ++e) {
        const std::uint32_t d = g.nbr[e];
        if (!core_cell[d]) continue;
        for (std::uint32_t t = g.begin[d]; t < g.begin[d + 1]; ++t) {
          if (!core[t]) continue;
          const double d2 = Dist2(points[i], points[g.index[t]]);
          if (d2 <= r2 && Closer(d2, g.index[t], out.nearest_d2[i], out.nearest[i])) {
            out.nearest[i] = g.index[t];
            out.nearest_d2[i] = d2;
          }
        }
      }
    }
  }
  return out;
}

}  // namespace

std::vector<int> DbscanBatch(const std::vector<Point2>& points, const DbscanOptions& options) {
  CheckOptions(options);
  const BatchState b = ClusterBatch(points, options);
  // Ids in the order of each cluster's lowest core point index (its root).
  std::vector<int> id(points.size(), kNoise);
  int next = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (b.core[i] && b.root[i] == i) id[i] = next++;
  }
  std::vector<int> labels(points.size(), kNoise);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (b.core[i]) {
      labels[i] = id[b.root[i]];
    } else if (b.nearest[i] >= 0) {
      labels[i] = id[b.root[static_cast<std::size_t>(b.nearest[i])]];
    }
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

void IncrementalDbscan::Rebuild(std::vector<Point2> points) {
  if (points.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::length_error("DBSCAN: too many points");
  }
  Clear();
  BatchState b = ClusterBatch(points, options_);
  const std::size_t n = points.size();
  points_ = std::move(points);
  count_ = std::move(b.count);
  core_ = std::move(b.core);
  parent_ = std::move(b.root);  // core points: the cluster's lowest index, as Union leaves it
  for (std::size_t i = 0; i < n; ++i) {
    if (!core_[i]) parent_[i] = static_cast<std::uint32_t>(i);
  }
  component_id_.assign(n, -1);
  nearest_core_ = std::move(b.nearest);
  nearest_d2_ = std::move(b.nearest_d2);
  for (std::size_t i = 0; i < n; ++i) grid_.Insert(points_[i], static_cast<std::uint32_t>(i));
  for (std::size_t i = 0; i < n; ++i) {  // fresh ids in root order, as Add gives them
    if (core_[i] && parent_[i] == i) component_id_[i] = next_id_++;
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
