#include "draco/graph/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace draco::graph {

ProgressPrinter::ProgressPrinter(std::string label, double total_s)
    : label_(std::move(label)),
      total_s_(total_s),
      tty_(::isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()) {}

std::string ProgressPrinter::Line(double mission_s) const {
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double rate = wall_s > 0 ? mission_s / wall_s : 0.0;
  char buf[160];
  if (total_s_ > 0) {
    const double fraction = std::clamp(mission_s / total_s_, 0.0, 1.0);
    const double eta_s = rate > 0 ? (total_s_ - mission_s) / rate : 0.0;
    const int eta = static_cast<int>(std::max(0.0, eta_s));
    std::snprintf(buf, sizeof(buf), "%s %7.1f/%.1f s %4.0f %% %6.1f x real time  ETA %dm%02ds",
                  label_.c_str(), mission_s, total_s_, 100.0 * fraction, rate, eta / 60, eta % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%s %7.1f s %6.1f x real time", label_.c_str(), mission_s,
                  rate);
  }
  return buf;
}

void ProgressPrinter::Update(Time mission_time) {
  const double s = mission_time.Seconds();
  if (tty_) {
    std::fprintf(stderr, "\r%s\033[K", Line(s).c_str());
    return;
  }
  const double step = total_s_ > 0 ? total_s_ / 10.0 : 60.0;
  if (s < next_report_s_) return;
  next_report_s_ = (static_cast<int>(s / step) + 1) * step;
  std::fprintf(stderr, "%s\n", Line(s).c_str());
}

void ProgressPrinter::Finish(Time mission_time) {
  std::fprintf(stderr, tty_ ? "\r%s\033[K\n" : "%s\n", Line(mission_time.Seconds()).c_str());
}

}  // namespace draco::graph
