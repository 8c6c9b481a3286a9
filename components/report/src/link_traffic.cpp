// Link traffic of a team run (team_run.hpp): the frames of link_traffic.csv and their bit
// rates per message kind in time windows.
#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "csv.hpp"
#include "draco/report/team_run.hpp"
#include "message_kinds.hpp"

namespace draco::report {

// Message kinds in the order of docs/fleet.md; unknown kinds after them, by name.
int internal::KindRank(const std::string& kind) {
  static const char* kOrder[] = {"object_map", "keyframe_poses", "scan_request",
                                 "scan_reply", "loop_closures",  "heartbeat"};
  for (int i = 0; i < static_cast<int>(std::size(kOrder)); ++i) {
    if (kind == kOrder[i]) return i;
  }
  return static_cast<int>(std::size(kOrder));
}

namespace {

using internal::Csv;
using internal::KindRank;
using internal::ReadCsv;

}  // namespace

std::vector<TrafficFrame> ReadLinkTraffic(const std::string& csv_path) {
  const Csv csv = ReadCsv(csv_path);
  std::vector<TrafficFrame> out;
  if (csv.rows.empty()) return out;
  const std::size_t start = csv.Col("start_s"), end = csv.Col("end_s"), kind = csv.Col("kind"),
                    bits = csv.Col("bits"), lost = csv.Col("lost");
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    TrafficFrame f;
    f.start_s = csv.Number(i, start);
    f.end_s = csv.Number(i, end);
    if (kind >= csv.rows[i].size()) throw std::runtime_error(csv_path + ": too few columns");
    f.kind = csv.rows[i][kind];
    f.bits = csv.Number(i, bits);
    f.lost = csv.Number(i, lost) != 0.0;
    out.push_back(std::move(f));
  }
  return out;
}

TrafficSeries BinTraffic(const std::vector<TrafficFrame>& frames, double window_s, double end_s) {
  TrafficSeries t;
  if (!(window_s > 0)) throw std::invalid_argument("BinTraffic: window_s must be positive");
  t.window_s = window_s;
  double last_s = std::max(end_s, 0.0);
  for (const auto& f : frames) last_s = std::max(last_s, f.start_s);
  const std::size_t windows =
      frames.empty() && last_s <= 0
          ? 0
          : std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(last_s / window_s - 1e-9)));
  std::vector<double> length(windows, window_s);
  for (std::size_t w = 0; w < windows; ++w) {
    t.window_start_s.push_back(static_cast<double>(w) * window_s);
    // The last window, when the mission ends inside it, is as long as what is left.
    if (end_s > t.window_start_s[w]) length[w] = std::min(window_s, end_s - t.window_start_s[w]);
  }
  t.total_bps.assign(windows, 0.0);
  std::map<std::string, std::size_t> index;
  std::vector<std::string> seen;
  for (const auto& f : frames) {
    if (index.emplace(f.kind, 0).second) seen.push_back(f.kind);
  }
  std::stable_sort(seen.begin(), seen.end(), [](const std::string& a, const std::string& b) {
    return KindRank(a) < KindRank(b) || (KindRank(a) == KindRank(b) && a < b);
  });
  for (std::size_t k = 0; k < seen.size(); ++k) index[seen[k]] = k;
  t.kinds = seen;
  t.bps.assign(seen.size(), std::vector<double>(windows, 0.0));
  for (const auto& f : frames) {
    if (f.start_s < 0) continue;
    const auto w =
        std::min(windows - 1, static_cast<std::size_t>(std::floor(f.start_s / window_s)));
    t.bps[index[f.kind]][w] += f.bits / length[w];
    t.total_bps[w] += f.bits / length[w];
  }
  return t;
}

}  // namespace draco::report
