// Memory bound of a fuzz target (docs/hardening.md "Memory bounds"): the heap bytes live at
// once while one input is read may not exceed multiple * input bytes + fixed. Counted through
// the sanitizer allocator's malloc and free hooks (every fuzz target is built with ASan), so
// what third-party libraries allocate (yaml-cpp, zlib, OpenCV, rosbag) counts too. Above the
// bound the target aborts naming the peak, and libFuzzer keeps the input as a crash.
//
//   extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
//     const draco::fuzz::AllocationBound bound(size, 64, 16 << 20, "fuzz_x");
//     ...
//
// DRACO_FUZZ_ALLOCATIONS=1 in the environment prints every input's peak (to choose a bound);
// DRACO_FUZZ_NO_MEMORY_BOUND=1 turns the check off (to look for other findings first).
#pragma once

#include <sanitizer/allocator_interface.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

namespace draco::fuzz {

class AllocationBound {
 public:
  AllocationBound(std::size_t input_bytes, std::size_t multiple, std::size_t fixed,
                  const char* target)
      : limit_(multiple * input_bytes + fixed),
        input_bytes_(input_bytes),
        multiple_(multiple),
        fixed_(fixed),
        target_(target) {
    static const bool installed = [] {
      __sanitizer_install_malloc_and_free_hooks(&OnMalloc, &OnFree);
      return true;
    }();
    (void)installed;
    live_ = 0;
    peak_ = 0;
    active_ = true;
  }

  ~AllocationBound() {
    active_ = false;
    const std::int64_t peak = peak_;
    static const bool report = std::getenv("DRACO_FUZZ_ALLOCATIONS") != nullptr;
    if (report) {
      std::fprintf(
          stderr, "%s: input %zu bytes, peak heap %lld bytes (%.1f x input)\n", target_,
          input_bytes_, static_cast<long long>(peak),
          static_cast<double>(peak) / static_cast<double>(std::max<std::size_t>(1, input_bytes_)));
    }
    static const bool enforce = std::getenv("DRACO_FUZZ_NO_MEMORY_BOUND") == nullptr;
    if (enforce && peak > static_cast<std::int64_t>(limit_)) {
      std::fprintf(stderr,
                   "%s: memory bound broken: an input of %zu bytes made %lld heap bytes live at "
                   "once; the bound is %zu x input + %zu = %zu bytes\n",
                   target_, input_bytes_, static_cast<long long>(peak), multiple_, fixed_, limit_);
      std::abort();
    }
  }

  AllocationBound(const AllocationBound&) = delete;
  AllocationBound& operator=(const AllocationBound&) = delete;

 private:
  static void OnMalloc(const volatile void*, std::size_t size) {
    if (!active_.load(std::memory_order_relaxed)) return;
    const std::int64_t now =
        live_.fetch_add(static_cast<std::int64_t>(size)) + static_cast<std::int64_t>(size);
    std::int64_t peak = peak_.load(std::memory_order_relaxed);
    while (now > peak && !peak_.compare_exchange_weak(peak, now)) {
    }
  }
  static void OnFree(const volatile void* ptr) {
    if (!active_.load(std::memory_order_relaxed) || ptr == nullptr) return;
    live_.fetch_sub(
        static_cast<std::int64_t>(__sanitizer_get_allocated_size(const_cast<const void*>(ptr))));
  }

  static inline std::atomic<bool> active_{false};
  static inline std::atomic<std::int64_t> live_{0};
  static inline std::atomic<std::int64_t> peak_{0};

  std::size_t limit_;
  std::size_t input_bytes_;
  std::size_t multiple_;
  std::size_t fixed_;
  const char* target_;
};

}  // namespace draco::fuzz
