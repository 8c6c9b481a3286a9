// Child processes of the apps that run other apps (draco-fleet starts draco-robot daemons,
// draco-worlds starts draco-sim and draco-fleet).
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace draco::fleet_app {

// The folder of the running executable (its siblings are the other apps of the build).
std::filesystem::path SelfDir();

// Another app's executable: next to this one (an installed bin/), else in its folder of the
// build tree (<build>/apps/<build_folder>/<name>). The first when neither exists.
std::filesystem::path SiblingApp(const std::string& name, const std::string& build_folder);

// Starts args[0] with args, its stdout and stderr appended to log_path; returns its pid.
// Throws std::runtime_error when fork fails; a child that cannot exec exits with 127.
pid_t Spawn(const std::vector<std::string>& args, const std::string& log_path);

// Spawn, then waits: the exit code, or -1 when the child did not exit normally.
int RunAndWait(const std::vector<std::string>& args, const std::string& log_path);

}  // namespace draco::fleet_app
