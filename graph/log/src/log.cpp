#include "draco/log/log.hpp"

#include <spdlog/logger.h>
#include <spdlog/sinks/stdout_color_sinks.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace draco::log {
namespace {

constexpr double kNever = std::numeric_limits<double>::infinity();

spdlog::level::level_enum ToSpdlog(Level level) {
  switch (level) {
    case Level::kTrace:
      return spdlog::level::trace;
    case Level::kDebug:
      return spdlog::level::debug;
    case Level::kInfo:
      return spdlog::level::info;
    case Level::kWarn:
      return spdlog::level::warn;
    case Level::kError:
      return spdlog::level::err;
    case Level::kOff:
      break;
  }
  return spdlog::level::off;
}

// The syslog priority systemd's journal reads from a "<N>" line prefix (sd-daemon.h).
const char* JournalPrefix(Level level) {
  switch (level) {
    case Level::kTrace:
    case Level::kDebug:
      return "<7>";
    case Level::kInfo:
      return "<6>";
    case Level::kWarn:
      return "<4>";
    default:
      return "<3>";
  }
}

// stderr through spdlog: time and level on a terminal or in a file, the bare message with
// its syslog priority when stderr is the journal (which stamps lines itself).
Sink StderrSink() {
  auto logger = std::make_shared<spdlog::logger>(
      "draco", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  const bool journal = std::getenv("JOURNAL_STREAM") != nullptr;
  logger->set_pattern(journal ? "%v" : "[%Y-%m-%d %H:%M:%S.%e] [%^%l%$] %v");
  logger->set_level(spdlog::level::trace);  // the Logger filters
  logger->flush_on(spdlog::level::trace);
  return [logger, journal](Level level, std::string_view message) {
    if (journal) {
      const std::string line = JournalPrefix(level) + std::string(message);
      logger->log(ToSpdlog(level), spdlog::string_view_t(line.data(), line.size()));
    } else {
      logger->log(ToSpdlog(level), spdlog::string_view_t(message.data(), message.size()));
    }
  };
}

double SteadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string_view BaseName(std::string_view path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string_view::npos ? path : path.substr(slash + 1);
}

}  // namespace

std::string_view LevelName(Level level) {
  switch (level) {
    case Level::kTrace:
      return "trace";
    case Level::kDebug:
      return "debug";
    case Level::kInfo:
      return "info";
    case Level::kWarn:
      return "warn";
    case Level::kError:
      return "error";
    case Level::kOff:
      break;
  }
  return "off";
}

Level ParseLevel(std::string_view text) {
  for (Level l :
       {Level::kTrace, Level::kDebug, Level::kInfo, Level::kWarn, Level::kError, Level::kOff}) {
    if (text == LevelName(l)) return l;
  }
  if (text == "warning") return Level::kWarn;
  throw std::invalid_argument("log level '" + std::string(text) +
                              "': expected trace, debug, info, warn, error or off");
}

struct Logger::State {
  struct Place {
    std::string where;  // "link.cpp:210 (alpha)"
    double window_start = -kNever;
    int printed = 0;
    std::uint64_t suppressed = 0;
    Level level = Level::kInfo;  // of the last suppressed message
    std::string last;            // the last suppressed message
  };

  Options options;
  Sink sink;
  Clock clock;
  std::atomic<int> level{static_cast<int>(Level::kInfo)};
  std::mutex mutex;
  std::unordered_map<std::string, Place> places;
  double next_summary = kNever;  // earliest end of a window with suppressed messages

  void Summarise(Place& p, double now) {
    if (p.suppressed == 0) return;
    char span[32];
    std::snprintf(span, sizeof span, "%.1f", std::max(0.0, now - p.window_start));
    sink(p.level, std::to_string(p.suppressed) + " more like this from " + p.where + " in " + span +
                      " s (suppressed); last: " + p.last);
    p.suppressed = 0;
    p.last.clear();
  }

  // Summaries of the places whose window ended by `now` (all of them when force).
  void SummariseDue(double now, bool force) {
    if (!force && now < next_summary) return;
    next_summary = kNever;
    for (auto& [key, p] : places) {
      if (p.suppressed == 0) continue;
      if (force || now >= p.window_start + options.window_s) {
        Summarise(p, force ? now : p.window_start + options.window_s);
      } else {
        next_summary = std::min(next_summary, p.window_start + options.window_s);
      }
    }
  }
};

Logger::Logger(Options options, Sink sink, Clock clock) : state_(std::make_unique<State>()) {
  state_->options = options;
  state_->sink = sink ? std::move(sink) : StderrSink();
  state_->clock = clock ? std::move(clock) : Clock(SteadySeconds);
  state_->level = static_cast<int>(options.level);
}

Logger::~Logger() { Flush(); }

void Logger::SetLevel(Level level) { state_->level = static_cast<int>(level); }

Level Logger::level() const { return static_cast<Level>(state_->level.load()); }

bool Logger::Enabled(Level level) const {
  return level != Level::kOff && static_cast<int>(level) >= state_->level.load();
}

void Logger::Write(Level level, std::string_view message, const std::source_location& where,
                   std::string_view key) {
  if (!Enabled(level)) return;
  State& s = *state_;
  std::lock_guard lock(s.mutex);
  const double now = s.clock();
  s.SummariseDue(now, false);
  std::string id = std::string(where.file_name()) + ":" + std::to_string(where.line());
  if (!key.empty()) id += "|" + std::string(key);
  auto [it, fresh] = s.places.try_emplace(std::move(id));
  State::Place& p = it->second;
  if (fresh) {
    p.where = std::string(BaseName(where.file_name())) + ":" + std::to_string(where.line());
    if (!key.empty()) p.where += " (" + std::string(key) + ")";
  }
  if (now >= p.window_start + s.options.window_s) {
    s.Summarise(p, now);  // a window ended before SummariseDue saw it (same instant)
    p.window_start = now;
    p.printed = 0;
  }
  if (p.printed < s.options.max_per_window) {
    ++p.printed;
    s.sink(level, message);
    return;
  }
  ++p.suppressed;
  p.level = level;
  p.last.assign(message);
  s.next_summary = std::min(s.next_summary, p.window_start + s.options.window_s);
}

void Logger::Flush() {
  State& s = *state_;
  std::lock_guard lock(s.mutex);
  s.SummariseDue(s.clock(), true);
}

Logger& Global() {
  static Logger logger;
  return logger;
}

}  // namespace draco::log
