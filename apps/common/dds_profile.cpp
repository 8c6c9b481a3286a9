#include "dds_profile.hpp"

#include <cstdlib>
#include <filesystem>
#include <system_error>

namespace draco::app {
namespace fs = std::filesystem;

std::string DdsConfigChoice::Describe() const {
  if (source == "$CYCLONEDDS_URI") {
    return "DDS config: $CYCLONEDDS_URI=" + cyclonedds_uri + " (from the environment)";
  }
  if (source == "--dds-config") return "DDS config: " + file + " (--dds-config)";
  return "DDS config: " + file +
         " (default: loopback only; --dds-config or $CYCLONEDDS_URI choose another)";
}

DdsConfigChoice ChooseDdsConfig(const std::string& command_line, const std::string& cyclonedds_uri,
                                const DataSearch& search) {
  if (!command_line.empty()) {
    std::error_code ec;
    const bool profile_name = command_line.find('/') == std::string::npos &&
                              fs::path(command_line).extension().empty() &&
                              !fs::exists(command_line, ec);
    if (profile_name) {
      return {ResolveDataFile("dds/" + command_line + ".xml", "", search).path.string(),
              "--dds-config"};
    }
    return {ResolveDataFile("", command_line, search).path.string(), "--dds-config"};
  }
  if (!cyclonedds_uri.empty()) return {"", "$CYCLONEDDS_URI", cyclonedds_uri};
  return {ResolveDataFile("dds/loopback.xml", "", search).path.string(), "default"};
}

DdsConfigChoice ChooseDdsConfigFromEnvironment(const std::string& command_line) {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  return ChooseDdsConfig(command_line, uri ? uri : "");
}

}  // namespace draco::app
