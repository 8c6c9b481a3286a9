// Progress of a replay for people: on a terminal one line rewritten in place ("alpha
// 412.3/981.8 s  42 %  85 x real time  ETA 0m07s"); otherwise (CI logs) a plain line at
// every 10 % (or every 60 s of mission time when the total is unknown).
#pragma once

#include <chrono>
#include <string>

#include "draco/graph/time.hpp"

namespace draco::graph {

class ProgressPrinter {
 public:
  // total_s <= 0: unknown length. Writes to stderr.
  ProgressPrinter(std::string label, double total_s);
  void Update(Time mission_time);
  void Finish(Time mission_time);

 private:
  std::string Line(double mission_s) const;
  std::string label_;
  double total_s_;
  bool tty_;
  double next_report_s_ = 0.0;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace draco::graph
