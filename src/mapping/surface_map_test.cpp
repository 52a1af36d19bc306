// Where the surface map puts the canonical's boundary on the source (surface_map.cpp): the
// in-patch relaxation, the smooth reconstruction and the planar placement, against the host's
// own surface or the voxel plate's planes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "mapping/interior_solve.h"
#include "mapping/mapping_quality.h"
#include "mapping/mapping_test_util.h"
#include "mapping/mesh_mapper.h"
#include "mesh/sample.h"
#include "mesh/surface_distance.h"

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// The in-patch relaxation (surface_map.cpp) on the bracket's curved bend: mapped boundary
// vertices stay on the source's surface (the host's mesh is the truth), and the boundary
// approximates the source no worse than the composed disk maps alone (a patch keeps the
// relaxation only where it is nearer), better over the pairs, within the 1e-3 target.
TEST(MeshMapper, InPatchRelaxationTightensCurvedFacesAndStaysOnTheSource) {
  const Model bracket("bracket", "cells=8");
  const std::vector<std::pair<std::vector<double>, std::vector<double>>> pairs{
      {{42, 58, 7.5, 50}, {78, 33, 3.5, 130}},
      {{60, 45, 5, 70}, {62, 47, 5.5, 110}},
      {{50, 40, 4, 100}, {70, 50, 6, 60}}};
  double total[2] = {0, 0};
  for (const auto& [xa, xc] : pairs) {
    const mesh::Sample source = bracket.at(xa), canonical = bracket.at(xc);
    double haus[2];
    for (int relax : {0, 1}) {
      mapping::MapOptions mo;
      if (!relax) mo.relax_iterations = 0;
      // The flat source triangles: the relaxation's own guarantee (the smooth reconstruction,
      // smooth_surface_test.cpp, lifts points off them by up to the chordal sag).
      mo.smooth_alpha = 0;
      mesh::MappedSample m;
      std::string why;
      ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, nullptr, mo))
          << "relax " << relax << ": " << why;
      const mapping::PairQuality q = mapping::measure_pair(source, canonical, m, nullptr);
      EXPECT_EQ(q.inverted, 0u);
      haus[relax] = q.hausdorff_max;
      const mesh::SurfaceIndex on(source.vertices, source.triangles);
      double off = 0;
      for (std::uint32_t v : canonical.triangles)
        off = std::max(off, on.distance(&m.vertices[3 * v]));
      EXPECT_LT(off, 1e-9 * source.bbox_diagonal());
    }
    std::printf("[ figures ] bracket Hausdorff without / with relaxation: %.3e / %.3e\n", haus[0],
                haus[1]);
    EXPECT_LE(haus[1], haus[0]);
    EXPECT_LT(haus[1], 1e-3);
    total[0] += haus[0];
    total[1] += haus[1];
  }
  EXPECT_LT(total[1], 0.9 * total[0]);
}

// Boundary vertices placed on the source's Phong reconstruction (smooth_surface.h) rather
// than on its flat triangles, on the bracket's curved bend. The source's own vertices lie on
// the analytic surface; the mapped boundary passes nearer them (the Hausdorff distance drops),
// lies off the source's triangles by no more than their chordal sag, and no tet inverts.
TEST(MeshMapper, SmoothReconstructionBringsTheBoundaryNearerCurvedFaces) {
  const Model bracket("bracket", "cells=8");
  const std::vector<std::pair<std::vector<double>, std::vector<double>>> pairs{
      {{50, 40, 4, 100}, {70, 50, 6, 60}}};
  for (const auto& [xa, xc] : pairs) {
    const mesh::Sample source = bracket.at(xa), canonical = bracket.at(xc);
    double haus[2], off[2];
    for (int smooth : {0, 1}) {
      mapping::MapOptions mo;
      mo.smooth_alpha = smooth ? 0.5 : 0.0;
      mesh::MappedSample m;
      std::string why;
      ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, nullptr, mo)) << why;
      const mapping::PairQuality q = mapping::measure_pair(source, canonical, m, nullptr);
      EXPECT_EQ(q.inverted, 0u);
      haus[smooth] = q.hausdorff_max;
      const mesh::SurfaceIndex on(source.vertices, source.triangles);
      // Where the maximum lies: a vertex of the mesh it names, that far from the other surface.
      const mesh::SurfaceIndex mapped(m.vertices, canonical.triangles);
      EXPECT_NEAR((q.hausdorff_at_source ? mapped : on).distance(q.hausdorff_at),
                  q.hausdorff_max * source.bbox_diagonal(), 1e-12 * source.bbox_diagonal());
      EXPECT_GE(q.hausdorff_tag, 0);
      off[smooth] = 0;
      for (std::uint32_t v : canonical.triangles)
        off[smooth] = std::max(off[smooth], on.distance(&m.vertices[3 * v]));
    }
    // Phong lifts a point off the chords by at most about their sag; the target bound on the
    // boundary's distance is 1e-3 of the diagonal.
    std::printf(
        "[ figures ] bracket Hausdorff flat / smooth: %.3e / %.3e, off the source %.1e "
        "of the diagonal\n",
        haus[0], haus[1], off[1] / source.bbox_diagonal());
    EXPECT_LT(haus[1], haus[0]);
    EXPECT_LT(off[0], 1e-9 * source.bbox_diagonal());
    EXPECT_GT(off[1], 0.0);  // curved faces: lifted off the chords
    EXPECT_LT(off[1], 1e-3 * source.bbox_diagonal());
  }
}

// A flat face whose hole sits near one corner on the source and near the opposite one on the
// canonical: the composed disk maps of the top and bottom faces (each slit to its hole) fold
// canonical triangles over, and the tets on them invert whatever the interior does. Laying the
// canonical into the face's plane (planar_placement) unfolds the faces, and the interior
// untangling (foldover_free.h) the tets; the truth is the source solid itself, which the mapped
// surface must match exactly (flat faces).
TEST(MeshMapper, FlatFaceWhoseHoleMovesFarIsUnfoldedInItsPlane) {
  const mesh::Sample source = voxel::plate(12, 8, 1, 1, {{1, 1, 2, 2}});
  const mesh::Sample canonical = voxel::plate(12, 8, 1, 0.5, {{8, 5, 10, 7}});
  ASSERT_EQ(mesh::validate(source), "");
  ASSERT_EQ(mesh::validate(canonical), "");
  mesh::MappedSample m;
  std::string why;
  mapping::MapStats stats;
  ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, &stats)) << why;
  EXPECT_EQ(stats.planar_patches, 2u);  // top and bottom
  EXPECT_EQ(mapping::tet_quality(m.vertices, canonical.tets).inverted, 0u);
  const mapping::PairQuality q = mapping::measure_pair(source, canonical, m, nullptr);
  EXPECT_LT(q.hausdorff_max, 1e-9);
  voxel::expect_on_outer_planes(canonical, m, 12, 1);
  // Without either step the folds stay and the pair is refused by name, never emitted.
  mapping::MapOptions without;
  without.planar_patches = false;
  without.foldover_free = false;
  mesh::MappedSample refused;
  why.clear();
  EXPECT_FALSE(mapping::map_sample(source, canonical, refused, why, nullptr, without));
  EXPECT_NE(why.find("would invert or flatten"), std::string::npos) << why;
}

}  // namespace
