// Mission time: integer nanoseconds, so ordering and equality are exact and replay is
// deterministic. The runtime never reads the system clock for message stamps.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

namespace draco::graph {

struct Time {
  std::int64_t ns = 0;

  static constexpr Time FromNanoseconds(std::int64_t ns) { return Time{ns}; }
  static Time FromSeconds(double s) {
    return Time{static_cast<std::int64_t>(std::llround(s * 1e9))};
  }
  static constexpr Time Max() { return Time{std::numeric_limits<std::int64_t>::max()}; }
  double Seconds() const { return static_cast<double>(ns) * 1e-9; }

  friend constexpr bool operator<(Time a, Time b) { return a.ns < b.ns; }
  friend constexpr bool operator>(Time a, Time b) { return a.ns > b.ns; }
  friend constexpr bool operator<=(Time a, Time b) { return a.ns <= b.ns; }
  friend constexpr bool operator>=(Time a, Time b) { return a.ns >= b.ns; }
  friend constexpr bool operator==(Time a, Time b) { return a.ns == b.ns; }
  friend constexpr bool operator!=(Time a, Time b) { return a.ns != b.ns; }
  friend constexpr Time operator+(Time a, Time b) { return Time{a.ns + b.ns}; }
  friend constexpr Time operator-(Time a, Time b) { return Time{a.ns - b.ns}; }
};

inline Time Seconds(double s) { return Time::FromSeconds(s); }

}  // namespace draco::graph
