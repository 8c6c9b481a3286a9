// A marina-like scene shared by the ICP tests and benchmark: a pier (two walls at right
// angles) and a row of five piles, n points with 40 % on one wall, 30 % on the other.
#pragma once

#include <cmath>
#include <random>

#include "draco/icp/kdtree2.hpp"

namespace draco::icp::testing {

inline Cloud2 Scene(std::mt19937_64& rng, int n) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Cloud2 pts;
  for (int i = 0; i < n; ++i) {
    const double r = u(rng);
    if (r < 0.4) {
      pts.emplace_back(2.0 + 18.0 * u(rng), 6.0);
    } else if (r < 0.7) {
      pts.emplace_back(20.0, -6.0 + 12.0 * u(rng));
    } else {
      const int pile = static_cast<int>(u(rng) * 5);
      const double a = 2.0 * M_PI * u(rng);
      pts.emplace_back(5.0 + 3.0 * pile + 0.3 * std::cos(a), -3.0 + 0.3 * std::sin(a));
    }
  }
  return pts;
}

}  // namespace draco::icp::testing
