// draco-team-eval's experiment file (apps/team_eval/experiment.hpp): defaults, every key read
// and written back, --exp-set overrides, and errors that name the file, line, column and key.
#include "experiment.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace draco::team_eval {
namespace {

// Every key, none at its default.
constexpr const char* kEveryKey = R"(matching:
  oracle: true
  shared_transforms: false
candidates:
  window: 1
  min_overlap: 0.8
filter:
  min_clique_size: 4
  map_sigma_m: 0.7
  map_sigma_deg: 2.5
  pose_covariance: chain
  map_frame_drift: true
optimizer:
  local_graph: full
  local_chain_sigma_xy_m: 0.03
  local_chain_sigma_yaw_deg: 0.172
  global_anchor: first_loop
  chain_from_factors: true
  loop_sigma_xy_m: 0.5
  loop_sigma_yaw_deg: 3
inject:
  fraction: 0.9
  kind: random
  group_size: 5
  offset_m: 3.1
  directions: 4
  seed: 18446744073709551615
)";

Experiment EveryKey() {
  Experiment e;
  e.matching = {true, false};
  e.candidates = {1, 0.8};
  e.filter = {4, 0.7, 2.5, "chain", true};
  e.optimizer = {"full", 0.03, 0.172, "first_loop", true, 0.5, 3.0};
  e.inject = {0.9, "random", 5, 3.1, 4, 18446744073709551615ull};
  return e;
}

// The one diagnostic of loading `yaml` as "exp.yaml".
graph::Diagnostic OneError(const std::string& yaml, const std::vector<std::string>& sets = {}) {
  try {
    LoadExperimentString(yaml, "exp.yaml", sets);
  } catch (const ExperimentError& e) {
    EXPECT_EQ(e.diagnostics().size(), 1u) << e.what();
    return e.diagnostics().empty() ? graph::Diagnostic{} : e.diagnostics().front();
  }
  ADD_FAILURE() << "no error for:\n" << yaml;
  return {};
}

TEST(Experiment, NoFileAndAnEmptyFileGiveTheDefaults) {
  EXPECT_EQ(LoadExperiment(""), Experiment{});
  EXPECT_EQ(LoadExperimentString("", "exp.yaml"), Experiment{});
  EXPECT_EQ(LoadExperimentString("# nothing but a comment\n", "exp.yaml"), Experiment{});
  EXPECT_EQ(LoadExperimentString("inject:\n", "exp.yaml"), Experiment{});
}

TEST(Experiment, AFileGivesOnlyWhatItChanges) {
  const auto e = LoadExperimentString("filter:\n  min_clique_size: 1000\n", "exp.yaml");
  Experiment expected;
  expected.filter.min_clique_size = 1000;
  EXPECT_EQ(e, expected);
}

TEST(Experiment, EveryKeyIsReadAndTheResolvedFileReadsBackEqual) {
  const auto loaded = LoadExperimentString(kEveryKey, "exp.yaml");
  EXPECT_EQ(loaded, EveryKey());
  const std::string resolved = ExperimentYaml(loaded);
  EXPECT_EQ(LoadExperimentString(resolved, "experiment.yaml"), loaded) << resolved;
  // Written again, the same text.
  EXPECT_EQ(ExperimentYaml(LoadExperimentString(resolved, "experiment.yaml")), resolved);
}

TEST(Experiment, TheResolvedFileHoldsEveryKey) {
  // The defaults written out: every key of kEveryKey is in it, each once, with its value.
  const std::string resolved = ExperimentYaml(Experiment{});
  std::istringstream every(kEveryKey);
  std::string line;
  int keys = 0;
  while (std::getline(every, line)) {
    if (line.rfind("  ", 0) != 0) continue;
    const std::string key = line.substr(0, line.find(':') + 1);
    EXPECT_NE(resolved.find("\n" + key + " "), std::string::npos) << key << "\n" << resolved;
    ++keys;
  }
  EXPECT_EQ(keys, 22);
  EXPECT_NE(resolved.find("\n  min_overlap: 0.85\n"), std::string::npos) << resolved;
  EXPECT_NE(resolved.find("\n  map_sigma_deg: 1.0\n"), std::string::npos) << resolved;
  EXPECT_NE(resolved.find("\n  global_anchor: touched\n"), std::string::npos) << resolved;
  EXPECT_EQ(LoadExperimentString(resolved, "experiment.yaml"), Experiment{});
}

TEST(Experiment, NumbersReadBackExactly) {
  Experiment e;
  e.candidates.min_overlap = 0.1 + 0.2;  // 0.30000000000000004
  e.filter.map_sigma_m = 1e-7;
  e.inject.offset_m = 2.0;
  EXPECT_EQ(LoadExperimentString(ExperimentYaml(e), "experiment.yaml"), e);
}

TEST(Experiment, OverridesComeAfterTheFile) {
  const auto e = LoadExperimentString("inject:\n  fraction: 0.3\n  kind: random\n", "exp.yaml",
                                      {"inject.fraction=0.9", "matching.oracle=true"});
  EXPECT_DOUBLE_EQ(e.inject.fraction, 0.9);
  EXPECT_EQ(e.inject.kind, "random");
  EXPECT_TRUE(e.matching.oracle);
  EXPECT_EQ(LoadExperiment("", {"filter.pose_covariance=chain"}).filter.pose_covariance, "chain");
}

TEST(Experiment, AnUnknownKeyNamesFileLineColumnAndTheKey) {
  const auto d = OneError("filter:\n  map_sigma_m: 0.4\n  min_cliqe_size: 3\n");
  EXPECT_EQ(d.file, "exp.yaml");
  EXPECT_EQ(d.line, 3);
  EXPECT_EQ(d.column, 3);
  EXPECT_NE(d.message.find("unknown key 'min_cliqe_size' in filter"), std::string::npos)
      << d.message;
  EXPECT_NE(d.message.find("did you mean 'min_clique_size'"), std::string::npos) << d.message;
  EXPECT_EQ(d.ToString().rfind("exp.yaml:3:3: error: ", 0), 0u) << d.ToString();
}

TEST(Experiment, AnUnknownSectionIsAnError) {
  const auto d = OneError("candidates:\n  window: 1\nfilters:\n  min_clique_size: 3\n");
  EXPECT_EQ(d.line, 3);
  EXPECT_NE(d.message.find("unknown section 'filters'"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("did you mean 'filter'"), std::string::npos) << d.message;
}

TEST(Experiment, AWrongTypeNamesTheKeyAndWhatWasExpected) {
  auto d = OneError("filter:\n  min_clique_size: five\n");
  EXPECT_EQ(d.line, 2);
  EXPECT_EQ(d.column, 20);
  EXPECT_NE(d.message.find("filter.min_clique_size: expected an integer >= 1, got 'five'"),
            std::string::npos)
      << d.message;
  d = OneError("filter:\n  min_clique_size: 2.5\n");
  EXPECT_NE(d.message.find("expected an integer"), std::string::npos) << d.message;
  d = OneError("candidates:\n  min_overlap: \"0.8\"\n");  // a string, not a number
  EXPECT_NE(d.message.find("candidates.min_overlap: expected a number in [0, 1]"),
            std::string::npos)
      << d.message;
  d = OneError("matching:\n  oracle: yes\n");
  EXPECT_NE(d.message.find("matching.oracle: expected true or false, got 'yes'"), std::string::npos)
      << d.message;
  d = OneError("inject:\n  seed: -1\n");
  EXPECT_NE(d.message.find("inject.seed: expected an integer >= 0"), std::string::npos)
      << d.message;
  d = OneError("inject:\n  kind: [random]\n");
  EXPECT_NE(d.message.find("inject.kind: expected one of: random, correlated, got a list"),
            std::string::npos)
      << d.message;
  d = OneError("filter: 5\n");
  EXPECT_EQ(d.line, 1);
  EXPECT_NE(d.message.find("filter: expected a mapping of keys"), std::string::npos) << d.message;
}

TEST(Experiment, AValueOutOfRangeNamesTheKeyAndTheRange) {
  auto d = OneError("matching:\n  oracle: false\ninject:\n  fraction: 1.0\n");
  EXPECT_EQ(d.line, 4);
  EXPECT_EQ(d.column, 13);
  EXPECT_NE(d.message.find("inject.fraction: expected a number in [0, 1), got '1.0'"),
            std::string::npos)
      << d.message;
  d = OneError("filter:\n  map_sigma_m: 0\n");
  EXPECT_NE(d.message.find("filter.map_sigma_m: expected a number > 0, got '0'"), std::string::npos)
      << d.message;
  d = OneError("candidates:\n  window: -1\n");
  EXPECT_NE(d.message.find("candidates.window: expected an integer >= 0, got '-1'"),
            std::string::npos)
      << d.message;
  d = OneError("optimizer:\n  global_anchor: first-loop\n");
  EXPECT_NE(d.message.find("optimizer.global_anchor: 'first-loop' is not allowed"),
            std::string::npos)
      << d.message;
  EXPECT_NE(d.message.find("did you mean 'first_loop'"), std::string::npos) << d.message;
}

TEST(Experiment, SigmasThatGoTogetherAreCheckedTogether) {
  auto d = OneError("optimizer:\n  loop_sigma_xy_m: 0.5\n");
  EXPECT_EQ(d.line, 2);
  EXPECT_NE(d.message.find("optimizer.loop_sigma_xy_m and optimizer.loop_sigma_yaw_deg go "
                           "together"),
            std::string::npos)
      << d.message;
  d = OneError("optimizer:\n  local_chain_sigma_yaw_deg: 0.2\n");
  EXPECT_EQ(d.line, 2);
  EXPECT_NE(d.message.find("local_chain_sigma_xy_m and optimizer.local_chain_sigma_yaw_deg"),
            std::string::npos)
      << d.message;
}

TEST(Experiment, EveryProblemIsReportedAtOnce) {
  try {
    LoadExperimentString("filter:\n  min_clique_size: 0\n  nope: 1\ninject:\n  kind: wrong\n",
                         "exp.yaml", {"candidates.windw=2"});
    FAIL() << "no error";
  } catch (const ExperimentError& e) {
    ASSERT_EQ(e.diagnostics().size(), 4u) << e.what();
    EXPECT_EQ(e.diagnostics()[0].line, 2);
    EXPECT_EQ(e.diagnostics()[1].line, 3);
    EXPECT_EQ(e.diagnostics()[2].line, 5);
    EXPECT_EQ(e.diagnostics()[3].file, "--exp-set candidates.windw=2");
    EXPECT_EQ(e.diagnostics()[3].line, 0);
    EXPECT_NE(e.diagnostics()[3].message.find("did you mean 'window'"), std::string::npos);
  }
}

TEST(Experiment, BadOverridesAndBadYamlAreErrors) {
  auto d = OneError("", {"inject.fraction"});
  EXPECT_EQ(d.file, "--exp-set");
  EXPECT_NE(d.message.find("expected section.key=value"), std::string::npos) << d.message;
  d = OneError("", {"inject.fraction=2"});
  EXPECT_EQ(d.file, "--exp-set inject.fraction=2");
  EXPECT_EQ(d.line, 0);
  EXPECT_NE(d.message.find("inject.fraction: expected a number in [0, 1), got '2'"),
            std::string::npos)
      << d.message;
  d = OneError("", {"optimiser.local_graph=full"});
  EXPECT_NE(d.message.find("did you mean 'optimizer'"), std::string::npos) << d.message;
  d = OneError("filter:\n  min_clique_size: [1, 2\n");
  EXPECT_EQ(d.file, "exp.yaml");
  EXPECT_GT(d.line, 0);
  EXPECT_NE(d.message.find("YAML syntax error"), std::string::npos) << d.message;
  d = OneError("filter:\n  min_clique_size: 3\nfilter:\n  map_sigma_m: 1\n");
  EXPECT_EQ(d.line, 3);
  EXPECT_NE(d.message.find("section 'filter' given twice"), std::string::npos) << d.message;
}

TEST(Experiment, AFileIsNamedInItsErrors) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("draco-experiment-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "bad.yaml").string();
  std::ofstream(path) << "# a comment\ncandidates:\n  window: many\n";
  try {
    LoadExperiment(path);
    ADD_FAILURE() << "no error";
  } catch (const ExperimentError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ":3:11: error: candidates.window: ", 0), 0u)
        << e.what();
  }
  std::ofstream(path) << ExperimentYaml(EveryKey());
  EXPECT_EQ(LoadExperiment(path), EveryKey());
  EXPECT_THROW(LoadExperiment((dir / "missing.yaml").string()), ExperimentError);
  EXPECT_THROW(LoadExperiment(dir.string()), ExperimentError);  // a folder is not a file
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace draco::team_eval
