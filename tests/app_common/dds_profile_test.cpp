// The Cyclone DDS configuration of a daemon: --dds-config wins, then $CYCLONEDDS_URI (left to
// Cyclone: the daemon passes no file), then the loopback profile from the data search path.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "dds_profile.hpp"
#include "scoped_env.hpp"

namespace draco::app {
namespace {
namespace fs = std::filesystem;

class DdsProfileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("draco-dds-profile-" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_ / "data/dds");
    for (const char* p : {"loopback", "lan"}) {
      std::ofstream(root_ / "data/dds" / (std::string(p) + ".xml")) << "<CycloneDDS/>\n";
    }
    std::ofstream(root_ / "mine.xml") << "<CycloneDDS/>\n";
    search_.data_dir = (root_ / "data").string();
  }
  void TearDown() override { fs::remove_all(root_); }

  fs::path root_;
  DataSearch search_;  // only $DRACO_DATA_DIR
};

TEST_F(DdsProfileTest, CyclonedsUriIsNotOverridden) {
  const auto c = ChooseDdsConfig("", "file:///etc/team.xml", search_);
  EXPECT_EQ(c.file, "");  // nothing passed: Cyclone reads $CYCLONEDDS_URI itself
  EXPECT_EQ(c.source, "$CYCLONEDDS_URI");
  EXPECT_EQ(c.Describe(),
            "DDS config: $CYCLONEDDS_URI=file:///etc/team.xml (from the environment)");
}

TEST_F(DdsProfileTest, CommandLineWinsOverTheEnvironment) {
  const std::string mine = (root_ / "mine.xml").string();
  const auto c = ChooseDdsConfig(mine, "file:///etc/team.xml", search_);
  EXPECT_EQ(c.file, mine);
  EXPECT_EQ(c.source, "--dds-config");
  EXPECT_EQ(c.Describe(), "DDS config: " + mine + " (--dds-config)");
  // A profile name is a shipped profile from the search path.
  EXPECT_EQ(ChooseDdsConfig("lan", "file:///etc/team.xml", search_).file,
            root_ / "data/dds/lan.xml");
}

TEST_F(DdsProfileTest, DefaultIsTheLoopbackProfile) {
  const auto c = ChooseDdsConfig("", "", search_);
  EXPECT_EQ(c.file, root_ / "data/dds/loopback.xml");
  EXPECT_EQ(c.source, "default");
  EXPECT_NE(c.Describe().find("loopback only"), std::string::npos) << c.Describe();
}

TEST_F(DdsProfileTest, MissingFileOrProfileIsAnError) {
  EXPECT_THROW(ChooseDdsConfig((root_ / "nope.xml").string(), "", search_), DataFileError);
  try {
    ChooseDdsConfig("unicast", "", search_);
    FAIL() << "no error";
  } catch (const DataFileError& e) {
    EXPECT_NE(std::string(e.what()).find((root_ / "data/dds/unicast.xml").string()),
              std::string::npos)
        << e.what();
  }
}

TEST_F(DdsProfileTest, ReadsCyclonedsUriFromTheEnvironment) {
  ScopedEnv env;
  env.Set("DRACO_DATA_DIR", search_.data_dir.c_str());
  env.Set("CYCLONEDDS_URI", "file:///etc/team.xml");
  EXPECT_EQ(ChooseDdsConfigFromEnvironment("").file, "");
  env.Set("CYCLONEDDS_URI", nullptr);
  EXPECT_EQ(ChooseDdsConfigFromEnvironment("").file, root_ / "data/dds/loopback.xml");
  env.Set("CYCLONEDDS_URI", "");  // set but empty: as unset
  EXPECT_EQ(ChooseDdsConfigFromEnvironment("").source, "default");
}

TEST(ShippedDdsProfiles, AllFoundByName) {
  DataSearch search;
  search.data_dir = DRACO_SOURCE_DIR "/config";
  for (const char* p : {"loopback", "lan", "unicast"}) {
    EXPECT_EQ(ChooseDdsConfig(p, "", search).file,
              std::string(DRACO_SOURCE_DIR "/config/dds/") + p + ".xml");
  }
}

}  // namespace
}  // namespace draco::app
