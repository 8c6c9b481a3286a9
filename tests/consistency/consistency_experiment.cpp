// Robustness experiment (docs/back-end.md): synthetic candidate streams with injected wrong
// loops (random, or correlated groups sharing one wrong offset) at 30, 60 and 90 % outliers;
// precision and recall of PCM and GCM over the loops they emit (every loop ever newly
// accepted, as a pose graph that never removes a factor would receive them).
//
//   consistency_experiment [--seeds N] [--all]   (--all: also first-loop covariance and
//                                                 reference queue rows)
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <string>
#include <vector>

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
  bool all = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--seeds") == 0 && i + 1 < argc) seeds = std::atoi(argv[++i]);
    if (std::strcmp(argv[i], "--all") == 0) all = true;
  }
  struct Kind {
    const char* name;
    synthetic::OutlierKind kind;
    bool shared_axis;
  };
  const Kind kinds[] = {{"random", synthetic::OutlierKind::kRandom, false},
                        {"groups, random offset", synthetic::OutlierKind::kCorrelated, false},
                        {"groups, +-2 m along x/y", synthetic::OutlierKind::kCorrelated, true}};
  struct Config {
    Method method;
    CovarianceModel cov;
    QueueMode queue;
    bool gate;
    int span;
    bool poor_guess_too;
  };
  std::vector<Config> configs = {
      {Method::kPcm, CovarianceModel::kPropagated, QueueMode::kIncremental, false, 0, true},
      {Method::kPcm, CovarianceModel::kPropagated, QueueMode::kIncremental, false, 5, false},
      {Method::kGcm, CovarianceModel::kPropagated, QueueMode::kIncremental, false, 0, true},
      {Method::kGcm, CovarianceModel::kPropagated, QueueMode::kIncremental, true, 0, true},
      {Method::kGcm, CovarianceModel::kPropagated, QueueMode::kIncremental, true, 5, false}};
  if (all) {
    for (const Method method : {Method::kPcm, Method::kGcm}) {
      configs.push_back(
          {method, CovarianceModel::kFirstLoop, QueueMode::kIncremental, false, 0, false});
      configs.push_back(
          {method, CovarianceModel::kPropagated, QueueMode::kReference, false, 0, false});
    }
  }
  // Map-to-map guess: the synthetic's (0.1 m, 0.005 rad error and sigma) and one as poor as
  // the apps' default sigma (1 m, 0.05 rad).
  struct Guess {
    const char* name;
    double sigma_m, sigma_rad;
  };
  const Guess guesses[] = {{"0.1 m, 0.005 rad", 0.1, 0.005}, {"1 m, 0.05 rad", 1.0, 0.05}};
  std::printf(
      "| outliers | kind | map guess | method | covariance | queue | precision (emitted) | "
      "recall (emitted) | precision (final set) |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const Kind& kind : kinds) {
    for (const double fraction : {0.3, 0.6, 0.9}) {
      for (const Guess& guess : guesses) {
        for (const Config& c : configs) {
          if (guess.sigma_m > 0.5 && !c.poor_guess_too) continue;
          Score s;
          for (int seed = 1; seed <= seeds; ++seed) {
            synthetic::MissionOptions mo;
            mo.outlier_fraction = fraction;
            mo.outliers = kind.kind;
            mo.shared_offset_axis = kind.shared_axis;
            mo.map_sigma_xy_m = guess.sigma_m;
            mo.map_sigma_yaw_rad = guess.sigma_rad;
            mo.seed = static_cast<std::uint32_t>(seed);
            const auto m = synthetic::MakeMission(mo);
            FilterOptions fo;
            fo.method = c.method;
            fo.pairwise.covariance = c.cov;
            fo.queue = c.queue;
            fo.map_prior_gate = c.gate;
            fo.min_clique_span_keyframes = c.span;
            RunOnce(m, fo, &s);
          }
          const std::string name =
              std::string(MethodName(c.method)) +
              (c.method == Method::kGcm ? (c.gate ? " + map prior" : " (no prior)") : "") +
              (c.span > 0 ? ", span " + std::to_string(c.span) : "");
          std::printf("| %.0f %% | %s | %s | %s | %s | %s | %.3f | %.3f | %.3f |\n", fraction * 100,
                      kind.name, guess.name, name.c_str(), CovarianceModelName(c.cov),
                      c.queue == QueueMode::kIncremental ? "incremental" : "reference",
                      s.emitted > 0 ? s.tp / s.emitted : 1.0, s.tp / s.inliers,
                      s.final_accepted > 0 ? s.final_tp / s.final_accepted : 1.0);
          std::fflush(stdout);
        }
      }
    }
  }
  return 0;
}
