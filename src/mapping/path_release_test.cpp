// The release of vertices sheared along traced paths (path_release.h) and the closest-point
// weights it places them with, on a constructed triangle and a flat grid.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "mapping/path_release.h"
#include "mapping/surface.h"
#include "mesh/sample.h"
#include "mesh/surface_distance.h"

namespace {

using namespace cadinterp;

TEST(PathRelease, NearestPointOnATriangleInEachRegion) {
  const double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {0, 2, 0};
  struct Case {
    double p[3], w[3];
  };
  const Case cases[] = {
      {{0.5, 0.5, 1.0}, {0.5, 0.25, 0.25}},  // above the face
      {{-1, -1, 0}, {1, 0, 0}},              // beyond vertex a
      {{3, -1, 0}, {0, 1, 0}},               // beyond vertex b
      {{1, -1, 0.5}, {0.5, 0.5, 0}},         // beyond edge ab
      {{2, 2, 0}, {0, 0.5, 0.5}},            // beyond edge bc
      {{-1, 1, 0}, {0.5, 0, 0.5}},           // beyond edge ca
  };
  for (const Case& k : cases) {
    double w[3];
    mesh::closest_point_weights(k.p, a, b, c, w);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(w[i], k.w[i], 1e-12) << k.p[0] << "," << k.p[1];
  }
}

// A flat 9 x 9 grid mapped onto itself with the vertices near a "traced path" (the middle row)
// sheared along it, as two patches' maps shear against each other: the release moves them back
// towards the canonical arrangement (here the identity), every position on the source plane and
// inside it, `where` and the positions consistent.
TEST(PathRelease, ShearAlongATracedPathRelaxesOnTheSourceSurface) {
  mesh::Sample grid;
  const int n = 9;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      grid.vertices.insert(grid.vertices.end(), {double(i), double(j), 0});
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const std::uint32_t v = std::uint32_t(j * n + i);
      grid.triangles.insert(grid.triangles.end(), {v, v + 1, v + n + 1, v, v + n + 1, v + n});
      grid.triangle_tags.insert(grid.triangle_tags.end(), {1, 1});
    }
  mapping::Surface surf;
  std::string why;
  ASSERT_TRUE(mapping::build_surface(grid, surf, why)) << why;
  auto place = [&](const mapping::SurfacePoint& pt, double* x) {
    for (int a = 0; a < 3; ++a) {
      x[a] = 0;
      for (int k = 0; k < 3; ++k) x[a] += pt.w[k] * grid.vertices[3 * std::size_t(pt.v[k]) + a];
    }
  };
  // The sheared map: vertices within 2 rows of row 4, inside, moved along x by up to 0.45.
  std::vector<std::uint32_t> movable;
  std::vector<double> x = grid.vertices;
  for (int j = 2; j <= 6; ++j)
    for (int i = 1; i + 1 < n; ++i) {
      const std::uint32_t v = std::uint32_t(j * n + i);
      movable.push_back(v);
      x[3 * v] += 0.45 * (j < 4 ? -1 : j > 4 ? 1 : 0) * (1.0 - std::abs(j - 4) / 3.0);
    }
  std::vector<mapping::SurfacePoint> where(grid.vertex_count());
  for (std::uint32_t v = 0; v < grid.vertex_count(); ++v) {
    double best = 1e300;
    for (std::size_t f = 0; f < grid.triangle_count(); ++f) {
      const std::uint32_t* t = &grid.triangles[3 * f];
      double w[3], p[3];
      mesh::closest_point_weights(&x[3 * v], &grid.vertices[3 * t[0]], &grid.vertices[3 * t[1]],
                                  &grid.vertices[3 * t[2]], w);
      mapping::SurfacePoint sp;
      for (int k = 0; k < 3; ++k) sp.v[k] = t[k], sp.w[k] = w[k];
      place(sp, p);
      const double d = std::hypot(p[0] - x[3 * v], p[1] - x[3 * v + 1], p[2] - x[3 * v + 2]);
      if (d < best) best = d, where[v] = sp;
    }
  }
  auto shear = [&] {
    double sum = 0;
    for (std::uint32_t v : movable) sum += std::pow(x[3 * v] - grid.vertices[3 * v], 2);
    return std::sqrt(sum / double(movable.size()));
  };
  const double before = shear();
  ASSERT_GT(before, 0.1);
  mapping::release_traced_paths(grid, surf, grid, movable, 20, where, place, x);
  EXPECT_LT(shear(), 0.2 * before);
  for (std::uint32_t v : movable) {
    EXPECT_EQ(x[3 * v + 2], 0.0);  // on the source plane
    EXPECT_GE(x[3 * v], 0.0);
    EXPECT_LE(x[3 * v], n - 1.0);
    double p[3];
    place(where[v], p);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(p[a], x[3 * v + std::size_t(a)]);
  }
}

}  // namespace
