// The data search path: where the apps find the files they ship (graphs, DDS profiles,
// missions, worlds) by a name relative to a data folder, e.g. "graphs/robot.yaml".
//
// In order, the first folder that holds the file wins:
//   1. $DRACO_DATA_DIR                                  (a whole data folder of your own)
//   2. $XDG_CONFIG_HOME/draco-slam, default ~/.config/draco-slam   (user overrides)
//   3. <folder of the executable>/../share/draco-slam   (the installed tree)
//   4. the source tree's config/                        (only when 3 does not exist: an
//                                                        executable run from the build tree)
// A path given on the command line is used as given and never searched for.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace draco::app {

// The inputs of the search, read from the process by FromEnvironment(); tests fill them in.
struct DataSearch {
  std::string data_dir;           // $DRACO_DATA_DIR; "" when unset or empty
  std::string config_home;        // $XDG_CONFIG_HOME, else $HOME/.config; "" when neither
  std::filesystem::path exe_dir;  // the executable's folder (/proc/self/exe)
  // The installed data folder relative to exe_dir ("../share/draco-slam" by default).
  std::filesystem::path installed_from_exe;
  std::filesystem::path source_config_dir;  // the source tree's config/ at build time

  static DataSearch FromEnvironment();
};

// One folder searched, and why it is on the list ("$DRACO_DATA_DIR", ...).
struct DataPlace {
  std::filesystem::path dir;
  std::string why;
};

// The folders searched, in order (those whose variable is unset are left out; the source
// tree only when the installed folder does not exist).
std::vector<DataPlace> DataPlaces(const DataSearch& search);

struct ResolvedFile {
  std::filesystem::path path;
  std::string from;  // "command line" or the DataPlace's why
};

class DataFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The data file `name` ("graphs/robot.yaml"): explicit_path when it is not empty (used as
// given; it must exist), else the first of DataPlaces() that holds it. Throws DataFileError
// naming the file and every place searched.
ResolvedFile ResolveDataFile(const std::string& name, const std::string& explicit_path = "",
                             const DataSearch& search = DataSearch::FromEnvironment());

}  // namespace draco::app
