// Not a test: the registration back ends (icp::Backend: draco's 2D ICP, PCL's ICP, GICP and
// NDT, MRPT's ICP) side by side on a recorded mission's real scan pairs, judged against its ground
// truth (docs/benchmarks.md, "Registration back ends").
//
//   registration_backends_bench MISSION_DIR --out DIR [--reuse]
//
// Every robot's local SLAM runs first through the local-SLAM graph with the default back end
// (frontend::RunRobots; --reuse takes the keyframes cached in DIR/slam). Then two sets of
// pairs, the same for every back end:
//   sequential  each keyframe k against keyframes k-3 .. k-1 placed by ground truth in k-1's
//               frame (the odometry's target, without its drift), seeded by dead reckoning's
//               increment, as slam.IcpOdometry does; judged against the true increment.
//   inter-robot for every ordered robot pair whose object maps match (object-graph matching of
//               the final maps), the scans the exchange would request, each against every
//               candidate own keyframe: window-3 registration (team.ScanExchange's default)
//               seeded by the match, ambiguity test off; judged against the true relative
//               pose. A detection is an answer with overlap >= 0.85 (the default threshold),
//               a true one within 1.5 m and 15 deg (draco-frontend-eval's criterion).
// Times are CPU time of the calling thread per registration, target preparation included.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "draco/eval/trajectory.hpp"
#include "draco/frontend/pipeline.hpp"
#include "draco/icp/icp.hpp"
#include "draco/recording/recording.hpp"
#include "draco/registration/registration.hpp"
#include "sequential_pairs.hpp"

namespace {

namespace fe = draco::frontend;
namespace icp = draco::icp;
namespace reg = draco::registration;
using draco::msgs::Pose2;
constexpr double kDeg = std::numbers::pi / 180.0;

double CpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}
double P90(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(0.9 * static_cast<double>(v.size() - 1) + 0.5)];
}

// Sequential pair: target = keyframes k-3..k-1 in k-1's frame by ground truth.
using SeqPair = draco::test::SequentialPair;

}  // namespace

constexpr const char* kUsage =
    "usage: registration_backends_bench MISSION_DIR --out DIR [--reuse] [--graph YAML]\n"
    "         [--backends draco,pcl_icp,pcl_gicp,pcl_ndt,mrpt_icp] [--ndt-resolution M] "
    "[--sequential-only]\n";

int main(int argc, char** argv) {
  // Plain argument parsing: CLI11 alone would double this file's compile time.
  std::string mission, out_dir,
      graph_path = std::string(DRACO_SOURCE_DIR) + "/config/graphs/local-slam.yaml";
  bool reuse = false, sequential_only = false;
  std::vector<std::string> backends = icp::BackendNames();
  double ndt_resolution_m = icp::IcpOptions{}.ndt_resolution_m;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--reuse") {
      reuse = true;
    } else if (a == "--sequential-only") {
      sequential_only = true;
    } else if (a == "--out" && has_value) {
      out_dir = argv[++i];
    } else if (a == "--graph" && has_value) {
      graph_path = argv[++i];
    } else if (a == "--ndt-resolution" && has_value) {
      ndt_resolution_m = std::stod(argv[++i]);
    } else if (a == "--backends" && has_value) {
      backends.clear();
      std::stringstream list(argv[++i]);
      for (std::string b; std::getline(list, b, ',');) backends.push_back(b);
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
  for (const auto& b : backends) {
    try {
      icp::ParseBackend(b);
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "registration_backends_bench: %s\n", e.what());
      return 2;
    }
  }

  try {
    const auto info = draco::recording::LoadMissionInfo(mission);
    fe::SlamRunOptions so;
    so.graph_path = graph_path;
    so.reuse = reuse;
    std::vector<fe::Robot> robots = fe::RunRobots(mission, info, out_dir, so);

    // Sequential pairs.
    const std::vector<SeqPair> seq = draco::test::SequentialPairs(robots, out_dir);

    // Inter-robot registrations the exchange would run: (A, ka, B, jb, seed, truth).
    struct InterPair {
      const fe::Robot *A, *B;
      int ka, jb;
      Pose2 seed, truth;
    };
    std::vector<InterPair> inter;
    int pairs_matched = 0, pairs_right = 0;
    fe::PairOptions po;
    po.windows.clear();  // matching and selection only
    for (const auto& A : robots) {
      for (const auto& B : robots) {
        if (&A == &B || sequential_only) continue;
        const fe::PairResult pr = fe::MatchAndRegister(A, B, po);
        if (!pr.matched) continue;
        ++pairs_matched;
        pairs_right += pr.correct;
        std::vector<reg::KeyframeInfo> ia, ib;
        for (const auto& k : A.kfs) ia.push_back({k.index, k.T_map_kf, int(k.points_kf.size())});
        for (const auto& k : B.kfs) ib.push_back({k.index, k.T_map_kf, int(k.points_kf.size())});
        std::map<int, int> pos_a, pos_b;
        for (std::size_t i = 0; i < A.kfs.size(); ++i) pos_a[A.kfs[i].index] = int(i);
        for (std::size_t i = 0; i < B.kfs.size(); ++i) pos_b[B.kfs[i].index] = int(i);
        for (const auto& req :
             reg::SelectScanRequests(A.objects, B.objects, pr.match, ia, ib, po.selection)) {
          const int jb = pos_b.at(req.teammate_keyframe);
          for (const int own : req.candidates) {
            const int ka = pos_a.at(own);
            if (!A.has_truth[ka] || !B.has_truth[jb]) continue;
            inter.push_back({&A, &B, ka, jb,
                             reg::SeedPose(A.kfs[ka].T_map_kf, pr.match.T_a_b, B.kfs[jb].T_map_kf),
                             reg::Between(A.truth_kf[ka], B.truth_kf[jb])});
          }
        }
      }
    }

    std::printf(
        "mission %s: %zu robots, %zu sequential pairs, %zu inter-robot registrations "
        "(%d ordered robot pairs matched, %d of them right)\n\n",
        info.name.c_str(), robots.size(), seq.size(), inter.size(), pairs_matched, pairs_right);

    struct Row {
      std::string name;
      double seq_ms = 0, inter_ms = 0;
      int seq_converged = 0, seq_good = 0, inter_converged = 0, detections = 0, truths = 0;
      std::vector<double> em, ed, tm, td;  // sequential errors; errors of true detections
    };
    std::vector<Row> rows;
    const auto judge = [](const Pose2& truth, const Pose2& est, double* m, double* d) {
      const Pose2 e = reg::Between(truth, est);
      *m = std::hypot(e.x_m, e.y_m);
      *d = std::abs(e.yaw_rad) / kDeg;
    };
    Row seed{"seed (dead reckoning / matching)"};
    for (const auto& p : seq) {
      double m, d;
      judge(p.truth, p.seed, &m, &d);
      seed.em.push_back(m);
      seed.ed.push_back(d);
      seed.seq_good += m <= 0.1 && d <= 1.0;
    }
    for (const auto& p : inter) {
      double m, d;
      judge(p.truth, p.seed, &m, &d);
      if (m > 1.5 || d > 15.0) continue;
      seed.tm.push_back(m);
      seed.td.push_back(d);
    }
    rows.push_back(seed);
    for (const auto& name : backends) {
      Row row{name};
      icp::IcpOptions io;
      io.backend = icp::ParseBackend(name);
      io.ndt_resolution_m = ndt_resolution_m;
      for (const auto& p : seq) {
        const double t0 = CpuMs();
        const auto r = icp::AlignIcp(p.source, p.target, p.seed, io);
        row.seq_ms += (CpuMs() - t0) / static_cast<double>(seq.size());
        double m, d;
        judge(p.truth, r.T_target_source, &m, &d);
        row.seq_converged += r.valid && r.converged;
        row.em.push_back(m);
        row.ed.push_back(d);
        row.seq_good += r.valid && m <= 0.1 && d <= 1.0;
      }
      reg::RegistrationOptions ro;
      ro.icp = io;
      ro.min_overlap = 0.0;  // decided below
      ro.ambiguity_offsets_m.clear();
      ro.ambiguity_turns_deg.clear();
      for (const auto& p : inter) {
        const double t0 = CpuMs();
        const auto r = reg::RegisterScan(p.A->kfs, p.ka, p.B->kfs[p.jb].points_kf, p.seed, ro);
        row.inter_ms += (CpuMs() - t0) / static_cast<double>(inter.size());
        row.inter_converged += r.icp.valid && r.icp.converged;
        if (!r.accepted() || r.loop.overlap < reg::RegistrationOptions{}.min_overlap) continue;
        ++row.detections;
        double m, d;
        judge(p.truth, r.loop.T_ownkf_teammatekf, &m, &d);
        if (m > 1.5 || d > 15.0) continue;
        ++row.truths;
        row.tm.push_back(m);
        row.td.push_back(d);
      }
      rows.push_back(row);
      std::fprintf(stderr, "%s done\n", name.c_str());
    }
    const auto pct = [](int n, std::size_t of) {
      return of ? std::to_string(static_cast<int>(std::lround(100.0 * n / double(of)))) + " %"
                : std::string("-");
    };
    const auto num = [](double v, const char* fmt) {
      char b[32];
      std::snprintf(b, sizeof b, fmt, v);
      return std::string(b);
    };
    std::printf("Sequential pairs (%zu):\n\n", seq.size());
    std::printf(
        "| back end | CPU ms / pair | converged | error median (m / deg) | error p90 (m / deg) "
        "| within 0.1 m and 1 deg |\n|---|---|---|---|---|---|\n");
    for (const auto& r : rows) {
      const bool is_seed = &r == &rows.front();
      std::printf("| %s | %s | %s | %.3f / %.2f | %.3f / %.2f | %s |\n", r.name.c_str(),
                  is_seed ? "-" : num(r.seq_ms, "%.2f").c_str(),
                  is_seed ? "-" : pct(r.seq_converged, seq.size()).c_str(), Median(r.em),
                  Median(r.ed), P90(r.em), P90(r.ed), pct(r.seq_good, seq.size()).c_str());
    }
    if (inter.empty()) {
      std::printf("\nNo inter-robot registrations: no pair of final object maps matched.\n");
      return 0;
    }
    std::printf("\nInter-robot registrations (%zu, window 3):\n\n", inter.size());
    std::printf(
        "| back end | CPU ms / registration | converged | detections (overlap >= 0.85) | "
        "true (1.5 m, 15 deg) | precision | error median of the true (m / deg) |\n"
        "|---|---|---|---|---|---|---|\n");
    for (const auto& r : rows) {
      if (&r == &rows.front()) {
        std::printf("| %s | - | - | - | %zu seeds within | - | %.3f / %.2f |\n", r.name.c_str(),
                    r.tm.size(), Median(r.tm), Median(r.td));
        continue;
      }
      std::printf("| %s | %.2f | %s | %d | %d | %s | %.3f / %.2f |\n", r.name.c_str(), r.inter_ms,
                  pct(r.inter_converged, inter.size()).c_str(), r.detections, r.truths,
                  pct(r.truths, static_cast<std::size_t>(r.detections)).c_str(), Median(r.tm),
                  Median(r.td));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "registration_backends_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
