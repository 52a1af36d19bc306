// The error model's calibration on held-out points (calibration.h): the order statistics, each
// point's need of a factor or a floor, and the choice between them, on needs and points given
// here. The calibration of a whole build against its host is in error_estimate_test.cpp
// (ErrorCalibration.HeldOutPointsScaleEveryElementsModel).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "builder/calibration.h"
#include "format/error_model.h"

namespace {

using namespace cadinterp;

// The order statistics that bracket the 90th percentile of n draws with 95 % confidence, against
// exact binomial sums (computed apart): the k-th smallest of n is above the percentile with
// probability P(Binomial(n, 0.9) <= k - 1), below it with P(Binomial(n, 0.9) >= k).
TEST(ErrorCalibration, RanksBracketTheQuantile) {
  const struct {
    int n, lower, upper;
  } cases[] = {{28, 22, 0}, {29, 23, 29}, {40, 33, 40}, {54, 45, 53}, {60, 50, 59}, {100, 85, 96}};
  for (const auto& c : cases) {
    int lower = -1, upper = -1;
    builder::calibration_ranks(c.n, lower, upper);
    EXPECT_EQ(lower, c.lower) << "n = " << c.n;
    EXPECT_EQ(upper, c.upper) << "n = " << c.n;
  }
}

// A point's need is the least factor whose reported estimate (the runtime's formula) reaches
// the point's error: linear adds the floor, cubic takes the larger, the geometry's floor is
// never below kGeometryFloor.
TEST(ErrorCalibration, NeedIsTheLeastFactorThatBounds) {
  auto reported = [](double c, double est, bool cubic, bool geometry, double floor) {
    return format::error_model_reported(c * est, cubic, geometry, floor);
  };
  const struct {
    double est;
    bool cubic, geometry;
    double floor, error;
  } cases[] = {{0.01, false, false, 0.002, 0.016},
               {0.01, false, false, 0.0, 0.05},
               {0.01, true, false, 0.004, 0.03},
               {2e-4, false, true, 1e-5, 1e-3},
               {2e-4, true, true, 0.0, 4e-5}};
  for (const auto& c : cases) {
    const double need = builder::calibration_need(c.est, c.cubic, c.geometry, c.floor, c.error);
    ASSERT_GT(need, 0);
    EXPECT_GE(reported(need, c.est, c.cubic, c.geometry, c.floor), c.error);
    EXPECT_LT(reported(need * (1 - 1e-9), c.est, c.cubic, c.geometry, c.floor), c.error);
  }
  // Linear: 1.4 c 0.01 + 0.002 >= 0.016 at c = 1 exactly.
  EXPECT_NEAR(builder::calibration_need(0.01, false, false, 0.002, 0.016), 1.0, 1e-9);
  // The floor alone bounds: 0 (the cubic floor, the geometry's float floor).
  EXPECT_EQ(builder::calibration_need(0.01, true, false, 0.02, 0.015), 0.0);
  EXPECT_EQ(builder::calibration_need(0.0, false, true, 0.0, 0.5 * format::kGeometryFloor), 0.0);
  // Nothing to scale, or rounding noise: infinite.
  EXPECT_TRUE(std::isinf(builder::calibration_need(0.0, false, false, 0.001, 0.002)));
  EXPECT_TRUE(std::isinf(builder::calibration_need(1e-9, false, false, 0.0, 0.002)));
  EXPECT_NEAR(builder::calibration_need(1e-6, false, false, 0.0, 1.4e-6), 1.0, 1e-9);
}

// The built-in factor stays unless the needs reject it with confidence; then the upper
// bracket, no less than `least`; too few points or an infinite bracket change nothing.
TEST(ErrorCalibration, FactorKeepsTheBuiltInUnlessTheNeedsRejectIt) {
  auto needs_of = [](int n, double lo, double hi) {
    std::vector<double> v;
    for (int i = 0; i < n; ++i) v.push_back(lo + (hi - lo) * i / (n - 1));
    return v;
  };
  // 60 needs from 0.1 to 1.1: 1 bounds 54 of them (the 50th is 0.93, the 59th 1.08): kept.
  std::vector<double> v = needs_of(60, 0.1, 1.1);
  EXPECT_EQ(builder::calibration_factor(v, 0.5), 1.0);
  // Every need at most 0.4: the built-in factor overstates; the 59th need.
  v = needs_of(60, 0.05, 0.4);
  std::vector<double> sorted = v;
  EXPECT_DOUBLE_EQ(builder::calibration_factor(v, 0.1), sorted[58]);
  // ... but no less than `least`.
  v = needs_of(60, 0.05, 0.4);
  EXPECT_EQ(builder::calibration_factor(v, 0.7), 0.7);
  // Needs from 0.5 to 3 (the 50th is 2.58): the built-in falls short; the 59th need.
  v = needs_of(60, 0.5, 3.0);
  sorted = v;
  EXPECT_DOUBLE_EQ(builder::calibration_factor(v, 0.7), sorted[58]);
  // Shuffled input: sorted first.
  v = needs_of(60, 0.5, 3.0);
  std::reverse(v.begin(), v.end());
  EXPECT_DOUBLE_EQ(builder::calibration_factor(v, 0.7), sorted[58]);
  // 28 points cannot bracket the 90th percentile with 95 % confidence.
  v = needs_of(28, 2.0, 3.0);
  EXPECT_EQ(builder::calibration_factor(v, 0.7), 1.0);
  // Two points of 60 with a zero estimate and an error: the 59th need is infinite.
  v = needs_of(60, 0.5, 3.0);
  v[0] = v[1] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(builder::calibration_factor(v, 0.7), 1.0);
}

// Where the points reject the built-in factor as too small, a floor serves instead when the
// errors do not follow the model's shape, and the factor when they do.
TEST(ErrorCalibration, FloorServesWhereTheErrorsDoNotFollowTheShape) {
  using builder::CalibrationPoint;
  // Linear: 1.4 x 0.01 + 0.002 + F >= 0.02 at F = 0.004.
  EXPECT_NEAR(builder::calibration_floor_need({0.01, false, false, 0.002, 0.02}), 0.004, 1e-12);
  // Cubic: max(1.15 x 0.01, 0.004 + F) >= 0.03 at F = 0.026.
  EXPECT_NEAR(builder::calibration_floor_need({0.01, true, false, 0.004, 0.03}), 0.026, 1e-12);
  EXPECT_EQ(builder::calibration_floor_need({0.01, false, false, 0.002, 0.016}), 0.0);
  EXPECT_EQ(builder::calibration_floor_need({0.0, false, false, 0.0, 0.0}), 0.0);
  const double s = format::kErrorModelSafetyLinear;

  // The shape follows the errors, the constant is half what it should be: every point needs
  // the factor 2, while the floors needed spread with the errors. The factor.
  std::vector<CalibrationPoint> p;
  for (int i = 0; i < 60; ++i) {
    const double e = 0.01 * (1 + i);
    p.push_back({e / (2 * s), false, false, 0.0, e});
  }
  builder::CalibrationChoice c = builder::calibrate_quantity(p, 0.7);
  EXPECT_NEAR(c.factor, 2.0, 1e-9);
  EXPECT_EQ(c.floor, 0.0);

  // A step: the error is 0.1 everywhere while the shaped estimate falls to 0 at the samples.
  // The factor would be 59 (the 59th need) and the estimates 29.5x the error at the median; the
  // floor that bounds 59 of the 60 points is the error less the second smallest estimate.
  p.clear();
  for (int i = 0; i < 60; ++i) p.push_back({0.1 / s * i / 59.0, false, false, 0.0, 0.1});
  c = builder::calibrate_quantity(p, 0.7);
  EXPECT_EQ(c.factor, 1.0);
  EXPECT_NEAR(c.floor, 0.1 - 0.1 / 59.0, 1e-9);
  int bounded = 0;
  for (const CalibrationPoint& q : p)
    bounded += format::error_model_reported(q.est, false, false, q.floor + c.floor) >= q.error;
  EXPECT_EQ(bounded, 59);

  // Two points where the estimate is 0 and the quantity errs: the factor's bracket is infinite
  // and no factor serves; the floor does (the 59th floor need is one of theirs, the error).
  p.clear();
  for (int i = 0; i < 60; ++i) p.push_back({i < 2 ? 0.0 : 0.01, false, false, 0.0, 0.02});
  c = builder::calibrate_quantity(p, 0.7);
  EXPECT_EQ(c.factor, 1.0);
  EXPECT_NEAR(c.floor, 0.02, 1e-12);

  // Kept; lowered (no floor: the points do not ask for more); too few points.
  p.clear();
  for (int i = 0; i < 60; ++i) p.push_back({0.01, false, false, 0.0, 0.014 * (0.1 + i / 59.0)});
  c = builder::calibrate_quantity(p, 0.7);
  EXPECT_EQ(c.factor, 1.0);
  EXPECT_EQ(c.floor, 0.0);
  for (CalibrationPoint& q : p) q.error *= 0.3;
  c = builder::calibrate_quantity(p, 0.1);
  EXPECT_LT(c.factor, 1.0);
  EXPECT_EQ(c.floor, 0.0);
  p.resize(28);
  for (CalibrationPoint& q : p) q.error = 1.0;
  c = builder::calibrate_quantity(p, 0.7);
  EXPECT_EQ(c.factor, 1.0);
  EXPECT_EQ(c.floor, 0.0);
}

}  // namespace
