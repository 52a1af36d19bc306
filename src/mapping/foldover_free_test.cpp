// The foldover-free untangler (foldover_free.h) on constructed meshes: a unit cube or square on
// a grid, its boundary fixed, its interior tangled in ways no vertex-by-vertex repair undoes.
#include "mapping/foldover_free.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "mapping/interior_solve.h"
#include "mapping/kuhn_cube.h"

namespace {

using namespace cadinterp;

using Cube = mapping::KuhnCube;

// The cube's positions with every interior vertex reflected through the centre.
std::vector<double> turned_inside_out(const Cube& cube) {
  std::vector<double> x = cube.x;
  for (std::size_t v = 0; v < cube.fixed.size(); ++v)
    if (!cube.fixed[v])
      for (std::size_t a = 0; a < 3; ++a) x[3 * v + a] = 1.0 - x[3 * v + a];
  return x;
}

std::size_t inverted(const std::vector<double>& x, const std::vector<std::uint32_t>& tets) {
  return mapping::tet_quality(x, tets).inverted;
}

// Every interior vertex reflected through the centre: the interior is turned inside out as a
// whole (each interior vertex's own star is inverted wherever it goes alone).
TEST(FoldoverFree, InteriorTurnedInsideOutIsUntangled) {
  const Cube cube(6);
  std::vector<double> x = turned_inside_out(cube);
  const std::size_t before = inverted(x, cube.tets);
  ASSERT_GT(before, 100u);
  const mapping::FoldoverFreeResult r =
      mapping::untangle_foldover_free(cube.x, cube.tets, cube.fixed, 0.0, x);
  EXPECT_EQ(r.inverted_before, before);
  EXPECT_EQ(r.inverted_after, 0u);
  EXPECT_EQ(inverted(x, cube.tets), 0u);
  for (std::size_t v = 0; v < cube.fixed.size(); ++v) {
    if (!cube.fixed[v]) continue;
    for (std::size_t a = 0; a < 3; ++a) EXPECT_EQ(x[3 * v + a], cube.x[3 * v + a]);
  }
}

// The evaluation budget bounds the work (one line search may finish past it): a mapping that
// cannot be rescued is refused in bounded time.
TEST(FoldoverFree, StopsWithinItsEvaluationBudget) {
  const Cube cube(6);
  std::vector<double> x = turned_inside_out(cube);
  mapping::FoldoverFreeOptions options;
  options.max_evaluations = 5;
  const mapping::FoldoverFreeResult r =
      mapping::untangle_foldover_free(cube.x, cube.tets, cube.fixed, 0.0, x, options);
  EXPECT_GT(r.evaluations, 0);
  EXPECT_LE(r.evaluations, 5 + 45);  // the budget, one line search (40 halvings), 4 for eps
  EXPECT_GT(r.inverted_after, 0u);
}

// The boundary twisted about the vertical axis by a full turn from bottom to top (at 300
// degrees and below the harmonic interior of this grid stays valid): the harmonic interior
// (interior_solve.h) pulls the vertices near the axis past each other and inverts tets; the
// untangler starts from there.
TEST(FoldoverFree, HarmonicInteriorOfATwistedBoxIsUntangled) {
  const Cube cube(6);
  std::vector<double> x = mapping::twisted_boundary(cube, 360);
  std::string why;
  ASSERT_TRUE(mapping::harmonic_interior(cube.x, cube.tets, cube.fixed, x, why)) << why;
  const std::size_t before = inverted(x, cube.tets);
  ASSERT_GT(before, 0u);
  const mapping::FoldoverFreeResult r =
      mapping::untangle_foldover_free(cube.x, cube.tets, cube.fixed, 0.0, x);
  EXPECT_EQ(r.inverted_after, 0u);
  EXPECT_EQ(inverted(x, cube.tets), 0u);
}

// A tet whose four vertices are all fixed cannot change: it stays counted, and positions that
// gain nothing are not written.
TEST(FoldoverFree, TetsOfFixedVerticesOnlyAreReportedAndLeftAlone) {
  const std::vector<double> reference = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::vector<double> x = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, -1};  // apex below: inverted
  const std::vector<std::uint32_t> tets = {0, 1, 2, 3};
  const std::vector<char> fixed = {1, 1, 1, 1};
  const std::vector<double> input = x;
  const mapping::FoldoverFreeResult r =
      mapping::untangle_foldover_free(reference, tets, fixed, 0.0, x);
  EXPECT_EQ(r.inverted_before, 1u);
  EXPECT_EQ(r.inverted_after, 1u);
  EXPECT_EQ(x, input);
}

// The planar variant: a square grid of triangles, interior reflected through the centre.
TEST(FoldoverFree, PlanarTrianglesTurnedInsideOutAreUntangled) {
  const int n = 8;
  std::vector<double> reference, x;
  std::vector<std::uint32_t> triangles;
  std::vector<char> fixed;
  auto id = [](int i, int j) { return std::uint32_t(i * (n + 1) + j); };
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double u = double(i) / n, v = double(j) / n;
      reference.insert(reference.end(), {u, v, 0.0});
      const bool border = i == 0 || j == 0 || i == n || j == n;
      fixed.push_back(border);
      x.insert(x.end(), {border ? u : 1 - u, border ? v : 1 - v});
    }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      triangles.insert(triangles.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j),
                                         id(i + 1, j + 1), id(i, j + 1)});
  auto turned = [&] {
    std::size_t k = 0;
    for (std::size_t t = 0; 3 * t < triangles.size(); ++t) {
      const double* a = &x[2 * triangles[3 * t]];
      const double* b = &x[2 * triangles[3 * t + 1]];
      const double* c = &x[2 * triangles[3 * t + 2]];
      k += (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) > 0 ? 0 : 1;
    }
    return k;
  };
  ASSERT_GT(turned(), 20u);
  const mapping::FoldoverFreeResult r =
      mapping::untangle_foldover_free_planar(reference, triangles, fixed, 0.0, x);
  EXPECT_EQ(r.inverted_after, 0u);
  EXPECT_EQ(turned(), 0u);
}

}  // namespace

// The energy's gradient against central differences, on a valid and on a tangled interior, for
// small and large eps. On the tangled cube eps starts where the schedule starts it (a fifth of
// the smallest determinant, here about 0.25): at eps = 1e-3 its energy is about 1e12 and the
// differences lose the digits to rounding.
TEST(FoldoverFree, EnergyGradientMatchesDifferences) {
  const Cube cube(3);
  std::vector<double> jittered = cube.x;
  for (std::size_t v = 0; v < cube.fixed.size(); ++v)
    if (!cube.fixed[v])
      for (std::size_t a = 0; a < 3; ++a)
        jittered[3 * v + a] += 0.05 * std::sin(double(7 * v + 3 * a));  // deterministic
  const std::vector<double> tangled = turned_inside_out(cube);
  ASSERT_EQ(inverted(jittered, cube.tets), 0u);
  ASSERT_GT(inverted(tangled, cube.tets), 0u);
  const struct {
    const std::vector<double>* x;
    double eps;
  } cases[] = {{&jittered, 1e-3}, {&jittered, 0.5}, {&tangled, 0.05}, {&tangled, 0.5}};
  for (const auto& c : cases) {
    SCOPED_TRACE(std::string(c.x == &jittered ? "valid" : "tangled") + ", eps " +
                 std::to_string(c.eps));
    const std::vector<double>& x = *c.x;
    std::vector<double> g;
    const double f = mapping::foldover_free_energy(cube.x, cube.tets, cube.fixed, x, c.eps, &g);
    ASSERT_TRUE(std::isfinite(f));
    ASSERT_EQ(g.size(), x.size());
    double largest = 0;
    for (double gi : g) largest = std::max(largest, std::fabs(gi));
    ASSERT_GT(largest, 0.0);
    const double h = 1e-6;
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (cube.fixed[i / 3]) {
        EXPECT_EQ(g[i], 0.0);
        continue;
      }
      std::vector<double> up = x, down = x;
      up[i] += h;
      down[i] -= h;
      const double fd =
          (mapping::foldover_free_energy(cube.x, cube.tets, cube.fixed, up, c.eps) -
           mapping::foldover_free_energy(cube.x, cube.tets, cube.fixed, down, c.eps)) /
          (2 * h);
      EXPECT_NEAR(g[i], fd, 1e-6 * largest) << "coordinate " << i;
    }
  }
}
