// --log-level for every app: trace, debug, info (default), warn, error, off; $DRACO_LOG_LEVEL
// when the option is not given. Applied while the command line is parsed, so everything after
// CLI11_PARSE logs at the chosen level.
//   CLI::App app{"..."};
//   draco::app::AddLogLevelOption(app);
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "draco/log/log.hpp"

namespace draco::app {

inline CLI::Option* AddLogLevelOption(CLI::App& app) {
  return app
      .add_option_function<std::string>(
          "--log-level", [](const std::string& level) { log::SetLevel(log::ParseLevel(level)); },
          "what to log on stderr: trace, debug, info, warn, error or off (default info)")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}))
      ->envname("DRACO_LOG_LEVEL");
}

}  // namespace draco::app
