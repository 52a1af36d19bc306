// The boundary untangling (boundary_untangle.h) on a constructed wedge whose vertices all lie on
// its boundary: only moves within faces and along edges can repair it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "mapping/boundary_untangle.h"
#include "mapping/interior_solve.h"

namespace {

using namespace cadinterp;

// A thin wedge: two faces meeting at a sharp edge (the x axis) at 8 degrees, one prism of three
// tets whose vertices all lie on the boundary. Moving one face vertex within its face folds a
// tet; no interior vertex exists, so only the boundary untangling can repair it, by moving
// vertices within their faces (2-D), along the edge (1-D), never the anchor.
TEST(BoundaryUntangle, ThinWedgeFoldedAtItsSharpEdgeIsRepairedWithinItsFaces) {
  const double th = 8 * 3.14159265358979 / 180, c = std::cos(th), s = std::sin(th);
  // e0, a0, b0 at x = 0; e1, a1, b1 at x = 1. Face A: z = 0; face B: (x, r c, r s).
  std::vector<double> x = {0, 0, 0, 0, 1, 0, 0, c, s, 1, 0, 0, 1, 1, 0, 1, c, s};
  std::vector<std::uint32_t> tets = {0, 1, 2, 3, 1, 2, 3, 4, 2, 3, 4, 5};
  for (std::size_t t = 0; t < 3; ++t)
    if (mapping::scaled_jacobian(x, &tets[4 * t]) < 0) std::swap(tets[4 * t + 2], tets[4 * t + 3]);
  ASSERT_EQ(mapping::tet_quality(x, tets).inverted, 0u);
  // Freedoms: e0 an anchor; e1 along the edge; a* in face A (u = x, v = y), b* in face B.
  std::vector<mapping::BoundaryDof> dofs(6);
  std::vector<int> dof_of = {0, 1, 2, 3, 4, 5};
  const int face[6] = {-1, 0, 1, -1, 0, 1};
  for (std::uint32_t v = 0; v < 6; ++v) {
    mapping::BoundaryDof& d = dofs[v];
    d.vertex = v;
    d.patch = face[v];
    d.dims = v == 0 ? 0 : v == 3 ? 1 : 2;
    d.p[0] = x[3 * v];
    d.p[1] = face[v] == 0 ? x[3 * v + 1] : face[v] == 1 ? x[3 * v + 1] / c : 0;
    d.lo = 0.5;
    d.hi = 2.0;
    d.step = 0.25;
  }
  const mapping::PlaceFn place = [&](const mapping::BoundaryDof& d, const double* p, double* y) {
    if (d.dims == 2 && !(p[1] > 0.05)) return false;  // stay on the face, off the edge
    y[0] = p[0];
    y[1] = d.dims == 1 ? 0 : d.patch == 0 ? p[1] : p[1] * c;
    y[2] = d.dims == 1 ? 0 : d.patch == 0 ? 0 : p[1] * s;
    return true;
  };
  // Fold: a1 slides along face A to x = -0.6 (behind the edge's start).
  dofs[4].p[0] = -0.6;
  place(dofs[4], dofs[4].p, &x[3 * 4]);
  const std::size_t folded = mapping::tet_quality(x, tets).inverted;
  ASSERT_GT(folded, 0u);
  const double diag = std::sqrt(3.0);
  const double min_six = 1e-12 * diag * diag * diag;
  // With every vertex pinned nothing can move: the failure is reported, not hidden.
  {
    std::vector<mapping::BoundaryDof> pinned = dofs;
    for (auto& d : pinned) d.dims = 0;
    std::vector<double> y = x;
    const mapping::BoundaryUntangleResult r =
        mapping::untangle_boundary(tets, dof_of, pinned, place, min_six, y);
    EXPECT_EQ(r.inverted_after, folded);
    EXPECT_EQ(r.moved, 0u);
    EXPECT_EQ(y, x);
  }
  const mapping::BoundaryUntangleResult r =
      mapping::untangle_boundary(tets, dof_of, dofs, place, min_six, x);
  EXPECT_EQ(r.inverted_before, folded);
  EXPECT_EQ(r.inverted_after, 0u);
  EXPECT_GT(r.moved, 0u);
  EXPECT_EQ(mapping::tet_quality(x, tets).inverted, 0u);
  // Every vertex is where its freedom allows: the anchor unmoved, e1 on the edge within its
  // bounds, a* on face A, b* on face B, each at its parameters.
  EXPECT_EQ(x[0], 0.0);
  EXPECT_EQ(x[1], 0.0);
  EXPECT_EQ(x[2], 0.0);
  EXPECT_EQ(x[3 * 3 + 1], 0.0);
  EXPECT_EQ(x[3 * 3 + 2], 0.0);
  EXPECT_GE(dofs[3].p[0], 0.5);
  EXPECT_LE(dofs[3].p[0], 2.0);
  for (std::uint32_t v : {1u, 4u}) EXPECT_EQ(x[3 * v + 2], 0.0);
  for (std::uint32_t v : {2u, 5u}) EXPECT_NEAR(x[3 * v + 2] * c - x[3 * v + 1] * s, 0.0, 1e-15);
  for (std::uint32_t v = 0; v < 6; ++v) {
    double y[3];
    place(dofs[v], dofs[v].p, y);
    if (dofs[v].dims > 0) {
      for (int a = 0; a < 3; ++a) EXPECT_EQ(y[a], x[3 * v + std::size_t(a)]);
    }
  }
}

}  // namespace
