// Deterministic random numbers for the simulator.
//
// The engine is std::mt19937_64 (its output sequence is fixed by the C++ standard); every
// distribution is written out here, so a seed gives the same mission with any standard
// library. Streams are derived from (seed, robot, purpose, index) with DeriveSeed, so work
// can be split across threads without changing the result.
#pragma once

#include <cstdint>
#include <random>

namespace draco::sim {

// splitmix64 finaliser: a well-mixed 64-bit hash.
std::uint64_t Mix64(std::uint64_t x);

// Seed of an independent stream: DeriveSeed(seed, a, b) differs for every (a, b).
std::uint64_t DeriveSeed(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0);

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}

  std::uint64_t NextU64() { return engine_(); }
  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  // Uniform in (0, 1]: safe for log().
  double UniformPositive() { return (static_cast<double>(engine_() >> 11) + 1.0) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Standard normal (Box-Muller, second value cached).
  double Normal();
  double Normal(double mean, double sigma) { return mean + sigma * Normal(); }
  // Exponential with mean 1.
  double Exponential();
  // Gamma(shape, scale 1), Marsaglia-Tsang squeeze method; shape < 1 by the U^(1/shape) boost.
  double Gamma(double shape);
  // Rayleigh amplitude with scale sigma (mean sigma * sqrt(pi / 2)).
  double Rayleigh(double sigma);
  bool Bernoulli(double p) { return Uniform() < p; }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace draco::sim
