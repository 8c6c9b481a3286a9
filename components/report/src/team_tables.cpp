// A team run's results as tables for draco-fleet (team_run.hpp): plain text and Markdown
// (unchanged layout).
#include <cstdio>
#include <sstream>
#include <string>

#include "draco/report/team_run.hpp"

namespace draco::report {

std::string FormatTeamResult(const TeamResult& t, const std::string& title) {
  std::ostringstream o;
  char line[256];
  o << title << "\n";
  std::snprintf(line, sizeof line, "%-9s %5s %8s %8s %8s %6s %6s %6s %9s %8s\n", "robot", "kfs",
                "DR m", "local m", "team m", "placed", "cand", "accept", "sent kbit", "mean bps");
  o << line;
  for (const auto& r : t.robots) {
    std::snprintf(line, sizeof line, "%-9s %5d %8.3f %8.3f %8.3f %6d %6d %6d %9.1f %8.0f\n",
                  r.name.c_str(), r.keyframes, r.dr_ate_m, r.local_ate_m, r.team_ate_m, r.placed,
                  r.candidates, r.accepted, r.bits_sent / 1000.0, r.mean_bps);
    o << line;
  }
  std::snprintf(line, sizeof line, "\n%-15s %7s %10s %9s %8s %8s\n", "message", "frames",
                "mean bits", "max bits", "dropped", "rejected");
  o << line;
  for (const auto& k : t.kinds) {
    std::snprintf(line, sizeof line, "%-15s %7.0f %10.0f %9.0f %8.0f %8.0f\n", k.kind.c_str(),
                  k.frames, k.frames > 0 ? k.bits / k.frames : 0.0, k.max_bits, k.dropped,
                  k.rejected);
    o << line;
  }
  return o.str();
}

std::string TeamResultMarkdown(const TeamResult& t) {
  std::ostringstream o;
  char line[256];
  o << "| robot | keyframes | DR ATE m | local ATE m | team ATE m | robots placed | candidates "
       "| accepted | sent kbit | mean bps |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : t.robots) {
    std::snprintf(line, sizeof line,
                  "| %s | %d | %.3f | %.3f | %.3f | %d | %d | %d | %.1f | %.0f |\n", r.name.c_str(),
                  r.keyframes, r.dr_ate_m, r.local_ate_m, r.team_ate_m, r.placed, r.candidates,
                  r.accepted, r.bits_sent / 1000.0, r.mean_bps);
    o << line;
  }
  o << "\n| message | frames | mean bits | max bits | dropped | rejected "
       "|\n|---|---|---|---|---|---|\n";
  for (const auto& k : t.kinds) {
    std::snprintf(line, sizeof line, "| %s | %.0f | %.0f | %.0f | %.0f | %.0f |\n", k.kind.c_str(),
                  k.frames, k.frames > 0 ? k.bits / k.frames : 0.0, k.max_bits, k.dropped,
                  k.rejected);
    o << line;
  }
  return o.str();
}

}  // namespace draco::report
