// The C ABI end to end on synthetic assets: queries, eval against the basis and against the
// analytic host, gradients against finite differences, the vector-Jacobian product, mass
// properties and their gradients, and the failure statuses.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <future>
#include <random>
#include <set>
#include <string>

#include "cadinterp/cadinterp.h"
#include "cadinterp_generated.h"
#include "capi/capi_guard.h"
#include "format/asset_reader.h"
#include "format/synthetic_asset.h"
#include "runtime/mesh_metrics.h"
#include "runtime/opened_asset_test_util.h"

namespace {

using cadinterp::format::SyntheticSpec;

struct Opened {
  std::vector<std::uint8_t> bytes;
  cadinterp::format::SyntheticAsset synthetic;
  cadinterp_asset* asset = nullptr;
  cadinterp_workspace* ws = nullptr;
  ~Opened() {
    cadinterp_workspace_destroy(ws);
    cadinterp_close(asset);
  }
};

std::unique_ptr<Opened> open_synthetic(SyntheticSpec spec) {
  auto o = std::make_unique<Opened>();
  o->synthetic = cadinterp::format::make_synthetic_asset(spec);
  o->bytes = cadinterp::format::write_asset(o->synthetic.content, {});
  EXPECT_EQ(cadinterp_open_memory(o->bytes.data(), o->bytes.size(), 0, &o->asset), CADINTERP_OK)
      << cadinterp_open_error();
  EXPECT_EQ(cadinterp_workspace_create(o->asset, &o->ws), CADINTERP_OK);
  return o;
}

SyntheticSpec spec(int K, cadinterp::core::Degree g) {
  return cadinterp::runtime_test::small_synthetic_spec(K, g);
}

TEST(Runtime, QueriesDescribeTheAsset) {
  const auto o = open_synthetic(spec(3, cadinterp::core::Degree::Cubic));
  EXPECT_EQ(cadinterp_parameter_count(o->asset), 3);
  EXPECT_EQ(cadinterp_degree(o->asset), 3);
  EXPECT_EQ(cadinterp_element_count(o->asset), o->synthetic.basis->element_count());
  cadinterp_parameter_info p;
  ASSERT_EQ(cadinterp_parameter(o->asset, 1, &p), CADINTERP_OK);
  EXPECT_STREQ(p.name, "twist");
  EXPECT_STREQ(p.unit, "rad/m");
  EXPECT_EQ(p.lower, 0.0);
  EXPECT_EQ(p.upper, 1.0);
  EXPECT_EQ(cadinterp_parameter(o->asset, 3, &p), CADINTERP_E_INVALID_ARGUMENT);
  ASSERT_EQ(cadinterp_field_count(o->asset), 2);
  cadinterp_field_info f;
  ASSERT_EQ(cadinterp_field(o->asset, 1, &f), CADINTERP_OK);
  EXPECT_STREQ(f.name, "stress");
  EXPECT_EQ(f.location, CADINTERP_PER_TET);
  int idx = -1;
  EXPECT_EQ(cadinterp_find_field(o->asset, "temperature", &idx), CADINTERP_OK);
  EXPECT_EQ(idx, 0);
  EXPECT_EQ(cadinterp_find_field(o->asset, "pressure", &idx), CADINTERP_E_NOT_FOUND);
  ASSERT_EQ(cadinterp_region_count(o->asset), 2);
  cadinterp_region_info r;
  ASSERT_EQ(cadinterp_region(o->asset, 0, &r), CADINTERP_OK);
  EXPECT_STREQ(r.kind, "fixed");
  ASSERT_EQ(r.face_tag_count, 1);
  EXPECT_EQ(r.face_tags[0], 0);
  cadinterp_provenance prov;
  ASSERT_EQ(cadinterp_asset_provenance(o->asset, &prov), CADINTERP_OK);
  EXPECT_STREQ(prov.host, "synthetic box");
  int major = 0, minor = -1;
  EXPECT_EQ(cadinterp_asset_format(o->asset, &major, &minor), CADINTERP_OK);
  EXPECT_EQ(major, 1);
  EXPECT_EQ(minor, 0);  // no field units: written as format 1.0
  const char* unit = nullptr;
  ASSERT_EQ(cadinterp_field_unit(o->asset, 0, &unit), CADINTERP_OK);
  EXPECT_STREQ(unit, "");
}

// Field units (format 1.1): what the writer was given comes back per field; a field without one
// gives ""; bad arguments give a named status and leave the output alone.
TEST(Runtime, FieldUnitsRoundTrip) {
  SyntheticSpec s = spec(1, cadinterp::core::Degree::Linear);
  s.field_units = true;
  const auto o = open_synthetic(s);
  int major = 0, minor = -1;
  ASSERT_EQ(cadinterp_asset_format(o->asset, &major, &minor), CADINTERP_OK);
  EXPECT_EQ(minor, 1);
  const char* unit = nullptr;
  ASSERT_EQ(cadinterp_field_unit(o->asset, 0, &unit), CADINTERP_OK);
  EXPECT_STREQ(unit, "K");
  ASSERT_EQ(cadinterp_field_unit(o->asset, 1, &unit), CADINTERP_OK);
  EXPECT_STREQ(unit, "MPa");
  const char* untouched = "x";
  unit = untouched;
  EXPECT_EQ(cadinterp_field_unit(o->asset, 2, &unit), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_field_unit(o->asset, -1, &unit), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_field_unit(nullptr, 0, &unit), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_field_unit(o->asset, 0, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(unit, untouched);
  // The unit-less fields of a mixed asset give "".
  cadinterp::format::AssetContent c = o->synthetic.content;
  c.fields[0].unit.clear();
  const std::vector<std::uint8_t> bytes = cadinterp::format::write_asset(c, {});
  cadinterp_asset* a = nullptr;
  ASSERT_EQ(cadinterp_open_memory(bytes.data(), bytes.size(), 0, &a), CADINTERP_OK);
  ASSERT_EQ(cadinterp_field_unit(a, 0, &unit), CADINTERP_OK);
  EXPECT_STREQ(unit, "");
  ASSERT_EQ(cadinterp_field_unit(a, 1, &unit), CADINTERP_OK);
  EXPECT_STREQ(unit, "MPa");
  cadinterp_close(a);
}

// Eval equals the blend of the stored samples with the basis weights, and approximates the host.
TEST(Runtime, EvalMatchesTheBasisBlendAndTheHost) {
  for (auto g : {cadinterp::core::Degree::Linear, cadinterp::core::Degree::Cubic}) {
    const auto o = open_synthetic(spec(3, g));
    const cadinterp::core::CompiledBasis& cb = *o->synthetic.basis;
    cadinterp::core::EvalWorkspace bws = cb.make_workspace();
    std::mt19937_64 rng(5);
    const int fields[2] = {0, 1};
    double worst_host = 0.0;
    for (int i = 0; i < 100; ++i) {
      double x[3];
      for (double& v : x) v = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
      cadinterp_mesh m;
      ASSERT_EQ(cadinterp_eval(o->ws, x, fields, 2, &m), CADINTERP_OK)
          << cadinterp_workspace_error(o->ws);
      cadinterp::core::BasisWeights w;
      ASSERT_TRUE(cb.eval(x, bws, false, &w));
      ASSERT_EQ(m.element, w.element);
      const auto& ed = o->synthetic.content.elements[static_cast<std::size_t>(w.element)];
      for (std::size_t v = 0; v < m.vertex_count * 3; ++v) {
        double ref = 0.0;
        for (int t = 0; t < w.count; ++t)
          ref += w.psi[t] * ed.positions[static_cast<std::size_t>(t)][v];
        ASSERT_NEAR(m.positions[v], ref, 1e-5);
      }
      const std::size_t nv = m.vertex_count, nt = m.tet_count;
      for (std::size_t k = 0; k < nt; ++k) {
        double ref = 0.0;
        for (int t = 0; t < w.count; ++t)
          ref += w.psi[t] * ed.fields[static_cast<std::size_t>(t)][nv + k];
        ASSERT_NEAR(m.fields[1][k], ref, 1e-4);
      }
      std::vector<float> pos, fld;
      ASSERT_TRUE(cadinterp::format::synthetic_host(spec(3, g), x, pos, fld));
      for (std::size_t v = 0; v < nv * 3; ++v)
        worst_host = std::max(worst_host, std::abs(double(m.positions[v]) - pos[v]));
    }
    std::printf("[ figures ] %s: max position error against the host %.2e (tolerance 2e-3)\n",
                g == cadinterp::core::Degree::Linear ? "linear" : "cubic", worst_host);
    EXPECT_LT(worst_host, 1e-2);
  }
}

// eval_subset against the full eval at the same x: the boundary vertices (shuffled, one
// repeated) and a random subset of tets, for both degrees; every row equals the full mesh's row
// of the same id (same blend, same summation order; only fused multiply-adds of the AVX2 kernel
// may move the last bits of the full eval), and the whole-mesh data match.
TEST(Runtime, EvalSubsetMatchesFullEvalRowByRow) {
  for (auto g : {cadinterp::core::Degree::Linear, cadinterp::core::Degree::Cubic}) {
    const auto o = open_synthetic(spec(3, g));
    cadinterp_workspace* full_ws = nullptr;
    ASSERT_EQ(cadinterp_workspace_create(o->asset, &full_ws), CADINTERP_OK);
    std::mt19937_64 rng(11);
    const int fields[2] = {1, 0};  // per tet, then per vertex: request order, not index order
    for (int i = 0; i < 40; ++i) {
      double x[3];
      for (double& v : x) v = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
      cadinterp_mesh full;
      ASSERT_EQ(cadinterp_eval(full_ws, x, fields, 2, &full), CADINTERP_OK);
      std::set<std::uint32_t> boundary(full.triangles, full.triangles + 3 * full.triangle_count);
      std::vector<std::uint32_t> vids(boundary.begin(), boundary.end());
      ASSERT_LT(vids.size(), full.vertex_count) << "the box should have interior vertices";
      std::shuffle(vids.begin(), vids.end(), rng);
      vids.push_back(vids.front());
      std::vector<std::uint32_t> tids;
      for (std::uint32_t t = 0; t < full.tet_count; ++t)
        if (rng() % 3 == 0) tids.push_back(t);
      tids.push_back(full.tet_count - 1);
      cadinterp_mesh sub;
      ASSERT_EQ(cadinterp_eval_subset(o->ws, x, vids.data(), vids.size(), tids.data(), tids.size(),
                                      fields, 2, &sub),
                CADINTERP_OK)
          << cadinterp_workspace_error(o->ws);
      ASSERT_EQ(sub.element, full.element);
      ASSERT_EQ(sub.vertex_count, full.vertex_count);
      ASSERT_EQ(sub.tet_count, full.tet_count);
      ASSERT_EQ(sub.triangle_count, full.triangle_count);
      ASSERT_EQ(std::memcmp(sub.triangles, full.triangles, 12u * full.triangle_count), 0);
      ASSERT_EQ(std::memcmp(sub.tets, full.tets, 16u * full.tet_count), 0);
      for (std::size_t k = 0; k < vids.size(); ++k)
        for (int c = 0; c < 3; ++c) {
          const float want = full.positions[3 * vids[k] + static_cast<std::size_t>(c)];
          ASSERT_NEAR(sub.positions[3 * k + static_cast<std::size_t>(c)], want,
                      1e-6f * std::max(1.0f, std::abs(want)))
              << "vertex " << vids[k];
        }
      for (std::size_t k = 0; k < tids.size(); ++k) {
        const float want = full.fields[0][tids[k]];
        ASSERT_NEAR(sub.fields[0][k], want, 1e-6f * std::max(1.0f, std::abs(want)));
      }
      for (std::size_t k = 0; k < vids.size(); ++k) {
        const float want = full.fields[1][vids[k]];
        ASSERT_NEAR(sub.fields[1][k], want, 1e-6f * std::max(1.0f, std::abs(want)));
      }
    }
    // Empty subsets: only the element and the whole-mesh counts and topology.
    const double x[3] = {0.3, 0.6, 0.2};
    cadinterp_mesh full, sub;
    ASSERT_EQ(cadinterp_eval(full_ws, x, nullptr, 0, &full), CADINTERP_OK);
    ASSERT_EQ(cadinterp_eval_subset(o->ws, x, nullptr, 0, nullptr, 0, nullptr, 0, &sub),
              CADINTERP_OK);
    EXPECT_EQ(sub.element, full.element);
    EXPECT_EQ(sub.vertex_count, full.vertex_count);
    EXPECT_EQ(sub.tet_count, full.tet_count);
    cadinterp_workspace_destroy(full_ws);
  }
}

TEST(Runtime, EvalSubsetRefusesBadIdsAndLeavesItsOutputUntouched) {
  SyntheticSpec s = spec(2, cadinterp::core::Degree::Linear);
  s.infeasible_corner = true;
  const auto o = open_synthetic(s);
  const double x[2] = {0.2, 0.3};
  cadinterp_mesh full;
  ASSERT_EQ(cadinterp_eval(o->ws, x, nullptr, 0, &full), CADINTERP_OK);
  const std::uint32_t nv = full.vertex_count, nt = full.tet_count;
  cadinterp_mesh m;
  std::memset(&m, 0x5a, sizeof m);
  const cadinterp_mesh before = m;
  const int fields[1] = {1};
  const std::uint32_t good[2] = {0, nv - 1}, bad_v[3] = {0, nv, 1}, bad_t[1] = {nt};
  // A bad id is the caller's argument (CADINTERP_E_OUT_OF_RANGE names a blob outside the file).
  EXPECT_EQ(cadinterp_eval_subset(o->ws, x, bad_v, 3, nullptr, 0, nullptr, 0, &m),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(cadinterp_workspace_error(o->ws)).find("vertices[1]"), std::string::npos)
      << cadinterp_workspace_error(o->ws);
  EXPECT_EQ(cadinterp_eval_subset(o->ws, x, good, 2, bad_t, 1, fields, 1, &m),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(cadinterp_workspace_error(o->ws)).find("tets[0]"), std::string::npos);
  EXPECT_EQ(cadinterp_eval_subset(o->ws, x, nullptr, 2, nullptr, 0, nullptr, 0, &m),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_subset(o->ws, x, good, 2, nullptr, 1, nullptr, 0, &m),
            CADINTERP_E_INVALID_ARGUMENT);
  const int bad_field[1] = {7};
  EXPECT_EQ(cadinterp_eval_subset(o->ws, x, good, 2, nullptr, 0, bad_field, 1, &m),
            CADINTERP_E_INVALID_ARGUMENT);
  const double corner[2] = {0.99, 0.99}, outside[2] = {-0.5, 0.5};
  EXPECT_EQ(cadinterp_eval_subset(o->ws, corner, good, 2, nullptr, 0, nullptr, 0, &m),
            CADINTERP_E_INFEASIBLE);
  EXPECT_EQ(cadinterp_eval_subset(o->ws, outside, good, 2, nullptr, 0, nullptr, 0, &m),
            CADINTERP_E_OUTSIDE_DOMAIN);
  EXPECT_EQ(cadinterp_eval_subset(o->ws, x, good, 2, nullptr, 0, nullptr, 0, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_subset(nullptr, x, good, 2, nullptr, 0, nullptr, 0, &m),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(std::memcmp(&m, &before, sizeof m), 0) << "a failed eval_subset wrote its output";
  ASSERT_EQ(cadinterp_eval_subset(o->ws, x, good, 2, nullptr, 0, nullptr, 0, &m), CADINTERP_OK);
  EXPECT_STREQ(cadinterp_workspace_error(o->ws), "");
}

// Central differences of eval, inside one element (the cubic asset is C2 anyway).
TEST(Runtime, GradMatchesFiniteDifferences) {
  const auto o = open_synthetic(spec(2, cadinterp::core::Degree::Cubic));
  std::mt19937_64 rng(8);
  const int fields[1] = {0};
  for (int i = 0; i < 20; ++i) {
    double x[2] = {std::uniform_real_distribution<double>(0.05, 0.95)(rng),
                   std::uniform_real_distribution<double>(0.05, 0.95)(rng)};
    cadinterp_mesh_grad g;
    ASSERT_EQ(cadinterp_grad(o->ws, x, fields, 1, &g), CADINTERP_OK);
    const std::vector<float> dpos(g.dpositions, g.dpositions + 2 * 3 * g.vertex_count);
    const std::vector<float> dfield(g.dfields[0], g.dfields[0] + 2 * g.vertex_count);
    const std::size_t nv = g.vertex_count;
    for (int d = 0; d < 2; ++d) {
      const double h = 1e-4;
      double xp[2] = {x[0], x[1]}, xm[2] = {x[0], x[1]};
      xp[d] += h;
      xm[d] -= h;
      cadinterp_mesh mp, mm;
      ASSERT_EQ(cadinterp_eval(o->ws, xp, fields, 1, &mp), CADINTERP_OK);
      const std::vector<float> pp(mp.positions, mp.positions + nv * 3),
          fp(mp.fields[0], mp.fields[0] + nv);
      ASSERT_EQ(cadinterp_eval(o->ws, xm, fields, 1, &mm), CADINTERP_OK);
      for (std::size_t v = 0; v < nv * 3; ++v)
        ASSERT_NEAR(dpos[static_cast<std::size_t>(d) * nv * 3 + v],
                    (pp[v] - mm.positions[v]) / (2 * h), 2e-3);
      for (std::size_t v = 0; v < nv; ++v)
        ASSERT_NEAR(dfield[static_cast<std::size_t>(d) * nv + v],
                    (fp[v] - mm.fields[0][v]) / (2 * h), 5e-2);
    }
  }
}

TEST(Runtime, VectorJacobianProductContractsTheGradient) {
  const auto o = open_synthetic(spec(3, cadinterp::core::Degree::Linear));
  std::mt19937_64 rng(2);
  const int fields[1] = {1};
  for (int i = 0; i < 10; ++i) {
    double x[3];
    for (double& v : x) v = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    cadinterp_mesh_grad g;
    ASSERT_EQ(cadinterp_grad(o->ws, x, fields, 1, &g), CADINTERP_OK);
    const std::size_t nv = g.vertex_count;
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(o->ws, x, fields, 1, &m), CADINTERP_OK);
    const std::size_t nt = m.tet_count;
    ASSERT_EQ(cadinterp_grad(o->ws, x, fields, 1, &g), CADINTERP_OK);
    std::vector<float> adj(nv * 3), fadj(nt);
    for (float& a : adj) a = std::uniform_real_distribution<float>(-1, 1)(rng);
    for (float& a : fadj) a = std::uniform_real_distribution<float>(-1, 1)(rng);
    double expect[3] = {0, 0, 0};
    for (int d = 0; d < 3; ++d) {
      for (std::size_t v = 0; v < nv * 3; ++v)
        expect[d] += double(adj[v]) * g.dpositions[static_cast<std::size_t>(d) * nv * 3 + v];
      for (std::size_t k = 0; k < nt; ++k)
        expect[d] += double(fadj[k]) * g.dfields[0][static_cast<std::size_t>(d) * nt + k];
    }
    const float* fadjs[1] = {fadj.data()};
    double got[3];
    ASSERT_EQ(cadinterp_vjp(o->ws, x, adj.data(), fields, fadjs, 1, got), CADINTERP_OK);
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(got[d], expect[d], 1e-3 * (1 + std::abs(expect[d])));
  }
}

TEST(Runtime, PropertiesAndTheirGradients) {
  const auto o = open_synthetic(spec(2, cadinterp::core::Degree::Cubic));
  const double dir[3] = {0.0, 0.0, 1.0};
  double x[2] = {0.3, 0.6};
  cadinterp_properties p, g[2];
  ASSERT_EQ(cadinterp_eval_properties(o->ws, x, 7.8, dir, &p, g), CADINTERP_OK);
  // Against the kernel on the evaluated mesh.
  cadinterp_mesh m;
  ASSERT_EQ(cadinterp_eval(o->ws, x, nullptr, 0, &m), CADINTERP_OK);
  cadinterp::runtime::MassPropertiesOptions opt;
  opt.density = 7.8;
  const auto mp = cadinterp::runtime::mass_properties(
      {m.positions, m.vertex_count, m.tets, m.tet_count, m.triangles, m.triangle_count}, opt);
  EXPECT_NEAR(p.volume, mp.volume, 1e-12);
  EXPECT_NEAR(p.mass, 7.8 * p.volume, 1e-12);
  EXPECT_NEAR(p.volume, 0.125 * (1 - 0.3 * 0.0), 0.01) << "a 1 x 0.5 x 0.25 box, slightly deformed";
  // Gradients against central differences.
  for (int d = 0; d < 2; ++d) {
    const double h = 1e-4;
    double xp[2] = {x[0], x[1]}, xm[2] = {x[0], x[1]};
    xp[d] += h;
    xm[d] -= h;
    cadinterp_properties pp, pm;
    ASSERT_EQ(cadinterp_eval_properties(o->ws, xp, 7.8, dir, &pp, nullptr), CADINTERP_OK);
    ASSERT_EQ(cadinterp_eval_properties(o->ws, xm, 7.8, dir, &pm, nullptr), CADINTERP_OK);
    EXPECT_NEAR(g[d].volume, (pp.volume - pm.volume) / (2 * h), 1e-4);
    EXPECT_NEAR(g[d].area, (pp.area - pm.area) / (2 * h), 1e-3);
    EXPECT_NEAR(g[d].frontal_area, (pp.frontal_area - pm.frontal_area) / (2 * h), 1e-3);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(g[d].centroid[c], (pp.centroid[c] - pm.centroid[c]) / (2 * h), 1e-3);
    for (int c = 0; c < 9; ++c)
      EXPECT_NEAR(g[d].inertia[c], (pp.inertia[c] - pm.inertia[c]) / (2 * h), 1e-3);
  }
}

// The caller's density and direction are checked before any work: a non-finite one is an invalid
// argument, not an overflow of the asset's values.
TEST(Runtime, PropertiesRefuseBadDensityAndDirection) {
  const auto o = open_synthetic(spec(2, cadinterp::core::Degree::Linear));
  const double x[2] = {0.3, 0.6}, dir[3] = {0, 0, 1};
  const double nan_dir[3] = {0, std::nan(""), 1}, inf_dir[3] = {HUGE_VAL, 0, 0};
  cadinterp_properties p, g[2];
  std::memset(&p, 0x5a, sizeof p);
  const cadinterp_properties before = p;
  EXPECT_EQ(cadinterp_eval_properties(o->ws, x, 1.0, nullptr, &p, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_properties(o->ws, x, std::nan(""), dir, &p, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_properties(o->ws, x, HUGE_VAL, dir, &p, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_properties(o->ws, x, 1.0, nan_dir, &p, g), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(cadinterp_workspace_error(o->ws)).find("direction"), std::string::npos)
      << cadinterp_workspace_error(o->ws);
  EXPECT_EQ(cadinterp_eval_properties(o->ws, x, 1.0, inf_dir, &p, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(std::memcmp(&p, &before, sizeof p), 0) << "a failed eval_properties wrote its output";
  ASSERT_EQ(cadinterp_eval_properties(o->ws, x, 1.0, dir, &p, g), CADINTERP_OK);
  EXPECT_STREQ(cadinterp_workspace_error(o->ws), "");
}

TEST(Runtime, FailuresAreNamedAndLeaveOutputsUntouched) {
  SyntheticSpec s = spec(2, cadinterp::core::Degree::Linear);
  s.infeasible_corner = true;
  const auto o = open_synthetic(s);
  cadinterp_mesh m;
  std::memset(&m, 0x5a, sizeof m);
  cadinterp_mesh before = m;
  const double outside[2] = {1.5, 0.5};
  EXPECT_EQ(cadinterp_eval(o->ws, outside, nullptr, 0, &m), CADINTERP_E_OUTSIDE_DOMAIN);
  EXPECT_GT(std::strlen(cadinterp_workspace_error(o->ws)), 0u);
  const double nan[2] = {std::nan(""), 0.5};
  EXPECT_EQ(cadinterp_eval(o->ws, nan, nullptr, 0, &m), CADINTERP_E_OUTSIDE_DOMAIN);
  const double corner[2] = {0.99, 0.99};
  EXPECT_EQ(cadinterp_eval(o->ws, corner, nullptr, 0, &m), CADINTERP_E_INFEASIBLE);
  int e = -1, feasible = -1;
  EXPECT_EQ(cadinterp_locate(o->asset, corner, &e, &feasible), CADINTERP_OK);
  EXPECT_EQ(feasible, 0);
  const int bad_field[1] = {7};
  const double ok_x[2] = {0.2, 0.2};
  EXPECT_EQ(cadinterp_eval(o->ws, ok_x, bad_field, 1, &m), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval(o->ws, nullptr, nullptr, 0, &m), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(std::memcmp(&m, &before, sizeof m), 0) << "a failed eval wrote its output";
  double err = -5;
  EXPECT_EQ(cadinterp_error_estimate(o->asset, corner, &err), CADINTERP_E_INFEASIBLE);
  EXPECT_EQ(err, -5);
  EXPECT_EQ(cadinterp_error_estimate(o->asset, ok_x, &err), CADINTERP_OK);
  EXPECT_NE(err, -5);
  EXPECT_EQ(cadinterp_eval(o->ws, ok_x, nullptr, 0, &m), CADINTERP_OK);
  EXPECT_STREQ(cadinterp_workspace_error(o->ws), "");
  EXPECT_EQ(cadinterp_eval(nullptr, ok_x, nullptr, 0, &m), CADINTERP_E_INVALID_ARGUMENT);
}

TEST(Runtime, OpenReportsNamedErrors) {
  const auto o = open_synthetic(spec(2, cadinterp::core::Degree::Linear));
  std::vector<std::uint8_t> b = o->bytes;
  b[8] = 9;  // another major
  cadinterp_asset* a = nullptr;
  EXPECT_EQ(cadinterp_open_memory(b.data(), b.size(), 1, &a), CADINTERP_E_UNSUPPORTED_VERSION);
  EXPECT_EQ(a, nullptr);
  EXPECT_NE(std::string(cadinterp_open_error()).find("format"), std::string::npos);
  b = o->bytes;
  b.resize(b.size() / 2);
  EXPECT_EQ(cadinterp_open_memory(b.data(), b.size(), 1, &a), CADINTERP_E_TRUNCATED);
}

// A guarded body's status and message for the exception it throws.
template <class E>
cadinterp_status guarded_throw(const E& e, std::string* error) {
  CADINTERP_CATCH_BEGIN
  throw e;
  CADINTERP_CATCH_END(error)
}

bool map_range_errors(cadinterp_status* status, std::string* error) {
  try {
    throw;
  } catch (const std::out_of_range& e) {
    *status = CADINTERP_E_INVALID_ARGUMENT;
    if (error) *error = e.what();
    return true;
  } catch (...) {
    return false;
  }
}

cadinterp_status guarded_mapped_throw(const std::exception& e, std::string* error) {
  CADINTERP_CATCH_BEGIN
  if (dynamic_cast<const std::out_of_range*>(&e)) throw std::out_of_range(e.what());
  throw std::runtime_error(e.what());
  CADINTERP_CATCH_END_MAP(error, map_range_errors)
}

TEST(CapiGuard, MapsEachExceptionToItsStatusAndMessage) {
  std::string error;
  EXPECT_EQ(guarded_throw(
                cadinterp::format::FormatError(cadinterp::format::Status::Truncated, "short file"),
                &error),
            CADINTERP_E_TRUNCATED);
  EXPECT_EQ(error, "short file");
  EXPECT_EQ(guarded_throw(std::bad_alloc(), &error), CADINTERP_E_OUT_OF_MEMORY);
  EXPECT_EQ(error, "out of memory");
  EXPECT_EQ(guarded_throw(std::logic_error("boom"), &error), CADINTERP_E_INTERNAL);
  EXPECT_EQ(error, "internal error: boom");
  EXPECT_EQ(guarded_throw(42, &error), CADINTERP_E_INTERNAL);
  EXPECT_EQ(error, "internal error: unknown exception");
  EXPECT_EQ(guarded_throw(std::bad_alloc(), nullptr), CADINTERP_E_OUT_OF_MEMORY);
  EXPECT_EQ(guarded_mapped_throw(std::out_of_range("index 9"), &error),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(error, "index 9");
  EXPECT_EQ(guarded_mapped_throw(std::runtime_error("other"), &error), CADINTERP_E_INTERNAL);
  EXPECT_EQ(error, "internal error: other");
}

// Opening a FIFO without a writer must not wait for one: open refuses anything but a regular file
// before reading it. Should open block, the test writes to the FIFO to release it, then fails.
TEST(Runtime, OpenRefusesFifosAndDirectoriesWithoutBlocking) {
  char dir[] = "/tmp/cadinterp_fifo_XXXXXX";
  ASSERT_NE(::mkdtemp(dir), nullptr);
  const std::string fifo = std::string(dir) + "/asset.cadi";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  cadinterp_asset* a = nullptr;
  auto opened = std::async(std::launch::async, [&] {
    const cadinterp_status s = cadinterp_open(fifo.c_str(), &a);
    return std::make_pair(s, std::string(cadinterp_open_error()));
  });
  if (opened.wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
    const int w = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (w >= 0) ::close(w);
    ADD_FAILURE() << "cadinterp_open blocked on a FIFO without a writer";
  }
  const auto [status, message] = opened.get();
  EXPECT_EQ(status, CADINTERP_E_IO);
  EXPECT_NE(message.find("not a readable regular file"), std::string::npos) << message;
  EXPECT_EQ(a, nullptr);
  EXPECT_EQ(cadinterp_open(dir, &a), CADINTERP_E_IO);
  EXPECT_NE(std::string(cadinterp_open_error()).find("not a readable regular file"),
            std::string::npos);
  EXPECT_EQ(a, nullptr);
  ::unlink(fifo.c_str());
  ::rmdir(dir);
}

// The argument and message rules cadinterp.h states, where no other test exercises them.
TEST(Runtime, DocumentedArgumentAndMessageRules) {
  const auto o = open_synthetic(spec(2, cadinterp::core::Degree::Linear));
  EXPECT_STREQ(cadinterp_open_error(), "") << "a successful open clears the open message";
  EXPECT_STREQ(cadinterp_workspace_error(o->ws), "") << "a new workspace has no message";
  EXPECT_STREQ(cadinterp_workspace_error(nullptr), "");
  int major = -1, minor = -1;
  EXPECT_EQ(cadinterp_asset_format(o->asset, nullptr, &minor), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_asset_format(o->asset, &major, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(major, -1);
  EXPECT_EQ(minor, -1);
  const double x[2] = {0.3, 0.4};
  int feasible = -1;
  EXPECT_EQ(cadinterp_locate(o->asset, x, nullptr, &feasible), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(feasible, -1);
  cadinterp_region_info r;
  EXPECT_EQ(cadinterp_region(o->asset, cadinterp_region_count(o->asset), &r),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_asset_provenance(o->asset, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_set_cache_budget(nullptr, 0), CADINTERP_E_INVALID_ARGUMENT);
  // The message is the most recent call's: a failure's text, then "" after a success.
  cadinterp_mesh m;
  const double outside[2] = {2, 0};
  EXPECT_EQ(cadinterp_eval(o->ws, outside, nullptr, 0, &m), CADINTERP_E_OUTSIDE_DOMAIN);
  EXPECT_STRNE(cadinterp_workspace_error(o->ws), "");
  double dfdx[2];
  EXPECT_EQ(cadinterp_vjp(o->ws, x, nullptr, nullptr, nullptr, 0, dfdx), CADINTERP_OK);
  EXPECT_STREQ(cadinterp_workspace_error(o->ws), "");
}

// A budget of 0 keeps the most recently used element only: every element switch decodes again,
// with the same results.
TEST(Runtime, ZeroCacheBudgetKeepsTheCurrentElement) {
  const auto o = open_synthetic(spec(2, cadinterp::core::Degree::Linear));
  const double xs[3][2] = {{0.1, 0.1}, {0.9, 0.8}, {0.1, 0.1}};
  std::vector<std::vector<float>> first;
  std::vector<int> elements;
  for (const auto& x : xs) {
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(o->ws, x, nullptr, 0, &m), CADINTERP_OK);
    first.emplace_back(m.positions, m.positions + m.vertex_count * 3);
    elements.push_back(m.element);
  }
  ASSERT_NE(elements[0], elements[1]);
  ASSERT_EQ(cadinterp_set_cache_budget(o->asset, 0), CADINTERP_OK);
  for (int i = 0; i < 3; ++i) {
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(o->ws, xs[i], nullptr, 0, &m), CADINTERP_OK);
    EXPECT_EQ(std::vector<float>(m.positions, m.positions + m.vertex_count * 3),
              first[static_cast<std::size_t>(i)]);
  }
}

TEST(Runtime, TinyCacheBudgetStillEvaluatesCorrectly) {
  const auto o = open_synthetic(spec(2, cadinterp::core::Degree::Linear));
  std::mt19937_64 rng(4);
  std::vector<std::vector<float>> first;
  std::vector<std::array<double, 2>> xs(50);
  for (auto& x : xs)
    x = {std::uniform_real_distribution<double>(0, 1)(rng),
         std::uniform_real_distribution<double>(0, 1)(rng)};
  for (const auto& x : xs) {
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(o->ws, x.data(), nullptr, 0, &m), CADINTERP_OK);
    first.emplace_back(m.positions, m.positions + m.vertex_count * 3);
  }
  ASSERT_EQ(cadinterp_set_cache_budget(o->asset, 1), CADINTERP_OK);
  for (std::size_t i = 0; i < xs.size(); ++i) {
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(o->ws, xs[i].data(), nullptr, 0, &m), CADINTERP_OK);
    EXPECT_EQ(std::vector<float>(m.positions, m.positions + m.vertex_count * 3), first[i]);
  }
}

// Byte offset of blob `r` in the file `b`.
std::size_t blob_at(const std::vector<std::uint8_t>& b, const cadinterp::fb::BlobRef* r) {
  std::uint64_t index_size = 0;
  for (int i = 7; i >= 0; --i) index_size = (index_size << 8) | b[static_cast<std::size_t>(32 + i)];
  return static_cast<std::size_t>(48 + index_size + r->offset());
}

std::unique_ptr<Opened> open_bytes(std::vector<std::uint8_t> bytes) {
  auto o = std::make_unique<Opened>();
  o->bytes = std::move(bytes);
  EXPECT_EQ(cadinterp_open_memory(o->bytes.data(), o->bytes.size(), 0, &o->asset), CADINTERP_OK)
      << cadinterp_open_error();
  EXPECT_EQ(cadinterp_workspace_create(o->asset, &o->ws), CADINTERP_OK);
  return o;
}

// Elements with the same topology share it: meshes evaluated in different elements point to the
// same topology arrays.
TEST(Runtime, ElementsShareOneDecodedTopology) {
  const auto o = open_synthetic(spec(2, cadinterp::core::Degree::Linear));
  ASSERT_GE(cadinterp_element_count(o->asset), 2);
  cadinterp_workspace* ws2 = nullptr;
  ASSERT_EQ(cadinterp_workspace_create(o->asset, &ws2), CADINTERP_OK);
  const double a[2] = {0.1, 0.1}, b[2] = {0.9, 0.9};
  cadinterp_mesh ma, mb;
  ASSERT_EQ(cadinterp_eval(o->ws, a, nullptr, 0, &ma), CADINTERP_OK);
  ASSERT_EQ(cadinterp_eval(ws2, b, nullptr, 0, &mb), CADINTERP_OK);
  ASSERT_NE(ma.element, mb.element);
  EXPECT_EQ(ma.tets, mb.tets);
  EXPECT_EQ(ma.triangles, mb.triangles);
  EXPECT_EQ(ma.triangle_tags, mb.triangle_tags);
  cadinterp_workspace_destroy(ws2);
}

// A flipped byte in the topology blob all elements share: every element reports it, on every call.
TEST(Runtime, CorruptSharedTopologyIsReportedByEveryElement) {
  const auto good = open_synthetic(spec(2, cadinterp::core::Degree::Linear));
  std::vector<std::uint8_t> b = good->bytes;
  const auto reader = cadinterp::format::AssetReader::open_memory(b.data(), b.size(), true);
  const auto* tets = reader->index().elements()->Get(0)->tets();
  b[blob_at(b, tets) + tets->size() / 2] ^= 0x08;
  const auto o = open_bytes(std::move(b));
  std::mt19937_64 rng(11);
  std::set<int> elements;
  for (int i = 0; i < 200; ++i) {
    const double x[2] = {std::uniform_real_distribution<double>(0, 1)(rng),
                         std::uniform_real_distribution<double>(0, 1)(rng)};
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(o->ws, x, nullptr, 0, &m), CADINTERP_E_CHECKSUM);
    int e = -1;
    ASSERT_EQ(cadinterp_locate(o->asset, x, &e, nullptr), CADINTERP_OK);
    elements.insert(e);
  }
  EXPECT_EQ(static_cast<int>(elements.size()), cadinterp_element_count(o->asset));
}

// Fields are decoded on the first call that asks for one: a corrupt field blob fails exactly the
// calls that need fields (with the named status, outputs untouched, every time), never the
// shape-only ones.
TEST(Runtime, LazyFieldsFailOnlyTheCallsThatNeedThem) {
  const auto good = open_synthetic(spec(2, cadinterp::core::Degree::Linear));
  const double x[2] = {0.3, 0.6};
  int e = -1;
  ASSERT_EQ(cadinterp_locate(good->asset, x, &e, nullptr), CADINTERP_OK);
  cadinterp_mesh ref;
  ASSERT_EQ(cadinterp_eval(good->ws, x, nullptr, 0, &ref), CADINTERP_OK);
  const std::vector<float> ref_pos(ref.positions, ref.positions + 3 * ref.vertex_count);

  // Two ways to break the field arrays of element e: a flipped byte (checksum) and a NaN stored
  // losslessly (caught by the decoder's finiteness check).
  std::vector<std::uint8_t> flipped = good->bytes;
  {
    const auto reader =
        cadinterp::format::AssetReader::open_memory(flipped.data(), flipped.size(), true);
    const auto* f =
        reader->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e))->fields();
    flipped[blob_at(flipped, f->Get(f->size() - 1)) + 20] ^= 0x01;
  }
  cadinterp::format::AssetContent nan_content = good->synthetic.content;
  nan_content.elements[static_cast<std::size_t>(e)].fields.back()[5] = std::nanf("");
  const std::pair<std::vector<std::uint8_t>, cadinterp_status> cases[] = {
      {flipped, CADINTERP_E_CHECKSUM},
      {cadinterp::format::write_asset(nan_content, {}), CADINTERP_E_CORRUPT_BLOB}};
  for (const auto& [bytes, status] : cases) {
    SCOPED_TRACE(cadinterp_status_string(status));
    const auto o = open_bytes(bytes);
    const int field[1] = {0};
    for (int round = 0; round < 2; ++round) {  // the failure is not remembered as success
      cadinterp_mesh m;
      std::memset(&m, 0x5a, sizeof m);
      const cadinterp_mesh before = m;
      EXPECT_EQ(cadinterp_eval(o->ws, x, field, 1, &m), status);
      EXPECT_EQ(std::memcmp(&m, &before, sizeof m), 0) << "a failed eval wrote its output";
      EXPECT_GT(std::strlen(cadinterp_workspace_error(o->ws)), 0u);
      cadinterp_mesh_grad g;
      std::memset(&g, 0x5a, sizeof g);
      const cadinterp_mesh_grad gbefore = g;
      EXPECT_EQ(cadinterp_grad(o->ws, x, field, 1, &g), status);
      EXPECT_EQ(std::memcmp(&g, &gbefore, sizeof g), 0);
      std::vector<float> adj(3 * ref.vertex_count, 1.0f), fadj(ref.vertex_count, 1.0f);
      const float* fadjs[1] = {fadj.data()};
      double dx[2] = {7, 7};
      EXPECT_EQ(cadinterp_vjp(o->ws, x, adj.data(), field, fadjs, 1, dx), status);
      EXPECT_EQ(dx[0], 7);
      EXPECT_EQ(dx[1], 7);
      // Shape-only calls never decode the fields.
      EXPECT_EQ(cadinterp_vjp(o->ws, x, adj.data(), nullptr, nullptr, 0, dx), CADINTERP_OK);
      ASSERT_EQ(cadinterp_eval(o->ws, x, nullptr, 0, &m), CADINTERP_OK);
      EXPECT_EQ(std::vector<float>(m.positions, m.positions + 3 * m.vertex_count), ref_pos);
      const double dir[3] = {0, 0, 1};
      cadinterp_properties p;
      EXPECT_EQ(cadinterp_eval_properties(o->ws, x, 1.0, dir, &p, nullptr), CADINTERP_OK);
    }
  }
  // And the intact asset evaluates the fields after shape-only calls.
  const int both[2] = {0, 1};
  cadinterp_mesh m;
  EXPECT_EQ(cadinterp_eval(good->ws, x, both, 2, &m), CADINTERP_OK);
  EXPECT_TRUE(std::isfinite(m.fields[0][0]) && std::isfinite(m.fields[1][0]));
}

}  // namespace

#include "cadinterp/cadinterp.hpp"

namespace {

TEST(RuntimeCpp, WrapperOwnsHandlesAndThrowsNamedErrors) {
  cadinterp::format::SyntheticSpec s;
  s.K = 2;
  s.max_samples = 40;
  const auto synthetic = cadinterp::format::make_synthetic_asset(s);
  const auto bytes = cadinterp::format::write_asset(synthetic.content, {});
  const cadinterp::Asset asset = cadinterp::Asset::open_memory(bytes.data(), bytes.size(), true);
  cadinterp::Workspace ws(asset);
  const double x[2] = {0.4, 0.7};
  const cadinterp_mesh m = ws.eval(x, {asset.find_field("stress")});
  EXPECT_GT(m.vertex_count, 0u);
  const double outside[2] = {-1, 0};
  try {
    ws.eval(outside);
    FAIL() << "no exception";
  } catch (const cadinterp::Error& e) {
    EXPECT_EQ(e.status(), CADINTERP_E_OUTSIDE_DOMAIN);
  }
  EXPECT_THROW(cadinterp::Asset::open("/nonexistent.cadi"), cadinterp::Error);
  EXPECT_THROW(asset.find_field("nope"), cadinterp::Error);
}

}  // namespace
