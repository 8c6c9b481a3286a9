// Not a test: draco's own inputs of a recorded mission written to files, with draco's answers
// and times on exactly those inputs, for the peers that read the same files
// (tests/peers/reference_peers.py: the DRACo-SLAM2 reference algorithms on numpy, scipy,
// scikit-learn, OpenCV and networkx, and Open3D's ICP; docs/benchmarks.md, "Peers on
// identical inputs").
//
//   peers_inputs MISSION_DIR --out DIR [--reuse] [--repeats N]
//
// Every robot's local SLAM runs first (frontend::RunRobots; --reuse takes the keyframes
// cached in DIR/slam). Then, each item in its own folder of DIR:
//   cfar/    keyframe pings of the first robot (8-bit polar images) and the CFAR parameters;
//            draco: CfarDetector (SOCA) with the intensity threshold, detections per ping.
//   dbscan/  the first robot's point-cloud map (every keyframe's points in the map frame);
//            draco: DbscanBatch, then per cluster the minimum-area rectangle and the mean.
//   match/   the final object maps of every robot (landmarks left out); draco:
//            MatchObjectMaps in the reference's form (code affinity, mu 8, every candidate
//            and entry kept, RANSAC 5 m, 4 inliers, no landmark, heading or vote paths) for
//            every ordered robot pair.
//   icp/     sequential scan pairs (each keyframe against keyframes k-3 .. k-1 placed by
//            ground truth, seeded by dead reckoning, as registration_backends_bench);
//            draco: AlignIcp (point-to-point, defaults), kd-tree build included; again
//            without the covariance (IcpOptions::covariance false: pose, validity and
//            overlap, the work the reference does), item icp_pose.
//   gcm/     inter-robot loop candidates of the first robot (accepted window-3
//            registrations against its matched teammates, plus as many random wrong loops),
//            the keyframe poses and map transforms; draco: ConsistencyFilter (GCM, first-loop
//            covariance, every pair tested), one batch decision.
// Times: wall time of the whole item (every ping, pair, ...), best of --repeats runs, in
// DIR/draco_times.csv (item, instances, best ms).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "draco/cfar/cfar.hpp"
#include "draco/consistency/filter.hpp"
#include "draco/eval/trajectory.hpp"
#include "draco/frontend/pipeline.hpp"
#include "draco/icp/icp.hpp"
#include "draco/objects/dbscan.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "draco/objects/object_mapper.hpp"
#include "draco/recording/recording.hpp"
#include "draco/registration/registration.hpp"
#include "sequential_pairs.hpp"

namespace {

namespace fe = draco::frontend;
namespace fs = std::filesystem;
namespace icp = draco::icp;
namespace obj = draco::objects;
namespace reg = draco::registration;
namespace cons = draco::consistency;
using draco::msgs::Point2;
using draco::msgs::Pose2;

// A file opened for writing that closes itself; throws when it cannot be opened.
class File {
 public:
  explicit File(const fs::path& path) : f_(std::fopen(path.c_str(), "w")) {
    if (f_ == nullptr) throw std::runtime_error("cannot write " + path.string());
  }
  ~File() { std::fclose(f_); }
  File(const File&) = delete;
  File& operator=(const File&) = delete;
  std::FILE* get() const { return f_; }

 private:
  std::FILE* f_;
};

// Best wall time of `repeats` runs of f, in ms.
double BestMs(int repeats, const std::function<void()>& f) {
  double best = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    const auto t1 = std::chrono::steady_clock::now();
    best = std::min(best, std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  return best;
}

std::vector<Point2> MapPoints(const fe::Robot& r) {
  std::vector<Point2> points;
  for (const auto& k : r.kfs) {
    for (const auto& p : k.points_kf) points.push_back(reg::Apply(k.T_map_kf, p));
  }
  return points;
}

void WritePoints(const fs::path& path, const std::vector<Point2>& points) {
  File f(path);
  std::fprintf(f.get(), "x_m,y_m\n");
  for (const auto& p : points) std::fprintf(f.get(), "%.17g,%.17g\n", p.x_m, p.y_m);
}

void WritePoints(const fs::path& path, const icp::Cloud2& points) {
  File f(path);
  std::fprintf(f.get(), "x_m,y_m\n");
  for (const auto& p : points) std::fprintf(f.get(), "%.17g,%.17g\n", p.x(), p.y());
}

// (a) CFAR on the first robot's keyframe pings.
struct CfarItem {
  std::vector<draco::msgs::SonarPing> pings;
};

CfarItem CollectPings(const std::string& mission, const fe::Robot& r, int count) {
  CfarItem item;
  draco::recording::ReadOptions ro;
  ro.dvl = ro.ahrs = ro.depth = ro.ground_truth = false;
  auto reader = draco::recording::RobotReader::Open(mission, r.name, ro);
  // Keyframes spread over the mission, each the ping closest in time.
  std::vector<double> times;
  const std::size_t step = std::max<std::size_t>(1, r.kfs.size() / static_cast<std::size_t>(count));
  for (std::size_t i = step / 2; i < r.kfs.size() && static_cast<int>(times.size()) < count;
       i += step) {
    times.push_back(r.kfs[i].time_s);
  }
  std::size_t next = 0;
  while (next < times.size()) {
    auto rec = reader.Next();
    if (!rec) break;
    if (const auto* ping = std::get_if<draco::msgs::SonarPing>(&*rec)) {
      if (ping->time_s >= times[next] - 1e-6) {
        item.pings.push_back(*ping);
        ++next;
      }
    }
  }
  return item;
}

}  // namespace

constexpr const char* kUsage =
    "usage: peers_inputs MISSION_DIR --out DIR [--reuse] [--repeats N]\n";

int main(int argc, char** argv) {
  std::string mission, out_dir;
  bool reuse = false;
  int repeats = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--reuse") {
      reuse = true;
    } else if (a == "--out" && has_value) {
      out_dir = argv[++i];
    } else if (a == "--repeats" && has_value) {
      repeats = std::max(1, std::stoi(argv[++i]));
    } else if (a.rfind("--", 0) != 0 && mission.empty()) {
      mission = a;
    } else {
      std::fprintf(stderr, "%s", kUsage);
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (mission.empty() || out_dir.empty()) {
    std::fprintf(stderr, "%s", kUsage);
    return 2;
  }

  try {
    const fs::path out(out_dir);
    const auto info = draco::recording::LoadMissionInfo(mission);
    fe::SlamRunOptions so;
    so.graph_path = std::string(DRACO_SOURCE_DIR) + "/config/graphs/local-slam.yaml";
    so.reuse = reuse;
    std::vector<fe::Robot> robots = fe::RunRobots(mission, info, out_dir, so);
    if (robots.empty()) throw std::runtime_error("no robots");
    const fe::Robot& first = robots.front();
    File times(out / "draco_times.csv");
    std::fprintf(times.get(), "item,instances,best_ms\n");

    // (a) CFAR: SOCA 40 / 20 / 0.1, then the intensity threshold, on the u8 image as float.
    {
      fs::create_directories(out / "cfar");
      const CfarItem item = CollectPings(mission, first, 8);
      draco::cfar::CfarOptions co;  // SOCA, 40 training, 20 guard, Pfa 0.1 (the reference)
      const double min_intensity = draco::cfar::FeatureOptions{}.min_intensity;
      draco::cfar::CfarDetector detector(co);
      {
        File f(out / "cfar" / "params.csv");
        std::fprintf(
            f.get(),
            "method,train_cells,guard_cells,pfa,tau,min_intensity\nSOCA,%d,%d,%.17g,%.17g,%.17g\n",
            co.train_cells, co.guard_cells, co.false_alarm_probability, detector.tau(),
            min_intensity);
      }
      std::vector<std::vector<draco::cfar::Cell>> cells(item.pings.size());
      std::vector<float> image;
      const double ms = BestMs(repeats, [&] {
        for (std::size_t i = 0; i < item.pings.size(); ++i) {
          const auto& p = item.pings[i];
          image.assign(p.intensity.begin(), p.intensity.end());
          detector.Detect(image.data(), p.num_ranges, p.num_beams,
                          static_cast<float>(min_intensity), &cells[i]);
        }
      });
      for (std::size_t i = 0; i < item.pings.size(); ++i) {
        const auto& p = item.pings[i];
        const fs::path base = out / "cfar" / ("ping" + std::to_string(i));
        File img(base.string() + ".u8");
        std::fprintf(img.get(), "%d %d\n", p.num_ranges, p.num_beams);  // header line
        std::fwrite(p.intensity.data(), 1, p.intensity.size(), img.get());
        File det(base.string() + ".draco.csv");
        std::fprintf(det.get(), "range_bin,beam\n");
        for (const auto& c : cells[i]) std::fprintf(det.get(), "%d,%d\n", c.range_bin, c.beam);
      }
      std::fprintf(times.get(), "cfar,%zu,%.6f\n", item.pings.size(), ms);
      std::printf("cfar: %zu pings, draco %.3f ms\n", item.pings.size(), ms);
    }

    // (b) DBSCAN and rectangles on the first robot's map.
    {
      fs::create_directories(out / "dbscan");
      const std::vector<Point2> points = MapPoints(first);
      WritePoints(out / "dbscan" / "points.csv", points);
      obj::DbscanOptions dbo;      // eps 1.5 m, 20 points (the reference)
      const double d_min_m = 3.0;  // the reference's long-side filter
      {
        File f(out / "dbscan" / "params.csv");
        std::fprintf(f.get(), "eps_m,min_samples,min_length_m\n%.17g,%d,%.17g\n", dbo.eps_m,
                     dbo.min_points, d_min_m);
      }
      std::vector<int> labels;
      std::vector<std::pair<int, draco::msgs::Object>> objects;
      const double ms = BestMs(repeats, [&] {
        labels = obj::DbscanBatch(points, dbo);
        const int n = labels.empty() ? 0 : *std::max_element(labels.begin(), labels.end()) + 1;
        std::vector<std::vector<Point2>> clusters(static_cast<std::size_t>(std::max(n, 0)));
        for (std::size_t i = 0; i < points.size(); ++i) {
          if (labels[i] >= 0) clusters[static_cast<std::size_t>(labels[i])].push_back(points[i]);
        }
        objects.clear();
        for (int c = 0; c < n; ++c) {
          auto o = obj::DescribeCluster(clusters[static_cast<std::size_t>(c)], false);
          if (o.length_m >= d_min_m) objects.emplace_back(c, o);
        }
      });
      {
        File f(out / "dbscan" / "draco_labels.csv");
        std::fprintf(f.get(), "label\n");
        for (const int l : labels) std::fprintf(f.get(), "%d\n", l);
      }
      {
        File f(out / "dbscan" / "draco_objects.csv");
        std::fprintf(f.get(), "label,cx_m,cy_m,length_m,breadth_m\n");
        for (const auto& [c, o] : objects) {
          std::fprintf(f.get(), "%d,%.17g,%.17g,%.17g,%.17g\n", c, o.center.x_m, o.center.y_m,
                       o.length_m, o.breadth_m);
        }
      }
      std::fprintf(times.get(), "dbscan,1,%.6f\n", ms);
      std::printf("dbscan: %zu points, %zu objects, draco %.3f ms\n", points.size(), objects.size(),
                  ms);
    }

    // (c) Object-graph matching in the reference's form, every ordered robot pair.
    {
      fs::create_directories(out / "match");
      obj::MatcherOptions mo;
      mo.affinity = obj::AffinityForm::kCode;
      mo.mu_per_m = 8.0;
      mo.keep_zero_weight_assignments = true;
      mo.min_inliers = 4;
      mo.ransac_threshold_m = 5.0;
      mo.max_heading_gap_rad = 0.0;
      mo.heading_votes = false;
      mo.votes_cross_check = false;
      mo.structure_lines = false;
      mo.landmarks = false;
      // Every candidate and affinity entry kept, as the reference's dense matrix holds them.
      mo.min_shape_similarity = 0.0;
      mo.min_affinity = 0.0;
      {
        File f(out / "match" / "params.csv");
        std::fprintf(f.get(),
                     "mu,min_objects,min_edges,min_assignments,min_inliers,ransac_threshold_m,"
                     "rematch_distance_m\n%.17g,%d,%d,%d,%d,%.17g,%.17g\n",
                     mo.mu_per_m, mo.min_objects, mo.min_edges, mo.min_assignments, mo.min_inliers,
                     mo.ransac_threshold_m, mo.rematch_distance_m);
      }
      std::vector<draco::msgs::ObjectMap> maps;
      for (const auto& r : robots) {
        draco::msgs::ObjectMap m = r.objects;
        std::erase_if(m.objects, [](const draco::msgs::Object& o) { return o.landmark; });
        File f(out / "match" / (r.name + ".objects.csv"));
        std::fprintf(f.get(), "id,cx_m,cy_m,length_m,breadth_m\n");
        for (const auto& o : m.objects) {
          std::fprintf(f.get(), "%u,%.17g,%.17g,%.17g,%.17g\n", o.id, o.center.x_m, o.center.y_m,
                       o.length_m, o.breadth_m);
        }
        maps.push_back(std::move(m));
      }
      std::vector<std::pair<std::size_t, std::size_t>> pairs;
      for (std::size_t a = 0; a < maps.size(); ++a) {
        for (std::size_t b = 0; b < maps.size(); ++b) {
          if (a != b) pairs.emplace_back(a, b);
        }
      }
      // Two variants: every entry kept (the reference's matrix, as above), and draco's own
      // sparsity (candidates and entries of at least 1e-2, MatcherOptions' defaults).
      obj::MatcherOptions sparse = mo;
      sparse.min_shape_similarity = obj::MatcherOptions{}.min_shape_similarity;
      sparse.min_affinity = obj::MatcherOptions{}.min_affinity;
      for (const auto& [item, variant] :
           {std::pair<std::string, obj::MatcherOptions>{"match", mo}, {"match_sparse", sparse}}) {
        const obj::MatcherOptions& options = variant;  // a lambda cannot capture a binding
        std::vector<draco::msgs::ObjectMatch> matches(pairs.size());
        const double ms = BestMs(repeats, [&] {
          for (std::size_t i = 0; i < pairs.size(); ++i) {
            matches[i] = obj::MatchObjectMaps(maps[pairs[i].first], maps[pairs[i].second], options);
          }
        });
        File f(out / "match" / ("draco_" + item + ".csv"));
        std::fprintf(f.get(), "a,b,status,x_m,y_m,yaw_rad,pairs\n");
        for (std::size_t i = 0; i < pairs.size(); ++i) {
          const auto& m = matches[i];
          std::string list;
          for (const auto& p : m.pairs) {
            list +=
                (list.empty() ? "" : " ") + std::to_string(p.id_a) + ":" + std::to_string(p.id_b);
          }
          std::fprintf(f.get(), "%s,%s,%d,%.17g,%.17g,%.17g,%s\n",
                       robots[pairs[i].first].name.c_str(), robots[pairs[i].second].name.c_str(),
                       static_cast<int>(m.status), m.T_a_b.x_m, m.T_a_b.y_m, m.T_a_b.yaw_rad,
                       list.c_str());
        }
        std::fprintf(times.get(), "%s,%zu,%.6f\n", item.c_str(), pairs.size(), ms);
        std::printf("%s: %zu ordered pairs, draco %.3f ms\n", item.c_str(), pairs.size(), ms);
      }
    }

    // (d) Sequential ICP pairs (registration_backends_bench's set).
    {
      fs::create_directories(out / "icp");
      const auto seq = draco::test::SequentialPairs(robots, out_dir);
      const icp::IcpOptions io;  // draco's defaults
      {
        File f(out / "icp" / "params.csv");
        std::fprintf(
            f.get(),
            "max_correspondence_distance_m,trim_fraction,max_iterations,"
            "convergence_window,convergence_translation_m,convergence_rotation_rad,"
            "min_correspondences,overlap_distance_m\n%.17g,%.17g,%d,%d,%.17g,%.17g,%d,%.17g\n",
            io.max_correspondence_distance_m, io.trim_fraction, io.max_iterations,
            io.convergence_window, io.convergence_translation_m, io.convergence_rotation_rad,
            io.min_correspondences, io.overlap_distance_m);
      }
      std::vector<icp::IcpResult> results(seq.size());
      const double ms = BestMs(repeats, [&] {
        for (std::size_t i = 0; i < seq.size(); ++i) {
          results[i] = icp::AlignIcp(seq[i].source, seq[i].target, seq[i].seed, io);
        }
      });
      File f(out / "icp" / "pairs.csv");
      std::fprintf(f.get(),
                   "pair,seed_x,seed_y,seed_yaw,truth_x,truth_y,truth_yaw,draco_x,draco_y,"
                   "draco_yaw,draco_valid,draco_iterations,draco_overlap\n");
      for (std::size_t i = 0; i < seq.size(); ++i) {
        const auto& p = seq[i];
        const auto& T = results[i].T_target_source;
        std::fprintf(f.get(),
                     "%zu,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%d,%d,%.17g\n", i,
                     p.seed.x_m, p.seed.y_m, p.seed.yaw_rad, p.truth.x_m, p.truth.y_m,
                     p.truth.yaw_rad, T.x_m, T.y_m, T.yaw_rad, results[i].valid ? 1 : 0,
                     results[i].iterations, results[i].overlap_ratio);
        WritePoints(out / "icp" / ("pair" + std::to_string(i) + ".source.csv"), p.source);
        WritePoints(out / "icp" / ("pair" + std::to_string(i) + ".target.csv"), p.target);
      }
      std::fprintf(times.get(), "icp,%zu,%.6f\n", seq.size(), ms);
      std::printf("icp: %zu pairs, draco %.3f ms\n", seq.size(), ms);
      icp::IcpOptions pose_only = io;
      pose_only.covariance = false;
      std::vector<icp::IcpResult> poses(seq.size());
      const double pose_ms = BestMs(repeats, [&] {
        for (std::size_t i = 0; i < seq.size(); ++i) {
          poses[i] = icp::AlignIcp(seq[i].source, seq[i].target, seq[i].seed, pose_only);
        }
      });
      for (std::size_t i = 0; i < seq.size(); ++i) {
        const auto& a = results[i];
        const auto& b = poses[i];
        if (a.T_target_source.x_m != b.T_target_source.x_m ||
            a.T_target_source.y_m != b.T_target_source.y_m ||
            a.T_target_source.yaw_rad != b.T_target_source.yaw_rad || a.valid != b.valid ||
            a.overlap_ratio != b.overlap_ratio) {
          throw std::runtime_error("icp pair " + std::to_string(i) +
                                   ": the answer without the covariance differs");
        }
      }
      std::fprintf(times.get(), "icp_pose,%zu,%.6f\n", seq.size(), pose_ms);
      std::printf("icp without the covariance: %zu pairs, draco %.3f ms\n", seq.size(), pose_ms);
    }

    // (e) GCM: the first robot's candidates against its matched teammates, plus wrong loops.
    {
      fs::create_directories(out / "gcm");
      fe::PairOptions po;
      po.windows = {3};
      const double min_overlap = 0.85;
      cons::ChainPoseSource poses;
      const Eigen::Matrix3d step_cov = Eigen::Vector3d(0.04, 0.04, 4e-4).asDiagonal();
      std::map<int, std::map<int, int>> position;  // robot id -> keyframe index -> position
      {
        File f(out / "gcm" / "poses.csv");
        std::fprintf(f.get(), "robot,keyframe,x_m,y_m,yaw_rad\n");
        for (const auto& r : robots) {
          for (std::size_t i = 0; i < r.kfs.size(); ++i) {
            poses.AddKeyframe(r.id, r.kfs[i].T_map_kf, step_cov);
            position[r.id][r.kfs[i].index] = static_cast<int>(i);
            const auto& T = r.kfs[i].T_map_kf;
            std::fprintf(f.get(), "%d,%zu,%.17g,%.17g,%.17g\n", r.id, i, T.x_m, T.y_m, T.yaw_rad);
          }
        }
      }
      std::vector<draco::msgs::InterRobotLoop> loops;
      File mt(out / "gcm" / "map_transforms.csv");
      std::fprintf(mt.get(), "own,teammate,x_m,y_m,yaw_rad\n");
      for (std::size_t b = 1; b < robots.size(); ++b) {
        const fe::PairResult pr = fe::MatchAndRegister(first, robots[b], po);
        if (!pr.matched) continue;
        const Pose2& T = pr.match.T_a_b;
        poses.SetMapTransform(first.id, robots[b].id, {T, Eigen::Matrix3d::Identity()});
        std::fprintf(mt.get(), "%d,%d,%.17g,%.17g,%.17g\n", first.id, robots[b].id, T.x_m, T.y_m,
                     T.yaw_rad);
        for (const auto& rg : pr.registrations) {
          if (!rg.valid || rg.overlap < min_overlap) continue;
          draco::msgs::InterRobotLoop l = rg.loop;
          l.own_robot = first.id;
          l.teammate_robot = robots[b].id;
          l.own_keyframe = position[first.id].at(rg.own_kf);
          l.teammate_keyframe = position[robots[b].id].at(rg.team_kf);
          loops.push_back(l);
        }
      }
      // As many wrong loops: random keyframe pairs and relative poses, a real loop's
      // covariance (deterministic seed).
      const std::size_t real = loops.size();
      std::mt19937_64 rng(17);
      for (std::size_t i = 0; i < real; ++i) {
        draco::msgs::InterRobotLoop l = loops[i];
        const fe::Robot& B = *std::find_if(robots.begin(), robots.end(), [&](const fe::Robot& r) {
          return r.id == l.teammate_robot;
        });
        l.own_keyframe = std::uniform_int_distribution<int>(0, int(first.kfs.size()) - 1)(rng);
        l.teammate_keyframe = std::uniform_int_distribution<int>(0, int(B.kfs.size()) - 1)(rng);
        std::uniform_real_distribution<double> xy(-20.0, 20.0), yaw(-3.14159, 3.14159);
        l.T_ownkf_teammatekf = Pose2{xy(rng), xy(rng), yaw(rng)};
        loops.push_back(l);
      }
      for (std::size_t i = 0; i < loops.size(); ++i) loops[i].id = i;
      cons::FilterOptions fo;
      fo.method = cons::Method::kGcm;
      fo.pairwise.covariance = cons::CovarianceModel::kFirstLoop;
      fo.map_prior_gate = false;
      cons::Decision d;
      const double ms = BestMs(repeats, [&] {
        cons::ConsistencyFilter filter(fo);
        d = filter.Add(loops, poses);
      });
      {
        File f(out / "gcm" / "loops.csv");
        std::fprintf(f.get(),
                     "id,own_robot,own_keyframe,teammate_robot,teammate_keyframe,x_m,y_m,yaw_rad,"
                     "c00,c01,c02,c10,c11,c12,c20,c21,c22,wrong\n");
        for (std::size_t i = 0; i < loops.size(); ++i) {
          const auto& l = loops[i];
          std::fprintf(f.get(), "%llu,%d,%d,%d,%d,%.17g,%.17g,%.17g",
                       static_cast<unsigned long long>(l.id), l.own_robot, l.own_keyframe,
                       l.teammate_robot, l.teammate_keyframe, l.T_ownkf_teammatekf.x_m,
                       l.T_ownkf_teammatekf.y_m, l.T_ownkf_teammatekf.yaw_rad);
          for (const double c : l.covariance) std::fprintf(f.get(), ",%.17g", c);
          std::fprintf(f.get(), ",%d\n", i >= real ? 1 : 0);
        }
      }
      {
        File f(out / "gcm" / "params.csv");
        std::fprintf(f.get(), "chi2_threshold,min_clique_size\n%.17g,%d\n",
                     fo.pairwise.chi2_threshold, fo.min_clique_size);
      }
      {
        File f(out / "gcm" / "draco_accepted.csv");
        std::fprintf(f.get(), "id\n");
        for (const auto id : d.accepted)
          std::fprintf(f.get(), "%llu\n", static_cast<unsigned long long>(id));
      }
      std::fprintf(times.get(), "gcm,%zu,%.6f\n", loops.size(), ms);
      std::printf("gcm: %zu candidates (%zu wrong), %zu accepted, draco %.3f ms\n", loops.size(),
                  loops.size() - real, d.accepted.size(), ms);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "peers_inputs: %s\n", e.what());
    return 1;
  }
  return 0;
}
