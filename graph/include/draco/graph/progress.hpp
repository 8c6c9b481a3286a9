// Progress of a long replay for people and for the journal: an info line (draco/log) at most
// every period_s of wall time, with the mission time reached, the share of the mission, the
// replay rate and the time left, e.g.
//   draco-robot: alpha: mission 412.3 / 981.8 s (42 %), 85.0x real time, ETA 0m07s
// and, when the mission's length is unknown, the mission time and the rate only:
//   draco: default: mission 412.3 s, 85.0x real time
// Finish() prints the summary line ("... done: 981.8 s of mission in 11.5 s, 85.4x real time").
//
// The mission's length comes from the caller (total_s, e.g. the recording's AHRS stream) or,
// when that is not given, from the executor (RunProgress::end: RunOptions::until, else the end
// the sources know from their recordings, Component::SourceEndTime()).
#pragma once

#include <functional>
#include <string>

#include "draco/graph/executor.hpp"
#include "draco/graph/time.hpp"

namespace draco::graph {

struct ProgressOptions {
  double total_s = 0.0;   // the mission's end; <= 0: take the executor's, else unknown
  double period_s = 5.0;  // wall seconds between lines
  // Where lines go (default: draco::log::Info) and the wall clock in seconds (default:
  // steady_clock); tests replace both.
  std::function<void(const std::string&)> emit;
  std::function<double()> wall_clock;
};

class ProgressPrinter {
 public:
  ProgressPrinter(std::string label, ProgressOptions options);
  ProgressPrinter(std::string label, double total_s)
      : ProgressPrinter(std::move(label), ProgressOptions{.total_s = total_s}) {}

  // Mission time reached; end: the executor's expected end (Time::Max() when unknown).
  void Update(Time mission_time, Time end = Time::Max());
  void Update(const RunProgress& p) { Update(p.mission_time, p.end); }
  // A callback for RunOptions::progress.
  std::function<void(const RunProgress&)> Callback() {
    return [this](const RunProgress& p) { Update(p); };
  }
  void Finish(Time mission_time);

  // The line for mission_s (seconds) of total_s (<= 0: unknown) after wall_s of wall time.
  std::string Line(double mission_s, double total_s, double wall_s) const;

 private:
  double Wall() const;
  std::string label_;
  ProgressOptions options_;
  double start_wall_s_ = 0.0;
  double next_line_wall_s_ = 0.0;
  double end_s_ = 0.0;  // the total in use (options or the executor's)
};

}  // namespace draco::graph
