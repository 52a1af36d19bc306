// Builder time of the adaptive driver (§4.2) with a free host: a 5-D analytic function sampled
// to a fixed budget, linear against cubic. Counters: samples, B-splines and splits of the result,
// so that runs of different code compare per unit of work, not only per wall second.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "core/adaptive.h"

namespace cadinterp::core {
namespace {

// A smooth bump plus a ridge: both directions-dependent, so the tree refines anisotropically.
bool five_d_host(const double* x, double* v) {
  double r2 = 0.0;
  for (int d = 0; d < 5; ++d) r2 += (x[d] - 0.35) * (x[d] - 0.35);
  v[0] = std::exp(-6.0 * r2) + 0.3 * std::tanh(8.0 * (x[0] + 0.5 * x[1] - 0.7)) + 0.2 * x[4];
  return true;
}

void BM_Adaptive5D(benchmark::State& state) {
  AdaptiveOptions opt;
  opt.degree = state.range(0) == 3 ? Degree::Cubic : Degree::Linear;
  opt.max_samples = static_cast<int>(state.range(1));
  opt.tolerance = 1e-6;  // the budget, not the tolerance, ends the run
  const std::vector<double> lo(5, 0.0), hi(5, 1.0);
  int samples = 0, bsplines = 0, splits = 0;
  for (auto _ : state) {
    AdaptiveResult r = adaptive_sample(5, 1, lo, hi, five_d_host, opt);
    samples = r.basis.sample_count();
    bsplines = r.basis.bspline_count();
    splits = r.splits;
    benchmark::DoNotOptimize(r.values.data());
  }
  state.counters["samples"] = samples;
  state.counters["bsplines"] = bsplines;
  state.counters["splits"] = splits;
}
BENCHMARK(BM_Adaptive5D)
    ->ArgNames({"degree", "budget"})
    ->Args({1, 2000})
    ->Args({3, 500})
    ->Args({3, 2000})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace cadinterp::core
