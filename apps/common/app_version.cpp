#include "app_version.hpp"

namespace draco::app {

// Defined in the generated version_info.cpp (cmake/GenerateVersion.cmake).
extern const char* const kProjectVersion;
extern const char* const kGitDescribe;

std::string ProjectVersion() { return kProjectVersion; }

std::string GitDescribe() { return kGitDescribe; }

std::string Version() {
  const std::string describe = GitDescribe();
  return describe.empty() ? ProjectVersion() : ProjectVersion() + " (" + describe + ")";
}

std::string VersionLine(const std::string& app_name) { return app_name + " " + Version(); }

}  // namespace draco::app
