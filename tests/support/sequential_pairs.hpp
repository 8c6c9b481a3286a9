// Sequential scan pairs of a recorded mission's local SLAM, for the registration benchmarks
// (tests/registration/backends_bench.cpp, tests/peers/peers_inputs.cpp): each keyframe's scan
// against the previous three keyframes' scans placed by ground truth, seeded by dead
// reckoning, with the true transform. Header-only: test code.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "draco/eval/trajectory.hpp"
#include "draco/frontend/pipeline.hpp"
#include "draco/icp/icp.hpp"
#include "draco/registration/registration.hpp"

namespace draco::test {

struct SequentialPair {
  icp::Cloud2 source, target;
  msgs::Pose2 seed, truth;  // T_previous_current
};

// `out_dir` holds the robots' slam/<robot>.dead_reckoning.tum (frontend::RunRobots writes it).
// Pairs with fewer than min_points points on either side (the odometry's) are left out.
inline std::vector<SequentialPair> SequentialPairs(const std::vector<frontend::Robot>& robots,
                                                   const std::string& out_dir,
                                                   std::size_t min_points = 50) {
  namespace reg = registration;
  std::vector<SequentialPair> seq;
  for (const auto& r : robots) {
    const auto dr = eval::ReadTum(out_dir + "/slam/" + r.name + ".dead_reckoning.tum");
    if (dr.size() != r.kfs.size()) {
      throw std::runtime_error(r.name + ": dead reckoning rows do not match the keyframes");
    }
    for (std::size_t k = 1; k < r.kfs.size(); ++k) {
      if (!r.has_truth[k] || !r.has_truth[k - 1]) continue;
      SequentialPair p;
      p.source = icp::ToCloud(r.kfs[k].points_kf);
      for (std::size_t j = k >= 3 ? k - 3 : 0; j < k; ++j) {
        if (!r.has_truth[j]) continue;
        const msgs::Pose2 T = reg::Between(r.truth_kf[k - 1], r.truth_kf[j]);
        for (const auto& q : r.kfs[j].points_kf) {
          const auto w = reg::Apply(T, q);
          p.target.emplace_back(w.x_m, w.y_m);
        }
      }
      if (p.source.size() < min_points || p.target.size() < min_points) continue;
      p.seed = reg::Between(msgs::Pose2{dr[k - 1].x_m, dr[k - 1].y_m, dr[k - 1].yaw_rad},
                            msgs::Pose2{dr[k].x_m, dr[k].y_m, dr[k].yaw_rad});
      p.truth = reg::Between(r.truth_kf[k - 1], r.truth_kf[k]);
      seq.push_back(std::move(p));
    }
  }
  return seq;
}

}  // namespace draco::test
