// draco::log: levelled logging to stderr for the apps, the runtime and the components.
//
//   draco::log::Info("draco-robot: alpha: DDS config: " + file);
//   draco::log::Debug("tick " + std::to_string(n));     // hidden at the default level (info)
//   if (draco::log::Enabled(draco::log::Level::kDebug)) { ...expensive text... }
//
// Levels: trace < debug < info < warn < error (and off). Apps set the level with
// --log-level (apps/common/log_option.hpp). Lines go to stderr, which systemd hands to the
// journal; under systemd ($JOURNAL_STREAM set) each line carries its syslog priority so
// `journalctl -p warning` works.
//
// Repeats are rate-limited per place: a source line (plus an optional key, e.g. a component
// id, for a line shared by many producers) that logs more than max_per_window messages in
// window_s prints the first ones, counts the rest, and prints one summary when its window
// is over ("... 4213 more like this from link.cpp:210 (alpha) in 1.0 s; last: ..."). A
// teammate sending garbage cannot flood the journal.
//
// The Logger class is the whole mechanism (tests make their own, with a sink and a clock);
// Global() is the process's logger, writing through spdlog.
#pragma once

#include <functional>
#include <memory>
#include <source_location>
#include <string>
#include <string_view>

namespace draco::log {

enum class Level : int { kTrace = 0, kDebug, kInfo, kWarn, kError, kOff };

// "trace", "debug", "info", "warn", "error", "off".
std::string_view LevelName(Level level);

// The inverse of LevelName (also accepts "warning"). Throws std::invalid_argument naming the
// text and the accepted values.
Level ParseLevel(std::string_view text);

struct Options {
  Level level = Level::kInfo;
  int max_per_window = 5;  // messages printed per place and window; the rest are counted
  double window_s = 1.0;   // the rate limit's window, wall seconds
};

// Receives every line to print (a message or a summary) with its level.
using Sink = std::function<void(Level level, std::string_view message)>;
// Monotonic seconds (the rate limit's clock).
using Clock = std::function<double()>;

class Logger {
 public:
  // sink: nullptr writes to stderr through spdlog; clock: nullptr is std::chrono::steady_clock.
  explicit Logger(Options options = {}, Sink sink = nullptr, Clock clock = nullptr);
  ~Logger();  // prints the summaries still pending (Flush)
  Logger(const Logger&) = delete;
  Logger& operator=(const Logger&) = delete;

  void SetLevel(Level level);
  Level level() const;
  bool Enabled(Level level) const;

  // Logs message at level when the level is enabled and the place is under its rate limit.
  // Thread-safe.
  void Write(Level level, std::string_view message,
             const std::source_location& where = std::source_location::current(),
             std::string_view key = {});

  // Prints the summary of every place with suppressed messages now, windows over or not.
  void Flush();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// The process's logger (stderr, level info until SetLevel).
Logger& Global();

inline bool Enabled(Level level) { return Global().Enabled(level); }
inline void SetLevel(Level level) { Global().SetLevel(level); }

inline void Trace(std::string_view m, std::source_location w = std::source_location::current()) {
  Global().Write(Level::kTrace, m, w);
}
inline void Debug(std::string_view m, std::source_location w = std::source_location::current()) {
  Global().Write(Level::kDebug, m, w);
}
inline void Info(std::string_view m, std::source_location w = std::source_location::current()) {
  Global().Write(Level::kInfo, m, w);
}
inline void Warn(std::string_view m, std::source_location w = std::source_location::current()) {
  Global().Write(Level::kWarn, m, w);
}
inline void Error(std::string_view m, std::source_location w = std::source_location::current()) {
  Global().Write(Level::kError, m, w);
}

}  // namespace draco::log
