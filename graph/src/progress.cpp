#include "draco/graph/progress.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "draco/log/log.hpp"

namespace draco::graph {

ProgressPrinter::ProgressPrinter(std::string label, ProgressOptions options)
    : label_(std::move(label)), options_(std::move(options)) {
  if (!options_.emit) options_.emit = [](const std::string& line) { log::Info(line); };
  if (!options_.wall_clock) {
    options_.wall_clock = [] {
      return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
          .count();
    };
  }
  start_wall_s_ = Wall();
  next_line_wall_s_ = start_wall_s_ + options_.period_s;
  end_s_ = options_.total_s;
}

double ProgressPrinter::Wall() const { return options_.wall_clock(); }

std::string ProgressPrinter::Line(double mission_s, double total_s, double wall_s) const {
  const double rate = wall_s > 0 ? mission_s / wall_s : 0.0;
  char buf[200];
  if (total_s > 0) {
    const double fraction = std::clamp(mission_s / total_s, 0.0, 1.0);
    const double eta_s = rate > 0 ? std::max(0.0, total_s - mission_s) / rate : 0.0;
    const long eta = std::lround(eta_s);
    std::snprintf(buf, sizeof(buf),
                  "%s: mission %.1f / %.1f s (%.0f %%), %.1fx real time, ETA %ldm%02lds",
                  label_.c_str(), mission_s, total_s, 100.0 * fraction, rate, eta / 60, eta % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%s: mission %.1f s, %.1fx real time", label_.c_str(),
                  mission_s, rate);
  }
  return buf;
}

void ProgressPrinter::Update(Time mission_time, Time end) {
  if (options_.total_s <= 0) end_s_ = end == Time::Max() ? 0.0 : end.Seconds();
  const double now = Wall();
  if (now < next_line_wall_s_) return;
  next_line_wall_s_ = now + options_.period_s;
  options_.emit(Line(mission_time.Seconds(), end_s_, now - start_wall_s_));
}

void ProgressPrinter::Finish(Time mission_time) {
  const double wall_s = Wall() - start_wall_s_;
  const double mission_s = mission_time.Seconds();
  char buf[200];
  std::snprintf(buf, sizeof(buf), "%s: done: %.1f s of mission in %.1f s, %.1fx real time",
                label_.c_str(), mission_s, wall_s, wall_s > 0 ? mission_s / wall_s : 0.0);
  options_.emit(buf);
}

}  // namespace draco::graph
