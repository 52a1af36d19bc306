// Patches with holes split into disks (hole_split.cpp) by paths or slits, on the analytic host's
// plate and the voxel plate of mapping_test_util.h: the source solid itself is the truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "mapping/interior_solve.h"
#include "mapping/mapping_quality.h"
#include "mapping/mapping_test_util.h"
#include "mapping/mesh_mapper.h"
#include "mesh/sample.h"

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// A patch that is not a disk: with the four side faces given one tag and the four vertical edges
// between them gone (as in a B-rep where the faces merged), the sides form a band (a disk with a
// hole) between the top and bottom loops. Two shortest paths between the same anchors on both
// sides split it into disks; the mapping stays on the source's boundary.
TEST(MeshMapper, PatchesWithHolesAreSplitIntoDisks) {
  const Model plate("plate", "edge=4");
  auto band = [](mesh::Sample s) {
    for (std::int32_t& t : s.triangle_tags)
      if (t <= 4) t = 1;
    s.paths.erase(std::remove_if(s.paths.begin(), s.paths.end(),
                                 [](const mesh::Path& p) {
                                   const std::size_t n = p.polyline.size();
                                   return p.polyline[0] == p.polyline[n - 3] &&
                                          p.polyline[1] == p.polyline[n - 2];
                                 }),
                  s.paths.end());
    return s;
  };
  const mesh::Sample source = band(plate.at({52, 28, 7})), canonical = band(plate.at({88, 46, 5}));
  mesh::MappedSample m;
  std::string why;
  mapping::MapStats stats;
  ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, &stats)) << why;
  EXPECT_EQ(stats.patches, 4u);  // top, bottom, and the band in two
  const mapping::PairQuality q =
      mapping::measure_pair(source, canonical, m, plate.truth({52, 28, 7}));
  std::printf("band: Hausdorff %.2e, area error %.2e, min SJ %.3f\n", q.hausdorff_max,
              q.region_area_error, q.min_scaled_jacobian);
  EXPECT_EQ(q.inverted, 0u);
  EXPECT_LT(q.region_area_error, 1e-2);
  EXPECT_LT(q.field_max, 5e-2);
  EXPECT_LE(q.hausdorff_max, 2e-2);
}

// The plate with three through-holes: its top and bottom faces have four boundary loops each,
// every hole loop with a single anchor, and each hole wall is an annulus with one anchor per
// loop: too few anchors for the two-path split, so each hole is joined to the loop outside it by
// a slit. Same solid at two resolutions, so the truth is the solid itself: every mapped boundary
// vertex on the source surface, the surface covered (Hausdorff both ways), every tet valid.
TEST(MeshMapper, FaceWithSeveralHolesIsSlitIntoOneDisk) {
  const std::vector<voxel::Hole> holes = {{2, 2, 4, 4}, {6, 4, 8, 6}, {9, 1, 10, 3}};
  const mesh::Sample source = voxel::plate(12, 8, 1, 1, holes);
  const mesh::Sample canonical = voxel::plate(12, 8, 1, 0.5, holes);
  ASSERT_EQ(mesh::validate(source), "");
  ASSERT_EQ(mesh::validate(canonical), "");
  mesh::MappedSample m;
  std::string why;
  mapping::MapStats stats;
  ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, &stats)) << why;
  // top, bottom, four outer walls, three hole walls: each one (slit) disk.
  EXPECT_EQ(stats.patches, 9u);
  EXPECT_EQ(stats.inverted, 0u);
  EXPECT_EQ(mapping::tet_quality(m.vertices, canonical.tets).inverted, 0u);
  const mapping::PairQuality q = mapping::measure_pair(source, canonical, m, nullptr);
  std::printf("plate with 3 holes: Hausdorff %.2e, min SJ %.3f\n", q.hausdorff_max,
              q.min_scaled_jacobian);
  // The faces are flat: the mapped surface lies on the source's and covers it.
  EXPECT_LT(q.hausdorff_max, 1e-9);
  voxel::expect_on_outer_planes(canonical, m, 12, 1);
}

}  // namespace
