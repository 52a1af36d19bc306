// Cost of locating x and computing every psi_k(x), grad psi_k(x) of its element, per point, vs
// K and degree, on adaptive trees (random splits, fixed seed). Counters: terms (#T) and
// B-splines (#B) per evaluated element, averaged over the points.
#include <benchmark/benchmark.h>

#include <memory>
#include <random>
#include <vector>

#include "core/core_test_util.h"

namespace cadinterp::core {
namespace {

struct Fixture {
  CompiledBasis cb;
  std::vector<double> points;  // kPoints by K
};

constexpr int kPoints = 4096;

const Fixture& fixture(int K, Degree g) {
  static std::vector<std::unique_ptr<Fixture>> cache(2 * (kMaxDim + 1));
  auto& slot = cache[static_cast<std::size_t>(2 * K + (g == Degree::Cubic ? 1 : 0))];
  if (!slot) {
    std::mt19937_64 rng(42);
    Basis basis(K, g);
    // First refine once in every direction (as the adaptive driver does), then adapt.
    for (int d = 0; d < K; ++d) {
      const std::vector<int> leaves = basis.tree().leaves();
      for (int leaf : leaves) basis.refine(leaf, d);
    }
    testing::random_splits(basis, rng, 4 * K, 6);
    slot = std::make_unique<Fixture>(Fixture{testing::compile_unit(basis), {}});
    slot->points.resize(static_cast<std::size_t>(kPoints * K));
    for (double& p : slot->points) p = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  }
  return *slot;
}

void BM_LocateAndEval(benchmark::State& state) {
  const int K = static_cast<int>(state.range(0));
  const Degree g = state.range(1) == 1 ? Degree::Linear : Degree::Cubic;
  const bool grad = state.range(2) != 0;
  const Fixture& f = fixture(K, g);
  EvalWorkspace ws = f.cb.make_workspace();
  std::size_t i = 0;
  double terms = 0.0, evals = 0.0, sink = 0.0;
  for (auto _ : state) {
    BasisWeights w;
    f.cb.eval(&f.points[i * static_cast<std::size_t>(K)], ws, grad, &w);
    benchmark::DoNotOptimize(sink += w.psi[0]);
    terms += w.count;
    evals += 1.0;
    if (++i == kPoints) i = 0;
  }
  state.counters["terms"] = benchmark::Counter(terms / evals);
  state.counters["elements"] = f.cb.element_count();
  state.counters["max_bsplines"] = f.cb.max_bsplines();
  state.SetItemsProcessed(state.iterations());
}

void BM_Locate(benchmark::State& state) {
  const int K = static_cast<int>(state.range(0));
  const Fixture& f = fixture(K, Degree::Linear);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.cb.locate(&f.points[i * static_cast<std::size_t>(K)]));
    if (++i == kPoints) i = 0;
  }
  state.counters["elements"] = f.cb.element_count();
  state.SetItemsProcessed(state.iterations());
}

void Args(benchmark::internal::Benchmark* b) {
  b->ArgNames({"K", "degree", "grad"});
  for (int g : {1, 3})
    for (int K = 1; K <= (g == 1 ? 6 : 5); ++K)
      for (int grad : {0, 1}) b->Args({K, g, grad});
}

BENCHMARK(BM_LocateAndEval)->Apply(Args);
BENCHMARK(BM_Locate)->ArgName("K")->DenseRange(1, 6);

}  // namespace
}  // namespace cadinterp::core

BENCHMARK_MAIN();
