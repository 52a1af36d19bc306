// Builder time of the adaptive driver (§4.2) with a free host: a 5-D analytic function sampled
// to a fixed budget, linear against cubic. Counters: samples, B-splines and splits of the result,
// so that runs of different code compare per unit of work, not only per wall second.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "core/adaptive.h"
#include "core/compiled_basis.h"
#include "core/core_test_util.h"

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

// Refinement alone on a 5-D cubic basis (random splits, fixed seed), through the per-leaf index
// against the scan of every nearby B-spline (Basis::set_reference_search): the same basis, so
// the ratio of the two is the index's gain on this machine and load.
void BM_Refine5DCubic(benchmark::State& state) {
  const bool reference = state.range(0) != 0;
  int bsplines = 0;
  for (auto _ : state) {
    Basis basis(5, Degree::Cubic);
    basis.set_reference_search(reference);
    std::mt19937_64 rng(7);
    for (int d = 0; d < 5; ++d) {
      const std::vector<int> leaves = basis.tree().leaves();
      for (int leaf : leaves) basis.refine(leaf, d);
    }
    testing::random_splits(basis, rng, 25, 4);
    bsplines = basis.bspline_count();
  }
  state.counters["bsplines"] = bsplines;
}
BENCHMARK(BM_Refine5DCubic)
    ->ArgNames({"reference"})
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// Host calls per kept sample (§4.2: a call is a CAD regeneration plus FEM in the paper, so it is
// what a build costs) and the max error measured against f at 100,000 random points, for the
// face-centre test with every face centre evaluated (faces:0), reused where the host has
// answered (faces:1, reuse_face_centres) or evaluated lazily (faces:2, lazy_face_centres).
// Functions: a ridge and a bump in 2-D, a bump in 3-D to tolerance; the bump in 3-D and
// BM_Adaptive5D's function in 4-D to a budget of 400 samples (tol_e3:0), where every element
// fails its test, as in the builder's figures; their max_error_over_tol is the max error itself.
double ridge2(const double* x) { return std::tanh(30.0 * (x[0] + 0.6 * x[1] - 0.8)); }
double bump2(const double* x) {
  return std::exp(-40.0 * ((x[0] - 0.6) * (x[0] - 0.6) + (x[1] - 0.3) * (x[1] - 0.3)));
}
double bump3(const double* x) {
  double r2 = 0.0;
  for (int d = 0; d < 3; ++d) r2 += (x[d] - 0.4) * (x[d] - 0.4);
  return std::exp(-20.0 * r2);
}

double bump_ridge4(const double* x) {
  double v = 0.0;
  five_d_host(std::array<double, 5>{x[0], x[1], x[2], 0.35, x[3]}.data(), &v);
  return v;
}

void BM_HostCalls(benchmark::State& state) {
  struct Fn {
    int K;
    double (*f)(const double*);
  };
  const Fn fns[] = {{2, ridge2}, {2, bump2}, {3, bump3}, {4, bump_ridge4}};
  const Fn fn = fns[static_cast<std::size_t>(state.range(0))];
  AdaptiveOptions opt;
  opt.tolerance = static_cast<double>(state.range(1)) * 1e-3;
  opt.max_samples = opt.tolerance > 0 ? 100000 : 400;
  opt.tolerance = std::max(opt.tolerance, 1e-9);
  opt.reuse_face_centres = state.range(2) == 1;
  opt.lazy_face_centres = state.range(2) == 2;
  const std::vector<double> lo(static_cast<std::size_t>(fn.K), 0.0), hi(lo.size(), 1.0);
  const HostFunction host = [&](const double* x, double* v) {
    v[0] = fn.f(x);
    return true;
  };
  for (auto _ : state) {
    AdaptiveResult r = adaptive_sample(fn.K, 1, lo, hi, host, opt);
    const CompiledBasis cb = CompiledBasis::compile(r.basis, lo, hi, &r.infeasible);
    EvalWorkspace ws = cb.make_workspace();
    std::mt19937_64 rng(5);
    double worst = 0.0;
    for (int i = 0; i < 100000; ++i) {
      double u[4];
      for (int d = 0; d < fn.K; ++d) u[d] = std::uniform_real_distribution<double>(0, 1)(rng);
      BasisWeights w;
      cb.eval(u, ws, false, &w);
      double s = 0.0;
      for (int t = 0; t < w.count; ++t)
        s += w.psi[t] * r.values[static_cast<std::size_t>(w.samples[t])];
      worst = std::max(worst, std::abs(s - fn.f(u)));
    }
    state.counters["calls"] = r.host_calls;
    state.counters["samples"] = r.basis.sample_count();
    state.counters["calls_per_sample"] = static_cast<double>(r.host_calls) / r.basis.sample_count();
    state.counters["max_error_over_tol"] = opt.max_samples == 400 ? worst : worst / opt.tolerance;
  }
}
BENCHMARK(BM_HostCalls)
    ->ArgNames({"fn", "tol_e3", "faces"})
    // The 3-D bump at 2e-3 (17,000 samples, 7 s) is left out: CI runs every benchmark once.
    ->ArgsProduct({{0, 1}, {10, 2}, {0, 1, 2}})
    ->ArgsProduct({{2}, {10, 0}, {0, 1, 2}})
    ->ArgsProduct({{3}, {0}, {0, 2}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace cadinterp::core
