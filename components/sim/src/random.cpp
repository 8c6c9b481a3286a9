#include "draco/sim/random.hpp"

#include <cmath>

namespace draco::sim {

std::uint64_t Mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

std::uint64_t DeriveSeed(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  return Mix64(Mix64(Mix64(seed) ^ (a * 0x632be59bd9b4e019ULL)) ^ (b * 0x85157af5ULL + 1));
}

double Rng::Normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  const double u1 = UniformPositive();
  const double u2 = Uniform();
  const double radius = std::sqrt(-2.0 * std::log(u1));
  const double angle = 2.0 * M_PI * u2;
  spare_ = radius * std::sin(angle);
  has_spare_ = true;
  return radius * std::cos(angle);
}

double Rng::Exponential() { return -std::log(UniformPositive()); }

double Rng::Gamma(double shape) {
  if (shape <= 0.0) return 0.0;
  if (shape < 1.0) {
    // Gamma(a) = Gamma(a + 1) * U^(1/a).
    return Gamma(shape + 1.0) * std::pow(UniformPositive(), 1.0 / shape);
  }
  // Marsaglia & Tsang (2000): d = a - 1/3, c = 1/sqrt(9d); accept v = (1 + c x)^3.
  const double d = shape - 1.0 / 3.0;
  const double c = 1.0 / std::sqrt(9.0 * d);
  for (;;) {
    double x = 0.0;
    double v = 0.0;
    do {
      x = Normal();
      v = 1.0 + c * x;
    } while (v <= 0.0);
    v = v * v * v;
    const double u = UniformPositive();
    const double x2 = x * x;
    if (u < 1.0 - 0.0331 * x2 * x2) return d * v;
    if (std::log(u) < 0.5 * x2 + d * (1.0 - v + std::log(v))) return d * v;
  }
}

double Rng::Rayleigh(double sigma) { return sigma * std::sqrt(-2.0 * std::log(UniformPositive())); }

}  // namespace draco::sim
