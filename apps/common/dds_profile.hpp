// Which Cyclone DDS configuration a daemon (draco-robot, draco-fleet) uses:
//   1. --dds-config FILE (a path, used as given; or a profile name such as "lan", which is
//      dds/lan.xml from the data search path),
//   2. else a non-empty $CYCLONEDDS_URI, left to Cyclone DDS (the daemon passes nothing),
//   3. else dds/loopback.xml from the data search path (one machine, loopback only).
// Shipped profiles (config/dds/): loopback.xml, lan.xml (multicast discovery on one LAN),
// unicast.xml (no multicast; peers from $DRACO_DDS_PEERS). docs/install.md.
#pragma once

#include <string>

#include "data_path.hpp"

namespace draco::app {

struct DdsConfigChoice {
  std::string file;            // the XML file to hand to Cyclone; "" when $CYCLONEDDS_URI decides
  std::string source;          // "--dds-config", "$CYCLONEDDS_URI" or "default"
  std::string cyclonedds_uri;  // the variable's value when it decides

  // One line for the start-up log: "DDS config: /usr/share/.../loopback.xml (default ...)".
  std::string Describe() const;
};

// command_line: the --dds-config value ("" when not given); cyclonedds_uri: the value of
// $CYCLONEDDS_URI ("" when unset). Throws DataFileError when the file or profile is missing.
DdsConfigChoice ChooseDdsConfig(const std::string& command_line, const std::string& cyclonedds_uri,
                                const DataSearch& search = DataSearch::FromEnvironment());

// ChooseDdsConfig with this process's $CYCLONEDDS_URI.
DdsConfigChoice ChooseDdsConfigFromEnvironment(const std::string& command_line);

}  // namespace draco::app
