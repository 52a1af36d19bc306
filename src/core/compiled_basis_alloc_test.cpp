// CompiledBasis::eval allocates nothing once its workspace exists: counted with a replaced
// global operator new (this file is its own test binary so the counter sees only this code).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <random>

#include "core/core_test_util.h"

namespace {
std::atomic<long> g_allocations{0};
}

// GCC cannot see that these replacements pair malloc with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

void* operator new(std::size_t n) {
  ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace cadinterp::core {
namespace {

TEST(CompiledBasisAllocations, EvalAndGradAllocateNothing) {
  for (Degree g : {Degree::Linear, Degree::Cubic}) {
    std::mt19937_64 rng(3);
    Basis basis(3, g);
    testing::random_splits(basis, rng, 15, 5);
    const CompiledBasis cb = testing::compile_unit(basis);
    EvalWorkspace ws = cb.make_workspace();
    std::vector<double> pts(3000);
    for (double& p : pts) p = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    const long before = g_allocations.load();
    double sink = 0.0;
    for (std::size_t i = 0; i + 3 <= pts.size(); i += 3) {
      BasisWeights w;
      ASSERT_TRUE(cb.eval(&pts[i], ws, true, &w));
      sink += w.psi[0] + w.dpsi[0];
    }
    EXPECT_EQ(g_allocations.load() - before, 0) << "allocations during 1000 eval+grad calls";
    EXPECT_TRUE(std::isfinite(sink));
  }
}

}  // namespace
}  // namespace cadinterp::core
