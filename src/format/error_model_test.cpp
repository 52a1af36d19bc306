// The linear error model's shape (format/error_model.h) against the exact error of multilinear
// interpolation of quadratics, computed here by interpolating them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "format/error_model.h"

namespace cadinterp::format {
namespace {

// Multilinear interpolation on the unit box of f(t) = sum_d a[v][d] t_d^2, one quadratic per
// "vertex" v, minus f: the error at t of each vertex.
std::vector<double> interpolation_errors(const std::vector<std::vector<double>>& a, int K,
                                         const double* t) {
  std::vector<double> err;
  for (const std::vector<double>& av : a) {
    auto f = [&](const double* p) {
      double s = 0;
      for (int d = 0; d < K; ++d) s += av[static_cast<std::size_t>(d)] * p[d] * p[d];
      return s;
    };
    double interpolated = 0;
    for (int corner = 0; corner < (1 << K); ++corner) {
      double p[8], w = 1;
      for (int d = 0; d < K; ++d) {
        p[d] = (corner >> d) & 1;
        w *= p[d] > 0 ? t[d] : 1 - t[d];
      }
      interpolated += w * f(p);
    }
    err.push_back(std::abs(interpolated - f(t)));
  }
  return err;
}

// The model row the builder measures: the largest error over the vertices at the centre, and
// per direction the largest midpoint error along it through the centre.
std::vector<double> measured_row(const std::vector<std::vector<double>>& a, int K) {
  std::vector<double> row(static_cast<std::size_t>(K + 1), 0.0),
      c(static_cast<std::size_t>(K), 0.5);
  for (double e : interpolation_errors(a, K, c.data())) row[0] = std::max(row[0], e);
  for (int d = 0; d < K; ++d)
    for (const std::vector<double>& av : a)  // (f(c - e_d/2) + f(c + e_d/2)) / 2 - f(c)
      row[1 + static_cast<std::size_t>(d)] = std::max(
          row[1 + static_cast<std::size_t>(d)], std::abs(av[static_cast<std::size_t>(d)]) / 4);
  return row;
}

double largest(const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); }

// One vertex, curvatures of one sign: the shape is the exact error everywhere (the estimate
// scaled to the centre error is the per-direction sum, which is exact for a quadratic).
TEST(ErrorModel, LinearShapeIsExactForAQuadraticOfOneSign) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  for (int K = 1; K <= 4; ++K) {
    std::vector<std::vector<double>> a(1);
    for (int d = 0; d < K; ++d) a[0].push_back(0.1 + u(rng));
    const std::vector<double> row = measured_row(a, K);
    for (int i = 0; i < 50; ++i) {
      double t[4];
      for (int d = 0; d < K; ++d) t[d] = u(rng);
      EXPECT_NEAR(error_model_estimate(row.data(), K, false, t),
                  largest(interpolation_errors(a, K, t)), 1e-12)
          << "K " << K;
    }
    EXPECT_NEAR(error_model_max(row.data(), K), row[0], 1e-15);
  }
}

// Several vertices, each curving along one direction only: the per-direction sum is K times
// the error at the centre, and the centre-scaled shape still bounds the error everywhere, as
// does a saddle in two directions, whose error at the centre cancels. (A saddle with more
// directions on one side, such as (2, -1, -1), is not bounded without the safety factor: the
// row does not say which directions share a sign.)
TEST(ErrorModel, LinearShapeBoundsSeparatedCurvaturesAndSaddles) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0, 1);
  for (int K = 2; K <= 4; ++K) {
    std::vector<std::vector<double>> separated(
        static_cast<std::size_t>(K), std::vector<double>(static_cast<std::size_t>(K), 0.0));
    for (int d = 0; d < K; ++d)
      separated[static_cast<std::size_t>(d)][static_cast<std::size_t>(d)] = 1;
    std::vector<std::vector<double>> saddle(1,
                                            std::vector<double>(static_cast<std::size_t>(K), 0.0));
    saddle[0][0] = 1;
    saddle[0][1] = -1;
    for (const auto& a : {separated, saddle}) {
      const std::vector<double> row = measured_row(a, K);
      double sum = 0;
      for (int d = 0; d < K; ++d) sum += row[1 + static_cast<std::size_t>(d)];
      for (int i = 0; i < 200; ++i) {
        double t[4];
        for (int d = 0; d < K; ++d) t[d] = u(rng);
        const double truth = largest(interpolation_errors(a, K, t));
        const double est = error_model_estimate(row.data(), K, false, t);
        EXPECT_GE(est, truth - 1e-12) << "K " << K;
        double unscaled = 0;  // the per-direction sum, the shape's upper bound
        for (int d = 0; d < K; ++d)
          unscaled += row[1 + static_cast<std::size_t>(d)] * 4 * t[d] * (1 - t[d]);
        EXPECT_LE(est, unscaled + 1e-12) << "K " << K;
      }
      EXPECT_LT(row[0], sum) << "the directions' largest errors are at different vertices";
      const std::vector<double> c(static_cast<std::size_t>(K), 0.5);
      if (row[0] > 0) {  // exact where it was measured, not the sum
        EXPECT_NEAR(error_model_estimate(row.data(), K, false, c.data()), row[0], 1e-15);
      }
    }
  }
}

// Unknown centre: unknown estimate; unmeasured directions take the centre error; no direction
// error: the centre error spread evenly, zero at the corners. The reported value adds the
// quantity's floor to a linear estimate; a cubic constant already holds it, so the floor only
// bounds it from below.
TEST(ErrorModel, LinearRowsWithMissingOrZeroEntries) {
  const double t[2] = {0.5, 0.5}, corner[2] = {0, 1}, edge[2] = {0.5, 0};
  const double unknown[3] = {-1, 0.1, 0.1}, zero_dirs[3] = {0.2, 0, 0},
               missing[3] = {0.2, -1, 0.05};
  EXPECT_LT(error_model_estimate(unknown, 2, false, t), 0);
  EXPECT_LT(error_model_max(unknown, 2), 0);
  EXPECT_DOUBLE_EQ(error_model_estimate(zero_dirs, 2, false, t), 0.2);
  EXPECT_DOUBLE_EQ(error_model_estimate(zero_dirs, 2, false, corner), 0.0);
  EXPECT_DOUBLE_EQ(error_model_estimate(zero_dirs, 2, false, edge), 0.1);
  EXPECT_DOUBLE_EQ(error_model_estimate(missing, 2, false, t), 0.2);
  EXPECT_DOUBLE_EQ(error_model_estimate(missing, 2, false, edge), 0.2);
  // Each quantity's floor adds unscaled; only the geometry's estimate has float storage's least.
  EXPECT_DOUBLE_EQ(error_model_reported(0.1, false, false, 0.5),
                   0.1 * kErrorModelSafetyLinear + 0.5);
  EXPECT_DOUBLE_EQ(error_model_reported(0.1, false, true, 0.5),
                   0.1 * kErrorModelSafetyLinear + 0.5);
  EXPECT_DOUBLE_EQ(error_model_reported(0.1, true, false, 0.5), 0.5);
  EXPECT_DOUBLE_EQ(error_model_reported(0.1, true, true, 0.05), 0.1 * kErrorModelSafetyCubic);
  EXPECT_DOUBLE_EQ(error_model_with_floor(0.1, false, 0.05), 0.1 + 0.05);
  EXPECT_DOUBLE_EQ(error_model_with_floor(0.1, true, 0.05), 0.1);
  EXPECT_DOUBLE_EQ(error_model_with_floor(0.1, true, 0.5), 0.5);
  EXPECT_DOUBLE_EQ(error_model_reported(0.0, false, true, 0.0), kGeometryFloor);
  EXPECT_EQ(error_model_reported(0.0, false, false, 0.0), 0.0);
  EXPECT_LT(error_model_reported(-1.0, false, false, 0.5), 0) << "unknown stays unknown";
  EXPECT_LT(error_model_reported(-1.0, false, true, 0.5), 0);
  const double huge = std::numeric_limits<double>::max();
  EXPECT_EQ(error_model_reported(huge, false, true, huge), huge) << "overflow stays finite";
}

}  // namespace
}  // namespace cadinterp::format
