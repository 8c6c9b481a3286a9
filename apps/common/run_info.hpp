// run_info.json: what made a run folder. Every app that writes a run folder (or a mission
// folder) writes one: the app, its version, the exact command line, where and when it ran,
// and the data files it used (graph, DDS profile) as resolved paths.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace draco::app {

struct RunInfo {
  std::string app;                // "draco-robot"
  std::vector<std::string> argv;  // the command line as given, argv[0] first
  std::string working_directory;
  std::string started_utc;  // "2024-05-01T12:00:00Z"
  std::string host;
  // The variables that choose data and DDS settings, those set: DRACO_DATA_DIR,
  // XDG_CONFIG_HOME, CYCLONEDDS_URI, DRACO_DDS_PEERS.
  std::vector<std::pair<std::string, std::string>> environment;
  // Data files the run used, in the order added: role ("graph", "dds_config"), path.
  std::vector<std::pair<std::string, std::string>> files;

  // Records a data file; a relative path is made absolute (against the working directory).
  void AddFile(const std::string& role, const std::filesystem::path& path);
};

// The RunInfo of this process: app name, argv, working directory, start time, host,
// environment.
RunInfo MakeRunInfo(const std::string& app, int argc, const char* const* argv);

// The command line as one string a POSIX shell would split back into argv (arguments with
// spaces or shell characters in single quotes).
std::string ShellQuote(const std::vector<std::string>& argv);

// The JSON text of run_info.json: app, version, project_version, git_describe, command_line
// (ShellQuote), argv, executable, working_directory, started_utc, host, environment
// {name: value}, files {role: path}.
std::string RunInfoJson(const RunInfo& info);

// Writes dir/<prefix>run_info.json atomically (temporary file + rename) and returns its path.
// Throws std::runtime_error naming the file when it cannot be written.
std::filesystem::path WriteRunInfo(const std::filesystem::path& dir, const RunInfo& info,
                                   const std::string& prefix = "");

}  // namespace draco::app
