// The build-time version: the CMake project version, git describe beside it when built from a
// git checkout, and what --version prints.
#include <gtest/gtest.h>

#include "app_version.hpp"

namespace draco::app {
namespace {

TEST(Version, ProjectVersionIsTheCMakeOne) { EXPECT_EQ(ProjectVersion(), DRACO_PROJECT_VERSION); }

TEST(Version, GitDescribeInParenthesesWhenKnown) {
  const std::string describe = GitDescribe();
  if (describe.empty()) {
    EXPECT_EQ(Version(), ProjectVersion());
  } else {
    EXPECT_EQ(Version(), ProjectVersion() + " (" + describe + ")");
    EXPECT_EQ(describe.find('\n'), std::string::npos);
  }
}

TEST(Version, LineStartsWithTheAppName) {
  EXPECT_EQ(VersionLine("draco-robot"), "draco-robot " + Version());
}

}  // namespace
}  // namespace draco::app
