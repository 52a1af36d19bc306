#include "core/adaptive.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>
#include <stdexcept>

#include "core/compiled_basis.h"

namespace cadinterp::core {
namespace {

// Interpolated values of an adaptive result at x (m values), or false when infeasible/outside.
bool interpolate(const AdaptiveResult& r, const CompiledBasis& cb, EvalWorkspace& ws,
                 const double* x, std::vector<double>& out) {
  BasisWeights w;
  if (!cb.eval(x, ws, false, &w) || !cb.element_feasible(w.element)) return false;
  out.assign(static_cast<std::size_t>(r.m), 0.0);
  for (int t = 0; t < w.count; ++t)
    for (int i = 0; i < r.m; ++i)
      out[static_cast<std::size_t>(i)] +=
          w.psi[t] * r.values[static_cast<std::size_t>(w.samples[t] * r.m + i)];
  return true;
}

double max_error(const AdaptiveResult& r, const HostFunction& f, const std::vector<double>& lo,
                 const std::vector<double>& hi, int points) {
  const CompiledBasis cb = CompiledBasis::compile(r.basis, lo, hi, &r.infeasible);
  EvalWorkspace ws = cb.make_workspace();
  std::mt19937_64 rng(99);
  double worst = 0.0;
  std::vector<double> x(lo.size()), got, truth(static_cast<std::size_t>(r.m));
  for (int i = 0; i < points; ++i) {
    for (std::size_t d = 0; d < lo.size(); ++d)
      x[d] = std::uniform_real_distribution<double>(lo[d], hi[d])(rng);
    if (!interpolate(r, cb, ws, x.data(), got)) continue;
    if (!f(x.data(), truth.data())) continue;
    worst = std::max(worst, max_norm_error(got.data(), truth.data(), r.m));
  }
  return worst;
}

TEST(Adaptive, RefinesAlongTheDirectionThatVaries) {
  // Varies sharply along x0 only; x1 is linear and needs no refinement.
  const HostFunction f = [](const double* x, double* v) {
    v[0] = std::tanh(12.0 * (x[0] - 0.3)) + 0.5 * x[1];
    return true;
  };
  const std::vector<double> lo{0.0, -1.0}, hi{1.0, 1.0};
  for (Degree g : {Degree::Linear, Degree::Cubic}) {
    AdaptiveOptions opt;
    opt.degree = g;
    opt.tolerance = 1e-3;
    const AdaptiveResult r = adaptive_sample(2, 1, lo, hi, f, opt);
    EXPECT_FALSE(r.budget_exhausted);
    int max_level[2] = {0, 0};
    for (int leaf : r.basis.tree().leaves())
      for (int d = 0; d < 2; ++d)
        max_level[d] = std::max(max_level[d], int(r.basis.tree().node(leaf).level[d]));
    EXPECT_GE(max_level[0], 5);
    EXPECT_LE(max_level[1], 2) << "x1 is linear: no refinement beyond the initial one";
    const double err = max_error(r, f, lo, hi, 2000);
    std::printf("[ figures ] tanh ridge, %s: %d samples, %d host calls, max error %.2e\n",
                g == Degree::Linear ? "linear" : "cubic", r.basis.sample_count(), r.host_calls,
                err);
    EXPECT_LT(err, 10 * opt.tolerance);
  }
}

TEST(Adaptive, HostIsCalledOncePerPointAndRunsAreDeterministic) {
  std::map<std::pair<double, double>, int> calls;
  const HostFunction f = [&](const double* x, double* v) {
    ++calls[{x[0], x[1]}];
    v[0] = std::sin(3 * x[0]) * std::cos(2 * x[1]);
    v[1] = x[0] * x[1];
    return true;
  };
  AdaptiveOptions opt;
  opt.degree = Degree::Cubic;
  opt.tolerance = 1e-3;
  const std::vector<double> lo{0.0, 0.0}, hi{2.0, 1.0};
  const AdaptiveResult a = adaptive_sample(2, 2, lo, hi, f, opt);
  for (const auto& kv : calls) EXPECT_EQ(kv.second, 1);
  EXPECT_EQ(static_cast<int>(calls.size()), a.host_calls);
  const AdaptiveResult b = adaptive_sample(2, 2, lo, hi, f, opt);
  ASSERT_EQ(a.basis.sample_count(), b.basis.sample_count());
  for (int k = 0; k < a.basis.sample_count(); ++k) EXPECT_EQ(a.basis.sample(k), b.basis.sample(k));
  EXPECT_EQ(a.values, b.values);
}

TEST(Adaptive, BudgetsAreRespected) {
  const HostFunction f = [](const double* x, double* v) {
    v[0] = std::sin(20 * x[0] * x[1] + x[2]);
    return true;
  };
  AdaptiveOptions opt;
  opt.tolerance = 1e-9;
  opt.max_samples = 300;
  const AdaptiveResult r = adaptive_sample(3, 1, {0, 0, 0}, {1, 1, 1}, f, opt);
  EXPECT_TRUE(r.budget_exhausted);
  // The last split starts below the budget and adds at most the samples of one split plane.
  EXPECT_LE(r.basis.sample_count(), opt.max_samples + 64);
  opt.max_samples = 1 << 20;
  opt.max_level = 3;
  const AdaptiveResult s = adaptive_sample(3, 1, {0, 0, 0}, {1, 1, 1}, f, opt);
  for (int leaf : s.basis.tree().leaves())
    for (int d = 0; d < 3; ++d) EXPECT_LE(s.basis.tree().node(leaf).level[d], 3);
}

TEST(Adaptive, UserMetricDrivesRefinement) {
  // Component 0 is rough, component 1 is linear; a metric that looks only at component 1
  // must stop after the initial refinement.
  const HostFunction f = [](const double* x, double* v) {
    v[0] = std::sin(30 * x[0]);
    v[1] = 2 * x[0] + 1;
    return true;
  };
  AdaptiveOptions opt;
  opt.tolerance = 1e-6;
  opt.metric = [](const double* a, const double* t, int) { return std::abs(a[1] - t[1]); };
  const AdaptiveResult r = adaptive_sample(1, 2, {0}, {1}, f, opt);
  EXPECT_EQ(r.basis.sample_count(), 3);
  opt.metric = nullptr;
  EXPECT_GT(adaptive_sample(1, 2, {0}, {1}, f, opt).basis.sample_count(), 20);
}

TEST(Adaptive, InfeasibleRegionIsRecordedAndNeverInterpolatedAcross) {
  // The host fails inside a disk (think: a fillet too large to build).
  auto inside = [](const double* x) {
    return (x[0] - 0.7) * (x[0] - 0.7) + (x[1] - 0.6) * (x[1] - 0.6) < 0.04;
  };
  const HostFunction f = [&](const double* x, double* v) {
    if (inside(x)) return false;
    v[0] = x[0] * x[0] + x[1];
    return true;
  };
  for (Degree g : {Degree::Linear, Degree::Cubic}) {
    AdaptiveOptions opt;
    opt.degree = g;
    opt.tolerance = 1e-3;
    opt.max_level = 6;
    const std::vector<double> lo{0, 0}, hi{1, 1};
    const AdaptiveResult r = adaptive_sample(2, 1, lo, hi, f, opt);
    const CompiledBasis cb = CompiledBasis::compile(r.basis, lo, hi, &r.infeasible);
    int infeasible_samples = 0;
    for (int k = 0; k < r.basis.sample_count(); ++k) {
      double x[2];
      cb.sample_position(k, x);
      EXPECT_EQ(bool(r.infeasible[static_cast<std::size_t>(k)]), inside(x));
      infeasible_samples += inside(x) ? 1 : 0;
    }
    EXPECT_GT(infeasible_samples, 0);
    for (int e = 0; e < cb.element_count(); ++e) {
      int n;
      const int* s = cb.element_samples(e, &n);
      bool any = false;
      for (int t = 0; t < n; ++t) any = any || r.infeasible[static_cast<std::size_t>(s[t])];
      EXPECT_EQ(cb.element_feasible(e), !any);
    }
    // Far from the disk everything is feasible and accurate.
    EvalWorkspace ws = cb.make_workspace();
    std::vector<double> got;
    const double far[2] = {0.1, 0.1};
    ASSERT_TRUE(interpolate(r, cb, ws, far, got));
    EXPECT_NEAR(got[0], 0.11, 2e-3);
    const double centre[2] = {0.7, 0.6};
    EXPECT_FALSE(interpolate(r, cb, ws, centre, got));
  }
}

TEST(Adaptive, RejectsBadArguments) {
  const HostFunction f = [](const double*, double* v) {
    v[0] = 0;
    return true;
  };
  AdaptiveOptions opt;
  EXPECT_THROW(adaptive_sample(2, 1, {0}, {1}, f, opt), std::invalid_argument);
  EXPECT_THROW(adaptive_sample(1, 1, {1}, {0}, f, opt), std::invalid_argument);
  EXPECT_THROW(adaptive_sample(1, 0, {0}, {1}, f, opt), std::invalid_argument);
  EXPECT_THROW(adaptive_sample(1, 1, {0}, {std::nan("")}, f, opt), std::invalid_argument);
  opt.max_level = kMaxLevel;
  EXPECT_THROW(adaptive_sample(1, 1, {0}, {1}, f, opt), std::invalid_argument);
}

// reuse_face_centres tests an element at the face centres already evaluated and evaluates the
// others only where the element fails (its split direction needs them): on a bump, whose
// elements mostly pass once refined, that saves calls at no loss of the measured accuracy.
TEST(Adaptive, ReusedFaceCentresCostFewerCallsAtTheSameAccuracy) {
  const HostFunction f = [](const double* x, double* v) {
    v[0] = std::exp(-40.0 * ((x[0] - 0.6) * (x[0] - 0.6) + (x[1] - 0.3) * (x[1] - 0.3)));
    return true;
  };
  const std::vector<double> lo{0.0, 0.0}, hi{1.0, 1.0};
  AdaptiveOptions opt;
  opt.tolerance = 2e-3;
  const AdaptiveResult all = adaptive_sample(2, 1, lo, hi, f, opt);
  opt.reuse_face_centres = true;
  const AdaptiveResult reused = adaptive_sample(2, 1, lo, hi, f, opt);
  ASSERT_FALSE(all.budget_exhausted);
  ASSERT_FALSE(reused.budget_exhausted);
  EXPECT_LT(reused.host_calls, all.host_calls * 9 / 10);
  EXPECT_LE(max_error(reused, f, lo, hi, 20000), 1.05 * max_error(all, f, lo, hi, 20000));
}

// lazy_face_centres on a budget-bound 4-D run (every element fails its test, as in the builder's
// figures): the split directions come from answered points and inherited errors instead of 2K
// new face centres per split, and the probes stop where the budget does. Fewer calls, the same
// measured accuracy; and the run stays deterministic.
TEST(Adaptive, LazyFaceCentresCostFewerCallsOnABudget) {
  const HostFunction f = [](const double* x, double* v) {
    double r2 = 0.0;
    for (int d = 0; d < 4; ++d) r2 += (x[d] - 0.35) * (x[d] - 0.35);
    v[0] = std::exp(-6.0 * r2) + 0.3 * std::tanh(8.0 * (x[0] + 0.5 * x[1] - 0.7)) + 0.2 * x[3];
    return true;
  };
  const std::vector<double> lo(4, 0.0), hi(4, 1.0);
  AdaptiveOptions opt;
  opt.tolerance = 1e-9;
  opt.max_samples = 400;
  opt.lazy_face_centres = false;
  const AdaptiveResult all = adaptive_sample(4, 1, lo, hi, f, opt);
  opt.lazy_face_centres = true;
  const AdaptiveResult lazy = adaptive_sample(4, 1, lo, hi, f, opt);
  const AdaptiveResult again = adaptive_sample(4, 1, lo, hi, f, opt);
  ASSERT_TRUE(all.budget_exhausted);
  ASSERT_TRUE(lazy.budget_exhausted);
  EXPECT_LT(lazy.host_calls, 2 * lazy.basis.sample_count());
  EXPECT_LT(lazy.host_calls, all.host_calls * 7 / 10);
  EXPECT_LE(max_error(lazy, f, lo, hi, 20000), 1.05 * max_error(all, f, lo, hi, 20000));
  EXPECT_EQ(again.host_calls, lazy.host_calls);
  EXPECT_EQ(again.values, lazy.values);
}

// lazy_face_centres keeps the test: an element is kept only once it passed at its centre and
// at all 2K face centres, so every kept leaf's face centres were evaluated.
TEST(Adaptive, LazyFaceCentresTestEveryKeptElementAtAllFaceCentres) {
  std::set<std::pair<double, double>> asked;
  const HostFunction f = [&](const double* x, double* v) {
    asked.insert({x[0], x[1]});
    v[0] = std::exp(-40.0 * ((x[0] - 0.6) * (x[0] - 0.6) + (x[1] - 0.3) * (x[1] - 0.3)));
    return true;
  };
  AdaptiveOptions opt;
  opt.tolerance = 1e-2;
  opt.lazy_face_centres = true;
  const AdaptiveResult r = adaptive_sample(2, 1, {0.0, 0.0}, {1.0, 1.0}, f, opt);
  ASSERT_FALSE(r.budget_exhausted);
  for (int leaf : r.basis.tree().leaves()) {
    const IBox& b = r.basis.tree().node(leaf).box;
    const double cx = to_unit((b.lo[0] + b.hi[0]) / 2), cy = to_unit((b.lo[1] + b.hi[1]) / 2);
    for (const auto& p :
         {std::make_pair(to_unit(b.lo[0]), cy), std::make_pair(to_unit(b.hi[0]), cy),
          std::make_pair(cx, to_unit(b.lo[1])), std::make_pair(cx, to_unit(b.hi[1]))})
      EXPECT_TRUE(asked.count(p)) << "leaf " << leaf;
    EXPECT_LE(r.leaf_error[static_cast<std::size_t>(leaf)], opt.tolerance);
  }
}

}  // namespace
}  // namespace cadinterp::core
