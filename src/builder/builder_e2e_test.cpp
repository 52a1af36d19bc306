// End to end on the analytic example host (examples/hosts/analytic): build each model through
// the C ABI, open the asset with the runtime, and compare with the host's own answer at 100
// random points (geometry: symmetric Hausdorff of the boundaries relative to the bbox diagonal;
// per-vertex fields relative to their range).
// Over 800 lines because each case is a whole build with its own host, options and figures,
// sharing only the helpers below; splitting them by theme would scatter those helpers.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "analytic_host.h"
#include "builder/build.h"
#include "builder/builder_e2e.h"
#include "cadinterp/cadinterp_builder.h"
#include "mapping/interior_solve.h"
#include "mesh/surface_distance.h"

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

// The plate's displacement (field 2, cubic along the plate) at the parameter box's 8 corners,
// against the closed form at the evaluated positions: per corner, the max error relative to the
// closed form's range there (empty where the asset cannot be evaluated).
std::vector<double> corner_displacement_errors(const std::string& path,
                                               const analytic_model* model) {
  std::vector<double> errors;
  cadinterp_asset* asset = nullptr;
  if (cadinterp_open(path.c_str(), &asset) != CADINTERP_OK) return errors;
  cadinterp_workspace* ws = nullptr;
  if (cadinterp_workspace_create(asset, &ws) != CADINTERP_OK) ws = nullptr;
  for (int corner = 0; corner < 8 && ws; ++corner) {
    double x[3];
    for (int d = 0; d < 3; ++d) {
      cadinterp_parameter_info desc;
      EXPECT_EQ(cadinterp_parameter(asset, d, &desc), CADINTERP_OK);
      x[d] = (corner >> d) & 1 ? desc.upper : desc.lower;
    }
    const int displacement[1] = {2};
    cadinterp_mesh m;
    if (cadinterp_eval(ws, x, displacement, 1, &m) != CADINTERP_OK) break;
    double err = 0, lo = 1e300, hi = -1e300;
    for (std::uint32_t v = 0; v < m.vertex_count; ++v) {
      const double p[3] = {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
      double truth[3];
      EXPECT_EQ(analytic_model_field_at(model, 2, x, p, truth), CADINTERP_OK);
      for (int c = 0; c < 3; ++c) {
        err = std::max(err, std::abs(m.fields[0][3 * v + std::uint32_t(c)] - truth[c]));
        lo = std::min(lo, truth[c]);
        hi = std::max(hi, truth[c]);
      }
    }
    errors.push_back(err / (hi - lo));
  }
  cadinterp_workspace_destroy(ws);
  cadinterp_close(asset);
  return errors;
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
  const builder::AccuracyReport a = builder::measure_accuracy(path, mesh::Host(*h), 100, 1);
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
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 120;
  o.threads = 2;
  const std::string path = temp_path("plate.cadi");
  const cadinterp_host* coarse = host("plate", "edge=100");
  ASSERT_NE(coarse, nullptr);
  builder::BuildOutcome r = build(coarse, o, path);
  ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
  builder::AccuracyReport a = builder::measure_accuracy(path, mesh::Host(*coarse), 100, 2);
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
  a = builder::measure_accuracy(
      path, mesh::Host(*fine), 60, 4, [model](int f, const double* x, const double* p, double* v) {
        return f == 0 && analytic_model_field_at(model, f, x, p, v) == CADINTERP_OK;
      });
  std::printf(
      "[ figures ] plate (edge=8, mesh mapper): %d samples, %d elements; geometry max %.2e p99 "
      "%.2e; temperature max %.2e p99 %.2e (closed form at the evaluated points)\n",
      r.report.samples, r.report.elements, a.geometry_max, a.geometry_p99, a.field_max,
      a.field_p99);
  EXPECT_EQ(a.infeasible, 0);
  EXPECT_LT(a.geometry_max, 10 * o.geometry_tolerance);
  EXPECT_LT(a.field_max, 10 * o.field_tolerance);

  const std::vector<double> corners = corner_displacement_errors(path, model);
  ASSERT_EQ(corners.size(), 8u);
  for (std::size_t corner = 0; corner < corners.size(); ++corner)
    EXPECT_LT(corners[corner], 2e-2) << "corner " << corner;
  std::filesystem::remove(path);
}

// simulate_mapped: each mapped term's fields are the host's simulate on the mapped mesh. The
// analytic host simulates in closed form at the vertices, so at the box's corners (samples,
// each mapped into its element's canonical mesh) the asset gives the closed form up to float
// rounding, where carrying the sample's fields over adds the barycentric interpolation's error.
// The accuracy measurement's comparison with the host's simulate on each evaluated mesh is, on
// this host, the closed-form comparison, and gives its numbers.
TEST(EndToEnd, SimulateMappedTermsHoldTheHostsFieldsOnTheirMappedMesh) {
  const cadinterp_host* h = host("plate", "edge=8");
  ASSERT_NE(h, nullptr);
  const analytic_model* model = analytic_host_model(h);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 40;
  o.threads = 2;
  const std::string carried = temp_path("plate_carried.cadi");
  const std::string simulated = temp_path("plate_simulated.cadi");
  const builder::BuildOutcome rc = build(h, o, carried);
  ASSERT_EQ(rc.status, CADINTERP_OK) << rc.error;
  EXPECT_EQ(rc.stages.mapped_simulated, 0);
  o.simulate_mapped = 1;
  const builder::BuildOutcome rs = build(h, o, simulated);
  ASSERT_EQ(rs.status, CADINTERP_OK) << rs.error;
  EXPECT_GT(rs.stages.mapped_simulated, 0);
  EXPECT_EQ(rs.stages.mapped_simulate_failures, 0);
  EXPECT_EQ(rs.report.samples, rc.report.samples);

  const std::vector<double> ec = corner_displacement_errors(carried, model),
                            es = corner_displacement_errors(simulated, model);
  ASSERT_EQ(ec.size(), 8u);
  ASSERT_EQ(es.size(), 8u);
  const double worst_carried = *std::max_element(ec.begin(), ec.end());
  const double worst_simulated = *std::max_element(es.begin(), es.end());
  std::printf(
      "[ figures ] plate corners, displacement: carried %.2e, simulated on the mapped "
      "mesh %.2e (relative to its range)\n",
      worst_carried, worst_simulated);
  EXPECT_LT(worst_simulated, 1e-5);  // float rounding of positions and values
  EXPECT_GT(worst_carried, 100 * worst_simulated);

  // On this host the host's simulate on an evaluated mesh is the closed form at its vertices.
  const mesh::Host bh(*h);
  const builder::AccuracyReport own =
      builder::measure_accuracy(simulated, bh, 20, 6, nullptr, false, true);
  const builder::AccuracyReport closed = builder::measure_accuracy(
      simulated, bh, 20, 6, [model](int f, const double* x, const double* p, double* v) {
        return analytic_model_field_at(model, f, x, p, v) == CADINTERP_OK;
      });
  EXPECT_EQ(own.evaluated_mesh_points, 20);
  EXPECT_EQ(own.evaluated_mesh_refused, 0) << own.evaluated_mesh_first_refusal;
  ASSERT_EQ(own.evaluated_mesh_max_by_field.size(), closed.field_max_by_field.size());
  for (std::size_t k = 0; k < closed.field_max_by_field.size(); ++k) {
    EXPECT_GT(closed.field_max_by_field[k], 0) << own.field_names[k];
    // float positions: the closed form at them, once in float and once in double
    EXPECT_NEAR(own.evaluated_mesh_max_by_field[k], closed.field_max_by_field[k],
                1e-4 * closed.field_max_by_field[k] + 1e-6)
        << own.field_names[k];
  }

  // A host whose simulate refuses every mesh but the one it regenerated (the first simulate at
  // an x; the builder simulates each sample once, its mapped terms later): the build goes on,
  // those terms keep their carried fields, and the host's message reaches the caller.
  struct OwnMeshOnly {
    const cadinterp_host* inner;
    std::mutex lock;
    std::set<std::vector<double>> simulated;
  } own_only{h, {}, {}};
  cadinterp_host picky = *h;
  picky.user = &own_only;
  picky.regenerate = [](void* u, const double* x, cadinterp_sample* out) {
    const cadinterp_host* in = static_cast<OwnMeshOnly*>(u)->inner;
    return in->regenerate(in->user, x, out);
  };
  picky.references = [](void* u, const double* x, cadinterp_sample* out) {
    const cadinterp_host* in = static_cast<OwnMeshOnly*>(u)->inner;
    return in->references(in->user, x, out);
  };
  picky.simulate = [](void* u, const double* x, const cadinterp_host_mesh* mesh,
                      cadinterp_sample* out) {
    auto* w = static_cast<OwnMeshOnly*>(u);
    {
      std::lock_guard<std::mutex> l(w->lock);
      if (!w->simulated.insert(std::vector<double>(x, x + w->inner->parameter_count)).second) {
        cadinterp_sample_set_message(out, "test host: only the mesh it regenerated");
        return CADINTERP_E_INFEASIBLE;
      }
    }
    return w->inner->simulate(w->inner->user, x, mesh, out);
  };
  const std::string refused = temp_path("plate_refused.cadi");
  const builder::BuildOutcome rr = build(&picky, o, refused);
  ASSERT_EQ(rr.status, CADINTERP_OK) << rr.error;
  EXPECT_EQ(rr.stages.mapped_simulated, 0);
  EXPECT_GT(rr.stages.mapped_simulate_failures, 0);
  EXPECT_NE(rr.first_mapped_simulate_failure.find("test host: only the mesh it regenerated"),
            std::string::npos)
      << rr.first_mapped_simulate_failure;
  EXPECT_TRUE(rs.first_mapped_simulate_failure.empty());
  const std::vector<double> er = corner_displacement_errors(refused, model);
  ASSERT_EQ(er.size(), 8u);
  EXPECT_EQ(er, ec);  // the carried fields, as without the option
  std::filesystem::remove(refused);

  // A host without simulate cannot build so: refused by name.
  cadinterp_host bare = *h;
  bare.simulate = nullptr;
  const builder::BuildOutcome rb = build(&bare, o, temp_path("plate_bare.cadi"));
  EXPECT_EQ(rb.status, CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_NE(rb.error.find("simulate_mapped"), std::string::npos) << rb.error;
  std::filesystem::remove(carried);
  std::filesystem::remove(simulated);
}

// The foldplate's B-rep topology changes at fold = 0 (its top face splits along a crease, a 13th
// edge and a 7th face appear) while its resolution follows its size: the mesh mapper's common
// layout carries samples across both, and the asset follows its host.
TEST(EndToEnd, FoldplateBuildsAcrossTopologyChanges) {
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
      path, mesh::Host(*h), 60, 5, [model](int f, const double* x, const double* p, double* v) {
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

// Canonical refinement (mapping/canonical_refine.h): a bracket meshed coarsely up to a 120 degree
// bend and finely beyond. The elements at the box's corners with a 135 degree bend have their
// canonical mesh (the centre, at 112.5 degrees) coarse and their corner term fine: the coarse
// triangles cut the fine bend as chords. At those corners (samples, so the asset gives the
// mapped term alone) the refined build follows the host's own mesh more closely than the same
// build without refinement, which refines nothing and is the same otherwise.
TEST(EndToEnd, CanonicalRefinementFollowsABendTheCanonicalMeshCutsAcross) {
  builder::SplitHost two;
  two.below = host("bracket", "cells=3");
  two.above = host("bracket", "cells=6");
  ASSERT_NE(two.below, nullptr);
  ASSERT_NE(two.above, nullptr);
  two.parameter = 3;  // the bend angle
  two.split = 120.0;
  two.identity = "bracket, cells=3 up to a 120 degree bend, cells=6 beyond";
  const cadinterp_host h = two.host();
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  EXPECT_EQ(o.canonical_refinement, 3);  // the default
  o.geometry_tolerance = 3e-3;
  o.field_tolerance = 1.0;
  o.max_samples = 20;
  o.threads = 2;
  const std::string refined = temp_path("bracket_refined.cadi");
  const builder::BuildOutcome rr = build(&h, o, refined);
  ASSERT_EQ(rr.status, CADINTERP_OK) << rr.error;
  o.canonical_refinement = 0;
  const std::string plain = temp_path("bracket_plain.cadi");
  const builder::BuildOutcome rp = build(&h, o, plain);
  ASSERT_EQ(rp.status, CADINTERP_OK) << rp.error;
  EXPECT_GT(rr.stages.refined_elements, 0);
  EXPECT_GT(rr.stages.refined_vertices, 0);
  EXPECT_EQ(rp.stages.refined_elements, 0);
  EXPECT_EQ(rp.stages.refined_vertices, 0);
  // Refinement changes no sample: the same tree, the same elements.
  EXPECT_EQ(rr.report.samples, rp.report.samples);
  EXPECT_EQ(rr.report.elements, rp.report.elements);

  // Per 135 degree corner: symmetric Hausdorff / diagonal against the host's mesh there, and
  // the vertex count of the element's mesh.
  const mesh::Host truth(h);
  auto at_corners = [&](const std::string& path, std::vector<double>& error,
                        std::vector<std::uint32_t>& vertices) {
    cadinterp_asset* asset = nullptr;
    ASSERT_EQ(cadinterp_open(path.c_str(), &asset), CADINTERP_OK);
    cadinterp_workspace* ws = nullptr;
    ASSERT_EQ(cadinterp_workspace_create(asset, &ws), CADINTERP_OK);
    for (int corner = 0; corner < 8; ++corner) {
      double x[4];
      for (int d = 0; d < 3; ++d) {
        cadinterp_parameter_info p;
        ASSERT_EQ(cadinterp_parameter(asset, d, &p), CADINTERP_OK);
        x[d] = (corner >> d) & 1 ? p.upper : p.lower;
      }
      x[3] = 135.0;
      cadinterp_mesh m;
      ASSERT_EQ(cadinterp_eval(ws, x, nullptr, 0, &m), CADINTERP_OK);
      const mesh::Sample s = truth.evaluate(x);
      ASSERT_TRUE(s.feasible);
      const std::vector<double> V(m.positions, m.positions + 3 * m.vertex_count);
      const std::vector<std::uint32_t> F(m.triangles, m.triangles + 3 * m.triangle_count);
      error.push_back(mesh::symmetric_hausdorff(V, F, s.vertices, s.triangles) / s.bbox_diagonal());
      vertices.push_back(m.vertex_count);
    }
    cadinterp_workspace_destroy(ws);
    cadinterp_close(asset);
  };
  std::vector<double> er, ep;
  std::vector<std::uint32_t> vr, vp;
  at_corners(refined, er, vr);
  at_corners(plain, ep, vp);
  ASSERT_EQ(er.size(), 8u);
  ASSERT_EQ(ep.size(), 8u);
  std::printf("[ figures ] two-mesh bracket: %d samples, %d elements, %d refined (+%d vertices)\n",
              rr.report.samples, rr.report.elements, rr.stages.refined_elements,
              rr.stages.refined_vertices);
  for (std::size_t c = 0; c < 8; ++c) {
    std::printf(
        "[ figures ]   135 deg corner %zu: Hausdorff %.2e on %u vertices, without "
        "refinement %.2e on %u\n",
        c, er[c], vr[c], ep[c], vp[c]);
    EXPECT_GT(vr[c], vp[c]) << "corner " << c;  // a refined element
    EXPECT_LT(er[c], 0.5 * ep[c]) << "corner " << c;
  }
  std::filesystem::remove(refined);
  std::filesystem::remove(plain);
}

// Cubic elements take samples of their neighbours (§5.3, Fig. 15). Carried from the neighbour's
// canonical mesh through a sample on both elements (mapping/neighbour_transfer.h; the builder's
// fallback where the direct mapping fails, forced here for every neighbour sample):
// Truth is the host: each term, however it was carried, must lie on its own sample's boundary
// (foldplate: neighbours across its B-rep topology change). The asset does not depend on the
// thread count, no stored tet is inverted, and the direct route gives other positions (the
// bridge is really used).
TEST(EndToEnd, CubicNeighbourSamplesGoThroughASharedSample) {
  const cadinterp_host* h = host("foldplate", "edge=25");
  ASSERT_NE(h, nullptr);
  const mesh::Host fold(*h);
  builder::BuildOptions o;
  o.degree = core::Degree::Cubic;
  o.max_samples = 24;
  o.threads = 1;
  o.neighbour_transfer = builder::NeighbourTransfer::Always;
  o.measure_neighbour_transfer = true;
  o.encode_elements = false;  // the positions are compared below
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
}

// BuildOptions::encode_elements: each element is held encoded from the moment it is built, its
// arrays released, and the asset is the one its arrays give, byte for byte (positions lossy
// here, so the build's write options reach the encoder), whether assembled in memory or written
// to a file part by part. Under other write options the writer refuses the encoded elements.
// A cubic foldplate across its topology change, whose elements hold mapped terms.
TEST(EndToEnd, ElementsEncodedAsBuiltWriteTheSameAsset) {
  const cadinterp_host* h = host("foldplate", "edge=25");
  ASSERT_NE(h, nullptr);
  const mesh::Host fold(*h);
  builder::BuildOptions o;
  o.degree = core::Degree::Cubic;
  o.max_samples = 24;
  o.threads = 2;
  o.position_max_abs_error = 1e-5;
  o.encode_elements = false;
  const builder::BuildResult raw = builder::build(fold, o);
  o.encode_elements = true;
  const builder::BuildResult held = builder::build(fold, o);
  const format::WriteOptions w = builder::asset_write_options(o);
  EXPECT_EQ(w.position_max_abs_error, 1e-5);
  ASSERT_EQ(held.content.elements.size(), raw.content.elements.size());
  std::size_t raw_bytes = 0, held_bytes = 0;
  int encoded = 0;
  for (std::size_t e = 0; e < raw.content.elements.size(); ++e) {
    SCOPED_TRACE(e);
    const format::ElementData& a = raw.content.elements[e];
    const format::ElementData& b = held.content.elements[e];
    EXPECT_EQ(b.vertex_count, a.vertex_count);
    EXPECT_EQ(b.error_model, a.error_model);
    EXPECT_EQ(b.geometry_floor, a.geometry_floor);
    if (a.vertex_count == 0) {
      EXPECT_FALSE(b.encoded);
      continue;
    }
    ASSERT_TRUE(b.encoded);
    ++encoded;
    EXPECT_EQ(format::element_array_bytes(b), 0u);
    EXPECT_EQ(b.encoded->positions.size(), a.positions.size());
    raw_bytes += format::element_array_bytes(a);
    held_bytes += b.encoded->bytes();
  }
  EXPECT_GT(encoded, 0);
  EXPECT_LT(held_bytes, raw_bytes);
  std::printf("[ figures ] %d elements: %zu bytes of arrays held as %zu encoded (%.2f)\n", encoded,
              raw_bytes, held_bytes,
              static_cast<double>(held_bytes) / static_cast<double>(raw_bytes));
  const std::vector<std::uint8_t> bytes = format::write_asset(raw.content, w);
  EXPECT_EQ(format::write_asset(held.content, w), bytes);
  const std::string path = temp_path("foldplate_encoded.cadi");
  format::write_asset_file(held.content, w, path);
  std::ifstream in(path, std::ios::binary);
  EXPECT_EQ(std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {}), bytes);
  std::filesystem::remove(path);
  EXPECT_THROW(format::write_asset(held.content, format::WriteOptions{}), format::FormatError);
}

// A cubic element one of whose neighbour terms (§5.3) cannot be mapped onto its canonical mesh
// is built on its corner fallback instead of being refused: its corners' multilinear blend,
// which needs only its own samples (§4.2's locality). The cubic foldplate at its start grid (no
// split, so the tree is the same), once with the mesh mapper and once with a mapper that refuses
// one pair (a neighbour term across the fold onto an element's centre; the direct transfer, so
// that no bridge carries it): that element, and only it, changes to its 2^K corners, and
// every other element's record is the same.
TEST(EndToEnd, AnUnmappedCubicTermLeavesItsElementOnItsCorners) {
  const cadinterp_host* h = host("foldplate", "edge=30");
  ASSERT_NE(h, nullptr);
  const mesh::Host fold(*h);
  builder::BuildOptions o;
  o.degree = core::Degree::Cubic;
  o.max_samples = 2;
  o.threads = 2;
  o.neighbour_transfer = builder::NeighbourTransfer::Direct;
  o.encode_elements = false;  // the positions are compared below
  const builder::BuildResult one = builder::build(fold, o);
  ASSERT_EQ(one.report.infeasible_elements, 0);
  EXPECT_EQ(one.details.unmapped_fallbacks, 0);
  const core::CompiledBasis& cb = *one.basis;
  const int K = cb.dim();
  // The first element with a term outside its box whose mesh differs from the element's centre.
  int element = -1;
  mesh::Sample term, centre;
  for (int e = 0; element < 0 && e < cb.element_count(); ++e) {
    std::vector<double> lo(static_cast<std::size_t>(K)), hi(lo), c(lo), x(lo);
    cb.element_box(e, lo.data(), hi.data());
    for (int d = 0; d < K; ++d) c[d] = (lo[d] + hi[d]) / 2;
    centre = fold.evaluate(c.data());
    int n = 0;
    const int* terms = cb.element_samples(e, &n);
    for (int t = 0; element < 0 && t < n; ++t) {
      cb.sample_position(terms[t], x.data());
      bool outside = false;
      for (int d = 0; d < K; ++d) outside = outside || x[d] < lo[d] || x[d] > hi[d];
      if (!outside) continue;
      term = fold.evaluate(x.data());
      if (!mesh::same_combinatorics(term, centre)) element = e;
    }
  }
  ASSERT_GE(element, 0);
  struct RefuseOne final : mesh::Mapper {
    const mesh::Sample *term, *centre;
    bool map(const mesh::Sample& source, const mesh::Sample& canonical, mesh::MappedSample& out,
             std::string& why) const override {
      if (source.vertices == term->vertices && canonical.vertices == centre->vertices) {
        why = "refused by the test mapper";
        return false;
      }
      return builder::default_mapper().map(source, canonical, out, why);
    }
    const char* name() const override { return builder::default_mapper().name(); }
  } refuse;
  refuse.term = &term;
  refuse.centre = &centre;
  o.mapper = &refuse;
  const builder::BuildResult two = builder::build(fold, o);
  EXPECT_EQ(two.report.infeasible_elements, 0);
  EXPECT_EQ(two.details.unmapped_elements, 0);
  EXPECT_EQ(two.details.unmapped_fallbacks, 1);
  EXPECT_TRUE(two.infeasible.empty());
  ASSERT_EQ(two.basis->element_count(), cb.element_count());
  for (int e = 0; e < cb.element_count(); ++e) {
    SCOPED_TRACE(e);
    const auto& a = one.content.elements[static_cast<std::size_t>(e)];
    const auto& b = two.content.elements[static_cast<std::size_t>(e)];
    EXPECT_FALSE(cb.element_on_corner_fallback(e));
    EXPECT_EQ(two.basis->element_on_corner_fallback(e), e == element);
    EXPECT_TRUE(two.basis->element_feasible(e));
    if (e == element) {
      EXPECT_EQ(b.positions.size(), std::size_t{1} << K);
    } else {
      EXPECT_EQ(b.positions, a.positions);
    }
  }
}

// The truth's own mesh term (cadinterp-occt-results --truth-against). A host against itself
// differs by nothing. Against a finer mesh of the same model, the plate's temperature (the
// closed form at the vertices, quadratic along the plate) differs by the coarser mesh's linear
// interpolation error, which is second order: a quarter per halving of the edge.
TEST(EndToEnd, TruthDependenceIsTheCoarserMeshsInterpolationError) {
  const cadinterp_host* e8 = host("plate", "edge=8");
  const cadinterp_host* e4 = host("plate", "edge=4");
  const cadinterp_host* e1 = host("plate", "edge=1");
  ASSERT_TRUE(e8 && e4 && e1);
  const mesh::Host h8(*e8), h4(*e4), h1(*e1);
  const builder::TruthDependenceReport self = builder::measure_truth_dependence(h8, h8, 4, 3);
  EXPECT_EQ(self.points, 4);
  EXPECT_EQ(self.compared, 4);
  ASSERT_EQ(self.field_names, (std::vector<std::string>{"temperature", "displacement"}));
  for (double m : self.max_by_field) EXPECT_LT(m, 1e-12);
  const builder::TruthDependenceReport coarse = builder::measure_truth_dependence(h8, h1, 4, 3);
  const builder::TruthDependenceReport fine = builder::measure_truth_dependence(h4, h1, 4, 3);
  ASSERT_EQ(coarse.compared, 4);
  ASSERT_EQ(fine.compared, 4);
  std::printf(
      "[ figures ] plate temperature against edge=1: edge=8 %.3e, edge=4 %.3e (99 %% %.3e, %.3e)\n",
      coarse.max_by_field[0], fine.max_by_field[0], coarse.vertex_p99_by_field[0],
      fine.vertex_p99_by_field[0]);
  EXPECT_GT(fine.max_by_field[0], 1e-4);
  const double order = std::log2(coarse.max_by_field[0] / fine.max_by_field[0]);
  EXPECT_GT(order, 1.7);
  EXPECT_LT(order, 2.3);
  // With an asset: the asset against the reference at the same points, as measure_accuracy
  // measures it against that host.
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 30;
  o.threads = 2;
  const std::string path = temp_path("truth_dependence.cadi");
  ASSERT_EQ(build(e8, o, path).status, CADINTERP_OK);
  const builder::TruthDependenceReport with = builder::measure_truth_dependence(h8, h4, 5, 9, path);
  const builder::AccuracyReport direct = builder::measure_accuracy(path, h4, 5, 9);
  std::filesystem::remove(path);
  ASSERT_TRUE(with.has_asset);
  EXPECT_FALSE(self.has_asset);
  EXPECT_EQ(with.asset.points, 5);
  EXPECT_EQ(with.asset.field_points, direct.field_points);
  EXPECT_EQ(with.asset.field_max_by_field, direct.field_max_by_field);
  EXPECT_EQ(with.asset.field_vertex_p99_by_field, direct.field_vertex_p99_by_field);
  EXPECT_EQ(with.asset.geometry_max, direct.geometry_max);
  EXPECT_GT(with.asset.field_max, 0.0);
  // Other boxes are refused by name.
  const cadinterp_host* other = host("bracket", "cells=2");
  ASSERT_NE(other, nullptr);
  EXPECT_THROW(builder::measure_truth_dependence(h8, mesh::Host(*other), 1, 3),
               std::invalid_argument);
}

// Every member of two accuracy reports, the per-point records included.
void expect_same_report(const builder::AccuracyReport& a, const builder::AccuracyReport& b) {
  EXPECT_EQ(a.points, b.points);
  EXPECT_EQ(a.infeasible, b.infeasible);
  EXPECT_EQ(a.lost, b.lost);
  EXPECT_EQ(a.field_points, b.field_points);
  EXPECT_EQ(a.geometry_max, b.geometry_max);
  EXPECT_EQ(a.geometry_p99, b.geometry_p99);
  EXPECT_EQ(a.field_max, b.field_max);
  EXPECT_EQ(a.field_p99, b.field_p99);
  EXPECT_EQ(a.field_names, b.field_names);
  EXPECT_EQ(a.field_max_by_field, b.field_max_by_field);
  EXPECT_EQ(a.field_p99_by_field, b.field_p99_by_field);
  EXPECT_EQ(a.field_vertex_p99_by_field, b.field_vertex_p99_by_field);
  EXPECT_EQ(a.evaluated_mesh_points, b.evaluated_mesh_points);
  EXPECT_EQ(a.evaluated_mesh_refused, b.evaluated_mesh_refused);
  EXPECT_EQ(a.evaluated_mesh_max_by_field, b.evaluated_mesh_max_by_field);
  EXPECT_EQ(a.evaluated_mesh_vertex_p99_by_field, b.evaluated_mesh_vertex_p99_by_field);
  EXPECT_EQ(a.estimate_points, b.estimate_points);
  EXPECT_EQ(a.estimate_coverage, b.estimate_coverage);
  EXPECT_EQ(a.estimate_median_ratio, b.estimate_median_ratio);
  ASSERT_EQ(a.per_point.size(), b.per_point.size());
  for (std::size_t i = 0; i < a.per_point.size(); ++i) {
    EXPECT_EQ(a.per_point[i].x, b.per_point[i].x) << i;
    EXPECT_EQ(a.per_point[i].estimate, b.per_point[i].estimate) << i;
    EXPECT_EQ(a.per_point[i].error, b.per_point[i].error) << i;
  }
}

// The measurements ask the host on several threads, yet report what one thread reports: the
// comparisons keep the points' order. The plate failing in a quarter disk gives points the
// runtime refuses (and the host's answer there for `lost`), and its simulate the comparison on
// each evaluated mesh. 13 points: batches of 4 points on one thread, of 12 on three, the last
// batch short.
TEST(EndToEnd, MeasurementsDoNotDependOnTheThreadCount) {
  const cadinterp_host* h8 = host("plate", "edge=8,fail_region=2");
  const cadinterp_host* h4 = host("plate", "edge=4,fail_region=2");
  ASSERT_TRUE(h8 && h4);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 40;
  o.threads = 2;
  const std::string path = temp_path("threads.cadi");
  ASSERT_EQ(build(h8, o, path).status, CADINTERP_OK);
  // The host's regenerations in flight at once, each held 5 ms so that threads overlap.
  struct InFlight {
    const cadinterp_host* inner;
    std::atomic<int> now{0}, most{0};
  } counted{h8};
  cadinterp_host wrapped = *h8;
  wrapped.user = &counted;
  wrapped.regenerate = [](void* u, const double* x, cadinterp_sample* out) {
    auto* w = static_cast<InFlight*>(u);
    const int now = ++w->now;
    for (int m = w->most; now > m && !w->most.compare_exchange_weak(m, now);) {
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const cadinterp_status s = w->inner->regenerate(w->inner->user, x, out);
    --w->now;
    return s;
  };
  wrapped.references = [](void* u, const double* x, cadinterp_sample* out) {
    const cadinterp_host* in = static_cast<InFlight*>(u)->inner;
    return in->references(in->user, x, out);
  };
  wrapped.simulate = [](void* u, const double* x, const cadinterp_host_mesh* mesh,
                        cadinterp_sample* out) {
    const cadinterp_host* in = static_cast<InFlight*>(u)->inner;
    return in->simulate(in->user, x, mesh, out);
  };
  const mesh::Host counting(wrapped), fine(*h4);
  const builder::AccuracyReport one =
      builder::measure_accuracy(path, counting, 13, 4, nullptr, true, true, 1);
  EXPECT_EQ(counted.most, 1);
  const builder::AccuracyReport three =
      builder::measure_accuracy(path, counting, 13, 4, nullptr, true, true, 3);
  EXPECT_GE(counted.most, 2);
  std::printf(
      "[ figures ] plate failing in a quarter disk, 13 points: %d refused (%d lost), %d "
      "compared, %d on their evaluated meshes\n",
      one.infeasible, one.lost, one.field_points, one.evaluated_mesh_points);
  EXPECT_EQ(one.points, 13);
  EXPECT_GT(one.infeasible, 0);
  EXPECT_GT(one.field_points, 0);
  EXPECT_GT(one.evaluated_mesh_points, 0);
  expect_same_report(one, three);

  counted.most = 0;
  const builder::TruthDependenceReport t1 =
      builder::measure_truth_dependence(counting, fine, 13, 4, path, 1);
  EXPECT_EQ(counted.most, 1);
  const builder::TruthDependenceReport t3 =
      builder::measure_truth_dependence(counting, fine, 13, 4, path, 3);
  EXPECT_GE(counted.most, 2);
  EXPECT_GT(t1.compared, 0);
  EXPECT_EQ(t1.points, t3.points);
  EXPECT_EQ(t1.infeasible, t3.infeasible);
  EXPECT_EQ(t1.compared, t3.compared);
  EXPECT_EQ(t1.field_names, t3.field_names);
  EXPECT_EQ(t1.max_by_field, t3.max_by_field);
  EXPECT_EQ(t1.vertex_p99_by_field, t3.vertex_p99_by_field);
  EXPECT_EQ(t1.max_x, t3.max_x);
  expect_same_report(t1.asset, t3.asset);
  std::filesystem::remove(path);
}

// Without the mesh mapper (the identity hook), elements across resolutions cannot be built, and
// the build says why by name.
TEST(EndToEnd, PlateWithTheIdentityMapperNamesWhyItCannotBlend) {
  const cadinterp_host* fine = host("plate", "edge=8");
  ASSERT_NE(fine, nullptr);
  const mesh::Host h(*fine);
  const mesh::IdentityMapper identity;
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

// The default mapper is the mesh mapper, and its name is what the asset's provenance records.
TEST(EndToEnd, DefaultMapperIsTheMeshMapperAndNamedInProvenance) {
  EXPECT_STREQ(builder::default_mapper().name(), "mesh-v10");
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
  const builder::AccuracyReport a = builder::measure_accuracy(path, mesh::Host(*h), 100, 3);
  EXPECT_GT(a.infeasible, 0);
  EXPECT_LT(a.infeasible, a.points);
  std::filesystem::remove(path);
}

// The refinement toward a failing region (cadinterp_build_options::infeasible_call_fraction):
// split toward the boundary, bounded in failed points, counted in the report and the stages;
// only a non-default bound is recorded in the provenance.
TEST(EndToEnd, InfeasibleRefinementIsBoundedAndCounted) {
  const cadinterp_host* h = host("bracket", "cells=1,fail_region=2");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  EXPECT_EQ(o.infeasible_call_fraction, 0.25);
  o.max_samples = 120;
  o.threads = 2;
  const std::string path = temp_path("infeasible.cadi");
  const builder::BuildOutcome d = build(h, o, path);
  ASSERT_EQ(d.status, CADINTERP_OK) << d.error;
  EXPECT_GT(d.report.infeasible_host_evaluations, 0);
  EXPECT_EQ(d.report.infeasible_host_evaluations, d.report.infeasible_points);  // no store
  EXPECT_GT(d.stages.infeasible_splits, 0);

  o.infeasible_call_fraction = 0.05;  // 6 failed points
  const builder::BuildOutcome b = build(h, o, path);
  ASSERT_EQ(b.status, CADINTERP_OK) << b.error;
  EXPECT_GT(b.stages.bound_unsplit, 0);
  // One wave's splits may still evaluate their points after the bound is reached.
  EXPECT_LE(b.report.infeasible_host_evaluations, 6 + 16);
  EXPECT_LT(b.report.infeasible_host_evaluations, d.report.infeasible_host_evaluations);

  o.infeasible_call_fraction = 0;
  const builder::BuildOutcome z = build(h, o, path);
  ASSERT_EQ(z.status, CADINTERP_OK) << z.error;
  EXPECT_EQ(z.stages.infeasible_splits, 0);

  o.infeasible_call_fraction = std::numeric_limits<double>::infinity();
  EXPECT_EQ(build(h, o, path).status, CADINTERP_E_INVALID_ARGUMENT);
  std::filesystem::remove(path);

  builder::BuildOptions bo;
  const char* mapper = builder::default_mapper().name();
  EXPECT_EQ(builder::options_json(bo, mapper).find("infeasible_call_fraction"), std::string::npos);
  bo.infeasible_call_fraction = -1;
  EXPECT_NE(builder::options_json(bo, mapper).find("infeasible_call_fraction"), std::string::npos);
}

// cadinterp_build_options::lazy_face_centres on a budget-bound build of the analytic bracket:
// fewer host calls per kept sample than testing every face centre, at an error measured against
// the host itself no worse than 1.1x; the same asset on 1 and 2 threads; recorded in the
// provenance only when on.
TEST(EndToEnd, LazyFaceCentresSpendFewerHostCallsPerSample) {
  const cadinterp_host* h = host("bracket", "cells=2");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  EXPECT_EQ(o.lazy_face_centres, 0);
  o.max_samples = 80;
  o.threads = 1;
  const std::string all_path = temp_path("faces_all.cadi"),
                    lazy_path = temp_path("faces_lazy.cadi");
  const builder::BuildOutcome all = build(h, o, all_path);
  ASSERT_EQ(all.status, CADINTERP_OK) << all.error;
  o.lazy_face_centres = 1;
  const builder::BuildOutcome lazy = build(h, o, lazy_path);
  ASSERT_EQ(lazy.status, CADINTERP_OK) << lazy.error;
  ASSERT_EQ(all.report.budget_exhausted, 1);  // the regime the option is for
  const auto per_sample = [](const builder::BuildOutcome& b) {
    return static_cast<double>(b.report.host_evaluations) / b.report.samples;
  };
  EXPECT_LT(per_sample(lazy), 0.8 * per_sample(all))
      << per_sample(lazy) << " against " << per_sample(all);
  const mesh::Host truth(*h);
  const builder::AccuracyReport a = builder::measure_accuracy(all_path, truth, 150, 11);
  const builder::AccuracyReport b = builder::measure_accuracy(lazy_path, truth, 150, 11);
  EXPECT_LE(b.geometry_max, 1.1 * a.geometry_max);
  EXPECT_LE(b.field_max, 1.1 * a.field_max);
  // Deterministic at any thread count.
  o.threads = 2;
  const std::string two_path = temp_path("faces_lazy2.cadi");
  ASSERT_EQ(build(h, o, two_path).status, CADINTERP_OK);
  const auto bytes = [](const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
  };
  EXPECT_EQ(bytes(two_path), bytes(lazy_path));
  for (const auto& p : {all_path, lazy_path, two_path}) std::filesystem::remove(p);

  builder::BuildOptions bo;
  const char* mapper = builder::default_mapper().name();
  EXPECT_EQ(builder::options_json(bo, mapper).find("lazy_face_centres"), std::string::npos);
  bo.lazy_face_centres = true;
  EXPECT_NE(builder::options_json(bo, mapper).find("\"lazy_face_centres\":true"),
            std::string::npos);
}

}  // namespace
