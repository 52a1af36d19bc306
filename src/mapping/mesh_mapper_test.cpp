// map_sample end to end (paper §6) on the analytic host's plate and foldplate, whose mesh
// resolution follows their size: independent truth is the host itself (its own mesh of the same
// solid at another resolution, and analytic_model_field_at's closed-form fields).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "mapping/mapping_quality.h"
#include "mapping/mapping_test_util.h"
#include "mapping/mesh_mapper.h"
#include "mesh/surface_distance.h"

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

// Same solid, two resolutions: the mapped canonical mesh is the canonical mesh itself (flat
// faces, affine interior), and the fields are the source's fields at those points.
TEST(MeshMapper, SameSolidAtAnotherResolutionLandsOnTheCanonicalMesh) {
  const Model fine("plate", "edge=4");
  const Model coarse("plate", "edge=7");
  const std::vector<double> x{63.0, 37.0, 6.5};
  const mesh::Sample source = coarse.at(x), canonical = fine.at(x);
  ASSERT_NE(source.vertex_count(), canonical.vertex_count());
  mesh::MappedSample m;
  std::string why;
  mapping::MapStats stats;
  ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, &stats)) << why;
  EXPECT_EQ(stats.patches, 6u);
  EXPECT_EQ(stats.inverted, 0u);
  // Vertices may slide within a face (the two disk parametrizations differ), never off it: the
  // mapped boundary is the canonical one, and the tets fill the same volume.
  const double diag = canonical.bbox_diagonal();
  EXPECT_LT(mesh::symmetric_hausdorff(m.vertices, canonical.triangles, canonical.vertices,
                                      canonical.triangles),
            1e-9 * diag);
  auto volume = [&](const std::vector<double>& v) {
    double sum = 0;
    for (std::size_t t = 0; t < canonical.tet_count(); ++t) {
      const double* p[4];
      for (int i = 0; i < 4; ++i)
        p[i] = &v[3 * std::size_t(canonical.tets[4 * t + std::size_t(i)])];
      double e[3][3];
      for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a) e[i][a] = p[i + 1][a] - p[0][a];
      sum += (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
              e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
              e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0])) /
             6.0;
    }
    return sum;
  };
  EXPECT_NEAR(volume(m.vertices), x[0] * x[1] * x[2], 1e-9 * x[0] * x[1] * x[2]);
  // B-rep corners are control points: they land exactly on themselves.
  for (const mesh::ControlPoint& p : canonical.points) {
    if (p.id[0] != 0) continue;
    double best = 1e300;
    for (std::size_t v = 0; v < canonical.vertex_count(); ++v) {
      double d = 0, e = 0;
      for (int a = 0; a < 3; ++a) {
        d += (canonical.vertices[3 * v + std::size_t(a)] - p.position[a]) *
             (canonical.vertices[3 * v + std::size_t(a)] - p.position[a]);
        e += (m.vertices[3 * v + std::size_t(a)] - p.position[a]) *
             (m.vertices[3 * v + std::size_t(a)] - p.position[a]);
      }
      if (d < 1e-18 * diag * diag) best = std::sqrt(e);
    }
    EXPECT_LT(best, 1e-9 * diag);
  }
  ASSERT_EQ(m.fields.size(), source.fields.size());
  // Displacement is linear along y and z and cubic in x: barycentric interpolation of the
  // coarse source's values is within a small fraction of its range.
  const mapping::PairQuality q = mapping::measure_pair(source, canonical, m, coarse.truth(x));
  EXPECT_LT(q.field_max, 2e-2);
  EXPECT_LT(q.region_area_error, 1e-9);
}

// Across the parameter box: the boundary stays on the source's boundary, no tet inverts,
// boundary-condition faces keep their area, fields follow.
TEST(MeshMapper, PlatePairsAcrossResolutionsMeetTheQualityTargets) {
  const Model plate("plate", "edge=5");
  const std::vector<std::vector<double>> xs{
      {40, 20, 2}, {100, 60, 10}, {57, 23, 9.1}, {91, 48, 3.3}, {44, 59, 7.7}};
  int pairs = 0;
  for (const auto& xa : xs)
    for (const auto& xc : xs) {
      if (xa == xc) continue;
      const mesh::Sample source = plate.at(xa), canonical = plate.at(xc);
      mesh::MappedSample m;
      std::string why;
      ASSERT_TRUE(mapping::map_sample(source, canonical, m, why)) << why;
      const mapping::PairQuality q = mapping::measure_pair(source, canonical, m, plate.truth(xa));
      EXPECT_LE(q.hausdorff_max, 1e-3);
      EXPECT_EQ(q.inverted, 0u);
      EXPECT_GT(q.min_scaled_jacobian, 0.0);
      EXPECT_LT(q.region_area_error, 1e-2);
      EXPECT_LT(q.field_max, 5e-2);
      ++pairs;
    }
  EXPECT_EQ(pairs, 20);
}

// Across a B-rep topology change (the foldplate's top face splits along a crease at fold > 0)
// and across resolutions, both ways: the crease is a layout path on the folded side and a
// shortest path between the same anchors on the flat side, so the boundary stays exact.
TEST(MeshMapper, FoldplatePairsAcrossItsTopologyChange) {
  const Model fold("foldplate", "edge=6");
  const std::vector<std::vector<double>> xs{
      {70, 40, 6, -0.4}, {52, 33, 4.2, 0.7}, {91, 25, 8.5, 0.05}, {45, 58, 3.1, -1}};
  int across = 0;
  for (const auto& xa : xs)
    for (const auto& xc : xs) {
      if (xa == xc) continue;
      const mesh::Sample source = fold.at(xa), canonical = fold.at(xc);
      const auto has7 = [](const mesh::Sample& s) {
        return std::count(s.triangle_tags.begin(), s.triangle_tags.end(), 7) > 0;
      };
      across += has7(source) != has7(canonical) ? 1 : 0;
      mesh::MappedSample m;
      std::string why;
      mapping::MapStats stats;
      ASSERT_TRUE(mapping::map_sample(source, canonical, m, why, &stats)) << why;
      EXPECT_EQ(stats.patches, has7(source) || has7(canonical) ? 7u : 6u);
      const mapping::PairQuality q = mapping::measure_pair(source, canonical, m, fold.truth(xa));
      EXPECT_LE(q.hausdorff_max, 1e-3);
      EXPECT_EQ(q.inverted, 0u);
      EXPECT_LT(q.region_area_error, 1e-2);
      EXPECT_LT(q.field_max, 5e-2);
    }
  EXPECT_EQ(across, 8);
}

TEST(MeshMapper, MappingASampleOntoItselfIsTheIdentity) {
  const Model plate("plate", "edge=6");
  const mesh::Sample s = plate.at({70, 30, 5});
  mesh::MappedSample m;
  std::string why;
  ASSERT_TRUE(mapping::map_sample(s, s, m, why)) << why;
  for (std::size_t i = 0; i < m.vertices.size(); ++i)
    ASSERT_NEAR(m.vertices[i], s.vertices[i], 1e-9 * s.bbox_diagonal());
  for (std::size_t f = 0; f < s.fields.size(); ++f) {
    const auto mm = std::minmax_element(s.fields[f].values.begin(), s.fields[f].values.end());
    for (std::size_t i = 0; i < s.fields[f].values.size(); ++i)
      ASSERT_NEAR(m.fields[f][i], s.fields[f].values[i], 1e-9 * (*mm.second - *mm.first + 1));
  }
}

TEST(MeshMapper, DeterministicAndThreadSafe) {
  const Model plate("plate", "edge=5");
  const mesh::Sample a = plate.at({48, 21, 4}), b = plate.at({95, 55, 9});
  const mapping::MeshMapper mapper;
  mesh::MappedSample first;
  std::string why;
  ASSERT_TRUE(mapper.map(a, b, first, why)) << why;
  std::vector<mesh::MappedSample> results(3);
  std::vector<std::thread> threads;
  for (auto& r : results)
    threads.emplace_back([&, rp = &r] {
      std::string w;
      mapper.map(a, b, *rp, w);
    });
  for (auto& t : threads) t.join();
  for (const auto& r : results) {
    EXPECT_EQ(r.vertices, first.vertices);
    EXPECT_EQ(r.fields, first.fields);
  }
}

TEST(MeshMapper, RefusesWithoutCommonControlPoints) {
  const Model plate("plate", "edge=5");
  mesh::Sample a = plate.at({48, 21, 4});
  const mesh::Sample b = plate.at({95, 55, 9});
  for (auto& p : a.points) p.id.push_back(99);  // no ID equal any more
  mesh::MappedSample m;
  std::string why;
  EXPECT_FALSE(mapping::map_sample(a, b, m, why));
  EXPECT_NE(why.find("no control point with the same ID"), std::string::npos) << why;
}

TEST(MeshMapper, RefusesPatchesThatAreNotDisks) {
  const Model plate("plate", "edge=5");
  mesh::Sample a = plate.at({48, 21, 4});
  mesh::Sample b = plate.at({95, 55, 9});
  // One face tag everywhere and no paths on both sides (a path inside a face is a seam and cut
  // like a border; one side's paths would be traced on the other): the whole closed surface is
  // one patch (a sphere).
  for (mesh::Sample* x : {&a, &b}) {
    std::fill(x->triangle_tags.begin(), x->triangle_tags.end(), 1);
    x->paths.clear();
  }
  mesh::MappedSample m;
  std::string why;
  EXPECT_FALSE(mapping::map_sample(a, b, m, why));
  EXPECT_NE(why.find("not a disk"), std::string::npos) << why;
}

TEST(MeshMapper, RefusesMalformedSamplesByName) {
  const Model plate("plate", "edge=5");
  mesh::Sample a = plate.at({48, 21, 4});
  const mesh::Sample b = plate.at({95, 55, 9});
  a.triangles[7] = static_cast<std::uint32_t>(a.vertex_count() + 3);
  mesh::MappedSample m;
  std::string why;
  EXPECT_FALSE(mapping::map_sample(a, b, m, why));
  EXPECT_NE(why.find("source sample is invalid: triangle vertex index out of range"),
            std::string::npos)
      << why;
  mesh::Sample c = b;
  c.fields[0].values.pop_back();
  EXPECT_FALSE(mapping::map_sample(b, c, m, why));
  EXPECT_NE(why.find("canonical sample is invalid"), std::string::npos) << why;
}

}  // namespace
