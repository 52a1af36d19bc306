// The interior map (interior_solve.h; paper §6.2, "Interior mapping"): P1-harmonic extensions
// reproduce affine maps exactly, in one solve or in boundary increments, and the tet quality
// measures them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "mapping/interior_solve.h"
#include "mapping/mapping_test_util.h"
#include "mesh/sample.h"

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// P1-harmonic extension reproduces affine maps exactly (a mirror image here), and the quality
// check sees that every mirrored tet is inverted.
TEST(MeshMapper, HarmonicInteriorIsExactForAffineMapsAndInversionsAreCounted) {
  // Small: the direct solve; large (over 3000 interior vertices): conjugate gradients.
  for (const auto& [options, x, tolerance] :
       {std::make_tuple("edge=2", std::vector<double>{41, 21, 6.2}, 1e-9),
        std::make_tuple("edge=1.2", std::vector<double>{60, 30, 6.2}, 1e-7)}) {
    const Model plate("plate", options);
    const mesh::Sample s = plate.at(x);
    std::vector<char> fixed(s.vertex_count(), 0);
    for (std::uint32_t v : s.triangles) fixed[v] = 1;
    ASSERT_NE(std::count(fixed.begin(), fixed.end(), 0), 0);
    auto affine = [](const double* p, double* q) {
      q[0] = -1.5 * p[0] + 0.2 * p[1] + 3;
      q[1] = 0.7 * p[1] - 0.1 * p[2];
      q[2] = 0.3 * p[0] + 1.1 * p[2] - 2;
    };
    std::vector<double> mapped(s.vertices.size(), 0.0), expected(s.vertices.size());
    for (std::size_t v = 0; v < s.vertex_count(); ++v) {
      affine(&s.vertices[3 * v], &expected[3 * v]);
      if (fixed[v]) std::copy_n(&expected[3 * v], 3, &mapped[3 * v]);
    }
    std::string why;
    ASSERT_TRUE(mapping::harmonic_interior(s.vertices, s.tets, fixed, mapped, why)) << why;
    for (std::size_t i = 0; i < mapped.size(); ++i) ASSERT_NEAR(mapped[i], expected[i], tolerance);
    // det of the linear part < 0: an orientation-reversing map inverts every tet.
    EXPECT_EQ(mapping::tet_quality(mapped, s.tets).inverted, s.tet_count());
    EXPECT_EQ(mapping::tet_quality(s.vertices, s.tets).inverted, 0u);
  }
}

// The interior solve in boundary increments, with the
// current mesh's stiffness, and with small tets stiffened (MapOptions). Truth: the P1
// Laplacian reproduces an affine boundary map exactly, in one step or many (each step's
// boundary data is affine in the current mesh), on a graded Kuhn-split box whose tets differ
// in volume; the stiffened solve keeps the boundary data and a valid mesh.
TEST(InteriorSolve, IncrementalSolveReproducesAffineMapsExactly) {
  const int n = 6;
  std::vector<double> x;
  std::vector<std::uint32_t> tets;
  auto index = [&](int i, int j, int k) { return std::uint32_t((k * (n + 1) + j) * (n + 1) + i); };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i)
        // Graded along x and z: the tets' volumes differ, so stiffening weights them unequally.
        x.insert(x.end(), {-1.0 + 2.0 * std::pow(double(i) / n, 1.7), -1.0 + 2.0 * j / n,
                           2.0 * std::pow(double(k) / n, 1.4)});
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const auto& p : perms) {
          int c[3] = {0, 0, 0};
          std::uint32_t q[4];
          q[0] = index(i, j, k);
          for (int s = 0; s < 3; ++s) {
            c[p[s]] = 1;
            q[s + 1] = index(i + c[0], j + c[1], k + c[2]);
          }
          tets.insert(tets.end(), q, q + 4);
        }
  // Orientation: positive volumes.
  for (std::size_t t = 0; t < tets.size(); t += 4) {
    std::vector<std::uint32_t> one(tets.begin() + long(t), tets.begin() + long(t) + 4);
    if (mapping::tet_quality(x, one).inverted) std::swap(tets[t + 2], tets[t + 3]);
  }
  ASSERT_EQ(mapping::tet_quality(x, tets).inverted, 0u);
  std::vector<char> fixed(x.size() / 3, 0);
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i)
        fixed[index(i, j, k)] = i == 0 || j == 0 || k == 0 || i == n || j == n || k == n;
  std::string why;
  // Stiffened (weighted) Laplacians do not reproduce affine maps (the weights break the
  // partition of unity of the gradients); of them, only validity is asserted.
  for (const auto& [steps, stiff] : {std::make_pair(1, 0.0), std::make_pair(5, 0.0),
                                     std::make_pair(1, 2.0), std::make_pair(4, 1.0)}) {
    std::vector<double> y(x.size());
    for (std::size_t v = 0; v < x.size() / 3; ++v) {
      const double* p = &x[3 * v];
      y[3 * v] = 1.3 * p[0] + 0.4 * p[1] + 0.1;
      y[3 * v + 1] = -0.2 * p[0] + 0.9 * p[1] + 0.3 * p[2];
      y[3 * v + 2] = 0.5 * p[2] + 0.2 * p[0] - 2.0;
    }
    std::vector<double> mapped = y;
    for (std::size_t v = 0; v < fixed.size(); ++v)
      if (!fixed[v]) mapped[3 * v] = mapped[3 * v + 1] = mapped[3 * v + 2] = 0;
    ASSERT_TRUE(mapping::incremental_interior(x, tets, fixed, mapped, why, steps, stiff)) << why;
    if (stiff > 0) {
      EXPECT_EQ(mapping::tet_quality(mapped, tets).inverted, 0u);
      for (std::size_t v = 0; v < fixed.size(); ++v)
        if (fixed[v]) {
          ASSERT_EQ(mapped[3 * v], y[3 * v]);
        }
      continue;
    }
    for (std::size_t i = 0; i < y.size(); ++i) ASSERT_NEAR(mapped[i], y[i], 1e-9) << steps;
  }
}

TEST(MeshMapper, ScaledJacobianOfARegularTetIsOne) {
  // Regular tet: alternate corners of a cube, positively oriented.
  const std::vector<double> v{0, 0, 0, 1, 1, 0, 1, 0, 1, 0, 1, 1};
  const std::vector<std::uint32_t> t{0, 1, 2, 3};
  mapping::TetQuality q = mapping::tet_quality(v, t);
  if (q.inverted) q = mapping::tet_quality(v, {0, 2, 1, 3});
  EXPECT_NEAR(q.min_scaled_jacobian, 1.0, 1e-12);
}

}  // namespace
