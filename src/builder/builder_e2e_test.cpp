// End to end on the analytic example host (examples/hosts/analytic): build each model through
// the C ABI, open the asset with the runtime, and compare with the host's own answer at 100
// random points (geometry: symmetric Hausdorff of the boundaries relative to the bbox diagonal;
// per-vertex fields relative to their range).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "analytic_host.h"
#include "builder/build.h"
#include "builder/builder_e2e.h"
#include "cadinterp/cadinterp_builder.h"
#ifdef CADINTERP_HAVE_MAPPING
#include "mapping/interior_solve.h"
#endif

namespace {

using namespace cadinterp;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("cadinterp_e2e_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

builder::BuildOutcome build(const cadinterp_host* host, const cadinterp_build_options& o,
                            const std::string& out) {
  return builder::build_asset(*host, o, out);
}

const cadinterp_host* host(const char* model, const char* options) {
  const char* err = nullptr;
  const cadinterp_host* h = cadinterp_host_entry(model, options, &err);
  if (!h) ADD_FAILURE() << model << ": " << (err ? err : "?");
  return h;
}

TEST(EndToEnd, BracketMatchesItsHost) {
  const cadinterp_host* h = host("bracket", "cells=2");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.geometry_tolerance = 2e-3;
  o.field_tolerance = 2e-2;
  o.max_samples = 300;
  o.threads = 2;
  const std::string path = temp_path("bracket.cadi");
  const builder::BuildOutcome r = build(h, o, path);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  const builder::AccuracyReport a = builder::measure_accuracy(path, builder::Host(*h), 100, 1);
  std::printf(
      "[ figures ] bracket: %d samples, %d elements, budget %s; geometry max %.2e p99 "
      "%.2e; field max %.2e p99 %.2e (targets 2e-3, 2e-2)\n",
      r.report.samples, r.report.elements, r.report.budget_exhausted ? "hit" : "not hit",
      a.geometry_max, a.geometry_p99, a.field_max, a.field_p99);
  EXPECT_EQ(a.infeasible, 0);
  // Targets are met at the points the builder tests; in between, and where the sample budget
  // stopped refinement, a small factor more.
  EXPECT_LT(a.geometry_max, 10 * o.geometry_tolerance);
  EXPECT_LT(a.field_max, 10 * o.field_tolerance);
  std::filesystem::remove(path);
}

// The plate's mesh resolution follows its size. Where every sample has the same mesh (one cell
// per side) it builds like any model; across resolutions the mesh mapper (src/mapping, paper §6)
// carries each sample into the element's canonical mesh and the asset meets its targets.
TEST(EndToEnd, PlateBuildsAcrossResolutionsWithTheMeshMapper) {
#ifndef CADINTERP_HAVE_MAPPING
  GTEST_SKIP() << "built without the mapping component (CADINTERP_WITH_MAPPING=OFF)";
#endif
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 120;
  o.threads = 2;
  const std::string path = temp_path("plate.cadi");
  const cadinterp_host* coarse = host("plate", "edge=100");
  ASSERT_NE(coarse, nullptr);
  builder::BuildOutcome r = build(coarse, o, path);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  builder::AccuracyReport a = builder::measure_accuracy(path, builder::Host(*coarse), 100, 2);
  std::printf(
      "[ figures ] plate (edge=100): %d samples; geometry max %.2e p99 %.2e; field max "
      "%.2e\n",
      r.report.samples, a.geometry_max, a.geometry_p99, a.field_max);
  EXPECT_LT(a.geometry_max, 10 * o.geometry_tolerance);

  const cadinterp_host* fine = host("plate", "edge=8");
  ASSERT_NE(fine, nullptr);
  r = build(fine, o, path);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  EXPECT_EQ(r.report.infeasible_elements, 0);
  // Fields against the closed form at the evaluated positions (vertices slide within faces).
  // Temperature is smooth in x and meets its target; the displacement (~ 1 / thickness^3) is
  // what the 120-sample budget stops short on, so it is checked where the asset must reproduce
  // the host up to the mapping alone: at the box's corners, which are samples.
  const analytic_model* model = analytic_host_model(fine);
  a = builder::measure_accuracy(path, builder::Host(*fine), 60, 4,
                                [model](int f, const double* x, const double* p, double* v) {
                                  return f == 0 &&
                                         analytic_model_field_at(model, f, x, p, v) == CADINTERP_OK;
                                });
  std::printf(
      "[ figures ] plate (edge=8, mesh mapper): %d samples, %d elements; geometry max %.2e p99 "
      "%.2e; temperature max %.2e p99 %.2e (closed form at the evaluated points)\n",
      r.report.samples, r.report.elements, a.geometry_max, a.geometry_p99, a.field_max,
      a.field_p99);
  EXPECT_EQ(a.infeasible, 0);
  EXPECT_LT(a.geometry_max, 10 * o.geometry_tolerance);
  EXPECT_LT(a.field_max, 10 * o.field_tolerance);

  cadinterp_asset* asset = nullptr;
  ASSERT_EQ(cadinterp_open(path.c_str(), &asset), CADINTERP_OK);
  cadinterp_workspace* ws = nullptr;
  ASSERT_EQ(cadinterp_workspace_create(asset, &ws), CADINTERP_OK);
  for (int corner = 0; corner < 8; ++corner) {
    double x[3];
    for (int d = 0; d < 3; ++d) {
      cadinterp_parameter_info desc;
      ASSERT_EQ(cadinterp_parameter(asset, d, &desc), CADINTERP_OK);
      x[d] = (corner >> d) & 1 ? desc.upper : desc.lower;
    }
    const int displacement[1] = {2};
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(ws, x, displacement, 1, &m), CADINTERP_OK);
    double err = 0, lo = 1e300, hi = -1e300;
    for (std::uint32_t v = 0; v < m.vertex_count; ++v) {
      const double p[3] = {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
      double truth[3];
      ASSERT_EQ(analytic_model_field_at(model, 2, x, p, truth), CADINTERP_OK);
      for (int c = 0; c < 3; ++c) {
        err = std::max(err, std::abs(m.fields[0][3 * v + std::uint32_t(c)] - truth[c]));
        lo = std::min(lo, truth[c]);
        hi = std::max(hi, truth[c]);
      }
    }
    EXPECT_LT(err, 2e-2 * (hi - lo)) << "corner " << corner;
  }
  cadinterp_workspace_destroy(ws);
  cadinterp_close(asset);
  std::filesystem::remove(path);
}

// The foldplate's B-rep topology changes at fold = 0 (its top face splits along a crease, a 13th
// edge and a 7th face appear) while its resolution follows its size: the mesh mapper's common
// layout carries samples across both, and the asset follows its host.
TEST(EndToEnd, FoldplateBuildsAcrossTopologyChanges) {
#ifndef CADINTERP_HAVE_MAPPING
  GTEST_SKIP() << "built without the mapping component (CADINTERP_WITH_MAPPING=OFF)";
#endif
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 120;
  o.threads = 2;
  const std::string path = temp_path("foldplate.cadi");
  const cadinterp_host* h = host("foldplate", "edge=10");
  ASSERT_NE(h, nullptr);
  const builder::BuildOutcome r = build(h, o, path);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  EXPECT_EQ(r.report.infeasible_elements, 0);
  const analytic_model* model = analytic_host_model(h);
  const builder::AccuracyReport a = builder::measure_accuracy(
      path, builder::Host(*h), 60, 5, [model](int f, const double* x, const double* p, double* v) {
        return f == 0 && analytic_model_field_at(model, f, x, p, v) == CADINTERP_OK;
      });
  std::printf(
      "[ figures ] foldplate (edge=10, mesh mapper): %d samples, %d elements; geometry max %.2e "
      "p99 %.2e; temperature max %.2e p99 %.2e\n",
      r.report.samples, r.report.elements, a.geometry_max, a.geometry_p99, a.field_max,
      a.field_p99);
  EXPECT_EQ(a.infeasible, 0);
  EXPECT_LT(a.geometry_max, 10 * o.geometry_tolerance);
  EXPECT_LT(a.field_max, 10 * o.field_tolerance);
  std::filesystem::remove(path);
}

// Cubic elements take samples of their neighbours (§5.3, Fig. 15). Carried from the neighbour's
// canonical mesh through a sample on both elements (mapping/neighbour_transfer.h; the builder's
// fallback where the direct mapping fails, forced here for every neighbour sample):
// Truth is the host: each term, however it was carried, must lie on its own sample's boundary
// (foldplate: neighbours across its B-rep topology change). The asset does not depend on the
// thread count, no stored tet is inverted, and the direct route gives other positions (the
// bridge is really used).
TEST(EndToEnd, CubicNeighbourSamplesGoThroughASharedSample) {
#ifndef CADINTERP_HAVE_MAPPING
  GTEST_SKIP() << "built without the mapping component (CADINTERP_WITH_MAPPING=OFF)";
#else
  const cadinterp_host* h = host("foldplate", "edge=25");
  ASSERT_NE(h, nullptr);
  const builder::Host fold(*h);
  builder::BuildOptions o;
  o.degree = core::Degree::Cubic;
  o.max_samples = 24;
  o.threads = 1;
  o.neighbour_transfer = builder::NeighbourTransfer::Always;
  o.measure_neighbour_transfer = true;
  const builder::BuildResult one = builder::build(fold, o);
  const builder::NeighbourTransferStats& st = one.neighbour;
  std::printf(
      "[ figures ] cubic foldplate (edge=25): %d neighbour terms, %d bridged; Hausdorff to the "
      "own sample: direct max %.2e mean %.2e, bridged max %.2e mean %.2e\n",
      st.neighbour_terms, st.bridged, st.direct_hausdorff_max,
      st.direct_hausdorff_sum / std::max(1, st.compared), st.bridged_hausdorff_max,
      st.bridged_hausdorff_sum / std::max(1, st.compared));
  EXPECT_EQ(one.report.infeasible_elements, 0);
  EXPECT_GT(st.neighbour_terms, 0);
  EXPECT_GT(st.bridged, 0);
  EXPECT_EQ(st.bridge_inverted, 0);
  EXPECT_EQ(st.compared, st.bridged);
  // The bridge adds a second discretization (p_s^l located in p_s^{l'}'s tets): near, not exact.
  EXPECT_LT(st.bridged_hausdorff_max, 5 * o.geometry_tolerance);
  for (const auto& e : one.content.elements)
    for (const auto& p : e.positions)
      EXPECT_EQ(mapping::tet_quality(std::vector<double>(p.begin(), p.end()), e.tets).inverted, 0u);

  o.threads = 2;
  o.measure_neighbour_transfer = false;
  const builder::BuildResult two = builder::build(fold, o);
  ASSERT_EQ(two.content.elements.size(), one.content.elements.size());
  for (std::size_t e = 0; e < one.content.elements.size(); ++e)
    EXPECT_EQ(two.content.elements[e].positions, one.content.elements[e].positions) << e;

  o.neighbour_transfer = builder::NeighbourTransfer::Direct;
  const builder::BuildResult direct = builder::build(fold, o);
  EXPECT_EQ(direct.neighbour.bridged, 0);
  bool differs = false;
  for (std::size_t e = 0; e < one.content.elements.size(); ++e)
    differs = differs || direct.content.elements[e].positions != one.content.elements[e].positions;
  EXPECT_TRUE(differs);
#endif
}

// Without the mesh mapper (the identity hook), elements across resolutions cannot be built, and
// the build says why by name.
TEST(EndToEnd, PlateWithTheIdentityMapperNamesWhyItCannotBlend) {
  const cadinterp_host* fine = host("plate", "edge=8");
  ASSERT_NE(fine, nullptr);
  const builder::Host h(*fine);
  const builder::IdentityMapper identity;
  builder::BuildOptions o;
  o.max_samples = 40;
  o.threads = 2;
  o.mapper = &identity;
  try {
    const builder::BuildResult r = builder::build(h, o);
    EXPECT_GT(r.report.infeasible_elements, 0);
  } catch (const builder::BuildInfeasible& e) {
    EXPECT_NE(std::string(e.what()).find("identity mapper maps equal combinatorics only"),
              std::string::npos)
        << e.what();
  }
}

// The default mapper is the mesh mapper when the mapping component is built, and its name is
// what the asset's provenance records.
TEST(EndToEnd, DefaultMapperIsTheMeshMapperAndNamedInProvenance) {
#ifdef CADINTERP_HAVE_MAPPING
  EXPECT_STREQ(builder::default_mapper().name(), "mesh-v9");
#else
  EXPECT_STREQ(builder::default_mapper().name(), "identity");
#endif
  const std::string json =
      builder::options_json(builder::BuildOptions{}, builder::default_mapper().name());
  EXPECT_NE(json.find(std::string("\"mapper\":\"") + builder::default_mapper().name() + "\""),
            std::string::npos)
      << json;
}

TEST(EndToEnd, FailRegionBecomesInfeasibleAndTheRestIsAccurate) {
  const cadinterp_host* h = host("bracket", "cells=2,fail_region=1");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 200;
  o.threads = 2;
  const std::string path = temp_path("fail.cadi");
  const builder::BuildOutcome r = build(h, o, path);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  EXPECT_GT(r.report.infeasible_points, 0);
  const builder::AccuracyReport a = builder::measure_accuracy(path, builder::Host(*h), 100, 3);
  EXPECT_GT(a.infeasible, 0);
  EXPECT_LT(a.infeasible, a.points);
  std::filesystem::remove(path);
}

}  // namespace
