// The order of the link's message kinds in the team run's tables and traffic series
// (internal: not installed; defined in link_traffic.cpp).
#pragma once

#include <string>

namespace draco::report::internal {

// Message kinds in the order of docs/fleet.md; unknown kinds after them, by name.
int KindRank(const std::string& kind);

}  // namespace draco::report::internal
