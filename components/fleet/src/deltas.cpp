// Object-map and keyframe-pose delta encoders (codec.hpp).
#include <algorithm>
#include <cmath>
#include <numbers>

#include "draco/fleet/codec.hpp"

namespace draco::fleet {

namespace {

bool ById(const msgs::Object& a, const msgs::Object& b) { return a.id < b.id; }

const msgs::Object* Find(const std::vector<msgs::Object>& sorted, std::uint32_t id) {
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), id,
                                   [](const msgs::Object& o, std::uint32_t v) { return o.id < v; });
  return it != sorted.end() && it->id == id ? &*it : nullptr;
}

// Difference of two pi-periodic directions, in [0, pi/2].
double HalfTurnDiff(double a, double b) {
  const double d = std::abs(std::remainder(a - b, std::numbers::pi));
  return std::isfinite(d) ? d : std::numbers::pi;
}

bool Changed(const msgs::Object& now, const msgs::Object& sent, const ObjectDeltaOptions& o) {
  const double dc = std::hypot(now.center.x_m - sent.center.x_m, now.center.y_m - sent.center.y_m);
  if (!(dc <= o.min_center_change_m)) return true;
  if (!(std::abs(now.length_m - sent.length_m) <= o.min_side_change_m)) return true;
  if (!(std::abs(now.breadth_m - sent.breadth_m) <= o.min_side_change_m)) return true;
  if (HalfTurnDiff(now.yaw_rad, sent.yaw_rad) > o.min_yaw_change_rad) return true;
  const double dn = std::abs(static_cast<double>(now.num_points - sent.num_points));
  return dn > o.min_points_change_ratio * std::max(1, sent.num_points);
}

std::vector<msgs::Object> SortedWithoutKeyframes(const std::vector<msgs::Object>& objects) {
  std::vector<msgs::Object> out = objects;
  for (auto& ob : out) ob.keyframes.clear();
  std::stable_sort(out.begin(), out.end(), ById);
  return out;
}

}  // namespace

ObjectMapDeltaEncoder::ObjectMapDeltaEncoder(const ObjectDeltaOptions& options)
    : options_(options) {}

bool ObjectMapDeltaEncoder::MakeUpdate(const msgs::ObjectMap& current, std::uint32_t base_version,
                                       msgs::ObjectMapUpdate* update) {
  const std::vector<msgs::Object> now = SortedWithoutKeyframes(current.objects);
  const msgs::ObjectMap* base = nullptr;
  if (base_version != 0)
    for (const auto& [v, map] : history_)
      if (v == base_version) base = &map;

  msgs::ObjectMapUpdate out;
  // What the receiver will hold after applying `out` (remembered as the new version, so that
  // changes under the thresholds never pile up unsent).
  msgs::ObjectMap held;
  held.robot_id = current.robot_id;
  held.time_s = current.time_s;
  held.map_heading_rad = current.map_heading_rad;
  out.map_heading_rad = current.map_heading_rad;
  if (base == nullptr) {
    out.base_version = 0;
    out.upserts = now;
    held.objects = now;
  } else {
    out.base_version = base_version;
    const std::vector<msgs::Object>& before = base->objects;  // sorted by id
    for (const auto& ob : now) {
      const msgs::Object* sent = Find(before, ob.id);
      if (sent == nullptr || Changed(ob, *sent, options_)) {
        out.upserts.push_back(ob);
        held.objects.push_back(ob);
      } else {
        held.objects.push_back(*sent);
      }
    }
    for (const auto& ob : before)
      if (Find(now, ob.id) == nullptr) out.removed.push_back(ob.id);
    if (out.upserts.empty() && out.removed.empty()) return false;
  }
  out.version = ++version_;
  out.header = update->header;
  out.header.robot_id = current.robot_id;
  out.header.time_s = current.time_s;
  *update = std::move(out);

  history_.emplace_back(version_, std::move(held));
  const std::size_t keep = static_cast<std::size_t>(std::max(1, options_.history));
  if (history_.size() > keep)
    history_.erase(history_.begin(), history_.end() - static_cast<std::ptrdiff_t>(keep));
  return true;
}

bool ApplyObjectMapUpdate(const msgs::ObjectMapUpdate& update, msgs::ObjectMap* held,
                          std::uint32_t* held_version) {
  if (update.base_version != 0 && update.base_version != *held_version) return false;
  std::vector<msgs::Object> objects;
  if (update.base_version == 0) {
    objects = SortedWithoutKeyframes(update.upserts);
  } else {
    objects = SortedWithoutKeyframes(held->objects);
    std::vector<msgs::Object> upserts = SortedWithoutKeyframes(update.upserts);
    std::vector<std::uint32_t> removed = update.removed;
    std::sort(removed.begin(), removed.end());
    std::vector<msgs::Object> merged;
    merged.reserve(objects.size() + upserts.size());
    std::size_t i = 0, j = 0;
    while (i < objects.size() || j < upserts.size()) {
      if (j == upserts.size() || (i < objects.size() && objects[i].id < upserts[j].id)) {
        if (!std::binary_search(removed.begin(), removed.end(), objects[i].id))
          merged.push_back(std::move(objects[i]));
        ++i;
      } else {
        if (i < objects.size() && objects[i].id == upserts[j].id) ++i;  // replaced
        merged.push_back(std::move(upserts[j++]));
      }
    }
    objects = std::move(merged);
  }
  // Duplicate ids in a (malformed) update: keep the first.
  objects.erase(
      std::unique(objects.begin(), objects.end(),
                  [](const msgs::Object& a, const msgs::Object& b) { return a.id == b.id; }),
      objects.end());
  held->objects = std::move(objects);
  held->robot_id = update.header.robot_id;
  held->time_s = update.header.time_s;
  held->map_heading_rad = update.map_heading_rad;
  *held_version = update.version;
  return true;
}

KeyframePoseDeltaEncoder::KeyframePoseDeltaEncoder(const PoseDeltaOptions& options)
    : options_(options) {}

bool KeyframePoseDeltaEncoder::MakeUpdate(const std::vector<msgs::KeyframePoseEntry>& current,
                                          bool full, msgs::KeyframePoses* update) {
  std::vector<msgs::KeyframePoseEntry> sorted = current;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const auto& a, const auto& b) { return a.index < b.index; });
  sorted.erase(std::unique(sorted.begin(), sorted.end(),
                           [](const auto& a, const auto& b) { return a.index == b.index; }),
               sorted.end());
  const auto find = [](std::vector<msgs::KeyframePoseEntry>& v, int index) {
    return std::lower_bound(v.begin(), v.end(), index,
                            [](const msgs::KeyframePoseEntry& s, int i) { return s.index < i; });
  };
  std::vector<msgs::KeyframePoseEntry> send;
  for (const auto& e : sorted) {
    const auto it = find(sent_, e.index);
    bool moved = full || it == sent_.end() || it->index != e.index;
    if (!moved) {
      const double dt =
          std::hypot(e.T_map_kf.x_m - it->T_map_kf.x_m, e.T_map_kf.y_m - it->T_map_kf.y_m);
      const double dr =
          std::abs(std::remainder(e.T_map_kf.yaw_rad - it->T_map_kf.yaw_rad, 2 * std::numbers::pi));
      moved = !(dt <= options_.min_translation_m) || !(dr <= options_.min_rotation_rad);
    }
    if (moved) send.push_back(e);
  }
  if (send.empty()) return false;
  // Remember what was sent (entries not sent keep their last sent pose).
  if (full) sent_.clear();
  for (const auto& e : send) {
    const auto it = find(sent_, e.index);
    if (it != sent_.end() && it->index == e.index)
      *it = e;
    else
      sent_.insert(it, e);
  }
  update->full = full;
  update->poses = std::move(send);
  return true;
}

}  // namespace draco::fleet
