// Robustness experiment (docs/back-end.md): synthetic candidate streams with injected wrong
// loops (random, or correlated groups sharing one wrong offset) at 30, 60 and 90 % outliers;
// precision and recall of PCM and GCM over the loops they emit (every loop ever newly
// accepted, as a pose graph that never removes a factor would receive them).
//
//   consistency_experiment [--seeds N]
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <string>

#include "draco/consistency/filter.hpp"
#include "synthetic.hpp"

using namespace draco::consistency;

namespace {

struct Score {
  double tp = 0, emitted = 0, inliers = 0, final_tp = 0, final_accepted = 0;
};

void RunOnce(const synthetic::Mission& m, const FilterOptions& fo, Score* s) {
  ConsistencyFilter filter(fo);
  std::set<std::uint64_t> emitted;
  Decision last;
  std::size_t next = 0;
  for (int step = 0; next < m.loops.size(); step += 5) {
    std::vector<draco::msgs::InterRobotLoop> batch;
    while (next < m.loops.size() && m.arrival[next] < step + 5) batch.push_back(m.loops[next++]);
    if (batch.empty()) continue;
    last = filter.Add(batch, m.poses);
    emitted.insert(last.newly_accepted.begin(), last.newly_accepted.end());
  }
  for (const auto id : emitted) s->tp += m.inlier[id] ? 1 : 0;
  s->emitted += static_cast<double>(emitted.size());
  for (const bool b : m.inlier) s->inliers += b ? 1 : 0;
  for (const auto id : last.accepted) s->final_tp += m.inlier[id] ? 1 : 0;
  s->final_accepted += static_cast<double>(last.accepted.size());
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 10;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--seeds") == 0 && i + 1 < argc) seeds = std::atoi(argv[++i]);
  }
  struct Kind {
    const char* name;
    synthetic::OutlierKind kind;
    bool shared_axis;
  };
  const Kind kinds[] = {{"random", synthetic::OutlierKind::kRandom, false},
                        {"groups, random offset", synthetic::OutlierKind::kCorrelated, false},
                        {"groups, +-2 m along x/y", synthetic::OutlierKind::kCorrelated, true}};
  std::printf(
      "| outliers | kind | method | covariance | queue | precision (emitted) | recall (emitted) "
      "| precision (final set) |\n|---|---|---|---|---|---|---|---|\n");
  for (const Kind& kind : kinds) {
    for (const double fraction : {0.3, 0.6, 0.9}) {
      for (const QueueMode queue : {QueueMode::kIncremental, QueueMode::kReference}) {
        for (const Method method : {Method::kPcm, Method::kGcm}) {
          for (const CovarianceModel cov :
               {CovarianceModel::kFirstLoop, CovarianceModel::kPropagated}) {
            Score s;
            for (int seed = 1; seed <= seeds; ++seed) {
              synthetic::MissionOptions mo;
              mo.outlier_fraction = fraction;
              mo.outliers = kind.kind;
              mo.shared_offset_axis = kind.shared_axis;
              mo.seed = static_cast<std::uint32_t>(seed);
              const auto m = synthetic::MakeMission(mo);
              FilterOptions fo;
              fo.method = method;
              fo.pairwise.covariance = cov;
              fo.queue = queue;
              fo.time_budget_ms = 0.0;
              RunOnce(m, fo, &s);
            }
            std::printf("| %.0f %% | %s | %s | %s | %s | %.3f | %.3f | %.3f |\n", fraction * 100,
                        kind.name, MethodName(method), CovarianceModelName(cov),
                        queue == QueueMode::kIncremental ? "incremental" : "reference",
                        s.emitted > 0 ? s.tp / s.emitted : 1.0, s.tp / s.inliers,
                        s.final_accepted > 0 ? s.final_tp / s.final_accepted : 1.0);
            std::fflush(stdout);
          }
        }
      }
    }
  }
  return 0;
}
