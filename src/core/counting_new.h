// Replaces the global operator new/delete of a test binary with counting versions (include it
// in exactly one translation unit per binary). A shared library's allocations resolve to them
// too (ELF interposition), so a test can count what the runtime allocates.
#pragma once

#include <atomic>
#include <cstdlib>
#include <new>

namespace cadinterp::testing {
inline std::atomic<long> g_allocations{0};
inline long allocation_count() { return g_allocations.load(); }
}  // namespace cadinterp::testing

// GCC cannot see that these replacements pair malloc with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t n) {
  ++cadinterp::testing::g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
