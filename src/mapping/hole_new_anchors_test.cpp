// Faces cut off where merging them would make a patch with handles, their rims given new anchors
// (hole_new_anchors.cpp, patch_layout.h's separate_faces), on the voxel plate whose hole walls
// change topology: each face's own plane is the truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "mapping/correspondence.h"
#include "mapping/interior_solve.h"
#include "mapping/mapping_quality.h"
#include "mapping/mapping_test_util.h"
#include "mapping/mesh_mapper.h"
#include "mapping/patch_layout.h"
#include "mapping/surface.h"
#include "mesh/sample.h"

namespace cadinterp::mapping_test::voxel {
namespace {

// The plate of `plate` as a B-rep whose hole walls changed topology: with `split_walls` each
// hole's wall is four faces (tags 20 + 4k + side) bounded at the top and the bottom by four CAD
// edges between four corner vertices, and between each other by four vertical edges; without, one
// face (tag 10 + k, as in `plate`) bounded by one closed edge through a single vertex. The rims'
// vertex and edge IDs differ between the two (their adjacent entities differ), so no control point
// on a rim matches: the hub's switch from round to obround bolt holes in miniature. Only the
// plate's 8 corners are common.
mesh::Sample plate_with_rims(double X, double Y, double Z, double h, const std::vector<Hole>& holes,
                             bool split_walls) {
  mesh::Sample s = plate(X, Y, Z, h, holes);
  s.points.resize(8);  // the hole corners of `plate` are gone
  for (std::size_t t = 0; t < s.triangle_count(); ++t) {
    std::int32_t& tag = s.triangle_tags[t];
    if (tag < 10 || !split_walls) continue;
    const std::size_t k = std::size_t(tag - 10);
    double m[3] = {0, 0, 0};
    for (int c = 0; c < 3; ++c)
      for (int a = 0; a < 3; ++a)
        m[a] +=
            s.vertices[3 * std::size_t(s.triangles[3 * t + std::size_t(c)]) + std::size_t(a)] / 3;
    const Hole& o = holes[k];
    const int side = std::fabs(m[1] - o.y0) < 1e-9   ? 0
                     : std::fabs(m[0] - o.x1) < 1e-9 ? 1
                     : std::fabs(m[1] - o.y1) < 1e-9 ? 2
                                                     : 3;
    tag = 20 + 4 * std::int32_t(k) + side;
  }
  for (std::size_t k = 0; k < holes.size(); ++k)
    for (int top = 0; top < 2; ++top) {
      const Hole& o = holes[k];
      const double z = top ? Z : 0;
      const double corner[4][2] = {{o.x0, o.y0}, {o.x1, o.y0}, {o.x1, o.y1}, {o.x0, o.y1}};
      auto id = [&](int c) {
        return std::vector<std::int64_t>{
            0, (split_walls ? 4000 : 3000) + 8 * std::int64_t(k) + 4 * top + (split_walls ? c : 0)};
      };
      for (int c = 0; c < (split_walls ? 4 : 1); ++c) {
        mesh::ControlPoint p;
        p.id = id(c);
        p.position[0] = corner[c][0];
        p.position[1] = corner[c][1];
        p.position[2] = z;
        s.points.push_back(p);
      }
      // The rim along the grid, corner to corner; one path per edge.
      mesh::Path path;
      for (int c = 0; c < 4; ++c) {
        const double* a = corner[c];
        const double* b = corner[(c + 1) % 4];
        const int n =
            int(std::lround(std::max(std::fabs(b[0] - a[0]), std::fabs(b[1] - a[1])) / h));
        if (path.polyline.empty()) path.a = id(c);
        for (int i = path.polyline.empty() ? 0 : 1; i <= n; ++i) {
          const double f = double(i) / n;
          path.polyline.insert(path.polyline.end(),
                               {a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), z});
        }
        if (split_walls || c == 3) {
          path.b = id((c + 1) % 4);
          s.paths.push_back(path);
          path = mesh::Path();
        }
        // The vertical edges between the four wall faces, once per corner.
        if (split_walls && top) {
          mesh::Path v;
          v.a = {0, 4000 + 8 * std::int64_t(k) + c};
          v.b = id(c);
          const int nz = int(std::lround(Z / h));
          for (int i = 0; i <= nz; ++i)
            v.polyline.insert(v.polyline.end(), {a[0], a[1], i * Z / nz});
          s.paths.push_back(v);
        }
      }
    }
  return s;
}

}  // namespace
}  // namespace cadinterp::mapping_test::voxel

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// Faces that merge across a topology change into a patch with handles: the plate's top and
// bottom joined by the walls of its holes, which are one face on the source and four on the
// canonical, with no common control point on their rims (plate_with_rims). Merged, the top,
// bottom and walls would be one patch of genus 2, which no disk map takes; so the walls' borders
// are cut instead (separate_faces), each rim gets a new anchor at the end of a slit, and every
// face keeps its own geometry: top and bottom vertices stay exactly on their planes, wall
// vertices on the walls' planes.
TEST(MeshMapper, HoleWallsOfOneSideOnlyAreCutOffInsteadOfMakingHandles) {
  const std::vector<voxel::Hole> holes = {{2, 2, 4, 4}, {6, 4, 8, 6}, {9, 1, 10, 3}};
  const mesh::Sample source = voxel::plate_with_rims(12, 8, 1, 1, holes, false);
  const mesh::Sample canonical = voxel::plate_with_rims(12, 8, 1, 0.5, holes, true);
  ASSERT_EQ(mesh::validate(source), "");
  ASSERT_EQ(mesh::validate(canonical), "");
  mesh::MappedSample m;
  std::string why;
  mapping::MapStats stats;
  ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, &stats)) << why;
  // top, bottom, four outer walls, three hole walls.
  EXPECT_EQ(stats.patches, 9u);
  EXPECT_EQ(mapping::tet_quality(m.vertices, canonical.tets).inverted, 0u);
  const mapping::PairQuality q = mapping::measure_pair(source, canonical, m, nullptr);
  std::printf("plate with 3 re-faced holes: Hausdorff %.2e, min SJ %.3f\n", q.hausdorff_max,
              q.min_scaled_jacobian);
  voxel::expect_on_outer_planes(canonical, m, 12, 1);
  voxel::for_each_tagged_corner(canonical, m, [&holes](std::int32_t tag, const double* x) {
    if (tag >= 20) {
      // On the source's wall of that hole: the boundary of its square, between z = 0 and 1.
      const voxel::Hole& o = holes[std::size_t(tag - 20) / 4];
      const double off = std::min({std::fabs(x[0] - o.x0), std::fabs(x[0] - o.x1),
                                   std::fabs(x[1] - o.y0), std::fabs(x[1] - o.y1)});
      EXPECT_LT(off, 1e-12);
      EXPECT_GE(x[0], o.x0 - 1e-12);
      EXPECT_LE(x[0], o.x1 + 1e-12);
      EXPECT_GE(x[1], o.y0 - 1e-12);
      EXPECT_LE(x[1], o.y1 + 1e-12);
    }
  });
  // The walls' corners are CAD edges on the canonical only: the source's wall is one face, so a
  // canonical corner vertex may land beside the source's corner and cut it, by a fraction of
  // the source's cell.
  EXPECT_LT(q.hausdorff_max, 1e-3);
  // The layout without separate_faces' cuts (the common edges only): a patch with handles.
  std::vector<mapping::Patch> patches;
  mapping::Surface surf;
  ASSERT_TRUE(mapping::build_surface(source, surf, why));
  const mapping::Correspondence corr = mapping::correspond(source, canonical);
  std::vector<const double*> anchors;
  for (const mapping::Anchor& a : corr.anchors) anchors.push_back(a.source);
  ASSERT_TRUE(mapping::build_patches(surf, mapping::layout_cuts(surf, corr.common_edges, 1e-9),
                                     anchors, 1e-9, true, patches, why));
  int genus = 0;
  for (const mapping::Patch& p : patches) genus += p.genus;
  EXPECT_EQ(genus, 2);
}

}  // namespace
