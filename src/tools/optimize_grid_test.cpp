// Brute-force grids (optimize_grid.h) on closed-form functions: the points, the best point that
// meets the constraints, the counts, and the named errors.
#include "optimize_grid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace cadinterp::cli {
namespace {

TEST(OptimizeGrid, PointsSpanTheBoxWithExactEndsAndFixedValues) {
  const ParameterBox box{{0.1, 2.0, -3.0}, {0.7, 2.0, 5.0}};  // the middle parameter fixed
  const std::vector<double> x = grid_points(box, 3);
  ASSERT_EQ(x.size(), 9u * 3u);
  const double first[3] = {0.1, 2.0, -3.0}, second[3] = {0.1, 2.0, 1.0}, last[3] = {0.7, 2.0, 5.0};
  for (int d = 0; d < 3; ++d) {
    EXPECT_EQ(x[static_cast<std::size_t>(d)], first[d]);
    EXPECT_EQ(x[static_cast<std::size_t>(3 + d)], second[d]);  // the last parameter fastest
    EXPECT_EQ(x[static_cast<std::size_t>(24 + d)], last[d]);   // ends exactly, not rounded
  }
  for (std::size_t p = 0; p < 9; ++p) EXPECT_EQ(x[3 * p + 1], 2.0);
}

TEST(OptimizeGrid, TooFewOrTooManyPointsAreNamedErrors) {
  const ParameterBox box{{0, 0, 0}, {1, 1, 1}};
  EXPECT_THROW(grid_points(box, 1), std::invalid_argument);
  try {
    grid_points(box, 101);  // 101^3 > 1e6
    FAIL() << "no error for a grid of 1,030,301 points";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("more than 1000000 points"), std::string::npos);
  }
  EXPECT_EQ(grid_points(box, 100).size(), 3u * 1000000u);
}

// f = (x0 - 0.3)^2 + (x1 - 0.7)^2 subject to x0 + x1 <= 0.8, on [0, 1]^2 with 11 points per
// axis: the constrained minimizer (0.2, 0.6) is a grid point; points with x0 > 0.95 fail.
TEST(OptimizeGrid, BestPointMeetsTheConstraintsWhateverTheThreads) {
  OptimizeSpec spec;
  spec.minimize = "f";
  spec.subject_to = {"x0 + x1 <= 0.8"};
  const GridFunction f = [](const double* x) {
    GridValue v;
    if (x[0] > 0.95) {
      v.reason = "infeasible corner";
      return v;
    }
    v.evaluated = true;
    v.values = {std::pow(x[0] - 0.3, 2) + std::pow(x[1] - 0.7, 2), x[0] + x[1]};
    return v;
  };
  const ParameterBox box{{0, 0}, {1, 1}};
  std::size_t violating = 0;
  for (int i = 0; i <= 9; ++i)
    for (int j = 0; j <= 10; ++j) violating += i + j > 8;
  for (int threads : {1, 3}) {
    const GridSummary g = run_grid(box, 11, spec, f, threads);
    EXPECT_EQ(g.points, 121u);
    EXPECT_EQ(g.failed, 11u);  // the x0 = 1 row
    EXPECT_EQ(g.first_failure, "infeasible corner");
    EXPECT_EQ(g.violating, violating);
    ASSERT_TRUE(g.found);
    EXPECT_NEAR(g.best_x[0], 0.2, 1e-12);
    EXPECT_NEAR(g.best_x[1], 0.6, 1e-12);
    EXPECT_NEAR(g.best_values[0], 0.02, 1e-12);
  }
}

TEST(OptimizeGrid, NoPointMeetingTheConstraintsIsReported) {
  OptimizeSpec spec;
  spec.minimize = "f";
  spec.subject_to = {"g >= 5"};
  const GridFunction f = [](const double* x) {
    GridValue v;
    v.evaluated = true;
    v.values = {x[0], x[0]};
    return v;
  };
  const GridSummary g = run_grid(ParameterBox{{0}, {1}}, 4, spec, f, 2);
  EXPECT_FALSE(g.found);
  EXPECT_EQ(g.violating, 4u);
  EXPECT_TRUE(g.best_x.empty());
}

}  // namespace
}  // namespace cadinterp::cli
