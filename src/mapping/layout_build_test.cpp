// The patch layout's subdivision of large patches (layout_build.cpp, paper §6.2) on the analytic
// host's plate, whose flat faces make the exact mapping the truth.
#include <gtest/gtest.h>

#include <string>

#include "mapping/mapping_quality.h"
#include "mapping/mapping_test_util.h"
#include "mapping/mesh_mapper.h"

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// §6.2's subdivision of large patches (MapOptions::subdivide_ratio, off by default): the plate's
// long faces carry edge samples on both long sides, whose straight path across is a small
// fraction of the way round the face's loop between them, so paths are added there; the faces
// are flat, so the mapping stays exact, and no tet inverts.
TEST(MeshMapper, LargePatchesAreSubdividedWhereAPathAcrossIsMuchShorter) {
  const Model plate("plate", "edge=5");
  mapping::MapOptions options;
  options.subdivide_ratio = 0.3;
  const mesh::Sample source = plate.at({100, 30, 4}), canonical = plate.at({90, 40, 6});
  mesh::MappedSample m;
  std::string why;
  mapping::MapStats with, without;
  ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, &with, options)) << why;
  EXPECT_GT(with.subdivided, 0u);
  const mapping::PairQuality q =
      mapping::measure_pair(source, canonical, m, plate.truth({100, 30, 4}));
  EXPECT_LT(q.hausdorff_max, 1e-9);
  EXPECT_EQ(q.inverted, 0u);
  EXPECT_LT(q.field_max, 5e-2);
  mesh::MappedSample plain;
  ASSERT_TRUE(mapping::map_sample(source, canonical, plain, why, &without)) << why;
  EXPECT_EQ(without.subdivided, 0u);
  EXPECT_EQ(with.patches, without.patches + with.subdivided);
}

}  // namespace
