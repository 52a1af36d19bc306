// libcadinterp_optimize through its C ABI on the test box (test_host.h), whose objectives have
// closed forms: gradients of every quantity against central differences, minimizers found to
// the interpolation's accuracy (K = 2..5, linear and cubic, with an active constraint and with
// a fixed parameter), the infeasible corner as a wall, deterministic multi-start, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_optimize.h"
#include "optimize/test_assets.h"

namespace {

using cadinterp::optimize::test::box_asset;
using cadinterp::optimize::test::BoxHost;
using cadinterp::optimize::test::OpenedAsset;

const std::array<double, 5> kTarget = {0.6, 0.6, 0.4, 0.7, 0.5};

struct Problem {
  cadinterp_optimize_problem* p = nullptr;
  explicit Problem(const cadinterp_asset* a) {
    EXPECT_EQ(cadinterp_optimize_create(a, &p), CADINTERP_OK);
  }
  ~Problem() { cadinterp_optimize_destroy(p); }
  operator cadinterp_optimize_problem*() const { return p; }
};

const OpenedAsset* asset(int K, int degree, std::array<double, 5> t = kTarget, bool fail = false) {
  std::string error;
  const OpenedAsset* a = box_asset(K, degree, t, fail, &error);
  EXPECT_TRUE(a) << error;
  return a;
}

// argmin over x0 in [0,1] of f (unimodal here): golden-section search to 1e-10.
template <class F>
double golden(F f) {
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = 0.0, b = 1.0;
  while (b - a > 1e-10) {
    const double c = b - g * (b - a), d = a + g * (b - a);
    (f(c) < f(d) ? b : a) = f(c) < f(d) ? d : c;
  }
  return 0.5 * (a + b);
}

TEST(Optimize, GradientsOfEveryQuantityMatchCentralDifferences) {
  const OpenedAsset* a = asset(3, 3);
  ASSERT_TRUE(a);
  Problem p(a->asset);
  const char* quantities[] = {"volume",
                              "mass(2.5)",
                              "area",
                              "frontal_area(0.3, 0.2, 1)",
                              "centroid_z",
                              "inertia_zz(2)",
                              "inertia_xz",
                              "integral(q)",
                              "integral(s)",
                              "region_integral(q, top)",
                              "region_integral(s, top)",
                              "region_area(top)",
                              "max(q)",
                              "max(s, p=4)",
                              "max(q, ks=20)",
                              "2*integral(q) - 0.5*area",
                              "output(brep_volume)",
                              "exact_integral_q",
                              "2*output(exact_integral_q) - brep_volume + volume"};
  for (const char* q : quantities) {
    int f = -1;
    ASSERT_EQ(cadinterp_optimize_add_constraint(p, -HUGE_VAL, HUGE_VAL, &f), CADINTERP_OK);
    ASSERT_EQ(cadinterp_optimize_parse(p, f, q), CADINTERP_OK)
        << q << ": " << cadinterp_optimize_error(p);
  }
  const int n = 1 + cadinterp_optimize_constraint_count(p);
  const double x[3] = {1.0 / 3.0, 2.0 / 3.0, 0.45};
  std::vector<double> v(n), g(3 * n), vp(n), vm(n);
  ASSERT_EQ(cadinterp_optimize_evaluate(p, x, v.data(), g.data()), CADINTERP_OK);
  for (int d = 0; d < 3; ++d) {
    const double h = 1e-3;
    double xp[3] = {x[0], x[1], x[2]}, xm[3] = {x[0], x[1], x[2]};
    xp[d] += h;
    xm[d] -= h;
    ASSERT_EQ(cadinterp_optimize_evaluate(p, xp, vp.data(), nullptr), CADINTERP_OK);
    ASSERT_EQ(cadinterp_optimize_evaluate(p, xm, vm.data(), nullptr), CADINTERP_OK);
    for (int f = 1; f < n; ++f) {
      const double fd = (vp[f] - vm[f]) / (2 * h);
      // Float rounding of the blended mesh (~1e-7 relative) over 2h bounds what fd can resolve.
      EXPECT_NEAR(g[3 * f + d], fd, 5e-4 * (std::fabs(fd) + std::fabs(v[f])) + 2e-4)
          << quantities[f - 1] << ", d = " << d;
    }
  }
  // Closed forms at x (the shape is exact, the fields to the interpolation's accuracy).
  const BoxHost& h = *a->host;
  const double max_q = 1.0 + h.misfit(x) + BoxHost::height(x);
  EXPECT_NEAR(v[1], BoxHost::height(x), 1e-5);
  EXPECT_NEAR(v[8], h.integral_q(x), 0.1);
  EXPECT_NEAR(v[10], h.top_integral_q(x), 0.1);
  EXPECT_NEAR(v[12], 1.0, 1e-5);
  EXPECT_GE(v[13], max_q - 0.1) << "p-norm >= max";
  EXPECT_LE(v[13], max_q * std::pow(27.0, 1.0 / 8.0) + 0.1) << "p-norm <= N^(1/p) max";
  EXPECT_GE(v[15], max_q - 0.1) << "KS >= max";
  EXPECT_LE(v[15], max_q + std::log(27.0) / 20.0 + 0.1) << "KS <= max + ln(N) / rho";
}

// Point i (1-based) of the Halton sequence in [0,1]^K (bases 2, 3, 5, 7, 11).
void halton(int i, int K, double* x) {
  static const int kPrimes[5] = {2, 3, 5, 7, 11};
  for (int d = 0; d < K; ++d) {
    double f = 1.0, r = 0.0;
    for (int n = i; n > 0; n /= kPrimes[d]) f /= kPrimes[d], r += f * (n % kPrimes[d]);
    x[d] = r;
  }
}

// The minimizer of integral(q) over the box: x_d = t_d for d >= 1, x0 by a 1-D search.
std::vector<double> known_minimizer(const BoxHost& h, int K) {
  std::vector<double> truth(kTarget.begin(), kTarget.begin() + K);
  truth[0] = golden([&](double x0) {
    truth[0] = x0;
    return h.integral_q(truth.data());
  });
  return truth;
}

// The interpolant's accuracy on integral(q): max |interpolated - closed form| over 200 points
// of a Halton sequence in the box (fixed parameters at their value).
double interpolation_error(cadinterp_optimize_problem* p, const BoxHost& h, int K, int fixed = -1,
                           double fixed_value = 0) {
  double worst = 0.0;
  for (int i = 1; i <= 200; ++i) {
    double x[5];
    halton(i, K, x);
    if (fixed >= 0) x[fixed] = fixed_value;
    double v[4];
    EXPECT_EQ(cadinterp_optimize_evaluate(p, x, v, nullptr), CADINTERP_OK);
    worst = std::max(worst, std::fabs(v[0] - h.integral_q(x)));
  }
  return worst;
}

// Where the interpolant's minimizer x* may lie, given its sup error eps against the true J:
// J(x*) <= J(x_true) + 2 eps, and J is strongly convex with modulus >= 1 on the box (its Hessian
// is 2h in x_1.. and 2u + 2h + 1/4 >= 1 in x0), so |x* - x_true| <= sqrt(4 eps). eps is
// measured at 200 points, not a supremum: a factor 1.5 of margin.
void expect_minimizer(const BoxHost& h, const cadinterp_optimize_result& r,
                      const std::vector<double>& truth, double eps, const std::string& what) {
  const double e = 1.5 * eps;
  const double gap = h.integral_q(r.x) - h.integral_q(truth.data());
  EXPECT_LE(gap, 2 * e + 1e-9) << what;
  double dx = 0.0;
  for (std::size_t d = 0; d < truth.size(); ++d) dx = std::max(dx, std::fabs(r.x[d] - truth[d]));
  EXPECT_LE(dx, std::sqrt(4 * e) + 1e-6) << what;
  EXPECT_NEAR(r.objective, h.integral_q(r.x), e) << what;
  std::printf(
      "[result] %s: eps %.2e, |x*-x|inf %.2e, J(x*)-J(x) %.2e, %d iterations, %d "
      "evaluations, %s\n",
      what.c_str(), eps, dx, gap, r.iterations, r.evaluations, r.status);
}

struct Case {
  int K, degree;
};

class Minimizer : public ::testing::TestWithParam<Case> {};

// min integral(q) (known_minimizer).
TEST_P(Minimizer, FindsTheKnownMinimizer) {
  const Case c = GetParam();
  const OpenedAsset* a = asset(c.K, c.degree);
  ASSERT_TRUE(a);
  const BoxHost& h = *a->host;
  Problem p(a->asset);
  ASSERT_EQ(cadinterp_optimize_parse(p, 0, "integral(q)"), CADINTERP_OK);
  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  ASSERT_EQ(cadinterp_optimize_solve(p, nullptr, &r), CADINTERP_OK) << cadinterp_optimize_error(p);
  const std::vector<double> truth = known_minimizer(h, c.K);
  expect_minimizer(h, r, truth, interpolation_error(p, h, c.K),
                   "K=" + std::to_string(c.K) + (c.degree == 1 ? " linear" : " cubic"));
  EXPECT_EQ(r.linear_asset, c.degree == 1);
  EXPECT_EQ(std::string(r.note).empty(), c.degree == 3);
  EXPECT_GT(r.path_length, 1);
  EXPECT_GT(r.evaluations, r.iterations);
  EXPECT_LE(r.constraint_violation, 0.0);
  EXPECT_EQ(r.refused_evaluations, 0) << "no wall in this asset";
}

// Per-sample outputs against the host's closed forms and against the same quantities of the
// interpolated mesh, at 200 Halton points; then the minimizer of the output objective.
TEST_P(Minimizer, OutputsMatchTheHostAndFindTheMinimizer) {
  const Case c = GetParam();
  const OpenedAsset* a = asset(c.K, c.degree);
  ASSERT_TRUE(a);
  const BoxHost& h = *a->host;
  Problem p(a->asset);
  ASSERT_EQ(cadinterp_optimize_parse(p, 0, "exact_integral_q"), CADINTERP_OK);
  for (const char* q : {"volume", "output(brep_volume)", "integral(q)"}) {
    int f = -1;
    ASSERT_EQ(cadinterp_optimize_add_constraint(p, -HUGE_VAL, HUGE_VAL, &f), CADINTERP_OK);
    ASSERT_EQ(cadinterp_optimize_parse(p, f, q), CADINTERP_OK);
  }
  double err[4] = {0, 0, 0, 0};  // output J, mesh volume, output volume, mesh J
  for (int i = 1; i <= 200; ++i) {
    double x[5], v[4];
    halton(i, c.K, x);
    ASSERT_EQ(cadinterp_optimize_evaluate(p, x, v, nullptr), CADINTERP_OK);
    const double truth[4] = {h.integral_q(x), BoxHost::height(x), BoxHost::height(x),
                             h.integral_q(x)};
    for (int k = 0; k < 4; ++k) err[k] = std::max(err[k], std::fabs(v[k] - truth[k]) / truth[k]);
  }
  const std::string what = "K=" + std::to_string(c.K) + (c.degree == 1 ? " linear" : " cubic");
  std::printf(
      "[outputs] %s: max relative error vs host, output exact_integral_q %.2e, mesh integral(q) "
      "%.2e, output brep_volume %.2e, mesh volume %.2e\n",
      what.c_str(), err[0], err[3], err[2], err[1]);
  // h is linear in x0 and every basis reproduces linear functions: the output is exact to double
  // rounding, the mesh volume to the float mesh's (sums of ~1e-7 relative values).
  EXPECT_LT(err[1], 1e-5);
  EXPECT_LT(err[2], 1e-12);
  // The build holds outputs to field_tolerance (2e-3) of their magnitude at its check points,
  // times the report's max_error (above 1 where the sample budget ran out: 1..109 here); between
  // check points the error is of the same order (measured at most 1.0x that product).
  EXPECT_LT(err[0], 3 * 2e-3 * std::max(1.0, a->report.max_error)) << what;
  // The same interpolation error as the mesh's field integral (measured within 10 % of it).
  EXPECT_LT(err[0], 1.5 * err[3] + 1e-6) << what;

  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  Problem only(a->asset);
  ASSERT_EQ(cadinterp_optimize_parse(only, 0, "output(exact_integral_q)"), CADINTERP_OK);
  ASSERT_EQ(cadinterp_optimize_solve(only, nullptr, &r), CADINTERP_OK)
      << cadinterp_optimize_error(only);
  const std::vector<double> truth = known_minimizer(h, c.K);
  // err[0] is relative; J <= 1.5 (1 + 5 + 0.75) bounds the absolute error.
  expect_minimizer(h, r, truth, err[0] * 10.0, what + ", output(exact_integral_q)");
}

INSTANTIATE_TEST_SUITE_P(KAndDegree, Minimizer,
                         ::testing::Values(Case{2, 1}, Case{3, 1}, Case{4, 1}, Case{5, 1},
                                           Case{2, 3}, Case{3, 3}, Case{4, 3}, Case{5, 3}),
                         [](const auto& p) {
                           return "K" + std::to_string(p.param.K) +
                                  (p.param.degree == 1 ? "Linear" : "Cubic");
                         });

// volume >= 1.4 is active (h >= 1.4: x0 >= 0.8, beyond the unconstrained x0), and a fixed
// parameter moves the optimum of the free ones.
void constrained_and_fixed(int degree) {
  const OpenedAsset* a = asset(3, degree);
  ASSERT_TRUE(a);
  const BoxHost& h = *a->host;
  Problem p(a->asset);
  ASSERT_EQ(cadinterp_optimize_parse(p, 0, "integral(q)"), CADINTERP_OK);
  int f = -1;
  ASSERT_EQ(cadinterp_optimize_parse_constraint(p, "volume >= 1.4", &f), CADINTERP_OK);
  EXPECT_EQ(f, 1);
  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  ASSERT_EQ(cadinterp_optimize_solve(p, nullptr, &r), CADINTERP_OK);
  const double eps = interpolation_error(p, h, 3);
  EXPECT_NEAR(r.x[0], 0.8, 1e-5) << "on the constraint (the shape is exact)";
  EXPECT_NEAR(r.constraints[0], 1.4, 1e-5);
  const std::string what = degree == 1 ? "K=3 linear" : "K=3 cubic";
  expect_minimizer(h, r, {0.8, kTarget[1], kTarget[2]}, eps, what + ", volume >= 1.4");
  EXPECT_LE(r.constraint_violation, 1e-6);
  // Fix x1 = 0.2 (far from its target): x0 moves with the misfit.
  ASSERT_EQ(cadinterp_optimize_set_bounds(p, 1, 0.2, 0.2), CADINTERP_OK);
  ASSERT_EQ(cadinterp_optimize_parse_constraint(p, "volume <= 2", nullptr), CADINTERP_OK);
  Problem q(a->asset);
  ASSERT_EQ(cadinterp_optimize_parse(q, 0, "integral(q)"), CADINTERP_OK);
  ASSERT_EQ(cadinterp_optimize_set_bounds(q, 1, 0.2, 0.2), CADINTERP_OK);
  ASSERT_EQ(cadinterp_optimize_solve(q, nullptr, &r), CADINTERP_OK);
  std::vector<double> truth = {0, 0.2, kTarget[2]};
  truth[0] = golden([&](double x0) {
    truth[0] = x0;
    return h.integral_q(truth.data());
  });
  EXPECT_EQ(r.x[1], 0.2) << "fixed";
  expect_minimizer(h, r, truth, interpolation_error(q, h, 3, 1, 0.2), what + ", a = 0.2 fixed");
}

TEST(Optimize, ActiveConstraintAndFixedParameterLinear) { constrained_and_fixed(1); }
TEST(Optimize, ActiveConstraintAndFixedParameterCubic) { constrained_and_fixed(3); }

// A constraint of large magnitude (a volume in mm^3 is 1e5-1e6): the same active constraint as
// above in units 1e8 times smaller. Feasibility is judged relative to a constraint's size (an
// absolute tolerance lies below the float noise of a large blended quantity: on the press Ipopt
// then reported "the constraints appear infeasible" at a point that met them), so the solve does
// not depend on the constraint's units: the same x*, and the constraint met to 1e-6 of its bound.
TEST(Optimize, ConstraintsOfLargeMagnitudeConverge) {
  const OpenedAsset* a = asset(3, 3);
  ASSERT_TRUE(a);
  // x* and the constraint's value per solve (the result's arrays live as long as its problem).
  std::vector<double> x[2], value(2), violation(2);
  const char* constraints[2] = {"volume >= 1.4", "1e8 * volume >= 1.4e8"};
  for (int k = 0; k < 2; ++k) {
    Problem p(a->asset);
    ASSERT_EQ(cadinterp_optimize_parse(p, 0, "integral(q)"), CADINTERP_OK);
    ASSERT_EQ(cadinterp_optimize_parse_constraint(p, constraints[k], nullptr), CADINTERP_OK);
    cadinterp_optimize_result r{};
    r.struct_size = sizeof r;
    ASSERT_EQ(cadinterp_optimize_solve(p, nullptr, &r), CADINTERP_OK);
    EXPECT_TRUE(r.converged) << constraints[k] << ": " << r.status;
    x[k].assign(r.x, r.x + 3);
    value[static_cast<std::size_t>(k)] = r.constraints[0];
    violation[static_cast<std::size_t>(k)] = r.constraint_violation;
  }
  for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(x[1][i], x[0][i], 1e-9) << "x" << i;
  EXPECT_GE(value[1], 1.4e8 * (1 - 1e-6));
  EXPECT_LE(violation[1], 1.4e8 * 1e-6);
}

// The host fails where x0 > 0.75 and x1 > 0.75, and the minimizer of the top integral lies in
// that corner: the optimizer ends at a point the runtime evaluates, and every iterate is one.
TEST(Optimize, InfeasibleCornerIsAWall) {
  // Minimizer of 1 + (x0 - 1.2)^2 + (x1 - 0.95)^2 + h: (0.95, 0.95).
  const OpenedAsset* a = asset(2, 3, {1.2, 0.95, 0, 0, 0}, true);
  ASSERT_TRUE(a);
  Problem p(a->asset);
  ASSERT_EQ(cadinterp_optimize_parse(p, 0, "region_integral(q, top)"), CADINTERP_OK);
  const double corner[2] = {0.95, 0.95};
  int element = -1, feasible = 1;
  ASSERT_EQ(cadinterp_locate(a->asset, corner, &element, &feasible), CADINTERP_OK);
  ASSERT_EQ(feasible, 0) << "the asset has the infeasible corner";
  double v[1];
  EXPECT_EQ(cadinterp_optimize_evaluate(p, corner, v, nullptr), CADINTERP_E_INFEASIBLE);
  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  const double start[2] = {0.2, 0.3};
  cadinterp_optimize_options o;
  cadinterp_optimize_options_init(&o);
  o.start = start;
  ASSERT_EQ(cadinterp_optimize_solve(p, &o, &r), CADINTERP_OK) << cadinterp_optimize_error(p);
  ASSERT_EQ(cadinterp_locate(a->asset, r.x, &element, &feasible), CADINTERP_OK);
  EXPECT_EQ(feasible, 1) << "x* = " << r.x[0] << ", " << r.x[1] << " (" << r.status << ")";
  for (int i = 0; i < r.path_length; ++i) {
    ASSERT_EQ(cadinterp_locate(a->asset, r.path + 2 * i, &element, &feasible), CADINTERP_OK);
    EXPECT_EQ(feasible, 1) << "iterate " << i;
  }
  EXPECT_LT(r.objective, r.path_objective[0] - 0.2) << "it moved well towards the corner";
  EXPECT_GT(r.x[0] + r.x[1], 1.3);
  EXPECT_GT(r.refused_evaluations, 0) << "the iterates ran into the wall";
  std::printf("[result] wall: x* = (%.4f, %.4f), %d of %d evaluations refused, %s\n", r.x[0],
              r.x[1], r.refused_evaluations, r.evaluations, r.status);
  // A start inside the wall is refused.
  o.start = corner;
  EXPECT_EQ(cadinterp_optimize_solve(p, &o, &r), CADINTERP_E_INFEASIBLE);
  EXPECT_NE(std::string(cadinterp_optimize_error(p)).find("start"), std::string::npos);
}

TEST(Optimize, MultistartIsDeterministicAndKeepsTheBest) {
  const OpenedAsset* a = asset(2, 3);
  ASSERT_TRUE(a);
  std::vector<double> first;
  for (int run = 0; run < 2; ++run) {
    Problem p(a->asset);
    ASSERT_EQ(cadinterp_optimize_parse(p, 0, "integral(q) + 0.2*max(s, ks=30)"), CADINTERP_OK);
    cadinterp_optimize_options o;
    cadinterp_optimize_options_init(&o);
    o.multistart = 4;
    cadinterp_optimize_result r{};
    r.struct_size = sizeof r;
    ASSERT_EQ(cadinterp_optimize_solve(p, &o, &r), CADINTERP_OK);
    EXPECT_EQ(r.starts, 4);
    if (run == 0)
      first.assign(r.x, r.x + 2);
    else
      EXPECT_EQ(std::vector<double>(r.x, r.x + 2), first);
  }
}

int stop_at_two(void*, int, int iteration, const double*, double, double, double) {
  return iteration >= 2;
}

TEST(Optimize, ProgressCanStopAndBadInputIsRefused) {
  const OpenedAsset* a = asset(2, 1);
  ASSERT_TRUE(a);
  Problem p(a->asset);
  ASSERT_EQ(cadinterp_optimize_parse(p, 0, "integral(q)"), CADINTERP_OK);
  cadinterp_optimize_options o;
  cadinterp_optimize_options_init(&o);
  o.progress = &stop_at_two;
  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  ASSERT_EQ(cadinterp_optimize_solve(p, &o, &r), CADINTERP_OK);
  EXPECT_EQ(std::string(r.status), "stopped by the caller");
  EXPECT_FALSE(r.converged);
  const double outside[2] = {1.5, 0.5};
  o.progress = nullptr;
  o.start = outside;
  EXPECT_EQ(cadinterp_optimize_solve(p, &o, &r), CADINTERP_E_INVALID_ARGUMENT);
  o.start = nullptr;
  o.multistart = 0;
  EXPECT_EQ(cadinterp_optimize_solve(p, &o, &r), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_optimize_set_bounds(p, 0, -1.0, 0.5), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_optimize_set_bounds(p, 5, 0.0, 0.5), CADINTERP_E_INVALID_ARGUMENT);
  cadinterp_optimize_term t;
  cadinterp_optimize_term_init(&t, CADINTERP_OPTIMIZE_MAX_PNORM);
  t.field = 0;
  t.parameter = 0.5;
  EXPECT_EQ(cadinterp_optimize_add_term(p, 0, &t), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_STREQ(cadinterp_optimize_error(p), "p-norm needs p >= 1");
  t.parameter = 8;
  EXPECT_EQ(cadinterp_optimize_add_term(p, 3, &t), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_optimize_add_term(p, 0, &t), CADINTERP_OK);
  r.struct_size = 8;
  EXPECT_EQ(cadinterp_optimize_solve(p, nullptr, &r), CADINTERP_E_INVALID_ARGUMENT);
}

}  // namespace
