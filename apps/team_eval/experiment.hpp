// A draco-team-eval experiment: the knobs of the Table III protocol, as a YAML file
// (`--experiment FILE`) and single keys (`--exp-set section.key=value`), in five sections:
//
//   matching    how each own robot places its teammates: oracle, shared_transforms
//   candidates  which registrations are candidate loops: window, min_overlap
//   filter      PCM and GCM: min_clique_size, map_sigma_m, map_sigma_deg, pose_covariance,
//               map_frame_drift
//   optimizer   two-step and full PGO: local_graph, local_chain_sigma_xy_m,
//               local_chain_sigma_yaw_deg, global_anchor, chain_from_factors, loop_sigma_xy_m,
//               loop_sigma_yaw_deg
//   inject      wrong loops added to the candidates: fraction, kind, group_size, offset_m,
//               directions, seed
//
// The defaults are the member initialisers of Experiment and nowhere else: a file gives only
// the keys it changes. Unknown sections or keys, wrong types and values out of range are
// errors naming the file, line, column and key. ExperimentYaml writes every key with its value
// and what it means (`draco-team-eval --print-experiment` prints it); every run folder holds it
// as experiment.yaml, and `draco-team-eval MISSION --experiment OUT/experiment.yaml` runs the
// same experiment again.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "draco/graph/graph.hpp"

namespace draco::team_eval {

struct Experiment {
  // How each own robot places its teammates (the map-to-map guesses).
  struct Matching {
    bool oracle = false;            // ground truth where object-graph matching is not right
    bool shared_transforms = true;  // unmatched teammates placed through teammates' matches
    bool operator==(const Matching&) const = default;
  };
  // Candidate inter-robot loops: accepted registrations with every teammate.
  struct Candidates {
    int window = 3;             // registration window, keyframes each side
    double min_overlap = 0.85;  // overlap threshold, [0, 1]
    bool operator==(const Candidates&) const = default;
  };
  // PCM and GCM (ConsistencyFilter, propagated covariance, no time budget).
  struct Filter {
    int min_clique_size = 5;
    double map_sigma_m = 0.5;  // map-to-map guess in GCM
    double map_sigma_deg = 1.0;
    std::string pose_covariance = "graph";  // graph | chain
    bool map_frame_drift = false;
    bool operator==(const Filter&) const = default;
  };
  // Two-step and full PGO.
  struct Optimizer {
    std::string local_graph = "chain";    // chain | full
    double local_chain_sigma_xy_m = 0.0;  // 0 (with yaw 0): the local graph's information
    double local_chain_sigma_yaw_deg = 0.0;
    std::string global_anchor = "touched";  // touched | first_loop | rigid
    bool chain_from_factors = false;
    double loop_sigma_xy_m = 0.0;  // 0 (with yaw 0): each loop's own covariance
    double loop_sigma_yaw_deg = 0.0;
    bool operator==(const Optimizer&) const = default;
  };
  // Wrong loops added to every robot's real candidates (frontend::InjectOutliers).
  struct Inject {
    double fraction = 0.0;            // [0, 1); 0: none
    std::string kind = "correlated";  // random | correlated
    int group_size = 6;
    double offset_m = 2.4;
    int directions = 0;
    std::uint64_t seed = 1;
    bool operator==(const Inject&) const = default;
  };

  Matching matching;
  Candidates candidates;
  Filter filter;
  Optimizer optimizer;
  Inject inject;
  bool operator==(const Experiment&) const = default;
};

// Every problem of an experiment file and of the --exp-set overrides, not only the first;
// what() is one "file:line:column: error: message" line per problem.
class ExperimentError : public std::runtime_error {
 public:
  explicit ExperimentError(std::vector<graph::Diagnostic> diagnostics);
  const std::vector<graph::Diagnostic>& diagnostics() const { return diagnostics_; }

 private:
  std::vector<graph::Diagnostic> diagnostics_;
};

// The defaults, then the file at `path` ("": none), then each override "section.key=value"
// (the value read as YAML) in order. Throws ExperimentError.
Experiment LoadExperiment(const std::string& path, const std::vector<std::string>& overrides = {});
// Same from text; `name` stands in for the file name in diagnostics.
Experiment LoadExperimentString(const std::string& yaml, const std::string& name,
                                const std::vector<std::string>& overrides = {});

// The experiment as a YAML file: every section and key with its value and, as comments, what
// it means. LoadExperimentString of it gives back an equal Experiment.
std::string ExperimentYaml(const Experiment& experiment);

}  // namespace draco::team_eval
