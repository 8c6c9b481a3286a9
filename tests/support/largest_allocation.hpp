// The largest single heap allocation made while a LargestAllocation is alive: tests of the
// readers' memory bounds (docs/hardening.md) check that a small corrupt input cannot make a
// reader allocate what a header field claims. Link largest_allocation.cpp into the test
// binary: it replaces the global operator new (not in sanitizer builds, whose allocator must
// see every allocation: there Supported() is false and the tests skip the measurement; the
// fuzz targets count allocations there instead, tests/fuzz/allocation_bound.hpp).
#pragma once

#include <cstddef>

namespace draco::test_support {

class LargestAllocation {
 public:
  LargestAllocation();
  ~LargestAllocation();
  LargestAllocation(const LargestAllocation&) = delete;
  LargestAllocation& operator=(const LargestAllocation&) = delete;

  std::size_t bytes() const;  // largest operator new size since construction

  static bool Supported();
};

}  // namespace draco::test_support
