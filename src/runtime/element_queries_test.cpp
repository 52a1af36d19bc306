// Per-element queries of the C ABI, read from the index without decoding anything: an
// element's mesh sizes (cadinterp_element_mesh_size) and its term count
// (cadinterp_element_term_count), each against what an evaluation in the element does.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp_generated.h"
#include "core/compiled_basis.h"
#include "format/asset_reader.h"
#include "runtime/opened_asset_test_util.h"
#include "runtime/runtime_objects.h"

namespace {

using cadinterp::format::SyntheticSpec;
using cadinterp::runtime_test::open_synthetic;
SyntheticSpec spec(int K, cadinterp::core::Degree g) {
  return cadinterp::runtime_test::small_synthetic_spec(K, g);
}

// Per-tet gradient arrays can be sized before any eval: locate, then the element's mesh size.
TEST(Runtime, ElementMeshSizeSizesGradArraysBeforeEval) {
  SyntheticSpec s = spec(2, cadinterp::core::Degree::Linear);
  s.infeasible_corner = true;
  const auto o = open_synthetic(s);
  int stress = -1;
  ASSERT_EQ(cadinterp_find_field(o->asset, "stress", &stress), CADINTERP_OK);
  cadinterp_field_info info;
  ASSERT_EQ(cadinterp_field(o->asset, stress, &info), CADINTERP_OK);
  ASSERT_EQ(info.location, CADINTERP_PER_TET);
  const double xs[3][2] = {{0.2, 0.3}, {0.7, 0.1}, {0.45, 0.55}};
  for (const auto& x : xs) {
    int e = -1;
    ASSERT_EQ(cadinterp_locate(o->asset, x, &e, nullptr), CADINTERP_OK);
    std::uint32_t nv = 0, nt = 0, nf = 0;
    ASSERT_EQ(cadinterp_element_mesh_size(o->asset, e, &nv, &nt, &nf), CADINTERP_OK);
    ASSERT_GT(nt, 0u);
    // Sized before the call: K blocks of #T rows of the field's components.
    std::vector<float> dstress(2 * std::size_t(nt) * std::size_t(info.components));
    cadinterp_mesh_grad g;
    ASSERT_EQ(cadinterp_grad(o->ws, x, &stress, 1, &g), CADINTERP_OK);
    EXPECT_EQ(g.vertex_count, nv);
    std::copy(g.dfields[0], g.dfields[0] + dstress.size(), dstress.begin());
    cadinterp_mesh m;
    ASSERT_EQ(cadinterp_eval(o->ws, x, nullptr, 0, &m), CADINTERP_OK);
    EXPECT_EQ(m.vertex_count, nv);
    EXPECT_EQ(m.tet_count, nt);
    EXPECT_EQ(m.triangle_count, nf);
  }
  const double corner[2] = {0.99, 0.99};
  int infeasible = -1;
  ASSERT_EQ(cadinterp_locate(o->asset, corner, &infeasible, nullptr), CADINTERP_OK);
  std::uint32_t nv = 7, nt = 7, nf = 7;
  EXPECT_EQ(cadinterp_element_mesh_size(o->asset, infeasible, &nv, &nt, &nf), CADINTERP_OK);
  EXPECT_EQ(nv + nt + nf, 0u);
  EXPECT_EQ(cadinterp_element_mesh_size(o->asset, 0, nullptr, nullptr, nullptr), CADINTERP_OK);
  nv = 7;
  const int n = cadinterp_element_count(o->asset);
  EXPECT_EQ(cadinterp_element_mesh_size(o->asset, n, &nv, nullptr, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_element_mesh_size(o->asset, -1, &nv, nullptr, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_element_mesh_size(nullptr, 0, &nv, nullptr, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(nv, 7u);
}

// An element's term count is the number of meshes an evaluation in it blends: the position
// blobs its index record stores, one per basis function of the element, and those basis
// functions are complete (a partition of unity at any point of the element).
TEST(Runtime, ElementTermCountIsTheMeshesAnEvaluationBlends) {
  for (const auto degree : {cadinterp::core::Degree::Linear, cadinterp::core::Degree::Cubic}) {
    SyntheticSpec s = spec(2, degree);
    s.infeasible_corner = true;
    const auto o = open_synthetic(s);
    const cadinterp::core::CompiledBasis& basis = o->asset->reader->basis();
    cadinterp::core::EvalWorkspace ws = basis.make_workspace();
    int feasible_seen = 0;
    for (int e = 0; e < cadinterp_element_count(o->asset); ++e) {
      int terms = -1;
      ASSERT_EQ(cadinterp_element_term_count(o->asset, e, &terms), CADINTERP_OK);
      EXPECT_GE(terms, 4);  // at least the 2^K corners' functions
      // A point inside the element, off its centre.
      std::vector<double> lo(2), hi(2), x(2);
      basis.element_box(e, lo.data(), hi.data());
      for (std::size_t d = 0; d < 2; ++d) x[d] = lo[d] + (d ? 0.5 : 0.3) * (hi[d] - lo[d]);
      cadinterp::core::BasisWeights w;
      basis.eval_element(e, x.data(), ws, false, &w);
      EXPECT_EQ(w.count, terms);
      double sum = 0;
      for (int t = 0; t < w.count; ++t) sum += w.psi[t];
      EXPECT_NEAR(sum, 1.0, 1e-12) << "element " << e;
      const auto* rec = o->asset->reader->index().elements()->Get(static_cast<unsigned>(e));
      if (rec->vertex_count() == 0) continue;  // infeasible: no meshes
      ++feasible_seen;
      ASSERT_NE(rec->positions(), nullptr);
      EXPECT_EQ(static_cast<int>(rec->positions()->size()), terms);
    }
    EXPECT_GT(feasible_seen, 1);
    int terms = 7;
    EXPECT_EQ(cadinterp_element_term_count(o->asset, -1, &terms), CADINTERP_E_INVALID_ARGUMENT);
    EXPECT_EQ(cadinterp_element_term_count(o->asset, cadinterp_element_count(o->asset), &terms),
              CADINTERP_E_INVALID_ARGUMENT);
    EXPECT_EQ(cadinterp_element_term_count(nullptr, 0, &terms), CADINTERP_E_INVALID_ARGUMENT);
    EXPECT_EQ(cadinterp_element_term_count(o->asset, 0, nullptr), CADINTERP_E_INVALID_ARGUMENT);
    EXPECT_EQ(terms, 7);
  }
}

}  // namespace
