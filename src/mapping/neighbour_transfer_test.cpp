// The bridge that carries a neighbour element's sample into this element's combinatorics
// (neighbour_transfer.h, paper §5.3) on the analytic host's plate.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "mapping/mapping_quality.h"
#include "mapping/mapping_test_util.h"
#include "mapping/mesh_mapper.h"
#include "mapping/neighbour_transfer.h"
#include "mesh/sample.h"

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// §5.3, Fig. 15: a neighbour element's sample brought into this element's combinatorics through
// a shared sample (one §6 mapping per sample, then barycentric transfer) lands on the sample's
// own boundary, like the direct mapping, with its fields.
TEST(MeshMapper, NeighbourTransferThroughASharedSample) {
  const Model plate("plate", "edge=5");
  const std::vector<double> xl{60, 30, 6}, xn{85, 50, 8}, xs{72, 40, 7}, xk{95, 55, 9};
  const mesh::Sample element = plate.at(xl), neighbour = plate.at(xn);
  const mesh::Sample shared = plate.at(xs), k = plate.at(xk);
  ASSERT_FALSE(mesh::same_combinatorics(element, neighbour));
  mesh::MappedSample s_n, s_l, k_n, k_l;
  std::string why;
  ASSERT_TRUE(mapping::map_sample(shared, neighbour, s_n, why)) << why;
  ASSERT_TRUE(mapping::map_sample(shared, element, s_l, why)) << why;
  ASSERT_TRUE(mapping::map_sample(k, neighbour, k_n, why)) << why;
  const mapping::NeighbourBridge bridge(neighbour, s_n.vertices, element, s_l.vertices);
  ASSERT_TRUE(bridge.ok()) << bridge.why();
  ASSERT_TRUE(bridge.apply(k_n, k_l, why)) << why;
  const mapping::PairQuality q = mapping::measure_pair(k, element, k_l, plate.truth(xk));
  EXPECT_LE(q.hausdorff_max, 1e-3);
  EXPECT_EQ(q.inverted, 0u);
  EXPECT_LT(q.region_area_error, 1e-2);
  EXPECT_LT(q.field_max, 5e-2);
  mesh::MappedSample wrong;
  EXPECT_FALSE(bridge.apply(s_l, wrong, why));  // not in the neighbour's combinatorics
}

}  // namespace
