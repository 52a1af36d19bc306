// Per-sample scalar outputs (format 1.3) through the C ABI: names and lookup, values and
// gradients against the mesh blend with the same weights and against central differences, the
// status of every refusal, the writer's refusals, and the file's minor (3 with outputs,
// unchanged without).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "format/asset_writer.h"
#include "format/synthetic_asset.h"
#include "opened_asset_test_util.h"

namespace {

using cadinterp::core::Degree;
using cadinterp::format::SyntheticSpec;
using cadinterp::runtime_test::open_content;
using cadinterp::runtime_test::open_synthetic;
using cadinterp::runtime_test::Opened;

SyntheticSpec spec(int K, Degree degree, bool outputs, bool infeasible = false) {
  SyntheticSpec s;
  s.K = K;
  s.degree = degree;
  s.cells[0] = 2;
  s.cells[1] = 1;
  s.cells[2] = 1;
  s.tolerance = 1e-3;
  s.max_samples = 200;
  s.outputs = outputs;
  s.infeasible_corner = infeasible;
  return s;
}

TEST(Outputs, NamesLookupAndMinor) {
  const auto o = open_synthetic(spec(2, Degree::Cubic, true));
  EXPECT_EQ(o->bytes[10], 3);  // header minor: outputs are format 1.3
  ASSERT_EQ(cadinterp_output_count(o->asset), 1);
  const char *name = nullptr, *unit = nullptr;
  ASSERT_EQ(cadinterp_output(o->asset, 0, &name, &unit), CADINTERP_OK);
  EXPECT_STREQ(name, "energy");
  EXPECT_STREQ(unit, "J");
  EXPECT_EQ(cadinterp_output(o->asset, 0, &name, nullptr), CADINTERP_OK);
  EXPECT_EQ(cadinterp_output(o->asset, 1, &name, &unit), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_output(o->asset, 0, nullptr, &unit), CADINTERP_E_INVALID_ARGUMENT);
  int i = -1;
  EXPECT_EQ(cadinterp_find_output(o->asset, "energy", &i), CADINTERP_OK);
  EXPECT_EQ(i, 0);
  EXPECT_EQ(cadinterp_find_output(o->asset, "Energy", &i), CADINTERP_E_NOT_FOUND);
  EXPECT_EQ(cadinterp_find_output(o->asset, nullptr, &i), CADINTERP_E_INVALID_ARGUMENT);

  // Without outputs the file keeps its older minor and the asset has none.
  const auto plain = open_synthetic(spec(2, Degree::Cubic, false));
  EXPECT_EQ(plain->bytes[10], 0);
  EXPECT_EQ(cadinterp_output_count(plain->asset), 0);
  EXPECT_EQ(cadinterp_output_count(nullptr), 0);
}

// The outputs use the mesh's weights: with o_k = the z coordinate of vertex v in the host's mesh
// at sample k, the interpolated output equals the interpolated position (cadinterp_eval) and its
// gradient the position's derivative (cadinterp_grad), to float precision, at any x; and the
// gradient equals central differences of the output itself (cubic: C2). Linear and cubic.
TEST(Outputs, SameWeightsAsTheMeshAndExactGradients) {
  for (Degree g : {Degree::Linear, Degree::Cubic})
    for (int K : {1, 3}) {
      SyntheticSpec s = spec(K, g, true);
      auto a = cadinterp::format::make_synthetic_asset(s);
      const std::size_t v = 5;  // a vertex away from the clamped end: it moves with x
      std::vector<float> pos, fld;
      for (int k = 0; k < a.samples; ++k) {
        double xk[4];
        a.basis->sample_position(k, xk);
        ASSERT_TRUE(cadinterp::format::synthetic_host(s, xk, pos, fld));
        a.content.outputs[0].values[static_cast<std::size_t>(k)] = pos[3 * v + 2];
      }
      const auto opened = open_content(a.content);
      ASSERT_NE(opened->ws, nullptr);
      const Opened& o = *opened;
      std::mt19937_64 rng(5);
      std::uniform_real_distribution<double> u(0.05, 0.95);
      for (int p = 0; p < 30; ++p) {
        std::vector<double> x(static_cast<std::size_t>(K));
        for (double& c : x) c = u(rng);
        const int which = 0;
        double val = 0, grad[4] = {};
        ASSERT_EQ(cadinterp_eval_outputs(o.ws, x.data(), &which, 1, &val, grad), CADINTERP_OK)
            << cadinterp_workspace_error(o.ws);
        cadinterp_mesh_grad mg;
        ASSERT_EQ(cadinterp_grad(o.ws, x.data(), nullptr, 0, &mg), CADINTERP_OK);
        EXPECT_NEAR(val, mg.positions[3 * v + 2], 1e-6 * (1 + std::abs(val)));
        const std::size_t nv3 = 3 * static_cast<std::size_t>(mg.vertex_count);
        for (int d = 0; d < K; ++d)
          EXPECT_NEAR(grad[d], mg.dpositions[static_cast<std::size_t>(d) * nv3 + 3 * v + 2],
                      1e-5 * (1 + std::abs(grad[d])));
        double only = 0;
        ASSERT_EQ(cadinterp_eval_outputs(o.ws, x.data(), &which, 1, &only, nullptr), CADINTERP_OK);
        EXPECT_EQ(only, val);
        if (g == Degree::Linear) continue;  // C0: a central difference may straddle a kink
        for (int d = 0; d < K; ++d) {
          const double h = 1e-6;
          std::vector<double> hi = x, lo = x;
          hi[static_cast<std::size_t>(d)] += h;
          lo[static_cast<std::size_t>(d)] -= h;
          double vh = 0, vl = 0;
          ASSERT_EQ(cadinterp_eval_outputs(o.ws, hi.data(), &which, 1, &vh, nullptr), CADINTERP_OK);
          ASSERT_EQ(cadinterp_eval_outputs(o.ws, lo.data(), &which, 1, &vl, nullptr), CADINTERP_OK);
          EXPECT_NEAR(grad[d], (vh - vl) / (2 * h), 1e-6 * (1 + std::abs(grad[d])))
              << "K=" << K << " d=" << d;
        }
      }
    }
}

TEST(Outputs, RefusalsLeaveOutputsUntouched) {
  const auto o = open_synthetic(spec(2, Degree::Linear, true, true));
  const double inside[2] = {0.3, 0.3}, outside[2] = {1.5, 0.3}, corner[2] = {0.99, 0.99};
  const int which = 0, bad = 1;
  double v = 42, g[2] = {42, 42};
  EXPECT_EQ(cadinterp_eval_outputs(o->ws, outside, &which, 1, &v, g), CADINTERP_E_OUTSIDE_DOMAIN);
  EXPECT_EQ(cadinterp_eval_outputs(o->ws, corner, &which, 1, &v, g), CADINTERP_E_INFEASIBLE);
  EXPECT_NE(std::strstr(cadinterp_workspace_error(o->ws), "infeasible"), nullptr);
  EXPECT_EQ(cadinterp_eval_outputs(o->ws, inside, &bad, 1, &v, g), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_NE(std::strstr(cadinterp_workspace_error(o->ws), "out of range"), nullptr);
  EXPECT_EQ(cadinterp_eval_outputs(o->ws, inside, nullptr, 1, &v, g), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_outputs(o->ws, inside, &which, -1, &v, g), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_outputs(o->ws, inside, &which, 1, nullptr, g),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_outputs(o->ws, nullptr, &which, 1, &v, g), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_outputs(nullptr, inside, &which, 1, &v, g),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(v, 42);
  EXPECT_EQ(g[0], 42);
  EXPECT_EQ(cadinterp_eval_outputs(o->ws, inside, nullptr, 0, &v, nullptr), CADINTERP_OK);
  EXPECT_EQ(cadinterp_eval_outputs(o->ws, inside, &which, 1, &v, g), CADINTERP_OK);
  EXPECT_STREQ(cadinterp_workspace_error(o->ws), "");
}

// The writer refuses what the reader would: a duplicate name, a count other than one value per
// sample, a non-finite value at a sample a feasible element uses.
TEST(Outputs, WriterRefusesInconsistentOutputs) {
  auto a = cadinterp::format::make_synthetic_asset(spec(2, Degree::Linear, true));
  auto dup = a.content;
  dup.outputs.push_back(dup.outputs[0]);
  EXPECT_THROW(cadinterp::format::write_asset(dup, {}), cadinterp::format::FormatError);
  auto shortened = a.content;
  shortened.outputs[0].values.pop_back();
  EXPECT_THROW(cadinterp::format::write_asset(shortened, {}), cadinterp::format::FormatError);
  auto nan = a.content;
  nan.outputs[0].values[0] = std::nan("");
  EXPECT_THROW(cadinterp::format::write_asset(nan, {}), cadinterp::format::FormatError);
}

}  // namespace
