#include "core/bspline.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cadinterp::core {
namespace {

double value(Degree g, double t) {
  double v, dv;
  bspline_1d(g, t, false, &v, &dv);
  return v;
}

// Eq. 5 and Eq. 12: a B-spline equals the weighted sum of its half-width children.
TEST(Bspline, RefinementRelationsHoldPointwise) {
  for (Degree g : {Degree::Linear, Degree::Cubic}) {
    const RefinementMask m = refinement_mask(g);
    for (double t = -3.0; t <= 3.0; t += 0.0137) {
      double fine = 0.0;
      for (int i = 0; i < m.count; ++i)
        fine += m.weight[static_cast<std::size_t>(i)] * value(g, 2.0 * t - (m.first_offset + i));
      EXPECT_NEAR(value(g, t), fine, 1e-14) << "t=" << t;
    }
  }
}

TEST(Bspline, UniformPartitionOfUnityAndLinearReproduction) {
  for (Degree g : {Degree::Linear, Degree::Cubic})
    for (double t = 0.0; t < 1.0; t += 0.01) {
      double s = 0.0, lin = 0.0;
      for (int i = -3; i <= 4; ++i) {
        s += value(g, t - i);
        lin += i * value(g, t - i);
      }
      EXPECT_NEAR(s, 1.0, 1e-14);
      EXPECT_NEAR(lin, t, 1e-14);
    }
}

TEST(Bspline, DerivativeMatchesFiniteDifferences) {
  const double h = 1e-6;
  for (Degree g : {Degree::Linear, Degree::Cubic})
    for (double t = -2.5; t <= 2.5; t += 0.0731) {
      if (g == Degree::Linear && std::abs(t - std::round(t)) < 2 * h) continue;  // kink
      double v, dv;
      bspline_1d(g, t, false, &v, &dv);
      EXPECT_NEAR(dv, (value(g, t + h) - value(g, t - h)) / (2 * h), 1e-7) << "t=" << t;
    }
}

TEST(Bspline, OneSidedLimitsAtKnots) {
  double v, dv;
  bspline_1d(Degree::Linear, 0.0, false, &v, &dv);
  EXPECT_EQ(v, 1.0);
  EXPECT_EQ(dv, -1.0);
  bspline_1d(Degree::Linear, 0.0, true, &v, &dv);
  EXPECT_EQ(v, 1.0);
  EXPECT_EQ(dv, 1.0);
  bspline_1d(Degree::Linear, 1.0, true, &v, &dv);
  EXPECT_EQ(v, 0.0);
  EXPECT_EQ(dv, -1.0);
  bspline_1d(Degree::Linear, 1.0, false, &v, &dv);
  EXPECT_EQ(dv, 0.0);
  // Cubic is C2: both sides agree at every knot.
  for (int k = -2; k <= 2; ++k) {
    double v1, d1, v2, d2;
    bspline_1d(Degree::Cubic, k, false, &v1, &d1);
    bspline_1d(Degree::Cubic, k, true, &v2, &d2);
    EXPECT_NEAR(v1, v2, 1e-15);
    EXPECT_NEAR(d1, d2, 1e-15);
  }
}

}  // namespace
}  // namespace cadinterp::core
