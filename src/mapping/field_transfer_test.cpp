// The mapped mesh handed to the host's simulate (mesh_for_simulation, field_transfer.h): the
// analytic host simulates in closed form, so its fields on the mapped mesh are the truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "mapping/field_transfer.h"
#include "mapping/mapping_quality.h"
#include "mapping/mapping_test_util.h"
#include "mapping/mesh_mapper.h"

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// The host's simulate on the mapped mesh (`cadinterp-mapping-report pairs --fem`): the analytic
// host simulates in closed form at each vertex, so the comparison with it gives the closed-form
// comparison's numbers; its boundary-condition faces are found through the canonical's regions
// even where the canonical's face tags are not the source's; and what cannot be simulated is
// said, never crashed on.
TEST(MeshMapper, SimulateOnTheMappedMeshFindsTheRegionsByTheCanonicalsTags) {
  const Model plate("plate", "edge=5");
  const mesh::Host host(*plate.host);
  const std::vector<double> xa{57, 23, 9.1}, xc{91, 48, 3.3};
  const mesh::Sample source = plate.at(xa), canonical = plate.at(xc);
  ASSERT_FALSE(source.regions.empty());
  mesh::MappedSample m;
  std::string why;
  ASSERT_TRUE(mapping::map_sample(source, canonical, m, why)) << why;
  mesh::Sample mesh;
  ASSERT_TRUE(mapping::mesh_for_simulation(source, canonical, m.vertices, mesh, why)) << why;
  EXPECT_EQ(mesh.triangle_tags, canonical.triangle_tags);  // the same faces on both sides
  const mesh::Sample r = host.simulate(xa.data(), mesh);
  ASSERT_TRUE(r.feasible) << r.message;
  const std::vector<mapping::FieldError> errors = mapping::compare_fields(source, m, r);
  ASSERT_FALSE(errors.empty());
  double worst = 0;
  for (const mapping::FieldError& e : errors) worst = std::max(worst, e.max);
  const mapping::PairQuality q = mapping::measure_pair(source, canonical, m, plate.truth(xa));
  EXPECT_GT(q.field_max, 1e-6);  // the transfer interpolates a cubic: not exact
  EXPECT_NEAR(worst, q.field_max, 1e-12);

  // The canonical's tags renumbered (its regions too): each face gets back a source tag in the
  // same regions, and each region keeps its mapped area.
  mesh::Sample renamed = canonical;
  for (std::int32_t& t : renamed.triangle_tags) t += 1000;
  for (mesh::Region& g : renamed.regions)
    for (std::int32_t& t : g.face_tags) t += 1000;
  mesh::Sample retagged;
  ASSERT_TRUE(mapping::mesh_for_simulation(source, renamed, m.vertices, retagged, why)) << why;
  for (const mesh::Region& g : source.regions) {
    const auto c = std::find_if(canonical.regions.begin(), canonical.regions.end(),
                                [&](const mesh::Region& h) { return h.name == g.name; });
    ASSERT_NE(c, canonical.regions.end());
    const double want = mapping::tagged_area(m.vertices, canonical, c->face_tags);
    EXPECT_GT(want, 0) << g.name;
    EXPECT_NEAR(mapping::tagged_area(retagged.vertices, retagged, g.face_tags), want, 1e-9 * want)
        << g.name;
  }
  const mesh::Sample r2 = host.simulate(xa.data(), retagged);
  ASSERT_TRUE(r2.feasible) << r2.message;

  // A canonical face in a region the source lacks has no face to take its tag from.
  renamed.regions.push_back({"nowhere", "fixed", {renamed.triangle_tags[0]}});
  EXPECT_FALSE(mapping::mesh_for_simulation(source, renamed, m.vertices, retagged, why));
  EXPECT_NE(why.find("nowhere"), std::string::npos) << why;

  // A host without simulate, and a mesh with an inverted tet: infeasible, with the reason.
  cadinterp_host bare = *plate.host;
  bare.simulate = nullptr;
  const mesh::Sample none = mesh::Host(bare).simulate(xa.data(), mesh);
  EXPECT_FALSE(none.feasible);
  EXPECT_NE(none.message.find("no simulate"), std::string::npos) << none.message;
  mesh::Sample inverted = mesh;
  std::swap(inverted.tets[0], inverted.tets[1]);
  const mesh::Sample bad = host.simulate(xa.data(), inverted);
  EXPECT_FALSE(bad.feasible);
  EXPECT_NE(bad.message.find("the mesh to simulate on"), std::string::npos) << bad.message;
}

}  // namespace
