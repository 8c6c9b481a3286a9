#include "largest_allocation.hpp"

#include <atomic>
#include <cstdlib>
#include <new>

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(memory_sanitizer) || \
    __has_feature(thread_sanitizer)
#define DRACO_SANITIZED 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define DRACO_SANITIZED 1
#endif

namespace {
std::atomic<int> g_active{0};
std::atomic<std::size_t> g_largest{0};

// Unused when sanitized (the sanitizer owns operator new).
[[maybe_unused]] void Note(std::size_t size) {
  if (g_active.load(std::memory_order_relaxed) == 0) return;
  std::size_t seen = g_largest.load(std::memory_order_relaxed);
  while (size > seen && !g_largest.compare_exchange_weak(seen, size)) {
  }
}
}  // namespace

#ifndef DRACO_SANITIZED
void* operator new(std::size_t size) {
  Note(size);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return ::operator new(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
#endif

namespace draco::test_support {

LargestAllocation::LargestAllocation() {
  g_largest = 0;
  ++g_active;
}
LargestAllocation::~LargestAllocation() { --g_active; }
std::size_t LargestAllocation::bytes() const { return g_largest.load(); }

bool LargestAllocation::Supported() {
#ifdef DRACO_SANITIZED
  return false;
#else
  return true;
#endif
}

}  // namespace draco::test_support
