// Refinement toward the feasibility boundary (AdaptiveOptions::refine_infeasible,
// max_infeasible_points): the part of the box the compiled basis refuses stays close to the part
// where the host truly fails, elements wholly inside the failing region are not split, and the
// failed points respect their bound.
#include <gtest/gtest.h>

#include <cmath>

#include "core/adaptive.h"
#include "core/compiled_basis.h"

namespace cadinterp::core {
namespace {

// The host fails in a quarter disk at the corner (1, 1) of the unit square covering 16 % of it
// (pi r^2 / 4 = 0.16): a curved boundary that no dyadic split line follows.
const double kRadius = std::sqrt(0.64 / M_PI);

bool fails(const double* x) {
  return (1 - x[0]) * (1 - x[0]) + (1 - x[1]) * (1 - x[1]) < kRadius * kRadius;
}

const HostFunction kHost = [](const double* x, double* v) {
  if (fails(x)) return false;
  v[0] = std::sin(3 * x[0]) * std::cos(2 * x[1]);
  return true;
};

// Fractions of a 100 x 100 grid of cell centres that the basis refuses and where the host fails.
struct Fractions {
  double refused = 0, truth = 0;
};

Fractions measure(const AdaptiveResult& r) {
  const std::vector<double> lo{0, 0}, hi{1, 1};
  const CompiledBasis cb = CompiledBasis::compile(r.basis, lo, hi, &r.infeasible);
  const int n = 100;
  Fractions f;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x[2] = {(i + 0.5) / n, (j + 0.5) / n};
      f.refused += cb.element_feasible(cb.locate(x)) ? 0 : 1;
      f.truth += fails(x) ? 1 : 0;
    }
  f.refused /= n * n;
  f.truth /= n * n;
  return f;
}

AdaptiveOptions options(Degree degree, int max_samples) {
  AdaptiveOptions o;
  o.degree = degree;
  o.tolerance = 1e-2;
  o.max_samples = max_samples;
  o.max_level = 8;
  return o;
}

TEST(AdaptiveInfeasible, RefusedAreaApproachesTheFailingArea) {
  // Refused minus failing, measured on this host at 600 samples: linear 0.3 % of the box,
  // cubic 1.6 % (its terms reach an element further, so it needs finer elements along the
  // boundary).
  for (Degree g : {Degree::Linear, Degree::Cubic}) {
    const int budget = 600;
    const AdaptiveResult r = adaptive_sample(2, 1, {0, 0}, {1, 1}, kHost, options(g, budget));
    const Fractions f = measure(r);
    SCOPED_TRACE(g == Degree::Linear ? "linear" : "cubic");
    EXPECT_NEAR(f.truth, 0.16, 0.01);
    EXPECT_GE(f.refused, f.truth - 0.005);  // never interpolates across the failing region
    EXPECT_LE(f.refused - f.truth, 0.02);
    // Without the refinement toward the boundary the same budget refuses far more.
    AdaptiveOptions plain = options(g, budget);
    plain.max_infeasible_points = 0;
    const Fractions p = measure(adaptive_sample(2, 1, {0, 0}, {1, 1}, kHost, plain));
    EXPECT_GT(p.refused - p.truth, 2 * (f.refused - f.truth) + 0.01);
  }
}

TEST(AdaptiveInfeasible, ElementsInsideTheFailingRegionAreNotSplit) {
  // The failing quarter disk is convex: an element whose four corners fail lies inside it, so
  // the driver must never have split one.
  for (Degree g : {Degree::Linear, Degree::Cubic}) {
    const AdaptiveResult r = adaptive_sample(2, 1, {0, 0}, {1, 1}, kHost, options(g, 600));
    const KdTree& tree = r.basis.tree();
    int inside_leaves = 0;
    for (int n = 0; n < tree.node_count(); ++n) {
      const IBox& b = tree.node(n).box;
      bool all_fail = true;
      for (int c = 0; c < 4; ++c) {
        const double x[2] = {to_unit((c & 1) ? b.hi[0] : b.lo[0]),
                             to_unit((c & 2) ? b.hi[1] : b.lo[1])};
        all_fail = all_fail && fails(x);
      }
      if (!all_fail) continue;
      EXPECT_TRUE(tree.is_leaf(n)) << "node " << n << " lies inside the failing region";
      ++inside_leaves;
    }
    EXPECT_GT(inside_leaves, 0);  // the region is large enough to hold whole elements
  }
}

TEST(AdaptiveInfeasible, FailedPointsRespectTheirBound) {
  for (Degree g : {Degree::Linear, Degree::Cubic}) {
    AdaptiveOptions o = options(g, 600);
    const AdaptiveResult unbounded = adaptive_sample(2, 1, {0, 0}, {1, 1}, kHost, o);
    o.max_infeasible_points = 12;
    const AdaptiveResult bounded = adaptive_sample(2, 1, {0, 0}, {1, 1}, kHost, o);
    SCOPED_TRACE(g == Degree::Linear ? "linear" : "cubic");
    EXPECT_GT(unbounded.infeasible_calls, 2 * o.max_infeasible_points);
    // Splits already decided when the bound is reached still evaluate their points: one wave's
    // worth (a handful in 2-D).
    EXPECT_LE(bounded.infeasible_calls, o.max_infeasible_points + 8);
    EXPECT_LT(bounded.infeasible_calls, unbounded.infeasible_calls);
    // Bound 0: no element is split for being infeasible, and the failures are the few points
    // the initial refinement and the feasible elements' tests met.
    o.max_infeasible_points = 0;
    const AdaptiveResult none = adaptive_sample(2, 1, {0, 0}, {1, 1}, kHost, o);
    EXPECT_LE(none.infeasible_calls, bounded.infeasible_calls);
  }
}

TEST(AdaptiveInfeasible, FeasibleEverywhereHostIsUnchangedByTheBound) {
  const HostFunction f = [](const double* x, double* v) {
    v[0] = std::sin(3 * x[0]) * std::cos(2 * x[1]);
    return true;
  };
  AdaptiveOptions o = options(Degree::Cubic, 300);
  const AdaptiveResult a = adaptive_sample(2, 1, {0, 0}, {1, 1}, f, o);
  o.max_infeasible_points = 0;
  const AdaptiveResult b = adaptive_sample(2, 1, {0, 0}, {1, 1}, f, o);
  EXPECT_EQ(a.infeasible_calls, 0);
  EXPECT_EQ(a.basis.sample_count(), b.basis.sample_count());
  EXPECT_EQ(a.values, b.values);
}

}  // namespace
}  // namespace cadinterp::core
