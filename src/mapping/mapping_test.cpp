// The mesh mapper (paper §6) on the analytic host's plate, whose mesh resolution follows its
// size: independent truth is the host itself (its own mesh of the same solid at another
// resolution, and analytic_model_field_at's closed-form fields).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "analytic_host.h"
#include "mesh/host_call.h"
#include "mesh/surface_distance.h"
#include "mapping/boundary_untangle.h"
#include "mapping/correspondence.h"
#include "mapping/field_transfer.h"
#include "mapping/geodesic.h"
#include "mapping/interior_solve.h"
#include "mapping/layout_paths.h"
#include "mapping/mapping_quality.h"
#include "mapping/mesh_mapper.h"
#include "mapping/neighbour_transfer.h"
#include "mapping/patch_layout.h"
#include "mapping/path_release.h"
#include "mapping/surface.h"

namespace {

using namespace cadinterp;

struct Model {
  const cadinterp_host* host = nullptr;
  const analytic_model* model = nullptr;
  explicit Model(const char* name, const char* options) {
    const char* err = nullptr;
    host = cadinterp_host_entry(name, options, &err);
    if (!host) throw std::runtime_error(err ? err : "no host");
    model = analytic_host_model(host);
  }
  mesh::Sample at(const std::vector<double>& x) const {
    mesh::Sample s = mesh::Host(*host).evaluate(x.data());
    if (!s.feasible) throw std::runtime_error("infeasible: " + s.message);
    return s;
  }
  mapping::FieldTruth truth(const std::vector<double>& x) const {
    return [this, x](int f, const double* p, double* v) {
      return analytic_model_field_at(model, f, x.data(), p, v) == CADINTERP_OK;
    };
  }
};

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
  const mesh::Sample source = band(plate.at({52, 28, 7})),
                        canonical = band(plate.at({88, 46, 5}));
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

// Round 5: boundary vertices placed on the source's Phong reconstruction (smooth_surface.h)
// instead of its flat triangles, on the bracket's curved bend. The source's own vertices lie on
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
    // Phong lifts a point off the chords by at most about their sag; the bound on the
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

// Kraevoy–Sheffer's cyclic-order check (§6.2) on a constructed case: an octahedron with paths
// from the top (+z) to +x and -x on both sides. A new path from the top to +y leaves the top
// between +x and -x on one side; on the other side a path to +y that runs round the back (via
// -y and the bottom) leaves the top in the -y slot, between -x and +x the other way round. The
// check rejects it and accepts the direct path.
TEST(LayoutPaths, CyclicOrderCheckRejectsAPathOnTheWrongSideOfAnAnchor) {
  mesh::Sample oct;
  oct.feasible = true;
  // 0:+x 1:-x 2:+y 3:-y 4:+z 5:-z
  oct.vertices = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  oct.triangles = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  oct.triangle_tags.assign(8, 1);
  mapping::Surface s;
  std::string why;
  ASSERT_TRUE(mapping::build_surface(oct, s, why)) << why;
  // Anchors at +x, -x, +y and +z (indices 0, 1, 2, 4 = vertex index); -y and -z are not.
  const std::vector<int> anchor_of{0, 1, 2, -1, 4, -1};
  std::vector<char> before(3 * std::size_t(s.triangles()), 0);
  mapping::cut_along(s, {4, 0}, before);
  mapping::cut_along(s, {4, 1}, before);
  std::vector<char> direct = before, around = before;
  mapping::cut_along(s, {4, 2}, direct);
  mapping::cut_along(s, {4, 3, 5, 2}, around);
  // The paths around the top, by far anchor: the round-about path ends at +y too.
  std::vector<std::vector<int>> far = mapping::paths_around(s, around, 4, anchor_of, nullptr);
  std::sort(far.begin(), far.end());
  EXPECT_EQ(far, (std::vector<std::vector<int>>{{0}, {1}, {2}}));
  const mapping::PathEnd a{&s, &before, &direct, 4, &anchor_of};
  const mapping::PathEnd b{&s, &before, &around, 4, &anchor_of};
  EXPECT_TRUE(mapping::cyclic_order_agrees(a, a));
  EXPECT_FALSE(mapping::cyclic_order_agrees(a, b));
  EXPECT_FALSE(mapping::cyclic_order_agrees(b, a));
  // At +y, the far end, each side has the new path only: nothing to disagree with.
  const mapping::PathEnd a2{&s, &before, &direct, 2, &anchor_of};
  const mapping::PathEnd b2{&s, &before, &around, 2, &anchor_of};
  EXPECT_TRUE(mapping::cyclic_order_agrees(a2, b2));
}

// Two sides' paths between the same anchors, on a flat face with a hole of radius 2 at (5, 0)
// between the anchors (0, 0) and (10, 0): the canonical is the source scaled by 1.2 and moved by
// (30, 5, 0). A path over the hole on both sides runs alike, zigzag and all, and so does one
// with a few more vertices; a path over the hole on one side and under it on the other does not
// (the patch keys cannot tell them apart, the disk maps would shear the face between them).
TEST(LayoutPaths, PathsRoundAHoleOnDifferentSidesDoNotRunAlike) {
  mesh::Sample src, can;
  auto add = [](mesh::Sample& s, double x, double y) {
    s.vertices.insert(s.vertices.end(), {x, y, 0.0});
    return std::uint32_t(s.vertices.size() / 3 - 1);
  };
  auto moved = [&](double x, double y) { return add(can, 30 + 1.2 * x, 5 + 1.2 * y); };
  const std::uint32_t s0 = add(src, 0, 0), s1 = add(src, 10, 0);
  std::vector<std::uint32_t> src_over{s0}, can_over{moved(0, 0)}, can_fine{moved(0, 0)},
      can_under{moved(0, 0)};
  const double over[][2] = {{2, 1.5}, {3.5, 2.8}, {5, 3.2}, {6.5, 2.6}, {8, 1.4}};
  for (const auto& q : over) {
    src_over.push_back(add(src, q[0], q[1]));
    can_over.push_back(moved(q[0], q[1] + 0.3));
    can_under.push_back(moved(q[0], -q[1]));
  }
  for (int k = 1; k < 10; ++k) {
    const double x = k, y = std::sqrt(std::max(0.0, 9 - (x - 5) * (x - 5))) + 0.4 * (k % 2);
    can_fine.push_back(moved(x, y));
  }
  src_over.push_back(s1);
  for (auto* c : {&can_over, &can_fine, &can_under}) c->push_back(moved(10, 0));
  const mapping::Surface ss{&src, {}, {}, {}}, cs{&can, {}, {}, {}};
  EXPECT_TRUE(mapping::paths_run_alike(ss, src_over, cs, can_over));
  EXPECT_TRUE(mapping::paths_run_alike(ss, src_over, cs, can_fine));
  EXPECT_TRUE(mapping::paths_run_alike(cs, can_over, ss, src_over));
  EXPECT_FALSE(mapping::paths_run_alike(ss, src_over, cs, can_under));
  EXPECT_FALSE(mapping::paths_run_alike(cs, can_under, ss, src_over));
  EXPECT_FALSE(mapping::paths_run_alike(ss, {s0}, cs, can_over));
  // A caller's slack of a quarter of the hole's diameter (1) still tells over from under.
  EXPECT_FALSE(mapping::paths_run_alike(ss, src_over, cs, can_under, 1.0));
}

// A slit across a strip one triangle wide (the OpenCASCADE hub's rim face at a chord angle of
// 0.2) is one edge on the canonical; on the source, with a vertex inside the strip, it bends by
// 2.65 on a path of 8.6, more than a quarter of it. Such paths run alike only within a caller's
// slack of at least that bend.
TEST(LayoutPaths, SlackAcceptsAPathBentByTheMesh) {
  mesh::Sample src, can;
  src.vertices = {53.16, 0, 40, 56.45, -2.65, 40, 60, 0, 40};
  can.vertices = {55.27, 0, 40, 60, 0, 40};
  const mapping::Surface ss{&src, {}, {}, {}}, cs{&can, {}, {}, {}};
  const std::vector<std::uint32_t> bent{0, 1, 2}, straight{0, 1};
  EXPECT_FALSE(mapping::paths_run_alike(ss, bent, cs, straight));
  EXPECT_FALSE(mapping::paths_run_alike(ss, bent, cs, straight, 2.0));
  EXPECT_TRUE(mapping::paths_run_alike(ss, bent, cs, straight, 3.0));
  EXPECT_TRUE(mapping::paths_run_alike(cs, straight, ss, bent, 3.0));
}

// P1-harmonic extension reproduces affine maps exactly (a mirror image here), and the quality
// check sees that every mirrored tet is inverted.
TEST(MeshMapper, HarmonicInteriorIsExactForAffineMapsAndInversionsAreCounted) {
  // Small: the direct solve; large (over 3000 interior vertices): conjugate gradients.
  for (const auto& [options, x, tolerance] :
       {std::make_tuple("edge=2", std::vector<double>{41, 21, 6.2}, 1e-9),
        std::make_tuple("edge=1.2", std::vector<double>{60, 30, 6.2}, 1e-7)}) {
    const Model plate("plate", options);
    const mesh::Sample s = plate.at(x);
    std::vector<char> fixed(s.vertex_count(), 0);
    for (std::uint32_t v : s.triangles) fixed[v] = 1;
    ASSERT_NE(std::count(fixed.begin(), fixed.end(), 0), 0);
    auto affine = [](const double* p, double* q) {
      q[0] = -1.5 * p[0] + 0.2 * p[1] + 3;
      q[1] = 0.7 * p[1] - 0.1 * p[2];
      q[2] = 0.3 * p[0] + 1.1 * p[2] - 2;
    };
    std::vector<double> mapped(s.vertices.size(), 0.0), expected(s.vertices.size());
    for (std::size_t v = 0; v < s.vertex_count(); ++v) {
      affine(&s.vertices[3 * v], &expected[3 * v]);
      if (fixed[v]) std::copy_n(&expected[3 * v], 3, &mapped[3 * v]);
    }
    std::string why;
    ASSERT_TRUE(mapping::harmonic_interior(s.vertices, s.tets, fixed, mapped, why)) << why;
    for (std::size_t i = 0; i < mapped.size(); ++i) ASSERT_NEAR(mapped[i], expected[i], tolerance);
    // det of the linear part < 0: an orientation-reversing map inverts every tet.
    EXPECT_EQ(mapping::tet_quality(mapped, s.tets).inverted, s.tet_count());
    EXPECT_EQ(mapping::tet_quality(s.vertices, s.tets).inverted, 0u);
  }
}

TEST(MeshMapper, PathEdgeKeysNameTheCadEdge) {
  mesh::Path p;
  p.a = {0, 3, 2, 7, 11};
  p.b = {1, 7, 3, 4, -1, 0};
  EXPECT_EQ(mapping::path_edge_key(p), (mapping::Id{1, 7, 3, 4}));
  mesh::Path q;
  q.a = {0, 4, 1};
  q.b = {0, 3, 1};
  EXPECT_EQ(mapping::path_edge_key(q), (mapping::Id{2, 3, 0, 3, 1, 0, 4, 1}));
}

TEST(MeshMapper, ScaledJacobianOfARegularTetIsOne) {
  // Regular tet: alternate corners of a cube, positively oriented.
  const std::vector<double> v{0, 0, 0, 1, 1, 0, 1, 0, 1, 0, 1, 1};
  const std::vector<std::uint32_t> t{0, 1, 2, 3};
  mapping::TetQuality q = mapping::tet_quality(v, t);
  if (q.inverted) q = mapping::tet_quality(v, {0, 2, 1, 3});
  EXPECT_NEAR(q.min_scaled_jacobian, 1.0, 1e-12);
}

}  // namespace

// A thick-walled tube, tet-meshed here: the analytic stand-in for a B-rep cylinder face with a
// seam (what the OpenCASCADE host emits: its lateral faces bounded by two closed circle edges
// and crossed by a seam edge whose paths have the same face on both sides). Control points and
// paths follow cadinterp_builder.h's ID scheme with one subdivision level.
namespace tube {

constexpr double kPi = 3.14159265358979323846;

struct Shape {
  double r_in, r_out, height;
  int n, k;  // angular and axial segments (multiples of 4: the edge points are mesh vertices)
};

mesh::Sample make(const Shape& t) {
  mesh::Sample s;
  s.feasible = true;
  const int R = 3;  // radial nodes: one interior layer
  auto index = [&](int i, int j, int k) {
    return static_cast<std::uint32_t>((k * t.n + (j % t.n)) * R + i);
  };
  for (int k = 0; k <= t.k; ++k)
    for (int j = 0; j < t.n; ++j)
      for (int i = 0; i < R; ++i) {
        const double r = t.r_in + (t.r_out - t.r_in) * i / (R - 1), a = 2 * kPi * j / t.n;
        s.vertices.insert(s.vertices.end(), {r * std::cos(a), r * std::sin(a), t.height * k / t.k});
      }
  auto six_vol = [&](const std::uint32_t* q) {
    const double* p[4];
    for (int c = 0; c < 4; ++c) p[c] = &s.vertices[3 * std::size_t(q[c])];
    double e[3][3];
    for (int c = 0; c < 3; ++c)
      for (int d = 0; d < 3; ++d) e[c][d] = p[c + 1][d] - p[0][d];
    return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
           e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
           e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
  };
  // Kuhn's six tets per hex cell (the same diagonal everywhere: conforming).
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < t.k; ++k)
    for (int j = 0; j < t.n; ++j)
      for (int i = 0; i + 1 < R; ++i)
        for (const auto& p : perms) {
          int c[3] = {0, 0, 0};
          std::uint32_t q[4];
          q[0] = index(i, j, k);
          for (int s3 = 0; s3 < 3; ++s3) {
            c[p[s3]] = 1;
            q[s3 + 1] = index(i + c[0], j + c[1], k + c[2]);
          }
          if (six_vol(q) < 0) std::swap(q[2], q[3]);
          s.tets.insert(s.tets.end(), q, q + 4);
        }
  // Boundary: faces used by one tet, outward (tet faces (a,c,b), (a,b,d), (a,d,c), (b,c,d)).
  std::map<std::vector<std::uint32_t>, std::pair<int, std::vector<std::uint32_t>>> faces;
  for (std::size_t q = 0; q < s.tets.size(); q += 4) {
    const std::uint32_t a = s.tets[q], b = s.tets[q + 1], c = s.tets[q + 2], d = s.tets[q + 3];
    for (const std::vector<std::uint32_t>& f :
         {std::vector<std::uint32_t>{a, c, b}, {a, b, d}, {a, d, c}, {b, c, d}}) {
      std::vector<std::uint32_t> key = f;
      std::sort(key.begin(), key.end());
      auto& e = faces[key];
      ++e.first;
      e.second = f;
    }
  }
  for (const auto& [key, e] : faces) {
    if (e.first != 1) continue;
    s.triangles.insert(s.triangles.end(), e.second.begin(), e.second.end());
    int tag;  // 1 outer wall, 2 inner wall, 3 top, 4 bottom
    auto radial = [&](std::uint32_t v) { return static_cast<int>(v % R); };
    auto axial = [&](std::uint32_t v) { return static_cast<int>(v / (R * t.n)); };
    if (radial(key[0]) == R - 1 && radial(key[1]) == R - 1 && radial(key[2]) == R - 1)
      tag = 1;
    else if (radial(key[0]) == 0 && radial(key[1]) == 0 && radial(key[2]) == 0)
      tag = 2;
    else
      tag = axial(key[0]) == t.k ? 3 : 4;
    s.triangle_tags.push_back(tag);
  }
  // References: vertices OB, OT, IB, IT at angle 0; circles and seams with levels = 1.
  struct Vx {
    std::int64_t id;
    int i, k;
  };
  const Vx vx[4] = {{10, R - 1, 0}, {11, R - 1, t.k}, {12, 0, 0}, {13, 0, t.k}};
  struct Ed {
    std::int64_t id;
    int v0, v1;  // indices into vx; a circle has v0 == v1
  };
  const Ed ed[6] = {{20, 0, 0}, {21, 1, 1}, {22, 2, 2}, {23, 3, 3}, {24, 0, 1}, {25, 2, 3}};
  std::vector<std::vector<std::int64_t>> vid(4);
  for (int v = 0; v < 4; ++v) {
    vid[std::size_t(v)].push_back(0);
    vid[std::size_t(v)].push_back(vx[v].id);
    for (const Ed& e : ed)
      if (e.v0 == v || e.v1 == v) vid[std::size_t(v)].push_back(e.id);
    // Copy-constructed IDs (GCC 12's -Wnonnull misfires on vector<long> assignment here).
    mesh::ControlPoint cp{vid[std::size_t(v)], {0, 0, 0}};
    const double* x = &s.vertices[3 * std::size_t(index(vx[v].i, 0, vx[v].k))];
    std::copy(x, x + 3, cp.position);
    s.points.push_back(cp);
  }
  for (const Ed& e : ed) {
    const bool circle = e.v0 == e.v1;
    const int steps = circle ? t.n : t.k;  // mesh edges along the CAD edge
    auto node = [&](int m) {               // m = 0..steps along the edge
      return circle ? index(vx[e.v0].i, m, vx[e.v0].k) : index(vx[e.v0].i, 0, m);
    };
    const std::vector<std::int64_t> base{1, e.id, std::min(vx[e.v0].id, vx[e.v1].id),
                                         std::max(vx[e.v0].id, vx[e.v1].id), -1};
    std::vector<std::vector<std::int64_t>> ids{vid[std::size_t(e.v0)], base, base, base,
                                               vid[std::size_t(e.v1)]};
    ids[1].push_back(0);  // u = 1/4
    ids[3].push_back(1);  // u = 3/4
    for (int q = 1; q <= 3; ++q) {
      mesh::ControlPoint cp{ids[std::size_t(q)], {0, 0, 0}};
      const double* x = &s.vertices[3 * std::size_t(node(q * steps / 4))];
      std::copy(x, x + 3, cp.position);
      s.points.push_back(cp);
    }
    for (int q = 0; q < 4; ++q) {
      mesh::Path p{ids[std::size_t(q)], ids[std::size_t(q + 1)], {}};
      for (int m = q * steps / 4; m <= (q + 1) * steps / 4; ++m) {
        const double* x = &s.vertices[3 * std::size_t(node(m))];
        p.polyline.insert(p.polyline.end(), x, x + 3);
      }
      s.paths.push_back(std::move(p));
    }
  }
  return s;
}

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

}  // namespace tube

// Fix 1 of the OpenCASCADE round: the seam of a periodic face. The tube's walls are annuli
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

// A CAD edge of one sample only (faces that merge across the parameter box) is no layout cut: its
// mesh edges are found on its path by their midpoints. A host may put mesh vertices on the curve
// between the path's nodes (the OpenCASCADE host's bisection, projected onto the B-rep), off
// the polyline's chords. The tube's top outer circle (16 mesh edges) keeps every other node of
// its polyline, so 8 of its vertices lie 0.15 (a tenth of the chord) off it; with the circle's
// edge key not common, none of its mesh edges is cut, as with the whole polyline.
TEST(LayoutCuts, UnsharedEdgeWhoseMeshVerticesLieOffItsPolylineIsNotCut) {
  const tube::Shape shape{1.0, 2.0, 3.0, 16, 8};
  for (const bool thin : {false, true}) {
    mesh::Sample s = tube::make(shape);
    std::set<mapping::Id> common = mapping::correspond(s, s).common_edges;
    std::size_t circle_paths = 0;
    for (mesh::Path& p : s.paths) {
      std::vector<double>& pl = p.polyline;
      bool top_outer = true;
      for (std::size_t i = 0; i < pl.size(); i += 3)
        top_outer = top_outer && pl[i + 2] == shape.height &&
                    std::abs(std::hypot(pl[i], pl[i + 1]) - shape.r_out) < 1e-12;
      if (!top_outer) continue;
      common.erase(mapping::path_edge_key(p));
      ++circle_paths;
      ASSERT_EQ(pl.size(), 15u);  // 5 nodes: a quarter of the circle
      if (thin) pl = {pl[0], pl[1], pl[2], pl[6], pl[7], pl[8], pl[12], pl[13], pl[14]};
    }
    ASSERT_EQ(circle_paths, 4u);
    ASSERT_EQ(mesh::validate(s), "");
    mapping::Surface surf;
    std::string why;
    ASSERT_TRUE(mapping::build_surface(s, surf, why)) << why;
    const std::vector<char> cuts = mapping::layout_cuts(surf, common, 1e-9 * s.bbox_diagonal());
    std::size_t on_circle = 0, cut = 0;
    for (int h = 0; h < 3 * surf.triangles(); ++h) {
      const int t = surf.twin[std::size_t(h)];
      const std::int32_t a = s.triangle_tags[std::size_t(h / 3)];
      if (t < 0 || a != 1 || s.triangle_tags[std::size_t(t / 3)] != 3) continue;
      ++on_circle;
      cut += cuts[std::size_t(h)] ? 1 : 0;
    }
    EXPECT_EQ(on_circle, 16u) << (thin ? "thinned" : "whole");
    EXPECT_EQ(cut, 0u) << (thin ? "thinned" : "whole");
  }
}

// Fix 2 of the OpenCASCADE round: the interior solve in boundary increments, with the
// current mesh's stiffness, and with small tets stiffened (MapOptions). Truth: the P1
// Laplacian reproduces an affine boundary map exactly, in one step or many (each step's
// boundary data is affine in the current mesh), on a graded Kuhn-split box whose tets differ
// in volume; the stiffened solve keeps the boundary data and a valid mesh.
TEST(InteriorSolve, IncrementalSolveReproducesAffineMapsExactly) {
  const int n = 6;
  std::vector<double> x;
  std::vector<std::uint32_t> tets;
  auto index = [&](int i, int j, int k) { return std::uint32_t((k * (n + 1) + j) * (n + 1) + i); };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i)
        // Graded along x and z: the tets' volumes differ, so stiffening weights them unequally.
        x.insert(x.end(), {-1.0 + 2.0 * std::pow(double(i) / n, 1.7), -1.0 + 2.0 * j / n,
                           2.0 * std::pow(double(k) / n, 1.4)});
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const auto& p : perms) {
          int c[3] = {0, 0, 0};
          std::uint32_t q[4];
          q[0] = index(i, j, k);
          for (int s = 0; s < 3; ++s) {
            c[p[s]] = 1;
            q[s + 1] = index(i + c[0], j + c[1], k + c[2]);
          }
          tets.insert(tets.end(), q, q + 4);
        }
  // Orientation: positive volumes.
  for (std::size_t t = 0; t < tets.size(); t += 4) {
    std::vector<std::uint32_t> one(tets.begin() + long(t), tets.begin() + long(t) + 4);
    if (mapping::tet_quality(x, one).inverted) std::swap(tets[t + 2], tets[t + 3]);
  }
  ASSERT_EQ(mapping::tet_quality(x, tets).inverted, 0u);
  std::vector<char> fixed(x.size() / 3, 0);
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i)
        fixed[index(i, j, k)] = i == 0 || j == 0 || k == 0 || i == n || j == n || k == n;
  std::string why;
  // Stiffened (weighted) Laplacians do not reproduce affine maps (the weights break the
  // partition of unity of the gradients); of them, only validity is asserted.
  for (const auto& [steps, stiff] : {std::make_pair(1, 0.0), std::make_pair(5, 0.0),
                                     std::make_pair(1, 2.0), std::make_pair(4, 1.0)}) {
    std::vector<double> y(x.size());
    for (std::size_t v = 0; v < x.size() / 3; ++v) {
      const double* p = &x[3 * v];
      y[3 * v] = 1.3 * p[0] + 0.4 * p[1] + 0.1;
      y[3 * v + 1] = -0.2 * p[0] + 0.9 * p[1] + 0.3 * p[2];
      y[3 * v + 2] = 0.5 * p[2] + 0.2 * p[0] - 2.0;
    }
    std::vector<double> mapped = y;
    for (std::size_t v = 0; v < fixed.size(); ++v)
      if (!fixed[v]) mapped[3 * v] = mapped[3 * v + 1] = mapped[3 * v + 2] = 0;
    ASSERT_TRUE(mapping::incremental_interior(x, tets, fixed, mapped, why, steps, stiff)) << why;
    if (stiff > 0) {
      EXPECT_EQ(mapping::tet_quality(mapped, tets).inverted, 0u);
      for (std::size_t v = 0; v < fixed.size(); ++v)
        if (fixed[v]) {
          ASSERT_EQ(mapped[3 * v], y[3 * v]);
        }
      continue;
    }
    for (std::size_t i = 0; i < y.size(); ++i) ASSERT_NEAR(mapped[i], y[i], 1e-9) << steps;
  }
}

// ---- Round 4: boundary untangling and hole splitting on small meshes built here ----

namespace voxel {

// A plate [0, X] x [0, Y] x [0, Z] on a grid of step h, with square through-holes (cells
// removed), each hex split into the 6 Kuhn tets around its main diagonal (conforming across
// cells). Tags: top 1, bottom 2, the four outer walls 3..6, the walls of hole k one tag 10 + k
// (an annulus). Control points: the plate's 8 corners, and one corner of each hole at the top
// and at the bottom (a hole loop with a single anchor: the two-path split cannot cut it).
struct Hole {
  double x0, y0, x1, y1;
};

mesh::Sample plate(double X, double Y, double Z, double h, const std::vector<Hole>& holes) {
  const int nx = int(std::lround(X / h)), ny = int(std::lround(Y / h)),
            nz = int(std::lround(Z / h));
  auto in_hole = [&](double x, double y) {
    for (const Hole& o : holes)
      if (x > o.x0 && x < o.x1 && y > o.y0 && y < o.y1) return true;
    return false;
  };
  auto grid = [&](int i, int j, int k) { return std::size_t((k * (ny + 1) + j) * (nx + 1) + i); };
  std::vector<double> all(3 * std::size_t((nx + 1) * (ny + 1) * (nz + 1)));
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        all[3 * grid(i, j, k)] = i * h;
        all[3 * grid(i, j, k) + 1] = j * h;
        all[3 * grid(i, j, k) + 2] = k * h;
      }
  std::vector<std::uint32_t> tets;
  // The 6 paths from corner 000 to 111 through the cube's edges: each a Kuhn tet.
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (in_hole((i + 0.5) * h, (j + 0.5) * h)) continue;
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          std::uint32_t t[4];
          t[0] = std::uint32_t(grid(c[0], c[1], c[2]));
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[s + 1] = std::uint32_t(grid(c[0], c[1], c[2]));
          }
          if (mapping::scaled_jacobian(all, t) < 0) std::swap(t[2], t[3]);
          tets.insert(tets.end(), t, t + 4);
        }
      }
  // Compact (vertices inside holes are in no tet).
  std::vector<std::int64_t> index(all.size() / 3, -1);
  mesh::Sample s;
  s.feasible = true;
  for (std::uint32_t& v : tets) {
    if (index[v] < 0) {
      index[v] = std::int64_t(s.vertices.size() / 3);
      s.vertices.insert(s.vertices.end(), &all[3 * v], &all[3 * v] + 3);
    }
    v = std::uint32_t(index[v]);
  }
  s.tets = tets;
  // Boundary faces: those of one tet, oriented away from its fourth vertex.
  std::map<std::array<std::uint32_t, 3>, std::pair<int, std::array<std::uint32_t, 4>>> faces;
  for (std::size_t t = 0; t < s.tet_count(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<std::uint32_t, 3> tri;
      for (int a = 0, n = 0; a < 4; ++a)
        if (a != f) tri[std::size_t(n++)] = s.tets[4 * t + std::size_t(a)];
      std::array<std::uint32_t, 3> key = tri;
      std::sort(key.begin(), key.end());
      auto& e = faces[key];
      ++e.first;
      e.second = {tri[0], tri[1], tri[2], s.tets[4 * t + std::size_t(f)]};
    }
  for (const auto& [key, e] : faces) {
    if (e.first != 1) continue;
    std::array<std::uint32_t, 4> q = e.second;
    const double* a = &s.vertices[3 * q[0]];
    const double* b = &s.vertices[3 * q[1]];
    const double* c = &s.vertices[3 * q[2]];
    const double* d = &s.vertices[3 * q[3]];
    double n[3] = {(b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1]),
                   (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2]),
                   (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])};
    if (n[0] * (d[0] - a[0]) + n[1] * (d[1] - a[1]) + n[2] * (d[2] - a[2]) > 0) {
      std::swap(q[1], q[2]);
      for (double& x : n) x = -x;
    }
    s.triangles.insert(s.triangles.end(), {q[0], q[1], q[2]});
    const double m[3] = {(a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3,
                         (a[2] + b[2] + c[2]) / 3};
    std::int32_t tag = 0;
    if (std::fabs(n[2]) > 0.5 * std::hypot(n[0], n[1], n[2])) {
      tag = n[2] > 0 ? 1 : 2;
    } else if (m[0] < 1e-9 || m[0] > X - 1e-9 || m[1] < 1e-9 || m[1] > Y - 1e-9) {
      tag = m[0] < 1e-9 ? 3 : m[0] > X - 1e-9 ? 4 : m[1] < 1e-9 ? 5 : 6;
    } else {
      for (std::size_t k = 0; k < holes.size(); ++k)
        if (m[0] > holes[k].x0 - 1e-9 && m[0] < holes[k].x1 + 1e-9 && m[1] > holes[k].y0 - 1e-9 &&
            m[1] < holes[k].y1 + 1e-9)
          tag = 10 + std::int32_t(k);
    }
    s.triangle_tags.push_back(tag);
  }
  auto point = [&](std::int64_t id, double x, double y, double z) {
    mesh::ControlPoint p;
    p.id = {0, id};
    p.position[0] = x;
    p.position[1] = y;
    p.position[2] = z;
    s.points.push_back(p);
  };
  for (int c = 0; c < 8; ++c) point(1 + c, (c & 1) * X, (c >> 1 & 1) * Y, (c >> 2) * Z);
  for (std::size_t k = 0; k < holes.size(); ++k) {
    point(100 + std::int64_t(k), holes[k].x0, holes[k].y0, Z);
    point(200 + std::int64_t(k), holes[k].x0, holes[k].y0, 0);
  }
  return s;
}

// The plate of `plate` as a B-rep whose hole walls changed topology: with `split_walls` each
// hole's wall is four faces (tags 20 + 4k + side) bounded at the top and the bottom by four CAD
// edges between four corner vertices, and between each other by four vertical edges; without, one
// face (tag 10 + k, as in `plate`) bounded by one closed edge through a single vertex. The rims'
// vertex and edge IDs differ between the two (their adjacent entities differ), so no control point
// on a rim matches: the hub's switch from round to obround bolt holes in miniature. Only the
// plate's 8 corners are common.
mesh::Sample plate_with_rims(double X, double Y, double Z, double h,
                                const std::vector<Hole>& holes, bool split_walls) {
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

// Calls f(tag, x) for each corner of each canonical boundary triangle with its mapped position
// (a vertex once per triangle it is a corner of): the checks that a face keeps its geometry.
template <class F>
void for_each_tagged_corner(const mesh::Sample& canonical, const mesh::MappedSample& m, F f) {
  for (std::size_t t = 0; t < canonical.triangle_count(); ++t)
    for (int c = 0; c < 3; ++c)
      f(canonical.triangle_tags[t],
        &m.vertices[3 * std::size_t(canonical.triangles[3 * t + std::size_t(c)])]);
}

// Each mapped boundary vertex of the outer faces on its own face's plane (the faces keep their
// tags through the combinatorics): top z = Z, bottom z = 0, walls x = 0 and x = X.
void expect_on_outer_planes(const mesh::Sample& canonical, const mesh::MappedSample& m,
                            double X, double Z) {
  for_each_tagged_corner(canonical, m, [X, Z](std::int32_t tag, const double* x) {
    if (tag == 1) {
      EXPECT_NEAR(x[2], Z, 1e-12);
    }
    if (tag == 2) {
      EXPECT_NEAR(x[2], 0.0, 1e-12);
    }
    if (tag == 3) {
      EXPECT_NEAR(x[0], 0.0, 1e-12);
    }
    if (tag == 4) {
      EXPECT_NEAR(x[0], X, 1e-12);
    }
  });
}

}  // namespace voxel

// The plate with three through-holes: its top and bottom faces have four boundary loops each,
// every hole loop with a single anchor, and each hole wall is an annulus with one anchor per
// loop. Before round 4 this failed ("too few anchors on its loops"); now each hole is joined to
// the loop outside it by a slit. Same solid at two resolutions, so the truth is the solid itself:
// every mapped boundary vertex on the source surface, the surface covered (Hausdorff both ways),
// every tet valid.
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

// Faces that merge across a topology change into a patch with handles: the plate's top and
// bottom joined by the walls of its holes, which are one face on the source and four on the
// canonical, with no common control point on their rims (plate_with_rims). Merged, the top,
// bottom and walls are one patch of genus 2 (refused before: "patches with handles are not
// supported"); the walls' borders are cut instead (separate_faces), each rim gets a new
// anchor at the end of a slit, and every face keeps its own geometry: top and bottom vertices
// stay exactly on their planes, wall vertices on the walls' planes.
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
  // Merging the walls (no cut) is what the layout did before: a patch with handles.
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

// A thin wedge: two faces meeting at a sharp edge (the x axis) at 8 degrees, one prism of three
// tets whose vertices all lie on the boundary. Moving one face vertex within its face folds a
// tet; no interior vertex exists, so only the boundary untangling can repair it, by moving
// vertices within their faces (2-D), along the edge (1-D), never the anchor.
TEST(BoundaryUntangle, ThinWedgeFoldedAtItsSharpEdgeIsRepairedWithinItsFaces) {
  const double th = 8 * 3.14159265358979 / 180, c = std::cos(th), s = std::sin(th);
  // e0, a0, b0 at x = 0; e1, a1, b1 at x = 1. Face A: z = 0; face B: (x, r c, r s).
  std::vector<double> x = {0, 0, 0, 0, 1, 0, 0, c, s, 1, 0, 0, 1, 1, 0, 1, c, s};
  std::vector<std::uint32_t> tets = {0, 1, 2, 3, 1, 2, 3, 4, 2, 3, 4, 5};
  for (std::size_t t = 0; t < 3; ++t)
    if (mapping::scaled_jacobian(x, &tets[4 * t]) < 0) std::swap(tets[4 * t + 2], tets[4 * t + 3]);
  ASSERT_EQ(mapping::tet_quality(x, tets).inverted, 0u);
  // Freedoms: e0 an anchor; e1 along the edge; a* in face A (u = x, v = y), b* in face B.
  std::vector<mapping::BoundaryDof> dofs(6);
  std::vector<int> dof_of = {0, 1, 2, 3, 4, 5};
  const int face[6] = {-1, 0, 1, -1, 0, 1};
  for (std::uint32_t v = 0; v < 6; ++v) {
    mapping::BoundaryDof& d = dofs[v];
    d.vertex = v;
    d.patch = face[v];
    d.dims = v == 0 ? 0 : v == 3 ? 1 : 2;
    d.p[0] = x[3 * v];
    d.p[1] = face[v] == 0 ? x[3 * v + 1] : face[v] == 1 ? x[3 * v + 1] / c : 0;
    d.lo = 0.5;
    d.hi = 2.0;
    d.step = 0.25;
  }
  const mapping::PlaceFn place = [&](const mapping::BoundaryDof& d, const double* p, double* y) {
    if (d.dims == 2 && !(p[1] > 0.05)) return false;  // stay on the face, off the edge
    y[0] = p[0];
    y[1] = d.dims == 1 ? 0 : d.patch == 0 ? p[1] : p[1] * c;
    y[2] = d.dims == 1 ? 0 : d.patch == 0 ? 0 : p[1] * s;
    return true;
  };
  // Fold: a1 slides along face A to x = -0.6 (behind the edge's start).
  dofs[4].p[0] = -0.6;
  place(dofs[4], dofs[4].p, &x[3 * 4]);
  const std::size_t folded = mapping::tet_quality(x, tets).inverted;
  ASSERT_GT(folded, 0u);
  const double diag = std::sqrt(3.0);
  const double min_six = 1e-12 * diag * diag * diag;
  // With every vertex pinned nothing can move: the failure is reported, not hidden.
  {
    std::vector<mapping::BoundaryDof> pinned = dofs;
    for (auto& d : pinned) d.dims = 0;
    std::vector<double> y = x;
    const mapping::BoundaryUntangleResult r =
        mapping::untangle_boundary(tets, dof_of, pinned, place, min_six, y);
    EXPECT_EQ(r.inverted_after, folded);
    EXPECT_EQ(r.moved, 0u);
    EXPECT_EQ(y, x);
  }
  const mapping::BoundaryUntangleResult r =
      mapping::untangle_boundary(tets, dof_of, dofs, place, min_six, x);
  EXPECT_EQ(r.inverted_before, folded);
  EXPECT_EQ(r.inverted_after, 0u);
  EXPECT_GT(r.moved, 0u);
  EXPECT_EQ(mapping::tet_quality(x, tets).inverted, 0u);
  // Every vertex is where its freedom allows: the anchor unmoved, e1 on the edge within its
  // bounds, a* on face A, b* on face B, each at its parameters.
  EXPECT_EQ(x[0], 0.0);
  EXPECT_EQ(x[1], 0.0);
  EXPECT_EQ(x[2], 0.0);
  EXPECT_EQ(x[3 * 3 + 1], 0.0);
  EXPECT_EQ(x[3 * 3 + 2], 0.0);
  EXPECT_GE(dofs[3].p[0], 0.5);
  EXPECT_LE(dofs[3].p[0], 2.0);
  for (std::uint32_t v : {1u, 4u}) EXPECT_EQ(x[3 * v + 2], 0.0);
  for (std::uint32_t v : {2u, 5u}) EXPECT_NEAR(x[3 * v + 2] * c - x[3 * v + 1] * s, 0.0, 1e-15);
  for (std::uint32_t v = 0; v < 6; ++v) {
    double y[3];
    place(dofs[v], dofs[v].p, y);
    if (dofs[v].dims > 0) {
      for (int a = 0; a < 3; ++a) EXPECT_EQ(y[a], x[3 * v + std::size_t(a)]);
    }
  }
}

TEST(PathRelease, NearestPointOnATriangleInEachRegion) {
  const double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {0, 2, 0};
  struct Case {
    double p[3], w[3];
  };
  const Case cases[] = {
      {{0.5, 0.5, 1.0}, {0.5, 0.25, 0.25}},  // above the face
      {{-1, -1, 0}, {1, 0, 0}},              // beyond vertex a
      {{3, -1, 0}, {0, 1, 0}},               // beyond vertex b
      {{1, -1, 0.5}, {0.5, 0.5, 0}},         // beyond edge ab
      {{2, 2, 0}, {0, 0.5, 0.5}},            // beyond edge bc
      {{-1, 1, 0}, {0.5, 0, 0.5}},           // beyond edge ca
  };
  for (const Case& k : cases) {
    double w[3];
    mesh::closest_point_weights(k.p, a, b, c, w);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(w[i], k.w[i], 1e-12) << k.p[0] << "," << k.p[1];
  }
}

// A flat 9 x 9 grid mapped onto itself with the vertices near a "traced path" (the middle row)
// sheared along it, as two patches' maps shear against each other: the release moves them back
// towards the canonical arrangement (here the identity), every position on the source plane and
// inside it, `where` and the positions consistent.
TEST(PathRelease, ShearAlongATracedPathRelaxesOnTheSourceSurface) {
  mesh::Sample grid;
  const int n = 9;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      grid.vertices.insert(grid.vertices.end(), {double(i), double(j), 0});
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const std::uint32_t v = std::uint32_t(j * n + i);
      grid.triangles.insert(grid.triangles.end(), {v, v + 1, v + n + 1, v, v + n + 1, v + n});
      grid.triangle_tags.insert(grid.triangle_tags.end(), {1, 1});
    }
  mapping::Surface surf;
  std::string why;
  ASSERT_TRUE(mapping::build_surface(grid, surf, why)) << why;
  auto place = [&](const mapping::SurfacePoint& pt, double* x) {
    for (int a = 0; a < 3; ++a) {
      x[a] = 0;
      for (int k = 0; k < 3; ++k) x[a] += pt.w[k] * grid.vertices[3 * std::size_t(pt.v[k]) + a];
    }
  };
  // The sheared map: vertices within 2 rows of row 4, inside, moved along x by up to 0.45.
  std::vector<std::uint32_t> movable;
  std::vector<double> x = grid.vertices;
  for (int j = 2; j <= 6; ++j)
    for (int i = 1; i + 1 < n; ++i) {
      const std::uint32_t v = std::uint32_t(j * n + i);
      movable.push_back(v);
      x[3 * v] += 0.45 * (j < 4 ? -1 : j > 4 ? 1 : 0) * (1.0 - std::abs(j - 4) / 3.0);
    }
  std::vector<mapping::SurfacePoint> where(grid.vertex_count());
  for (std::uint32_t v = 0; v < grid.vertex_count(); ++v) {
    double best = 1e300;
    for (std::size_t f = 0; f < grid.triangle_count(); ++f) {
      const std::uint32_t* t = &grid.triangles[3 * f];
      double w[3], p[3];
      mesh::closest_point_weights(&x[3 * v], &grid.vertices[3 * t[0]], &grid.vertices[3 * t[1]],
                                     &grid.vertices[3 * t[2]], w);
      mapping::SurfacePoint sp;
      for (int k = 0; k < 3; ++k) sp.v[k] = t[k], sp.w[k] = w[k];
      place(sp, p);
      const double d = std::hypot(p[0] - x[3 * v], p[1] - x[3 * v + 1], p[2] - x[3 * v + 2]);
      if (d < best) best = d, where[v] = sp;
    }
  }
  auto shear = [&] {
    double sum = 0;
    for (std::uint32_t v : movable) sum += std::pow(x[3 * v] - grid.vertices[3 * v], 2);
    return std::sqrt(sum / double(movable.size()));
  };
  const double before = shear();
  ASSERT_GT(before, 0.1);
  mapping::release_traced_paths(grid, surf, grid, movable, 20, where, place, x);
  EXPECT_LT(shear(), 0.2 * before);
  for (std::uint32_t v : movable) {
    EXPECT_EQ(x[3 * v + 2], 0.0);  // on the source plane
    EXPECT_GE(x[3 * v], 0.0);
    EXPECT_LE(x[3 * v], n - 1.0);
    double p[3];
    place(where[v], p);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(p[a], x[3 * v + std::size_t(a)]);
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
