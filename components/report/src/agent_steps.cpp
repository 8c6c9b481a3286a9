// An agent's work per step in a team run (team_run.hpp ReadAgentSteps): the mean and maximum
// of each column of agent_steps.csv.
#include <algorithm>
#include <string>

#include "csv.hpp"
#include "draco/report/team_run.hpp"

namespace draco::report {
namespace {

using internal::Csv;
using internal::ReadCsv;

WorkStat Stat(const Csv& csv, const std::string& column) {
  WorkStat s;
  if (csv.rows.empty()) return s;
  const std::size_t c = csv.Col(column);
  double sum = 0.0;
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    const double v = csv.Number(i, c);
    sum += v;
    s.max = std::max(s.max, v);
  }
  s.mean = sum / static_cast<double>(csv.rows.size());
  return s;
}

}  // namespace

StepWork ReadAgentSteps(const std::string& csv_path) {
  const Csv csv = ReadCsv(csv_path);
  StepWork w;
  w.steps = static_cast<int>(csv.rows.size());
  if (csv.rows.empty()) return w;
  w.matches_tried = Stat(csv, "matches_tried");
  w.matches_found = Stat(csv, "matches_found");
  w.requests_sent = Stat(csv, "requests_sent");
  w.scans_registered = Stat(csv, "scans_registered");
  w.candidates_added = Stat(csv, "candidates_added");
  w.loops_accepted = Stat(csv, "loops_accepted");
  w.wall_ms = Stat(csv, "wall_ms");
  const std::size_t opt = csv.Col("optimized");
  for (std::size_t i = 0; i < csv.rows.size(); ++i) w.optimized += csv.Number(i, opt) != 0.0;
  return w;
}

}  // namespace draco::report
