// Periodic faces cut open along their seams into disk patches (patch_layout.h, correspondence.h)
// on the tube of mapping_test_util.h, whose geometry is the truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "mapping/correspondence.h"
#include "mapping/mapping_test_util.h"
#include "mapping/mesh_mapper.h"
#include "mapping/patch_layout.h"
#include "mapping/surface.h"
#include "mesh/sample.h"

namespace cadinterp::mapping_test::tube {
namespace {

// The layout of a sample against itself (every CAD path common): its patches.
void self_layout(const mesh::Sample& s, std::vector<mapping::Patch>& patches) {
  mapping::Surface surf;
  std::string why;
  ASSERT_TRUE(mapping::build_surface(s, surf, why)) << why;
  const mapping::Correspondence corr = mapping::correspond(s, s);
  const std::vector<char> cuts =
      mapping::layout_cuts(surf, corr.common_edges, 1e-9 * s.bbox_diagonal());
  std::vector<const double*> anchors;
  for (const mapping::Anchor& a : corr.anchors) anchors.push_back(a.source);
  ASSERT_TRUE(
      mapping::build_patches(surf, cuts, anchors, 1e-9 * s.bbox_diagonal(), true, patches, why))
      << why;
}

// Both walls of a tube {.., 16, 8} (tags 1 and 2) are one disk each in the sample's layout
// against itself: cut open along their seams, the 9 seam vertices twice in the local numbering.
void expect_walls_cut_open(const mesh::Sample& s) {
  std::vector<mapping::Patch> patches;
  ASSERT_NO_FATAL_FAILURE(self_layout(s, patches));
  std::size_t walls = 0;
  for (const mapping::Patch& p : patches) {
    if (s.triangle_tags[std::size_t(p.triangles[0])] > 2) continue;
    ++walls;
    EXPECT_TRUE(p.holes.empty());
    EXPECT_EQ(p.local_vertices.size(), 16u * 9u + 9u);
  }
  EXPECT_EQ(walls, 2u);
}

}  // namespace
}  // namespace cadinterp::mapping_test::tube

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// The seam of a periodic face. The tube's walls are annuli
// whose only anchors on the two circles are the seam's ends and the circles' edge points; the
// seam path (same face on both sides) must cut each wall open into a disk, its vertices
// duplicated in the patch's local numbering, on both sides alike. Truth: the tube's geometry
// (mapped wall vertices on the source's walls: radius between the source polygon's apothem and
// its radius, z within the height; cap vertices at z = 0 or the height).
TEST(MeshMapper, PeriodicFacesAreCutOpenAlongTheirSeam) {
  const tube::Shape src_shape{1.0, 2.0, 3.0, 16, 8}, can_shape{1.3, 2.4, 2.2, 24, 12};
  const mesh::Sample source = tube::make(src_shape), canonical = tube::make(can_shape);
  ASSERT_EQ(mesh::validate(source), "");
  ASSERT_EQ(mesh::validate(canonical), "");

  // The layout: the outer wall (tag 1) is one disk patch cut open along its seam.
  std::vector<mapping::Patch> patches;
  ASSERT_NO_FATAL_FAILURE(tube::self_layout(source, patches));
  ASSERT_EQ(patches.size(), 4u);
  for (const mapping::Patch& p : patches) {
    // The caps are plain annuli (two loops, no seam: the mapper splits them by paths).
    if (source.triangle_tags[std::size_t(p.triangles[0])] != 1) {
      EXPECT_EQ(p.holes.size(), source.triangle_tags[std::size_t(p.triangles[0])] >= 3 ? 1u : 0u);
      continue;
    }
    // 16 x 9 wall vertices, the 9 on the seam twice; the loop: both circles and the seam twice.
    EXPECT_EQ(p.local_vertices.size(), 16u * 9u + 9u);
    EXPECT_EQ(p.loop.size(), 2u * 16u + 2u * 8u);
    EXPECT_TRUE(p.holes.empty());
  }

  mesh::MappedSample m;
  mapping::MapStats stats;
  std::string why;
  ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, &stats)) << why;
  EXPECT_EQ(stats.patches, 6u);  // two walls, two caps split in two each
  EXPECT_EQ(stats.inverted, 0u);
  const double apothem = std::cos(tube::kPi / src_shape.n), tol = 1e-9;
  std::vector<int> tag_of(canonical.vertex_count(), 0);
  for (std::size_t f = 0; f < canonical.triangle_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      int& t = tag_of[canonical.triangles[3 * f + std::size_t(c)]];
      t = t == 0 || t == canonical.triangle_tags[f] ? canonical.triangle_tags[f] : -1;
    }
  std::size_t checked = 0;
  for (std::size_t v = 0; v < canonical.vertex_count(); ++v) {
    const double* x = &m.vertices[3 * v];
    const double r = std::hypot(x[0], x[1]);
    switch (tag_of[v]) {
      case 1:
      case 2: {
        const double wall = tag_of[v] == 1 ? src_shape.r_out : src_shape.r_in;
        EXPECT_GE(r, wall * apothem - tol) << v;
        EXPECT_LE(r, wall + tol) << v;
        EXPECT_GT(x[2], -tol);
        EXPECT_LT(x[2], src_shape.height + tol);
        ++checked;
        break;
      }
      case 3:
      case 4:
        EXPECT_NEAR(x[2], tag_of[v] == 3 ? src_shape.height : 0.0, tol) << v;
        EXPECT_GE(r, src_shape.r_in * apothem - tol);
        EXPECT_LE(r, src_shape.r_out + tol);
        ++checked;
        break;
      default:
        break;
    }
  }
  EXPECT_GT(checked, 2u * 24u * 11u);
  // The seam is not where the wall folds: the mapped outer wall covers the whole turn (every
  // 30-degree sector of the source wall gets canonical vertices).
  std::vector<int> sector(12, 0);
  for (std::size_t v = 0; v < canonical.vertex_count(); ++v)
    if (tag_of[v] == 1) {
      const double a = std::atan2(m.vertices[3 * v + 1], m.vertices[3 * v]) + tube::kPi;
      ++sector[std::min<std::size_t>(11, static_cast<std::size_t>(a / (tube::kPi / 6)))];
    }
  for (int c : sector) EXPECT_GT(c, 0);
}

// A host may split a path's segments after emitting it (the OpenCASCADE host bisects long or
// skinny surface triangles, seams included): a seam whose polyline skips every other mesh
// vertex along it (the skipped ones lie on its segments) still cuts its wall open, and the
// mapping still succeeds.
TEST(MeshMapper, SeamWhoseSegmentsAreSplitInTheMeshStillCutsItsFace) {
  const tube::Shape shape{1.0, 2.0, 3.0, 16, 8};
  mesh::Sample source = tube::make(shape);
  std::size_t thinned = 0;
  for (mesh::Path& p : source.paths) {
    // Seam paths only: a seam's polyline runs straight along z (the circles do not).
    const std::vector<double>& pl = p.polyline;
    bool straight = true;
    for (std::size_t i = 3; i < pl.size(); i += 3)
      straight = straight && pl[i] == pl[0] && pl[i + 1] == pl[1];
    if (!straight || pl.size() < 9) continue;
    std::vector<double> every_other;
    for (std::size_t i = 0; i < pl.size(); i += 6)
      every_other.insert(every_other.end(), pl.begin() + long(i), pl.begin() + long(i) + 3);
    if (every_other.size() / 3 != (pl.size() / 3 + 1) / 2 ||
        !std::equal(pl.end() - 3, pl.end(), every_other.end() - 3))
      continue;  // keep the end point: only paths of an odd node count thin exactly
    p.polyline = every_other;
    ++thinned;
  }
  ASSERT_GT(thinned, 0u);
  ASSERT_EQ(mesh::validate(source), "");
  // Each wall cut open along its seam, as with the whole polyline.
  ASSERT_NO_FATAL_FAILURE(tube::expect_walls_cut_open(source));
  mesh::MappedSample m;
  const mesh::Sample canonical = tube::make({1.3, 2.4, 2.2, 24, 12});
  std::string why;
  EXPECT_TRUE(mapping::map_sample(source, canonical, m, why)) << why;
}

// A path end need not be a mesh vertex: an edge sample the mesher did not keep (the OpenCASCADE
// hub's rim seam, coarsely meshed, has a vertex at its sample in one sample of the model and not
// in another). Each seam's sample at 1/4 is moved half a row along the seam, off every mesh
// vertex, with the junction of its two paths; the seam, cut as a whole CAD edge through the
// polyline between the nodes that are vertices, still opens each wall into a disk, and the
// mapping (which drops the moved sample as an anchor) still succeeds.
TEST(MeshMapper, SeamWhoseEdgeSampleIsNoMeshVertexStillCutsItsFace) {
  const tube::Shape shape{1.0, 2.0, 3.0, 16, 8};
  mesh::Sample source = tube::make(shape);
  auto straight = [](const std::vector<double>& pl) {
    bool z_only = true;
    for (std::size_t i = 3; i < pl.size(); i += 3)
      z_only = z_only && pl[i] == pl[0] && pl[i + 1] == pl[1];
    return z_only;
  };
  std::size_t moved = 0;
  for (mesh::Path& a : source.paths) {
    if (!straight(a.polyline) || a.polyline[2] != 0) continue;  // a seam's first path
    for (mesh::Path& b : source.paths) {
      if (&a == &b || !straight(b.polyline) || b.a != a.b) continue;
      // The junction moves half a row up, towards b's next node.
      const std::vector<double> old(a.polyline.end() - 3, a.polyline.end());
      const double row = shape.height / shape.k;
      ASSERT_NEAR(b.polyline[5] - old[2], row, 1e-12);
      const std::vector<double> j{old[0], old[1], old[2] + 0.5 * row};
      a.polyline.insert(a.polyline.end(), j.begin(), j.end());
      std::copy(j.begin(), j.end(), b.polyline.begin());
      for (mesh::ControlPoint& cp : source.points)
        if (cp.id == a.b) std::copy(j.begin(), j.end(), cp.position);
      ++moved;
    }
  }
  ASSERT_EQ(moved, 2u);  // the outer and the inner seam
  ASSERT_EQ(mesh::validate(source), "");
  // Each wall cut open along its seam, as with the sample on a vertex.
  ASSERT_NO_FATAL_FAILURE(tube::expect_walls_cut_open(source));
  mesh::MappedSample m;
  const mesh::Sample canonical = tube::make({1.3, 2.4, 2.2, 24, 12});
  std::string why;
  mapping::MapStats stats;
  ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, &stats)) << why;
  EXPECT_EQ(stats.inverted, 0u);
}

}  // namespace
