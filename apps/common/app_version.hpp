// The version of the build every app prints with --version and records in run_info.json.
#pragma once

#include <string>

namespace draco::app {

// The CMake project version, e.g. "0.1.0".
std::string ProjectVersion();

// `git describe --always --dirty --tags` of the source tree at build time, e.g.
// "v0.1.0-3-g1a2b3c4-dirty" or "1a2b3c4"; "" when built outside a git checkout.
std::string GitDescribe();

// "0.1.0 (1a2b3c4)", or "0.1.0" when built outside a git checkout.
std::string Version();

// What --version prints: "draco-robot 0.1.0 (1a2b3c4)". Apps pass it to CLI11:
//   app.set_version_flag("--version", draco::app::VersionLine("draco-robot"));
std::string VersionLine(const std::string& app_name);

}  // namespace draco::app
