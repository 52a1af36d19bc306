// One CompiledBasis shared by 8 threads, one workspace each: results must equal a serial run.
// Run under the tsan preset (label 'concurrency').
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <thread>
#include <vector>

#include "core/core_test_util.h"

namespace cadinterp::core {
namespace {

TEST(CompiledBasisThreads, SharedBasisWithPerThreadWorkspaces) {
  for (Degree g : {Degree::Linear, Degree::Cubic}) {
    std::mt19937_64 rng(5);
    Basis basis(3, g);
    testing::random_splits(basis, rng, 12, 5);
    const CompiledBasis cb = testing::compile_unit(basis);

    constexpr int kPoints = 2000, kThreads = 8;
    std::vector<double> pts(kPoints * 3);
    for (double& p : pts) p = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    auto run = [&](int begin, int step, std::vector<double>& out) {
      EvalWorkspace ws = cb.make_workspace();
      for (int i = begin; i < kPoints; i += step) {
        BasisWeights w;
        ASSERT_TRUE(cb.eval(&pts[static_cast<std::size_t>(i) * 3], ws, true, &w));
        double s = 0.0;
        for (int t = 0; t < w.count; ++t) s += w.psi[t] * (w.samples[t] + 1) + w.dpsi[t];
        out[static_cast<std::size_t>(i)] = s;
      }
    };
    std::vector<double> serial(kPoints), parallel(kPoints);
    run(0, 1, serial);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t) threads.emplace_back(run, t, kThreads, std::ref(parallel));
    for (auto& t : threads) t.join();
    EXPECT_EQ(serial, parallel);
  }
}

}  // namespace
}  // namespace cadinterp::core
