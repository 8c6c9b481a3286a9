// draco-fleet-sizes: sizes of the fleet messages (components/fleet codec) on recorded keyframes.
//
//   draco-fleet-sizes KEYFRAMES.bin... [--period 10]
//
// KEYFRAMES.bin: keyframe caches of the evaluation apps (OUT/slam/<robot>.keyframes.bin). For
// every file: each keyframe as a scan reply (every point coding, with and without deflate;
// point-step and subsampling sweeps), keyframe-pose updates and object-map updates (full and
// delta, ObjectMapper on the keyframes) every --period seconds of mission time. Prints mean
// and max bits per message (docs/fleet.md "Messages and their encoding").
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "app_version.hpp"
#include "draco/fleet/codec.hpp"
#include "draco/frontend/pipeline.hpp"
#include "draco/objects/object_mapper.hpp"
#include "log_option.hpp"
#include "points.hpp"  // private to the codec: the individual point codings

namespace {

using namespace draco;

struct Stat {
  double sum = 0.0;
  double max = 0.0;
  long n = 0;
  void Add(double v) {
    sum += v;
    max = std::max(max, v);
    ++n;
  }
  double mean() const { return n ? sum / static_cast<double>(n) : 0.0; }
};

void Row(const std::string& name, const Stat& s, const std::string& note = "") {
  std::printf("| %-44s | %6ld | %9.0f | %9.0f | %s\n", name.c_str(), s.n, s.mean(), s.max,
              note.c_str());
}

double Bits(const std::vector<std::uint8_t>& b) { return 8.0 * static_cast<double>(b.size()); }

msgs::ScanReply Reply(const registration::KeyframeScan& k, std::vector<msgs::Point2> pts) {
  msgs::ScanReply r;
  r.header = {.robot_id = 1, .incarnation = 0x12345678, .seq = 17, .time_s = k.time_s + 30};
  r.requester_robot = 0;
  r.keyframe = k.index;
  r.keyframe_time_s = k.time_s;
  r.T_map_kf = k.T_map_kf;
  r.points_kf = std::move(pts);
  return r;
}

// One point per voxel (cell_m square), the first one seen.
std::vector<msgs::Point2> Voxel(const std::vector<msgs::Point2>& in, double cell_m) {
  std::map<std::pair<long, long>, bool> seen;
  std::vector<msgs::Point2> out;
  for (const auto& p : in) {
    const auto key = std::make_pair(std::lround(p.x_m / cell_m), std::lround(p.y_m / cell_m));
    if (seen.emplace(key, true).second) out.push_back(p);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-fleet-sizes: fleet message sizes on recorded keyframes"};
  draco::app::AddLogLevelOption(app);
  std::vector<std::string> files;
  double period_s = 10.0;
  app.add_option("keyframes", files, "keyframe caches (OUT/slam/<robot>.keyframes.bin)")
      ->required();
  app.add_option("--period", period_s, "mission seconds between object-map / pose updates");
  app.set_version_flag("--version", draco::app::VersionLine("draco-fleet-sizes"));
  CLI11_PARSE(app, argc, argv);

  const fleet::CodecOptions o;
  using fleet::points::PointCoding;
  std::map<std::string, Stat> scan;
  std::vector<std::string> scan_order;
  const auto add_scan = [&](const std::string& name, double bits) {
    if (!scan.count(name)) scan_order.push_back(name);
    scan[name].Add(bits);
  };
  Stat points_per_scan, poses_update, poses_full, poses_per_update, map_full, map_delta,
      map_delta_upserts, map_objects, map_sent, heartbeat, deflate_chosen, bits_per_pose;
  const std::vector<double> steps = {0.05, 0.1, 0.15, 0.2};
  const std::vector<double> voxels = {0.1, 0.2, 0.3};

  for (const auto& file : files) {
    std::vector<registration::KeyframeScan> kfs;
    if (!frontend::LoadKeyframes(file, &kfs)) {
      draco::log::Error("draco-fleet-sizes: cannot read " + file);
      return 1;
    }
    draco::log::Info("draco-fleet-sizes: " + file + ": " + std::to_string(kfs.size()) +
                     " keyframes");

    // Scan replies.
    for (const auto& k : kfs) {
      if (k.points_kf.empty()) continue;
      points_per_scan.Add(static_cast<double>(k.points_kf.size()));
      const msgs::ScanReply r = Reply(k, k.points_kf);
      for (int c = 0; c < fleet::points::kNumPointCodings; ++c) {
        const auto coding = static_cast<PointCoding>(c);
        const std::string name = fleet::points::PointCodingName(coding);
        add_scan("scan reply, " + name,
                 Bits(fleet::points::EncodeScanReplyWith(r, o, coding, false)));
        add_scan("scan reply, " + name + " + deflate",
                 Bits(fleet::points::EncodeScanReplyWith(r, o, coding, true)));
      }
      const double auto_bits = Bits(fleet::Encode(r, o));
      add_scan("scan reply, auto (smallest), step 0.05 m", auto_bits);
      double best_raw = 1e300;
      for (int c = 0; c < fleet::points::kNumPointCodings; ++c)
        best_raw = std::min(best_raw, Bits(fleet::points::EncodeScanReplyWith(
                                          r, o, static_cast<PointCoding>(c), false)));
      deflate_chosen.Add(auto_bits < best_raw ? 1.0 : 0.0);
      if (k.points_kf.size() >= 30)  // selection never requests smaller scans
        add_scan("scan reply, auto, scans of >= 30 points", Bits(fleet::Encode(r, o)));
      for (const double step : steps) {
        fleet::CodecOptions os = o;
        os.point_step_m = step;
        char name[96];
        std::snprintf(name, sizeof(name), "scan reply, auto, point step %.2f m", step);
        add_scan(name, Bits(fleet::Encode(r, os)));
      }
      for (const double cell : voxels) {
        const auto pts = Voxel(k.points_kf, cell);
        char name[96];
        std::snprintf(name, sizeof(name), "scan reply, auto, step 0.05, voxel %.1f m", cell);
        add_scan(name, Bits(fleet::Encode(Reply(k, pts), o)));
        std::snprintf(name, sizeof(name), "  (points kept, voxel %.1f m)", cell);
        add_scan(name, static_cast<double>(pts.size()));
      }
      for (const int every : {2, 3}) {
        std::vector<msgs::Point2> pts;
        for (std::size_t i = 0; i < k.points_kf.size(); i += static_cast<std::size_t>(every))
          pts.push_back(k.points_kf[i]);
        add_scan("scan reply, auto, step 0.05, every " + std::to_string(every) + "th point",
                 Bits(fleet::Encode(Reply(k, pts), o)));
      }
    }

    // Keyframe poses and object maps every period_s of mission time (final poses: the pose
    // updates carry the new keyframes only).
    fleet::KeyframePoseDeltaEncoder pose_enc;
    fleet::ObjectMapDeltaEncoder map_enc;
    objects::ObjectMapper mapper;
    std::vector<msgs::KeyframePoseEntry> entries;
    std::size_t next = 0;
    std::uint32_t acked = 0;
    std::uint32_t seq = 0;
    const double t0 = kfs.empty() ? 0.0 : kfs.front().time_s;
    for (double t = t0 + period_s; next < kfs.size(); t += period_s) {
      while (next < kfs.size() && kfs[next].time_s <= t) {
        const auto& k = kfs[next++];
        entries.push_back({k.index, k.time_s, k.T_map_kf, static_cast<int>(k.points_kf.size())});
        mapper.AddKeyframe(k.index, k.T_map_kf, k.points_kf);
      }
      const msgs::FleetHeader h{
          .robot_id = 1, .incarnation = 0x12345678, .seq = ++seq, .time_s = t};
      msgs::KeyframePoses pu;
      pu.header = h;
      if (pose_enc.MakeUpdate(entries, false, &pu)) {
        poses_update.Add(Bits(fleet::Encode(pu, o)));
        poses_per_update.Add(static_cast<double>(pu.poses.size()));
      }
      msgs::KeyframePoses pf;
      pf.header = h;
      pf.full = true;
      pf.poses = entries;
      poses_full.Add(Bits(fleet::Encode(pf, o)));
      if (pf.poses.size() >= 10)
        bits_per_pose.Add(Bits(fleet::Encode(pf, o)) / static_cast<double>(pf.poses.size()));

      msgs::Heartbeat hb;
      hb.header = h;
      hb.num_keyframes = static_cast<int>(entries.size());
      hb.acks = {{0, 0x9abcdef0, acked}, {2, 0x0fedcba9, acked}};
      heartbeat.Add(Bits(fleet::Encode(hb, o)));

      const msgs::ObjectMap map = mapper.Objects(1, t);
      msgs::ObjectMapUpdate full;
      full.header = h;
      full.version = acked + 1;
      full.upserts = map.objects;
      map_full.Add(Bits(fleet::Encode(full, o)));
      map_objects.Add(static_cast<double>(map.objects.size()));
      msgs::ObjectMapUpdate u;
      u.header = h;
      if (map_enc.MakeUpdate(map, acked, &u)) {
        map_sent.Add(Bits(fleet::Encode(u, o)));
        if (u.base_version != 0) {
          map_delta.Add(Bits(fleet::Encode(u, o)));
          map_delta_upserts.Add(static_cast<double>(u.upserts.size() + u.removed.size()));
        }
        acked = u.version;  // every teammate received it
      }
    }
  }

  std::printf("| %-44s | %6s | %9s | %9s |\n", "message", "count", "mean bits", "max bits");
  std::printf("|%s|%s|%s|%s|\n", std::string(46, '-').c_str(), std::string(8, '-').c_str(),
              std::string(11, '-').c_str(), std::string(11, '-').c_str());
  Row("(points per scan)", points_per_scan);
  for (const auto& name : scan_order) Row(name, scan[name]);
  std::printf("| %-44s | %6ld | %9.3f |\n", "(share of scans where deflate was smaller)",
              deflate_chosen.n, deflate_chosen.mean());
  Row("keyframe poses, update (new/moved only)", poses_update);
  Row("  (poses per update)", poses_per_update);
  Row("keyframe poses, full", poses_full);
  Row("  (bits per pose in full updates of >= 10)", bits_per_pose);
  Row("object map, full", map_full);
  Row("  (objects in the map)", map_objects);
  Row("object map, delta (after the first)", map_delta);
  Row("  (upserts + removals per delta)", map_delta_upserts);
  Row("object map, every update sent (full, deltas)", map_sent);
  Row("heartbeat (2 acks)", heartbeat);
  return 0;
}
