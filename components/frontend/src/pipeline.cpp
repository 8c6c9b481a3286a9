#include "draco/frontend/pipeline.hpp"
#include "draco/log/log.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "draco/graph/component.hpp"
#include "draco/graph/executor.hpp"
#include "draco/graph/graph.hpp"
#include "draco/graph/progress.hpp"
#include "draco/msgs/map.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "draco/objects/object_mapper.hpp"

namespace draco::frontend {
namespace {

namespace reg = draco::registration;
constexpr double kDeg = std::numbers::pi / 180.0;

// ---- Capture: keyframes and the last optimised trajectory of one run ----------------------
struct Captured {
  std::map<int, graph::Stamped<msgs::Keyframe>> keyframes;
  std::shared_ptr<const msgs::KeyframeTrajectory> trajectory;
};
std::mutex g_capture_mutex;
std::map<int, Captured> g_captured;  // by slot

class Capture final : public graph::Component {
 public:
  void Declare(graph::Spec& spec) override {
    spec.Doc("frontend-eval: keeps keyframes and the newest optimised trajectory.");
    keyframe_ = spec.Input<msgs::Keyframe>("keyframe", {.depth = 1024, .doc = "keyframes"});
    trajectory_ = spec.Input<msgs::KeyframeTrajectory>(
        "trajectory", {.delivery = graph::Delivery::kLatest, .doc = "trajectory"});
    spec.Param("slot", &slot_, {.doc = "capture slot"});
  }
  graph::Status Process(graph::Context&) override {
    std::lock_guard lock(g_capture_mutex);
    auto& c = g_captured[slot_];
    for (auto& k : keyframe_.TakeAll()) c.keyframes[k->index] = k;
    for (auto& t : trajectory_.TakeAll()) c.trajectory = t.value;
    return graph::Status::Ok();
  }

 private:
  int slot_ = 0;
  graph::In<msgs::Keyframe> keyframe_;
  graph::In<msgs::KeyframeTrajectory> trajectory_;
};
DRACO_REGISTER_COMPONENT(Capture, "frontend_eval.Capture")

std::vector<reg::KeyframeScan> RunLocalSlam(const std::string& mission, const std::string& name,
                                            int slot, const std::string& graph_path,
                                            const std::string& run_dir,
                                            const std::vector<std::string>& overrides,
                                            bool progress) {
  std::ifstream in(graph_path);
  if (!in) throw std::runtime_error("cannot read " + graph_path);
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  yaml +=
      "\n  - id: capture\n    type: frontend_eval.Capture\n"
      "    inputs: { keyframe: keyframes/keyframe, trajectory: slam/trajectory }\n"
      "    params: { slot: " +
      std::to_string(slot) + " }\n";
  graph::LoadOptions load;
  load.overrides = {"reader.recording=" + mission, "reader.robot=" + name,
                    "slam.prefix=" + name + ".", "truth.file=" + name + ".ground_truth.tum"};
  load.overrides.insert(load.overrides.end(), overrides.begin(), overrides.end());
  const std::string base_dir = std::filesystem::path(graph_path).parent_path().string();
  auto g = graph::LoadGraphString(yaml, graph_path, load, base_dir);
  // What this robot ran, every parameter resolved, but for the capture sink of this app:
  // `draco run` of it writes the same local-SLAM files.
  graph::WriteFileAtomicallyOrThrow(
      run_dir + "/" + name + ".graph.yaml",
      graph::ResolvedYaml(*graph::LoadGraphString(text.str(), graph_path, load, base_dir)));
  graph::RunOptions run;
  run.output_dir = run_dir;
  run.log_errors = false;
  // Progress of the replay (robot, mission time, %, rate, time left); one robot at a time only,
  // so lines of robots replayed in parallel do not overwrite each other.
  std::optional<graph::ProgressPrinter> printer;
  if (progress) {
    printer.emplace("local SLAM " + name, recording::RobotReplayLengthS(mission, name));
    run.progress = printer->Callback();
  }
  const auto result = graph::RunDeterministic(*g, run);
  if (printer) printer->Finish(graph::Time::FromSeconds(result.stats.mission_s));
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

void AttachTruth(const std::string& mission, Robot* r) {
  const auto truth = eval::ReadTum(mission + "/" + r->name + "/groundtruth.tum");
  eval::Trajectory est, tru;
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
  const auto U = eval::AlignUmeyama(est, tru);
  r->T_world_map = {U.x_m, U.y_m, U.yaw_rad};
}

}  // namespace

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
            static_cast<std::streamsize>(k.points_kf.size() * sizeof(msgs::Point2)));
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
           static_cast<std::streamsize>(m * sizeof(msgs::Point2)));
  }
  return static_cast<bool>(f);
}

bool TruthAt(const eval::Trajectory& truth, double t, Pose2* pose) {
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

std::vector<Robot> RunRobots(const std::string& mission, const recording::MissionInfo& info,
                             const std::string& out_dir, const SlamRunOptions& options,
                             double* wall_s) {
  std::filesystem::create_directories(out_dir + "/slam");
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
        if (!(options.reuse && LoadKeyframes(cache, &r.kfs))) {
          log::Info("local SLAM of " + r.name + " ...");
          r.kfs = RunLocalSlam(mission, r.name, static_cast<int>(i), options.graph_path,
                               out_dir + "/slam", options.overrides, options.jobs <= 1);
          SaveKeyframes(cache, r.kfs);
        }
        r.slam_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - s).count();
      } catch (const std::exception& e) {
        std::lock_guard lock(err_mutex);
        error = e.what();
      }
    }
  };
  for (int j = 0; j < std::max(1, options.jobs); ++j) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  if (!error.empty()) throw std::runtime_error(error);
  if (wall_s)
    *wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  for (auto& r : robots) {
    AttachTruth(mission, &r);
    r.landmarks = LoadLandmarks(out_dir + "/slam/" + r.name + ".landmarks.csv");
    r.objects = BuildObjectMap(r, options.mapper);
  }
  return robots;
}

std::vector<Landmark> LoadLandmarks(const std::string& path) {
  std::ifstream in(path);
  std::vector<Landmark> out;
  if (!in) return out;
  std::string line;
  int line_no = 0;
  const auto fail = [&](const std::string& what) {
    throw std::runtime_error(path + ":" + std::to_string(line_no) + ": " + what);
  };
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1) {
      if (line.rfind("id,x_m,y_m,", 0) != 0) fail("not a landmarks.csv header");
      if (line.find(",radius_m,keyframes") == std::string::npos) {
        fail("written before landmark radius and keyframes were recorded: re-run the local SLAM");
      }
      continue;
    }
    if (line.empty()) continue;
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    if (line.back() == ',') f.emplace_back();
    if (f.size() != 10) fail("expected 10 fields, found " + std::to_string(f.size()));
    Landmark l;
    try {
      l.id = std::stoi(f[0]);
      l.p_map = {std::stod(f[1]), std::stod(f[2])};
      l.radius_m = std::stod(f[8]);
      std::stringstream ks(f[9]);
      for (std::string k; std::getline(ks, k, ';');) l.keyframes.push_back(std::stoi(k));
    } catch (const std::exception&) {
      fail("a field is not a number");
    }
    if (!std::isfinite(l.p_map.x_m) || !std::isfinite(l.p_map.y_m)) fail("position not finite");
    out.push_back(std::move(l));
  }
  return out;
}

msgs::ObjectMap BuildObjectMap(const Robot& r, const objects::ObjectMapperOptions& options,
                               double until_s) {
  objects::ObjectMapper mapper(options);
  double last_s = 0.0;
  int last_index = -1;
  for (const auto& k : r.kfs) {
    if (k.time_s > until_s) break;
    mapper.AddKeyframe(k.index, k.T_map_kf, k.points_kf);
    last_s = k.time_s;
    last_index = k.index;
  }
  msgs::ObjectMap map = mapper.Objects(r.id, last_s);
  AppendLandmarks(r, last_index, options.landmark_min_sightings, &map);
  return map;
}

void AppendLandmarks(const Robot& r, int last_keyframe, int min_sightings, msgs::ObjectMap* map) {
  objects::AppendLandmarks(r.landmarks, last_keyframe, min_sightings, map);
}

int SharedObjects(const Robot& A, const msgs::ObjectMap& a, const Robot& B,
                  const msgs::ObjectMap& b, double radius_m) {
  int n = 0;
  for (const auto& oa : a.objects) {
    const auto pa = reg::Apply(A.T_world_map, oa.center);
    for (const auto& ob : b.objects) {
      const auto pb = reg::Apply(B.T_world_map, ob.center);
      if (std::hypot(pa.x_m - pb.x_m, pa.y_m - pb.y_m) <= radius_m) {
        ++n;
        break;
      }
    }
  }
  return n;
}

objects::Coverage KeyframeCoverage(const Robot& r, const objects::CoverageOptions& options,
                                   double until_s) {
  std::vector<Pose2> poses;
  for (const auto& k : r.kfs) {
    if (k.time_s <= until_s) poses.push_back(k.T_map_kf);
  }
  return objects::Coverage(poses, options);
}

std::vector<TimedMatch> MatchOverTime(const Robot& A, const Robot& B,
                                      const objects::ObjectMapperOptions& mapper,
                                      const objects::MatcherOptions& matcher, double step_s,
                                      const OverTimeOptions& over_time) {
  std::vector<TimedMatch> out;
  if (A.kfs.empty() || B.kfs.empty() || step_s <= 0) return out;
  const double t0 = std::max(A.kfs.front().time_s, B.kfs.front().time_s);
  const double t1 = std::min(A.kfs.back().time_s, B.kfs.back().time_s);
  const Pose2 T_true = reg::Between(A.T_world_map, B.T_world_map);
  // Incremental maps: keyframes are added as time advances.
  objects::ObjectMapper ma(mapper), mb(mapper);
  objects::MatchTracker tracker(over_time.tracker);
  const bool negative = matcher.miss_weight > 0.0;
  std::size_t ia = 0, ib = 0;
  for (double t = t0 + step_s; t <= t1 + 1e-9; t += step_s) {
    while (ia < A.kfs.size() && A.kfs[ia].time_s <= t) {
      ma.AddKeyframe(A.kfs[ia].index, A.kfs[ia].T_map_kf, A.kfs[ia].points_kf);
      ++ia;
    }
    while (ib < B.kfs.size() && B.kfs[ib].time_s <= t) {
      mb.AddKeyframe(B.kfs[ib].index, B.kfs[ib].T_map_kf, B.kfs[ib].points_kf);
      ++ib;
    }
    TimedMatch m;
    m.time_s = t;
    auto a = ma.Objects(A.id, t), b = mb.Objects(B.id, t);
    AppendLandmarks(A, ia > 0 ? A.kfs[ia - 1].index : -1, mapper.landmark_min_sightings, &a);
    AppendLandmarks(B, ib > 0 ? B.kfs[ib - 1].index : -1, mapper.landmark_min_sightings, &b);
    m.objects_a = static_cast<int>(a.objects.size());
    m.objects_b = static_cast<int>(b.objects.size());
    m.shared = SharedObjects(A, a, B, b);
    if (negative) {
      const auto ca = KeyframeCoverage(A, over_time.coverage, t);
      const auto cb = KeyframeCoverage(B, over_time.coverage, t);
      m.match = objects::MatchObjectMaps(a, b, matcher, &ca, &cb);
    } else {
      m.match = objects::MatchObjectMaps(a, b, matcher);
    }
    if (over_time.track) m.match = tracker.Update(m.match);
    m.matched = m.match.status == msgs::MatchStatus::kMatched;
    const Pose2 d = reg::Between(T_true, m.match.T_a_b);
    m.err_m = std::hypot(d.x_m, d.y_m);
    m.err_deg = std::abs(d.yaw_rad) / kDeg;
    m.correct = m.matched && m.err_m <= 2.0 && m.err_deg <= 10.0;
    const auto truth = objects::ScoreStructure(a, b, T_true, matcher.lines);
    m.true_support = truth.support;
    m.true_line_support = truth.line_support;
    out.push_back(m);
  }
  return out;
}

PairResult MatchAndRegister(const Robot& A, const Robot& B, const PairOptions& options) {
  PairResult out;
  // True shared objects: object centres within 2 m of each other in the world.
  std::vector<msgs::ObjectPair> true_pairs;
  for (const auto& oa : A.objects.objects) {
    const auto pa = reg::Apply(A.T_world_map, oa.center);
    for (const auto& ob : B.objects.objects) {
      const auto pb = reg::Apply(B.T_world_map, ob.center);
      if (std::hypot(pa.x_m - pb.x_m, pa.y_m - pb.y_m) <= 2.0) {
        ++out.shared_objects;
        true_pairs.push_back({oa.id, ob.id, 0.0});
        break;
      }
    }
  }
  out.T_true = reg::Between(A.T_world_map, B.T_world_map);
  if (options.matcher.miss_weight > 0.0) {
    const auto ca = KeyframeCoverage(A, options.coverage),
               cb = KeyframeCoverage(B, options.coverage);
    out.match = objects::MatchObjectMaps(A.objects, B.objects, options.matcher, &ca, &cb);
  } else {
    out.match = objects::MatchObjectMaps(A.objects, B.objects, options.matcher);
  }
  out.matched = out.match.status == msgs::MatchStatus::kMatched;
  const Pose2 d = reg::Between(out.T_true, out.match.T_a_b);
  out.err_m = std::hypot(d.x_m, d.y_m);
  out.err_deg = std::abs(d.yaw_rad) / kDeg;
  out.correct = out.matched && out.err_m <= 2.0 && out.err_deg <= 10.0;
  if (options.oracle && !out.correct && !true_pairs.empty()) {
    // Registration as if matching had found the true transform and the true pairs.
    out.match.status = msgs::MatchStatus::kMatched;
    out.match.T_a_b = out.T_true;
    out.match.pairs = true_pairs;
    out.oracle_used = true;
  }
  SelectAndRegister(A, B, options, &out);
  return out;
}

PairResult RegisterWithTransform(const Robot& A, const Robot& B, const Pose2& T_a_b,
                                 const PairOptions& options) {
  PairResult out;
  out.shared_objects = SharedObjects(A, A.objects, B, B.objects);
  out.T_true = reg::Between(A.T_world_map, B.T_world_map);
  out.match.robot_a = A.id;
  out.match.robot_b = B.id;
  out.match.T_a_b = T_a_b;
  out.match.pairs =
      objects::PairsUnderTransform(A.objects, B.objects, T_a_b, options.chain_pair_margin_m);
  out.match.num_inliers = static_cast<int>(out.match.pairs.size());
  out.match.status =
      out.match.pairs.empty() ? msgs::MatchStatus::kTooFewInliers : msgs::MatchStatus::kMatched;
  const Pose2 d = reg::Between(out.T_true, T_a_b);
  out.err_m = std::hypot(d.x_m, d.y_m);
  out.err_deg = std::abs(d.yaw_rad) / kDeg;
  SelectAndRegister(A, B, options, &out);
  return out;
}

void SelectAndRegister(const Robot& A, const Robot& B, const PairOptions& options,
                       PairResult* result) {
  PairResult& out = *result;
  std::vector<reg::KeyframeInfo> ia_info, ib_info;
  for (const auto& k : A.kfs) {
    ia_info.push_back({k.index, k.T_map_kf, static_cast<int>(k.points_kf.size())});
  }
  for (const auto& k : B.kfs) {
    ib_info.push_back({k.index, k.T_map_kf, static_cast<int>(k.points_kf.size())});
  }
  const auto requests =
      reg::SelectScanRequests(A.objects, B.objects, out.match, ia_info, ib_info, options.selection);
  out.requests = requests.size();
  std::map<int, int> pos_a, pos_b;
  for (std::size_t i = 0; i < A.kfs.size(); ++i) pos_a[A.kfs[i].index] = static_cast<int>(i);
  for (std::size_t i = 0; i < B.kfs.size(); ++i) pos_b[B.kfs[i].index] = static_cast<int>(i);
  for (const auto& req : requests) {
    const int jb = pos_b.at(req.teammate_keyframe);
    for (const int own_index : req.candidates) {
      const int ka = pos_a.at(own_index);
      const Pose2 seed = reg::SeedPose(A.kfs[ka].T_map_kf, out.match.T_a_b, B.kfs[jb].T_map_kf);
      const bool truth_ok = A.has_truth[ka] && B.has_truth[jb];
      const Pose2 rel_true = reg::Between(A.truth_kf[ka], B.truth_kf[jb]);
      for (const int w : options.windows) {
        auto o = options.registration;
        o.window = w;
        const auto s = std::chrono::steady_clock::now();
        const auto r = reg::RegisterScan(A.kfs, ka, B.kfs[jb].points_kf, seed, o, A.id, B.id,
                                         req.teammate_keyframe);
        out.registration_time_s +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - s).count();
        const Pose2 e = reg::Between(rel_true, r.loop.T_ownkf_teammatekf);
        const double em = std::hypot(e.x_m, e.y_m), ed = std::abs(e.yaw_rad) / kDeg;
        Registration row;
        row.window = w;
        row.own_kf = own_index;
        row.team_kf = req.teammate_keyframe;
        row.source_points = static_cast<int>(B.kfs[jb].points_kf.size());
        row.valid = r.status == reg::RegistrationStatus::kAccepted;
        row.overlap = r.loop.overlap;
        row.err_m = truth_ok ? em : -1.0;
        row.err_deg = truth_ok ? ed : -1.0;
        row.tp = truth_ok && em <= options.tp_m && ed <= options.tp_deg;
        row.oracle = out.oracle_used;
        row.loop = r.loop;
        out.registrations.push_back(row);
      }
    }
  }
}

PossibleLoops CountPossibleLoops(const Robot& A, const Robot& B, const PairOptions& options,
                                 int window, double min_overlap) {
  PossibleLoops out;
  auto o = options.registration;
  o.window = window;
  o.min_overlap = 0.0;
  const double radius_m = options.selection.candidate_radius_m;
  for (std::size_t jb = 0; jb < B.kfs.size(); ++jb) {
    if (!B.has_truth[jb]) continue;
    if (static_cast<int>(B.kfs[jb].points_kf.size()) < options.selection.min_points) continue;
    for (std::size_t ka = 0; ka < A.kfs.size(); ++ka) {
      if (!A.has_truth[ka]) continue;
      const Pose2 rel_true = reg::Between(A.truth_kf[ka], B.truth_kf[jb]);
      if (std::hypot(rel_true.x_m, rel_true.y_m) > radius_m) continue;
      ++out.pairs_tested;
      const auto r = reg::RegisterScan(A.kfs, static_cast<int>(ka), B.kfs[jb].points_kf, rel_true,
                                       o, A.id, B.id, B.kfs[jb].index);
      if (r.status != reg::RegistrationStatus::kAccepted) continue;
      const Pose2 e = reg::Between(rel_true, r.loop.T_ownkf_teammatekf);
      if (std::hypot(e.x_m, e.y_m) > options.tp_m || std::abs(e.yaw_rad) / kDeg > options.tp_deg)
        continue;
      out.best_overlap = std::max(out.best_overlap, r.loop.overlap);
      if (r.loop.overlap >= min_overlap) ++out.possible;
    }
  }
  return out;
}

}  // namespace draco::frontend
