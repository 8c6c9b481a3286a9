// The data search path: command line, $DRACO_DATA_DIR, user overrides, the installed tree next
// to the executable, the source tree only without an installed tree; errors list every place.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "data_path.hpp"
#include "scoped_env.hpp"

namespace draco::app {
namespace {
namespace fs = std::filesystem;

// A fake layout under a temporary folder: data/, home/.config/draco-slam/, prefix/bin (the
// executable's folder), prefix/share/draco-slam (installed), source/config.
class DataPathTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("draco-data-path-" + std::to_string(::getpid()));
    fs::remove_all(root_);
    for (const char* d : {"data", "home/.config/draco-slam", "prefix/bin",
                          "prefix/share/draco-slam", "source/config"}) {
      fs::create_directories(root_ / d);
    }
    search_.data_dir = (root_ / "data").string();
    search_.config_home = (root_ / "home/.config").string();
    search_.exe_dir = root_ / "prefix/bin";
    search_.installed_from_exe = "../share/draco-slam";
    search_.source_config_dir = root_ / "source/config";
  }
  void TearDown() override { fs::remove_all(root_); }

  // Writes <dir>/graphs/robot.yaml and returns its path.
  fs::path Put(const std::string& dir) {
    const fs::path p = root_ / dir / "graphs/robot.yaml";
    fs::create_directories(p.parent_path());
    std::ofstream(p) << "schema: 1\n";
    return p;
  }
  fs::path Resolve() { return ResolveDataFile("graphs/robot.yaml", "", search_).path; }

  fs::path root_;
  DataSearch search_;
};

TEST_F(DataPathTest, SearchOrder) {
  const fs::path source = Put("source/config");
  // The installed folder exists: the source tree is not searched.
  EXPECT_THROW(Resolve(), DataFileError);
  fs::remove_all(root_ / "prefix/share");
  EXPECT_EQ(Resolve(), source);
  const fs::path installed = Put("prefix/share/draco-slam");
  EXPECT_EQ(Resolve(),
            (root_ / "prefix/bin/../share/draco-slam/graphs/robot.yaml").lexically_normal());
  EXPECT_TRUE(fs::equivalent(Resolve(), installed));
  const fs::path user = Put("home/.config/draco-slam");
  EXPECT_EQ(Resolve(), user);
  const fs::path data = Put("data");
  EXPECT_EQ(ResolveDataFile("graphs/robot.yaml", "", search_).from, "$DRACO_DATA_DIR");
  EXPECT_EQ(Resolve(), data);
  // A path on the command line wins and is used as given.
  const fs::path other = root_ / "other.yaml";
  std::ofstream(other) << "schema: 1\n";
  const auto explicit_file = ResolveDataFile("graphs/robot.yaml", other.string(), search_);
  EXPECT_EQ(explicit_file.path, other);
  EXPECT_EQ(explicit_file.from, "command line");
}

TEST_F(DataPathTest, UnsetVariablesAreLeftOut) {
  search_.data_dir.clear();
  search_.config_home.clear();
  const auto places = DataPlaces(search_);
  ASSERT_EQ(places.size(), 1u);  // the installed folder exists: no source tree
  EXPECT_EQ(places[0].dir, (root_ / "prefix/share/draco-slam").lexically_normal());
}

TEST_F(DataPathTest, MissingFileListsEveryPlaceSearched) {
  fs::remove_all(root_ / "prefix/share");
  try {
    Resolve();
    FAIL() << "no error";
  } catch (const DataFileError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'graphs/robot.yaml' not found"), std::string::npos) << m;
    for (const char* d :
         {"data", "home/.config/draco-slam", "prefix/share/draco-slam", "source/config"}) {
      EXPECT_NE(m.find((root_ / d / "graphs/robot.yaml").string()), std::string::npos)
          << d << " not listed in: " << m;
    }
    EXPECT_NE(m.find("$DRACO_DATA_DIR"), std::string::npos) << m;
  }
}

TEST_F(DataPathTest, MissingCommandLineFileIsNotSearchedFor) {
  Put("data");
  try {
    ResolveDataFile("graphs/robot.yaml", (root_ / "nope.yaml").string(), search_);
    FAIL() << "no error";
  } catch (const DataFileError& e) {
    EXPECT_NE(std::string(e.what()).find("nope.yaml: no such file (given on the command line)"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(DataPathTest, FromEnvironmentReadsTheVariables) {
  ScopedEnv env;
  env.Set("DRACO_DATA_DIR", "/tmp/d");
  env.Set("XDG_CONFIG_HOME", "/tmp/x");
  DataSearch s = DataSearch::FromEnvironment();
  EXPECT_EQ(s.data_dir, "/tmp/d");
  EXPECT_EQ(s.config_home, "/tmp/x");
  EXPECT_EQ(s.exe_dir, fs::read_symlink("/proc/self/exe").parent_path());
  env.Set("XDG_CONFIG_HOME", nullptr);
  env.Set("HOME", "/tmp/h");
  s = DataSearch::FromEnvironment();
  EXPECT_EQ(s.config_home, "/tmp/h/.config");
  env.Set("DRACO_DATA_DIR", nullptr);
  EXPECT_TRUE(DataSearch::FromEnvironment().data_dir.empty());
}

}  // namespace
}  // namespace draco::app
