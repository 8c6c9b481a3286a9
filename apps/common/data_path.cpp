#include "data_path.hpp"

#include <cstdlib>
#include <system_error>

namespace draco::app {
namespace fs = std::filesystem;

namespace {

std::string Env(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::string(v) : std::string();
}

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

bool IsDirectory(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

}  // namespace

DataSearch DataSearch::FromEnvironment() {
  DataSearch s;
  s.data_dir = Env("DRACO_DATA_DIR");
  s.config_home = Env("XDG_CONFIG_HOME");
  if (s.config_home.empty() && !Env("HOME").empty()) s.config_home = Env("HOME") + "/.config";
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) s.exe_dir = exe.parent_path();
  s.installed_from_exe = DRACO_DATA_FROM_BIN;
  s.source_config_dir = DRACO_SOURCE_CONFIG_DIR;
  return s;
}

std::vector<DataPlace> DataPlaces(const DataSearch& s) {
  std::vector<DataPlace> places;
  if (!s.data_dir.empty()) places.push_back({s.data_dir, "$DRACO_DATA_DIR"});
  if (!s.config_home.empty()) {
    places.push_back({fs::path(s.config_home) / "draco-slam",
                      "user overrides: $XDG_CONFIG_HOME/draco-slam or ~/.config/draco-slam"});
  }
  bool installed = false;
  if (!s.exe_dir.empty()) {
    const fs::path share = (s.exe_dir / s.installed_from_exe).lexically_normal();
    installed = IsDirectory(share);
    places.push_back({share, "installed data next to the executable"});
  }
  if (!installed && !s.source_config_dir.empty()) {
    places.push_back({s.source_config_dir, "source tree (an executable of the build tree)"});
  }
  return places;
}

ResolvedFile ResolveDataFile(const std::string& name, const std::string& explicit_path,
                             const DataSearch& search) {
  if (!explicit_path.empty()) {
    if (!IsFile(explicit_path)) {
      throw DataFileError(explicit_path + ": no such file (given on the command line)");
    }
    return {explicit_path, "command line"};
  }
  const auto places = DataPlaces(search);
  for (const auto& place : places) {
    const fs::path candidate = place.dir / name;
    if (IsFile(candidate)) return {candidate, place.why};
  }
  std::string message = "data file '" + name + "' not found; searched:";
  for (const auto& place : places) {
    message += "\n  " + (place.dir / name).string() + "  (" + place.why + ")";
  }
  message += "\nset DRACO_DATA_DIR to a folder that holds " + name +
             ", or give the file's path on the command line";
  throw DataFileError(message);
}

}  // namespace draco::app
