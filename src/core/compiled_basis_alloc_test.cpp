// CompiledBasis::eval allocates nothing once its workspace exists: counted with a replaced
// global operator new (this file is its own test binary so the counter sees only this code).
#include <gtest/gtest.h>

#include "core/counting_new.h"

#include <cmath>
#include <random>

#include "core/core_test_util.h"

using cadinterp::testing::allocation_count;

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
    const long before = allocation_count();
    double sink = 0.0;
    for (std::size_t i = 0; i + 3 <= pts.size(); i += 3) {
      BasisWeights w;
      ASSERT_TRUE(cb.eval(&pts[i], ws, true, &w));
      sink += w.psi[0] + w.dpsi[0];
    }
    EXPECT_EQ(allocation_count() - before, 0) << "allocations during 1000 eval+grad calls";
    EXPECT_TRUE(std::isfinite(sink));
  }
}

}  // namespace
}  // namespace cadinterp::core
