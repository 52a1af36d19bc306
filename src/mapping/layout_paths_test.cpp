// The checks a new layout path passes on both sides (layout_paths.h, paper §6.2): the cyclic
// order at its anchors and whether two sides' paths run alike, on small constructed surfaces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "mapping/layout_paths.h"
#include "mapping/surface.h"
#include "mesh/sample.h"

namespace {

using namespace cadinterp;

// Kraevoy–Sheffer's cyclic-order check (§6.2) on a constructed case: an octahedron with paths
// from the top (+z) to +x and -x on both sides. A new path from the top to +y leaves the top
// between +x and -x on one side; on the other side a path to +y that runs round the back (via
// -y and the bottom) leaves the top in the -y slot, between -x and +x the other way round. The
// check rejects it and accepts the direct path.
TEST(LayoutPaths, CyclicOrderCheckRejectsAPathOnTheWrongSideOfAnAnchor) {
  mesh::Sample oct;
  oct.feasible = true;
  // 0:+x 1:-x 2:+y 3:-y 4:+z 5:-z
  oct.vertices = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  oct.triangles = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  oct.triangle_tags.assign(8, 1);
  mapping::Surface s;
  std::string why;
  ASSERT_TRUE(mapping::build_surface(oct, s, why)) << why;
  // Anchors at +x, -x, +y and +z (indices 0, 1, 2, 4 = vertex index); -y and -z are not.
  const std::vector<int> anchor_of{0, 1, 2, -1, 4, -1};
  std::vector<char> before(3 * std::size_t(s.triangles()), 0);
  mapping::cut_along(s, {4, 0}, before);
  mapping::cut_along(s, {4, 1}, before);
  std::vector<char> direct = before, around = before;
  mapping::cut_along(s, {4, 2}, direct);
  mapping::cut_along(s, {4, 3, 5, 2}, around);
  // The paths around the top, by far anchor: the round-about path ends at +y too.
  std::vector<std::vector<int>> far = mapping::paths_around(s, around, 4, anchor_of, nullptr);
  std::sort(far.begin(), far.end());
  EXPECT_EQ(far, (std::vector<std::vector<int>>{{0}, {1}, {2}}));
  const mapping::PathEnd a{&s, &before, &direct, 4, &anchor_of};
  const mapping::PathEnd b{&s, &before, &around, 4, &anchor_of};
  EXPECT_TRUE(mapping::cyclic_order_agrees(a, a));
  EXPECT_FALSE(mapping::cyclic_order_agrees(a, b));
  EXPECT_FALSE(mapping::cyclic_order_agrees(b, a));
  // At +y, the far end, each side has the new path only: nothing to disagree with.
  const mapping::PathEnd a2{&s, &before, &direct, 2, &anchor_of};
  const mapping::PathEnd b2{&s, &before, &around, 2, &anchor_of};
  EXPECT_TRUE(mapping::cyclic_order_agrees(a2, b2));
}

// Two sides' paths between the same anchors, on a flat face with a hole of radius 2 at (5, 0)
// between the anchors (0, 0) and (10, 0): the canonical is the source scaled by 1.2 and moved by
// (30, 5, 0). A path over the hole on both sides runs alike, zigzag and all, and so does one
// with a few more vertices; a path over the hole on one side and under it on the other does not
// (the patch keys cannot tell them apart, the disk maps would shear the face between them).
TEST(LayoutPaths, PathsRoundAHoleOnDifferentSidesDoNotRunAlike) {
  mesh::Sample src, can;
  auto add = [](mesh::Sample& s, double x, double y) {
    s.vertices.insert(s.vertices.end(), {x, y, 0.0});
    return std::uint32_t(s.vertices.size() / 3 - 1);
  };
  auto moved = [&](double x, double y) { return add(can, 30 + 1.2 * x, 5 + 1.2 * y); };
  const std::uint32_t s0 = add(src, 0, 0), s1 = add(src, 10, 0);
  std::vector<std::uint32_t> src_over{s0}, can_over{moved(0, 0)}, can_fine{moved(0, 0)},
      can_under{moved(0, 0)};
  const double over[][2] = {{2, 1.5}, {3.5, 2.8}, {5, 3.2}, {6.5, 2.6}, {8, 1.4}};
  for (const auto& q : over) {
    src_over.push_back(add(src, q[0], q[1]));
    can_over.push_back(moved(q[0], q[1] + 0.3));
    can_under.push_back(moved(q[0], -q[1]));
  }
  for (int k = 1; k < 10; ++k) {
    const double x = k, y = std::sqrt(std::max(0.0, 9 - (x - 5) * (x - 5))) + 0.4 * (k % 2);
    can_fine.push_back(moved(x, y));
  }
  src_over.push_back(s1);
  for (auto* c : {&can_over, &can_fine, &can_under}) c->push_back(moved(10, 0));
  const mapping::Surface ss{&src, {}, {}, {}, {}}, cs{&can, {}, {}, {}, {}};
  EXPECT_TRUE(mapping::paths_run_alike(ss, src_over, cs, can_over));
  EXPECT_TRUE(mapping::paths_run_alike(ss, src_over, cs, can_fine));
  EXPECT_TRUE(mapping::paths_run_alike(cs, can_over, ss, src_over));
  EXPECT_FALSE(mapping::paths_run_alike(ss, src_over, cs, can_under));
  EXPECT_FALSE(mapping::paths_run_alike(cs, can_under, ss, src_over));
  EXPECT_FALSE(mapping::paths_run_alike(ss, {s0}, cs, can_over));
  // A caller's slack of a quarter of the hole's diameter (1) still tells over from under.
  EXPECT_FALSE(mapping::paths_run_alike(ss, src_over, cs, can_under, 1.0));
}

// A slit across a strip one triangle wide (the OpenCASCADE hub's rim face at a chord angle of
// 0.2) is one edge on the canonical; on the source, with a vertex inside the strip, it bends by
// 2.65 on a path of 8.6, more than a quarter of it. Such paths run alike only within a caller's
// slack of at least that bend.
TEST(LayoutPaths, SlackAcceptsAPathBentByTheMesh) {
  mesh::Sample src, can;
  src.vertices = {53.16, 0, 40, 56.45, -2.65, 40, 60, 0, 40};
  can.vertices = {55.27, 0, 40, 60, 0, 40};
  const mapping::Surface ss{&src, {}, {}, {}, {}}, cs{&can, {}, {}, {}, {}};
  const std::vector<std::uint32_t> bent{0, 1, 2}, straight{0, 1};
  EXPECT_FALSE(mapping::paths_run_alike(ss, bent, cs, straight));
  EXPECT_FALSE(mapping::paths_run_alike(ss, bent, cs, straight, 2.0));
  EXPECT_TRUE(mapping::paths_run_alike(ss, bent, cs, straight, 3.0));
  EXPECT_TRUE(mapping::paths_run_alike(cs, straight, ss, bent, 3.0));
}

}  // namespace

// vertex_at through the surface's vertices sorted by x (build_surface) finds what a scan of every
// triangle corner finds: the nearest vertex within the tolerance, the smallest index among equally
// near ones (two vertices at one position here), -1 where none is within it.
TEST(LayoutPaths, VertexAtByXAgreesWithAFullScan) {
  mesh::Sample m;
  m.feasible = true;
  // A 6 x 6 grid of squares in z = 0, with vertex 36 a copy of vertex 14.
  for (int j = 0; j <= 6; ++j)
    for (int i = 0; i <= 6; ++i)
      for (double c : {0.5 * i, 0.5 * j, 0.0}) m.vertices.push_back(c);
  m.vertices.insert(m.vertices.end(), {m.vertices[42], m.vertices[43], m.vertices[44]});
  for (std::uint32_t j = 0; j < 6; ++j)
    for (std::uint32_t i = 0; i < 6; ++i) {
      const std::uint32_t v = 7 * j + i;
      m.triangles.insert(m.triangles.end(), {v, v + 1, v + 8, v, v + 8, v + 7});
    }
  m.triangles[3 * 12 + 1] = 36;  // one corner of vertex 14 refers to its copy
  m.triangle_tags.assign(m.triangles.size() / 3, 1);
  mapping::Surface indexed;
  std::string why;
  ASSERT_TRUE(mapping::build_surface(m, indexed, why)) << why;
  ASSERT_FALSE(indexed.by_x.empty());
  const mapping::Surface scanned{&m, {}, {}, {}, {}};
  int found = 0;
  for (int k = 0; k < 400; ++k) {
    const double p[3] = {-0.2 + 0.0091 * k, 1.0 + 0.3 * std::sin(k), 0.01 * std::cos(3 * k)};
    for (double tol : {1e-9, 0.05, 0.3}) {
      const int a = mapping::vertex_at(indexed, p, tol), b = mapping::vertex_at(scanned, p, tol);
      EXPECT_EQ(a, b) << k << " " << tol;
      found += a >= 0 ? 1 : 0;
    }
  }
  EXPECT_GT(found, 100);
  // Exactly at the duplicated position: the smaller index.
  EXPECT_EQ(mapping::vertex_at(indexed, &m.vertices[42], 1e-9), 14);
  EXPECT_EQ(mapping::vertex_at(scanned, &m.vertices[42], 1e-9), 14);
}
