// Canonical refinement (canonical_refine.h) on the analytic bracket, whose bend is a cylinder:
// the bisection itself, and a coarse canonical under a finer source's bend.
#include "mapping/canonical_refine.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "mapping/interior_solve.h"
#include "mapping/mapping_quality.h"
#include "mapping/mapping_test_util.h"
#include "mapping/mesh_mapper.h"

namespace {

using namespace cadinterp;

mesh::Sample bracket(const char* options, const std::vector<double>& x) {
  return mapping_test::Model("bracket", options).at(x);
}

// Sum over tets of a per-tet field times the tet's volume, and the solid's volume.
void integrals(const mesh::Sample& s, int field, double& volume, double& integral) {
  volume = integral = 0;
  for (std::size_t t = 0; t < s.tet_count(); ++t) {
    const double v = mapping::six_volume(s.vertices, &s.tets[4 * t]) / 6.0;
    volume += v;
    integral += v * s.fields[static_cast<std::size_t>(field)].values[t];
  }
}

double boundary_area(const mesh::Sample& s) {
  const std::set<std::int32_t> tags(s.triangle_tags.begin(), s.triangle_tags.end());
  return mapping::tagged_area(s.vertices, s, std::vector<std::int32_t>(tags.begin(), tags.end()));
}

TEST(CanonicalRefine, BisectionSplitsEveryElementAroundTheEdgeAndKeepsTheSolid) {
  const mesh::Sample s = bracket("cells=2", {60.0, 45.0, 5.0, 90.0});
  ASSERT_EQ(mesh::validate(s), "");
  // Fields: temperature per vertex (0), von_mises per tet (1).
  ASSERT_EQ(s.fields.size(), 2u);
  ASSERT_EQ(s.fields[1].location, 1);
  auto around = [&](const mesh::Sample& m, std::uint32_t a, std::uint32_t b, bool tets) {
    const std::vector<std::uint32_t>& e = tets ? m.tets : m.triangles;
    const std::size_t n = tets ? 4 : 3;
    int count = 0;
    for (std::size_t t = 0; t < e.size() / n; ++t) {
      bool ha = false, hb = false;
      for (std::size_t k = 0; k < n; ++k) {
        ha = ha || e[n * t + k] == a;
        hb = hb || e[n * t + k] == b;
      }
      count += ha && hb ? 1 : 0;
    }
    return count;
  };
  // Two boundary edges far apart, one given twice, and a pair of vertices that is no edge.
  const std::uint32_t* f0 = &s.triangles[0];
  const std::uint32_t* f1 = &s.triangles[3 * (s.triangle_count() - 1)];
  std::set<std::uint32_t> near(f0, f0 + 3);
  near.insert(f1, f1 + 3);
  std::uint32_t far = 0;
  while (near.count(far) || around(s, f0[0], far, true) > 0) ++far;
  const std::vector<std::array<std::uint32_t, 2>> edges{
      {f0[0], f0[1]}, {f1[1], f1[2]}, {f0[1], f0[0]}, {f0[0], far}};
  const int tets0 = around(s, f0[0], f0[1], true), tets1 = around(s, f1[1], f1[2], true);
  ASSERT_GT(tets0, 0);
  ASSERT_GT(tets1, 0);
  ASSERT_EQ(around(s, f0[0], far, true), 0);

  const mesh::Sample r = mapping::bisect_edges(s, edges);
  EXPECT_EQ(mesh::validate(r), "");  // positive tets, consistent triangles, tags, fields
  ASSERT_EQ(r.vertex_count(), s.vertex_count() + 2);
  EXPECT_EQ(r.tet_count(), s.tet_count() + static_cast<std::size_t>(tets0 + tets1));
  EXPECT_EQ(r.triangle_count(), s.triangle_count() + 4);  // two triangles at each edge
  EXPECT_EQ(around(r, f0[0], f0[1], true), 0);            // the edges are gone
  // The new vertices are the midpoints, with the temperature's mean.
  const std::array<std::uint32_t, 2> split[2] = {{f0[0], f0[1]}, {f1[1], f1[2]}};
  for (int i = 0; i < 2; ++i) {
    const std::size_t m = s.vertex_count() + static_cast<std::size_t>(i);
    for (int c = 0; c < 3; ++c)
      EXPECT_DOUBLE_EQ(r.vertices[3 * m + c],
                       0.5 * (s.vertices[3 * split[i][0] + c] + s.vertices[3 * split[i][1] + c]));
    EXPECT_DOUBLE_EQ(r.fields[0].values[m],
                     0.5 * (s.fields[0].values[split[i][0]] + s.fields[0].values[split[i][1]]));
    EXPECT_EQ(around(r, split[i][0], static_cast<std::uint32_t>(m), true), i == 0 ? tets0 : tets1);
  }
  // The same solid: volume, boundary area, a per-tet field's integral (halves copy it).
  double v0, i0, v1, i1;
  integrals(s, 1, v0, i0);
  integrals(r, 1, v1, i1);
  EXPECT_NEAR(v1, v0, 1e-12 * v0);
  EXPECT_NEAR(i1, i0, 1e-12 * std::abs(i0));
  EXPECT_NEAR(boundary_area(r), boundary_area(s), 1e-12 * boundary_area(s));
  // References are kept as they are.
  EXPECT_EQ(r.points.size(), s.points.size());
  EXPECT_EQ(r.paths.size(), s.paths.size());
  EXPECT_EQ(r.regions.size(), s.regions.size());

  // Only pairs that are no boundary edge: nothing changes.
  const auto V = static_cast<std::uint32_t>(s.vertex_count());
  const mesh::Sample same =
      mapping::bisect_edges(s, {{f0[0], far}, {f0[0], f0[0]}, {f0[0], V}, {V + 7, 0}});
  EXPECT_EQ(same.vertices, s.vertices);
  EXPECT_EQ(same.tets, s.tets);
}

// The bracket's bend under a coarse canonical: each mapped triangle across it is a chord of the
// finer source's cylinder, by 1.3e-3 to 2.9e-3 of the diagonal here, whatever the mapping does.
// Refinement bisects the chords across the bend and brings every pair under the tolerance, the
// canonical sample itself mapped onto the refined mesh as well (an element's own term).
TEST(CanonicalRefine, CoarseCanonicalUnderABendFallsBelowTheTolerance) {
  const std::vector<double> xc{62.0, 44.0, 6.0, 100.0};
  const mesh::Sample canonical = bracket("cells=6", xc);
  for (const std::vector<double>& xa :
       {std::vector<double>{62.0, 44.0, 6.0, 100.0}, std::vector<double>{48.0, 56.0, 4.0, 130.0},
        std::vector<double>{75.0, 33.0, 7.5, 135.0}}) {
    SCOPED_TRACE(testing::Message() << "source at " << xa[0] << ", " << xa[3] << " deg");
    const mesh::Sample source = bracket("cells=12", xa);
    const mapping::MeshMapper mapper;
    mesh::MappedSample direct;
    std::string why;
    ASSERT_TRUE(mapper.map(source, canonical, direct, why)) << why;
    const double before = mapping::mapped_departure(source, canonical, direct.vertices, 0, nullptr);
    EXPECT_GT(before, 1e-3);  // what refinement is for

    mesh::Sample refined;
    std::vector<mesh::MappedSample> mapped;
    mapping::RefineStats stats;
    ASSERT_TRUE(mapping::refine_canonical({&source, &canonical}, canonical, mapper, refined, mapped,
                                          why, &stats))
        << why;
    EXPECT_NEAR(stats.before, before, 1e-12);  // the canonical's own departure is rounding
    EXPECT_GE(stats.rounds, 1);
    EXPECT_LT(stats.after, mapping::RefineOptions().tolerance) << stats.stopped;
    EXPECT_EQ(stats.added_vertices, refined.vertex_count() - canonical.vertex_count());
    EXPECT_LE(static_cast<double>(refined.vertex_count()),
              1.5 * static_cast<double>(canonical.vertex_count()));
    EXPECT_EQ(mesh::validate(refined), "");
    ASSERT_EQ(mapped.size(), 2u);
    for (const mesh::MappedSample& m : mapped) {
      EXPECT_EQ(m.vertices.size(), refined.vertices.size());
      EXPECT_EQ(mapping::tet_quality(m.vertices, refined.tets).inverted, 0u);
    }
    const mapping::PairQuality q = mapping::measure_pair(source, refined, mapped[0], {});
    EXPECT_LT(q.hausdorff_max, 1e-3);
    EXPECT_EQ(q.inverted, 0u);
    EXPECT_LT(q.region_area_error, 1e-2);
    // After the first round the maps were carried (no tet inverts on this bend); mapped again
    // instead, refinement bisects the same edges and the surfaces differ by far less than the
    // tolerance.
    EXPECT_GT(stats.carried, 0u);
    EXPECT_EQ(stats.remapped, 0u);
    mapping::RefineOptions remap;
    remap.carry_maps = false;
    mesh::Sample refined_remapped;
    std::vector<mesh::MappedSample> remapped;
    mapping::RefineStats remap_stats;
    ASSERT_TRUE(mapping::refine_canonical({&source, &canonical}, canonical, mapper,
                                          refined_remapped, remapped, why, &remap_stats, remap));
    EXPECT_EQ(remap_stats.carried, 0u);
    EXPECT_GT(remap_stats.remapped, 0u);
    EXPECT_LT(remap_stats.after, mapping::RefineOptions().tolerance);
    if (refined_remapped.tets == refined.tets) {
      const mapping::PairQuality r = mapping::measure_pair(source, refined, remapped[0], {});
      EXPECT_LT(std::fabs(q.hausdorff_max - r.hausdorff_max), 2e-4)
          << q.hausdorff_max << " carried, " << r.hausdorff_max << " mapped again";
      double field_gap = 0, field_range = 0;
      for (std::size_t f = 0; f < source.fields.size(); ++f) {
        if (source.fields[f].location != 0) continue;
        const auto [lo, hi] =
            std::minmax_element(source.fields[f].values.begin(), source.fields[f].values.end());
        field_range = std::max(field_range, *hi - *lo);
        for (std::size_t v = 0; v < mapped[0].fields[f].size(); ++v)
          field_gap =
              std::max(field_gap, std::fabs(mapped[0].fields[f][v] - remapped[0].fields[f][v]));
      }
      EXPECT_LT(field_gap, 2e-2 * field_range) << field_gap << " of a range " << field_range;
    } else {
      ADD_FAILURE() << "carried and mapped again, refinement bisected other edges";
    }
    // The same on two threads.
    mapping::RefineOptions two;
    two.threads = 2;
    mesh::Sample refined2;
    std::vector<mesh::MappedSample> mapped2;
    ASSERT_TRUE(mapping::refine_canonical({&source, &canonical}, canonical, mapper, refined2,
                                          mapped2, why, nullptr, two));
    EXPECT_EQ(refined2.tets, refined.tets);
    ASSERT_EQ(mapped2.size(), 2u);
    EXPECT_EQ(mapped2[0].vertices, mapped[0].vertices);
    EXPECT_EQ(mapped2[0].fields, mapped[0].fields);
    // The canonical's own term stays on its own surface.
    EXPECT_LT(mapping::mapped_departure(canonical, refined, mapped[1].vertices, 0, nullptr), 1e-3);
    // Cancelled: before the first mapping, refinement fails by name; after the two mappings onto
    // the original canonical, the round under way is dropped and the original kept.
    mapping::RefineOptions cancel;
    int asked = 0, allowed = 0;
    cancel.cancelled = [&] { return ++asked > allowed; };
    mesh::Sample refined3;
    std::vector<mesh::MappedSample> mapped3;
    EXPECT_FALSE(mapping::refine_canonical({&source, &canonical}, canonical, mapper, refined3,
                                           mapped3, why, nullptr, cancel));
    EXPECT_EQ(why, "cancelled");
    asked = 0;
    allowed = 2;
    mapped3.clear();
    ASSERT_TRUE(mapping::refine_canonical({&source, &canonical}, canonical, mapper, refined3,
                                          mapped3, why, &stats, cancel));
    EXPECT_EQ(stats.rounds, 0);
    EXPECT_NE(stats.stopped.find("cancelled"), std::string::npos) << stats.stopped;
    EXPECT_EQ(refined3.vertices, canonical.vertices);
    ASSERT_EQ(mapped3.size(), 2u);
    EXPECT_EQ(mapped3[0].vertices, direct.vertices);
  }
}

}  // namespace
