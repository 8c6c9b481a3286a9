// run_info.json: valid JSON with the version, the command line (re-splittable by a shell) and
// the data files used; written atomically.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "app_version.hpp"
#include "run_info.hpp"
#include "scoped_env.hpp"

namespace draco::app {
namespace {
namespace fs = std::filesystem;

class RunInfoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("draco-run-info-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST(ShellQuote, PlainArgumentsStayAndOthersAreQuoted) {
  EXPECT_EQ(ShellQuote({"draco-robot", "--robot", "alpha", "--set", "link.loss=0.1"}),
            "draco-robot --robot alpha --set link.loss=0.1");
  EXPECT_EQ(ShellQuote({"a b", "", "it's", "$HOME"}), "'a b' '' 'it'\\''s' '$HOME'");
}

TEST_F(RunInfoTest, WritesVersionCommandLineAndFiles) {
  const char* argv[] = {"draco-robot", "--mission", "/data/my mission", "--robot",
                        "alpha",       "--set",     "x=\"q\"\\"};
  ScopedEnv env;
  env.Set("DRACO_DDS_PEERS", "10.0.0.2,10.0.0.3");
  env.Set("CYCLONEDDS_URI", nullptr);
  RunInfo info = MakeRunInfo("draco-robot", 7, argv);
  info.AddFile("graph", "/usr/share/draco-slam/graphs/../graphs/robot.yaml");
  info.AddFile("dds_config", "relative/loopback.xml");
  const fs::path path = WriteRunInfo(dir_, info, "alpha.");
  EXPECT_EQ(path, dir_ / "alpha.run_info.json");
  for (const auto& e : fs::directory_iterator(dir_)) {
    EXPECT_EQ(e.path().filename(), "alpha.run_info.json") << "a temporary file was left";
  }

  std::ifstream in(path);
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("app"), "draco-robot");
  EXPECT_EQ(j.at("version"), Version());
  EXPECT_EQ(j.at("project_version"), ProjectVersion());
  EXPECT_EQ(j.at("git_describe"), GitDescribe());
  EXPECT_EQ(j.at("argv").get<std::vector<std::string>>(), std::vector<std::string>(argv, argv + 7));
  EXPECT_EQ(j.at("command_line"),
            "draco-robot --mission '/data/my mission' --robot alpha --set 'x=\"q\"\\'");
  EXPECT_EQ(j.at("working_directory"), fs::current_path().string());
  EXPECT_EQ(j.at("files").at("graph"), "/usr/share/draco-slam/graphs/robot.yaml");
  EXPECT_EQ(j.at("files").at("dds_config"),
            (fs::current_path() / "relative/loopback.xml").string());
  EXPECT_EQ(j.at("environment").at("DRACO_DDS_PEERS"), "10.0.0.2,10.0.0.3");
  EXPECT_FALSE(j.at("environment").contains("CYCLONEDDS_URI"));
  EXPECT_EQ(j.at("started_utc").get<std::string>().size(), 20u);  // 2024-05-01T12:00:00Z
}

TEST_F(RunInfoTest, UnwritableFolderThrowsNamingTheFile) {
  const RunInfo info = MakeRunInfo("draco", 0, nullptr);
  try {
    WriteRunInfo(dir_ / "missing", info);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing/run_info.json"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace draco::app
