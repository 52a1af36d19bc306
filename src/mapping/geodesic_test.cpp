// Traced paths measured along their geodesics (geodesic.h) on the voxel plate's flat top, where
// the geodesic is the straight segment.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "mapping/geodesic.h"
#include "mapping/layout_paths.h"
#include "mapping/mapping_test_util.h"
#include "mapping/patch_layout.h"
#include "mapping/surface.h"
#include "mesh/sample.h"

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// The geodesic of a traced path (geodesic.h) on the voxel plate's flat top: from corner to corner
// the Steiner graph's path is the straight segment to within a few percent, while the shortest
// edge path is longer by the grid's zigzag; a zigzag chain measured along the geodesic gets
// increasing arc lengths from 0 to the geodesic's length, its corners at their projections.
TEST(Geodesic, CorridorGeodesicOfAFlatFaceIsItsStraightSegment) {
  const mesh::Sample plate = voxel::plate(6, 4, 1, 1, {});
  mapping::Surface surf;
  std::string why;
  ASSERT_TRUE(mapping::build_surface(plate, surf, why)) << why;
  std::vector<int> top;
  for (int f = 0; f < surf.triangles(); ++f)
    if (plate.triangle_tags[std::size_t(f)] == 1) top.push_back(f);
  const double a[3] = {0, 0, 1}, b[3] = {6, 4, 1};
  const int va = mapping::vertex_at(surf, a, 1e-9), vb = mapping::vertex_at(surf, b, 1e-9);
  ASSERT_GE(va, 0);
  ASSERT_GE(vb, 0);
  const auto g = mapping::corridor_geodesic(surf, top, std::uint32_t(va), std::uint32_t(vb));
  ASSERT_GE(g.size(), 2u);
  double length = 0;
  for (std::size_t i = 1; i < g.size(); ++i)
    length += std::hypot(g[i][0] - g[i - 1][0], g[i][1] - g[i - 1][1], g[i][2] - g[i - 1][2]);
  const double straight = std::hypot(6.0, 4.0);
  EXPECT_GE(length, straight - 1e-9);
  EXPECT_LE(length, 1.03 * straight);
  for (const auto& p : g) EXPECT_NEAR(p[2], 1.0, 1e-12);
  // The shortest edge path zigzags: measured along the geodesic, its vertices get the arc
  // length of their projections onto the segment, increasing, from 0 to the geodesic's length.
  std::vector<char> none(3 * std::size_t(surf.triangles()), 0);
  std::vector<int> of(std::size_t(surf.triangles()), 0);
  const std::vector<std::uint32_t> chain =
      mapping::shortest_path(surf, none, std::uint32_t(va), std::uint32_t(vb), &of, 0);
  ASSERT_GE(chain.size(), 3u);
  const std::vector<double> t = mapping::arc_length_on(surf, chain, g);
  ASSERT_EQ(t.size(), chain.size());
  EXPECT_EQ(t.front(), 0.0);
  EXPECT_NEAR(t.back(), length, 1e-12);
  for (std::size_t i = 1; i < t.size(); ++i) EXPECT_GT(t[i], t[i - 1]);
  for (std::size_t i = 1; i + 1 < chain.size(); ++i) {
    const double* x = surf.position(chain[i]);
    const double along = (6 * x[0] + 4 * x[1]) / straight;  // projection onto the segment
    EXPECT_NEAR(t[i], along * length / straight, 0.05 * straight);
  }
}

// A traced path that detours (geodesic.h): on the plate's flat top, from (0, 1) to (6, 1), a
// U-shaped edge path up to y = 3 and back is 10 long against its geodesic's 6 (the straight
// segment along y = 1, inside the corridor). Measured along the geodesic, the U's legs would
// each crowd onto one point of the segment; such a path keeps its edges' lengths. The straight
// edge path between the same ends, its own geodesic, is measured along it.
TEST(Geodesic, PathThatDetoursKeepsItsEdgeLengths) {
  const mesh::Sample plate = voxel::plate(6, 4, 1, 1, {});
  mapping::Surface surf;
  std::string why;
  ASSERT_TRUE(mapping::build_surface(plate, surf, why)) << why;
  auto chain_through = [&](const std::vector<std::array<double, 2>>& corners) {
    std::vector<std::uint32_t> chain;
    for (std::size_t c = 0; c + 1 < corners.size(); ++c) {
      const double dx = corners[c + 1][0] - corners[c][0], dy = corners[c + 1][1] - corners[c][1];
      const int steps = int(std::lround(std::fabs(dx) + std::fabs(dy)));
      for (int k = c == 0 ? 0 : 1; k <= steps; ++k) {
        const double p[3] = {corners[c][0] + dx * k / steps, corners[c][1] + dy * k / steps, 1};
        const int v = mapping::vertex_at(surf, p, 1e-9);
        EXPECT_GE(v, 0);
        chain.push_back(std::uint32_t(std::max(v, 0)));
      }
    }
    return chain;
  };
  std::vector<const double*> anchors;
  const double a[3] = {0, 1, 1}, b[3] = {6, 1, 1};
  anchors.push_back(a);
  anchors.push_back(b);
  for (const mesh::ControlPoint& p : plate.points) anchors.push_back(p.position);
  for (const bool detour : {true, false}) {
    SCOPED_TRACE(detour ? "U-shaped path" : "straight path");
    const std::vector<std::uint32_t> chain =
        detour ? chain_through({{0, 1}, {1, 1}, {1, 3}, {5, 3}, {5, 1}, {6, 1}})
               : chain_through({{0, 1}, {6, 1}});
    ASSERT_EQ(chain.size(), detour ? 11u : 7u);
    // Cuts: the borders between the plate's faces, and the path.
    std::vector<char> cuts(3 * std::size_t(surf.triangles()), 0);
    for (int h = 0; h < 3 * surf.triangles(); ++h)
      cuts[std::size_t(h)] = plate.triangle_tags[std::size_t(h / 3)] !=
                             plate.triangle_tags[std::size_t(surf.twin[std::size_t(h)] / 3)];
    mapping::cut_along(surf, chain, cuts);
    std::vector<mapping::Patch> patches;
    ASSERT_TRUE(mapping::build_patches(surf, cuts, anchors, 1e-9, true, patches, why)) << why;
    const std::vector<mapping::Patch> before = patches;
    const std::size_t measured =
        mapping::measure_traced_paths_along_geodesics(surf, {chain}, patches);
    // Arc length along the path, in the loop of each patch beside it.
    std::size_t loops_along = 0;
    for (std::size_t p = 0; p < patches.size(); ++p) {
      const mapping::Patch& q = patches[p];
      const std::size_t n = q.loop.size();
      std::vector<double> along;
      for (std::size_t i = 0; i < n; ++i) {
        const auto at = std::find(chain.begin(), chain.end(), q.loop[i]);
        const auto next = std::find(chain.begin(), chain.end(), q.loop[(i + 1) % n]);
        if (at == chain.end() || next == chain.end() || std::abs(next - at) != 1) continue;
        along.push_back(q.loop_s[i + 1] - q.loop_s[i]);
        if (detour) {
          EXPECT_DOUBLE_EQ(q.loop_s[i + 1] - q.loop_s[i],
                           before[p].loop_s[i + 1] - before[p].loop_s[i]);
        }
      }
      if (along.size() + 1 != chain.size()) continue;
      ++loops_along;
      double length = 0;
      for (double d : along) {
        EXPECT_GT(d, 0.5);  // no edge crowded: each is 1 long, along the edges or the segment
        length += d;
      }
      EXPECT_NEAR(length, detour ? 10.0 : 6.0, 1e-9);
    }
    EXPECT_EQ(loops_along, 2u);  // the top's two patches on either side of the path
    EXPECT_EQ(measured, detour ? 0u : 1u);
  }
}

}  // namespace
