// draco-frontend-eval MISSION_DIR [--out DIR]: the inter-robot front end measured against
// ground truth, as the paper's Fig. 3. Every robot's local SLAM runs in-process through the
// local-SLAM graph (config/graphs/local-slam.yaml, with a capture component added); at the
// end of the mission each robot's object map is built from its optimised keyframes; then for
// every ordered robot pair (a, b): object-graph matching (checked against the ground-truth
// transform between the two map frames), scan-request selection, and sliding-window
// registration for w in {0, 1, 3}, judged against the ground-truth relative pose at the
// keyframe times (true positive: within 1.5 m and 15 deg). Prints precision and
// true-positive count per (w, overlap threshold) and writes CSVs.
//
//   draco-frontend-eval /tmp/marina --out runs/frontend-marina
//   draco-frontend-eval /tmp/marina --out runs/frontend-marina --reuse   (cached keyframes)
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <numbers>
#include <sstream>
#include <thread>

#include "draco/eval/trajectory.hpp"
#include "draco/graph/component.hpp"
#include "draco/graph/executor.hpp"
#include "draco/graph/graph.hpp"
#include "draco/msgs/map.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "draco/objects/object_mapper.hpp"
#include "draco/recording/recording.hpp"
#include "draco/registration/registration.hpp"

namespace {

using draco::msgs::Pose2;
namespace reg = draco::registration;
constexpr double kDeg = std::numbers::pi / 180.0;

// ---- Capture: keyframes and the last optimised trajectory of one run ----------------------
struct Captured {
  std::map<int, draco::graph::Stamped<draco::msgs::Keyframe>> keyframes;
  std::shared_ptr<const draco::msgs::KeyframeTrajectory> trajectory;
};
std::mutex g_capture_mutex;
std::map<int, Captured> g_captured;  // by slot

class Capture final : public draco::graph::Component {
 public:
  void Declare(draco::graph::Spec& spec) override {
    spec.Doc("frontend-eval: keeps keyframes and the newest optimised trajectory.");
    keyframe_ = spec.Input<draco::msgs::Keyframe>("keyframe", {.depth = 1024, .doc = "keyframes"});
    trajectory_ = spec.Input<draco::msgs::KeyframeTrajectory>(
        "trajectory", {.delivery = draco::graph::Delivery::kLatest, .doc = "trajectory"});
    spec.Param("slot", &slot_, {.doc = "capture slot"});
  }
  draco::graph::Status Process(draco::graph::Context&) override {
    std::lock_guard lock(g_capture_mutex);
    auto& c = g_captured[slot_];
    for (auto& k : keyframe_.TakeAll()) c.keyframes[k->index] = k;
    for (auto& t : trajectory_.TakeAll()) c.trajectory = t.value;
    return draco::graph::Status::Ok();
  }

 private:
  int slot_ = 0;
  draco::graph::In<draco::msgs::Keyframe> keyframe_;
  draco::graph::In<draco::msgs::KeyframeTrajectory> trajectory_;
};
DRACO_REGISTER_COMPONENT(Capture, "frontend_eval.Capture")

// ---- Per robot ------------------------------------------------------------------------------
struct Robot {
  std::string name;
  int id = 0;
  std::vector<reg::KeyframeScan> kfs;  // sorted by index
  std::vector<Pose2> truth_kf;         // world pose at each keyframe time
  std::vector<char> has_truth;
  Pose2 T_world_map;  // Umeyama alignment of the keyframes to the truth
  draco::msgs::ObjectMap objects;
  double slam_wall_s = 0.0;
};

void SaveKeyframes(const std::string& path, const std::vector<reg::KeyframeScan>& kfs) {
  std::ofstream f(path, std::ios::binary);
  const auto put = [&](const auto& v) { f.write(reinterpret_cast<const char*>(&v), sizeof(v)); };
  put(static_cast<std::uint64_t>(kfs.size()));
  for (const auto& k : kfs) {
    put(k.index);
    put(k.time_s);
    put(k.T_map_kf);
    put(static_cast<std::uint64_t>(k.points_kf.size()));
    f.write(reinterpret_cast<const char*>(k.points_kf.data()),
            static_cast<std::streamsize>(k.points_kf.size() * sizeof(draco::msgs::Point2)));
  }
}

bool LoadKeyframes(const std::string& path, std::vector<reg::KeyframeScan>* kfs) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return false;
  const auto get = [&](auto& v) { f.read(reinterpret_cast<char*>(&v), sizeof(v)); };
  std::uint64_t n = 0;
  get(n);
  kfs->resize(n);
  for (auto& k : *kfs) {
    std::uint64_t m = 0;
    get(k.index);
    get(k.time_s);
    get(k.T_map_kf);
    get(m);
    k.points_kf.resize(m);
    f.read(reinterpret_cast<char*>(k.points_kf.data()),
           static_cast<std::streamsize>(m * sizeof(draco::msgs::Point2)));
  }
  return static_cast<bool>(f);
}

std::vector<reg::KeyframeScan> RunLocalSlam(const std::string& mission, const std::string& name,
                                            int slot, const std::string& graph_path,
                                            const std::string& run_dir,
                                            const std::vector<std::string>& overrides) {
  std::ifstream in(graph_path);
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  yaml +=
      "\n  - id: capture\n    type: frontend_eval.Capture\n"
      "    inputs: { keyframe: keyframes/keyframe, trajectory: slam/trajectory }\n"
      "    params: { slot: " +
      std::to_string(slot) + " }\n";
  draco::graph::LoadOptions load;
  load.overrides = {"reader.recording=" + mission, "reader.robot=" + name,
                    "slam.prefix=" + name + ".", "truth.file=" + name + ".ground_truth.tum"};
  load.overrides.insert(load.overrides.end(), overrides.begin(), overrides.end());
  auto graph = draco::graph::LoadGraphString(
      yaml, graph_path, load, std::filesystem::path(graph_path).parent_path().string());
  draco::graph::RunOptions run;
  run.output_dir = run_dir;
  run.log_errors = false;
  const auto result = draco::graph::RunDeterministic(*graph, run);
  if (!result.ok) throw std::runtime_error(name + ": " + result.error);
  std::lock_guard lock(g_capture_mutex);
  const auto& c = g_captured[slot];
  std::vector<reg::KeyframeScan> out;
  if (!c.trajectory) return out;
  for (const auto& k : c.trajectory->keyframes) {
    const auto it = c.keyframes.find(k.index);
    if (it == c.keyframes.end()) continue;
    out.push_back({k.index, k.time_s, k.T_map_kf, it->second->points_body});
  }
  return out;
}

// Ground truth at time t (linear in position, shortest arc in yaw); false outside its span.
bool TruthAt(const draco::eval::Trajectory& truth, double t, Pose2* pose) {
  if (truth.empty() || t < truth.front().time_s || t > truth.back().time_s) return false;
  auto it = std::lower_bound(truth.begin(), truth.end(), t,
                             [](const auto& p, double v) { return p.time_s < v; });
  if (it == truth.begin()) {
    *pose = {it->x_m, it->y_m, it->yaw_rad};
    return true;
  }
  const auto& b = *it;
  const auto& a = *(it - 1);
  const double dt = b.time_s - a.time_s;
  if (dt > 0.5) return false;
  const double u = dt > 0 ? (t - a.time_s) / dt : 0.0;
  *pose = {a.x_m + u * (b.x_m - a.x_m), a.y_m + u * (b.y_m - a.y_m),
           reg::WrapAngle(a.yaw_rad + u * reg::WrapAngle(b.yaw_rad - a.yaw_rad))};
  return true;
}

void AttachTruth(const std::string& mission, Robot* r) {
  const auto truth = draco::eval::ReadTum(mission + "/" + r->name + "/groundtruth.tum");
  draco::eval::Trajectory est, tru;
  r->truth_kf.assign(r->kfs.size(), Pose2{});
  r->has_truth.assign(r->kfs.size(), 0);
  for (std::size_t i = 0; i < r->kfs.size(); ++i) {
    Pose2 p;
    if (!TruthAt(truth, r->kfs[i].time_s, &p)) continue;
    r->truth_kf[i] = p;
    r->has_truth[i] = 1;
    const auto& e = r->kfs[i].T_map_kf;
    est.push_back({r->kfs[i].time_s, e.x_m, e.y_m, e.yaw_rad});
    tru.push_back({r->kfs[i].time_s, p.x_m, p.y_m, p.yaw_rad});
  }
  const auto U = draco::eval::AlignUmeyama(est, tru);
  r->T_world_map = {U.x_m, U.y_m, U.yaw_rad};
}

struct Row {  // one registration
  int a, b, window, own_kf, team_kf, source_points;
  bool valid;
  double overlap, err_m, err_deg;
  bool tp;
  bool oracle;  // seeded by the ground-truth transform (matching failed)
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-frontend-eval: inter-robot loop-closure precision (paper Fig. 3)"};
  std::string mission;
  std::string out_dir;
  std::string graph_path = DRACO_SOURCE_DIR "/config/graphs/local-slam.yaml";
  std::vector<std::string> overrides;
  bool reuse = false;
  bool oracle = false;
  int jobs = 1;
  reg::SelectionOptions sel;
  reg::RegistrationOptions ro;
  double radius_m = -1, max_yaw_deg = -1;
  double default_threshold = ro.min_overlap;
  int default_window = ro.window;
  std::string metric = "point";
  double tp_m = 1.5, tp_deg = 15.0;
  app.add_option("mission", mission, "recorded mission folder")->required();
  app.add_option("--out", out_dir, "output folder (default runs/frontend-<mission>)");
  app.add_option("--graph", graph_path, "local-SLAM graph YAML");
  app.add_option("--set", overrides, "local-SLAM graph override component.param=value");
  app.add_flag("--oracle-matching", oracle,
               "where matching fails, seed registration with the ground-truth transform and "
               "true object pairs (registration measured alone)");
  app.add_flag("--reuse", reuse, "reuse the keyframes cached in the out folder");
  app.add_option("--jobs", jobs, "robots run in parallel");
  app.add_option("--max-requests", sel.max_requests, "scan requests per exchange");
  app.add_option("--max-candidates", sel.max_candidates_per_request,
                 "own keyframes registered per request (0: all within the radius)");
  app.add_option("--radius", radius_m, "candidate radius m (default 40, airplane 20)");
  app.add_option("--max-yaw-deg", max_yaw_deg, "candidate heading limit (180, airplane 90)");
  app.add_flag("--reference-window", ro.reference_window, "the reference's k-w..k+w-1 + k");
  app.add_option("--metric", metric, "point | line");
  app.add_option("--overlap-distance", ro.icp.overlap_distance_m, "overlap inlier distance m");
  app.add_option("--max-correction", ro.max_correction_m, "gate on the ICP correction m (0 off)");
  app.add_option("--threshold", default_threshold, "the default overlap threshold to report");
  app.add_option("--window", default_window, "the default window to report");
  CLI11_PARSE(app, argc, argv);
  ro.icp.metric =
      metric == "line" ? draco::icp::Metric::kPointToLine : draco::icp::Metric::kPointToPoint;
  ro.min_overlap = 0.0;  // thresholds are applied below

  try {
    const auto info = draco::recording::LoadMissionInfo(mission);
    if (out_dir.empty()) out_dir = "runs/frontend-" + info.name;
    std::filesystem::create_directories(out_dir + "/slam");
    const bool airplane = info.world.find("airplane") != std::string::npos ||
                          info.name.find("airplane") != std::string::npos;
    if (airplane) {
      const auto a = reg::AirplaneSelectionOptions();
      sel.candidate_radius_m = a.candidate_radius_m;
      sel.candidate_max_yaw_rad = a.candidate_max_yaw_rad;
    }
    if (radius_m > 0) sel.candidate_radius_m = radius_m;
    if (max_yaw_deg > 0) sel.candidate_max_yaw_rad = max_yaw_deg * kDeg;

    // Local SLAM per robot (or the cache).
    std::vector<Robot> robots(info.robots.size());
    std::vector<std::thread> threads;
    std::mutex err_mutex;
    std::string error;
    const auto t0 = std::chrono::steady_clock::now();
    std::size_t next = 0;
    std::mutex next_mutex;
    const auto worker = [&] {
      for (;;) {
        std::size_t i;
        {
          std::lock_guard lock(next_mutex);
          if (next >= robots.size()) return;
          i = next++;
        }
        Robot& r = robots[i];
        r.name = info.robots[i].name;
        r.id = info.robots[i].id;
        const std::string cache = out_dir + "/slam/" + r.name + ".keyframes.bin";
        try {
          const auto s = std::chrono::steady_clock::now();
          if (!(reuse && LoadKeyframes(cache, &r.kfs))) {
            std::fprintf(stderr, "draco-frontend-eval: local SLAM of %s ...\n", r.name.c_str());
            r.kfs = RunLocalSlam(mission, r.name, static_cast<int>(i), graph_path,
                                 out_dir + "/slam", overrides);
            SaveKeyframes(cache, r.kfs);
          }
          r.slam_wall_s =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - s).count();
        } catch (const std::exception& e) {
          std::lock_guard lock(err_mutex);
          error = e.what();
        }
      }
    };
    for (int j = 0; j < std::max(1, jobs); ++j) threads.emplace_back(worker);
    for (auto& t : threads) t.join();
    if (!error.empty()) throw std::runtime_error(error);
    const double slam_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    for (auto& r : robots) {
      AttachTruth(mission, &r);
      draco::objects::ObjectMapper mapper;
      for (const auto& k : r.kfs) mapper.AddKeyframe(k.index, k.T_map_kf, k.points_kf);
      r.objects = mapper.Objects(r.id, r.kfs.empty() ? 0.0 : r.kfs.back().time_s);
    }

    std::string objects_csv = "robot,id,x_m,y_m,world_x_m,world_y_m,length_m,breadth_m,points\n";
    std::string kf_csv =
        "robot,index,time_s,x_m,y_m,yaw_rad,world_x_m,world_y_m,truth_x_m,truth_y_m\n";
    for (const auto& r : robots) {
      for (const auto& o : r.objects.objects) {
        const auto w = reg::Apply(r.T_world_map, o.center);
        char line[256];
        std::snprintf(line, sizeof(line), "%s,%u,%.3f,%.3f,%.3f,%.3f,%.2f,%.2f,%d\n",
                      r.name.c_str(), o.id, o.center.x_m, o.center.y_m, w.x_m, w.y_m, o.length_m,
                      o.breadth_m, o.num_points);
        objects_csv += line;
      }
      for (std::size_t i = 0; i < r.kfs.size(); ++i) {
        const auto& k = r.kfs[i];
        const auto w = reg::Compose(r.T_world_map, k.T_map_kf);
        char line[256];
        std::snprintf(line, sizeof(line), "%s,%d,%.3f,%.3f,%.3f,%.4f,%.3f,%.3f,%.3f,%.3f\n",
                      r.name.c_str(), k.index, k.time_s, k.T_map_kf.x_m, k.T_map_kf.y_m,
                      k.T_map_kf.yaw_rad, w.x_m, w.y_m, r.truth_kf[i].x_m, r.truth_kf[i].y_m);
        kf_csv += line;
      }
    }
    draco::graph::WriteFileAtomically(out_dir + "/objects.csv", objects_csv);
    draco::graph::WriteFileAtomically(out_dir + "/keyframes.csv", kf_csv);

    // Pairs.
    std::vector<Row> rows;
    std::string match_csv =
        "own,teammate,own_objects,teammate_objects,shared_objects,status,inliers,confidence,"
        "err_m,err_deg,correct,requests,registrations,oracle\n";
    int pairs_eligible = 0, pairs_eligible_correct = 0, pairs_matched_correct = 0;
    std::map<std::pair<int, int>, int> shared_of;
    double reg_time_s = 0.0;
    int reg_count = 0;
    for (std::size_t ia = 0; ia < robots.size(); ++ia) {
      for (std::size_t ib = 0; ib < robots.size(); ++ib) {
        if (ia == ib) continue;
        const Robot& A = robots[ia];
        const Robot& B = robots[ib];
        // True shared objects: object centres within 2 m of each other in the world.
        int shared = 0;
        std::vector<draco::msgs::ObjectPair> true_pairs;
        for (const auto& oa : A.objects.objects) {
          const auto pa = reg::Apply(A.T_world_map, oa.center);
          for (const auto& ob : B.objects.objects) {
            const auto pb = reg::Apply(B.T_world_map, ob.center);
            if (std::hypot(pa.x_m - pb.x_m, pa.y_m - pb.y_m) <= 2.0) {
              ++shared;
              true_pairs.push_back({oa.id, ob.id, 0.0});
              break;
            }
          }
        }
        shared_of[{static_cast<int>(ia), static_cast<int>(ib)}] = shared;
        const Pose2 T_true = reg::Between(A.T_world_map, B.T_world_map);
        auto match = draco::objects::MatchObjectMaps(A.objects, B.objects);
        const bool matched = match.status == draco::msgs::MatchStatus::kMatched;
        const Pose2 d = reg::Between(T_true, match.T_a_b);
        const double err_m = std::hypot(d.x_m, d.y_m), err_deg = std::abs(d.yaw_rad) / kDeg;
        const bool correct = matched && err_m <= 2.0 && err_deg <= 10.0;
        if (shared >= 5) {
          ++pairs_eligible;
          pairs_eligible_correct += correct;
        }
        pairs_matched_correct += correct;
        bool oracle_used = false;
        if (oracle && !correct && !true_pairs.empty()) {
          // Registration as if matching had found the true transform and the true pairs.
          match.status = draco::msgs::MatchStatus::kMatched;
          match.T_a_b = T_true;
          match.pairs = true_pairs;
          oracle_used = true;
        }

        std::vector<reg::KeyframeInfo> ia_info, ib_info;
        for (const auto& k : A.kfs) {
          ia_info.push_back({k.index, k.T_map_kf, static_cast<int>(k.points_kf.size())});
        }
        for (const auto& k : B.kfs) {
          ib_info.push_back({k.index, k.T_map_kf, static_cast<int>(k.points_kf.size())});
        }
        const auto requests =
            reg::SelectScanRequests(A.objects, B.objects, match, ia_info, ib_info, sel);
        std::map<int, int> pos_a, pos_b;
        for (std::size_t i = 0; i < A.kfs.size(); ++i) pos_a[A.kfs[i].index] = static_cast<int>(i);
        for (std::size_t i = 0; i < B.kfs.size(); ++i) pos_b[B.kfs[i].index] = static_cast<int>(i);
        int registrations = 0;
        for (const auto& req : requests) {
          const int jb = pos_b.at(req.teammate_keyframe);
          for (const int own_index : req.candidates) {
            const int ka = pos_a.at(own_index);
            const Pose2 seed = reg::SeedPose(A.kfs[ka].T_map_kf, match.T_a_b, B.kfs[jb].T_map_kf);
            const bool truth_ok = A.has_truth[ka] && B.has_truth[jb];
            const Pose2 rel_true = reg::Between(A.truth_kf[ka], B.truth_kf[jb]);
            for (const int w : {0, 1, 3}) {
              auto o = ro;
              o.window = w;
              const auto s = std::chrono::steady_clock::now();
              const auto r = reg::RegisterScan(A.kfs, ka, B.kfs[jb].points_kf, seed, o, A.id, B.id,
                                               req.teammate_keyframe);
              reg_time_s +=
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - s).count();
              ++reg_count;
              ++registrations;
              const Pose2 e = reg::Between(rel_true, r.loop.T_ownkf_teammatekf);
              const double em = std::hypot(e.x_m, e.y_m), ed = std::abs(e.yaw_rad) / kDeg;
              rows.push_back({static_cast<int>(ia), static_cast<int>(ib), w, own_index,
                              req.teammate_keyframe, static_cast<int>(B.kfs[jb].points_kf.size()),
                              r.status == reg::RegistrationStatus::kAccepted, r.loop.overlap,
                              truth_ok ? em : -1.0, truth_ok ? ed : -1.0,
                              truth_ok && em <= tp_m && ed <= tp_deg, oracle_used});
            }
          }
        }
        char line[256];
        std::snprintf(line, sizeof(line), "%s,%s,%zu,%zu,%d,%s,%d,%.3f,%.3f,%.3f,%d,%zu,%d,%d\n",
                      A.name.c_str(), B.name.c_str(), A.objects.objects.size(),
                      B.objects.objects.size(), shared, draco::msgs::MatchStatusName(match.status),
                      match.num_inliers, match.confidence, matched ? err_m : -1.0,
                      matched ? err_deg : -1.0, correct ? 1 : 0, requests.size(), registrations,
                      oracle_used ? 1 : 0);
        match_csv += line;
      }
    }

    // Tables.
    std::string reg_csv =
        "own,teammate,window,own_kf,teammate_kf,source_points,valid,overlap,"
        "err_m,err_deg,true_positive,oracle\n";
    for (const auto& r : rows) {
      char line[256];
      std::snprintf(line, sizeof(line), "%s,%s,%d,%d,%d,%d,%d,%.4f,%.3f,%.3f,%d,%d\n",
                    robots[r.a].name.c_str(), robots[r.b].name.c_str(), r.window, r.own_kf,
                    r.team_kf, r.source_points, r.valid ? 1 : 0, r.overlap, r.err_m, r.err_deg,
                    r.tp ? 1 : 0, r.oracle ? 1 : 0);
      reg_csv += line;
    }
    std::string prec_csv = "window,threshold,detections,true_positives,precision\n";
    std::printf("\nmission %s (%s): %zu robots, local SLAM %.1f s wall\n", info.name.c_str(),
                info.world.c_str(), robots.size(), slam_s);
    for (const auto& r : robots) {
      std::printf("  %-8s %5zu keyframes, %3zu objects\n", r.name.c_str(), r.kfs.size(),
                  r.objects.objects.size());
    }
    std::printf("%s", ("\nobject-graph matching (own <- teammate):\n" + match_csv).c_str());
    std::printf(
        "matching right (<= 2 m, 10 deg): %d of %d pairs sharing >= 5 true objects (%.0f %%); "
        "%d of %zu ordered pairs overall\n",
        pairs_eligible_correct, pairs_eligible,
        pairs_eligible ? 100.0 * pairs_eligible_correct / pairs_eligible : 0.0,
        pairs_matched_correct, robots.size() * (robots.size() - 1));
    std::printf("registrations: %d, %.3f ms mean\n\n", reg_count,
                reg_count ? 1e3 * reg_time_s / reg_count : 0.0);
    std::printf("%-9s", "overlap");
    for (const int w : {0, 1, 3}) std::printf("  w=%d prec   TP  det", w);
    std::printf("\n");
    for (int ti = 0; ti <= 9; ++ti) {
      const double thr = 0.5 + 0.05 * ti;
      std::printf("%-9.2f", thr);
      for (const int w : {0, 1, 3}) {
        int det = 0, tp = 0;
        for (const auto& r : rows) {
          if (r.window != w || !r.valid || r.overlap < thr - 1e-9) continue;
          ++det;
          tp += r.tp;
        }
        const double prec = det ? static_cast<double>(tp) / det : 0.0;
        std::printf("  %8.3f %4d %4d", prec, tp, det);
        char line[128];
        std::snprintf(line, sizeof(line), "%d,%.2f,%d,%d,%.4f\n", w, thr, det, tp, prec);
        prec_csv += line;
      }
      std::printf("\n");
    }
    // Per pair at the default setting.
    std::printf("\nper pair at w=%d, overlap >= %.2f (true positives / detections):\n",
                default_window, default_threshold);
    for (std::size_t ia = 0; ia < robots.size(); ++ia) {
      for (std::size_t ib = 0; ib < robots.size(); ++ib) {
        if (ia == ib) continue;
        int det = 0, tp = 0;
        for (const auto& r : rows) {
          if (r.a != static_cast<int>(ia) || r.b != static_cast<int>(ib) ||
              r.window != default_window || !r.valid || r.overlap < default_threshold - 1e-9) {
            continue;
          }
          ++det;
          tp += r.tp;
        }
        std::printf("  %-8s <- %-8s shared objects %3d: %d / %d\n", robots[ia].name.c_str(),
                    robots[ib].name.c_str(),
                    shared_of[{static_cast<int>(ia), static_cast<int>(ib)}], tp, det);
      }
    }
    draco::graph::WriteFileAtomically(out_dir + "/matching.csv", match_csv);
    draco::graph::WriteFileAtomically(out_dir + "/registrations.csv", reg_csv);
    draco::graph::WriteFileAtomically(out_dir + "/precision.csv", prec_csv);
    std::printf("CSVs in %s\n", out_dir.c_str());
    return 0;
  } catch (const draco::graph::GraphError& e) {
    std::cerr << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "draco-frontend-eval: " << e.what() << "\n";
    return 1;
  }
}
