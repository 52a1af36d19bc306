// cadinterp_eval_integral: values against independent sums over the evaluated mesh and
// cadinterp_eval_properties, derivatives against central differences, on the synthetic asset
// (per-vertex "temperature", per-tet "stress", regions "clamp" and "tip load"), linear and cubic.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "format/asset_writer.h"
#include "format/synthetic_asset.h"
#include "opened_asset_test_util.h"

namespace {

using cadinterp::format::SyntheticSpec;

using cadinterp::runtime_test::Opened;

std::unique_ptr<Opened> open_synthetic(int K, cadinterp::core::Degree degree) {
  SyntheticSpec s;
  s.K = K;
  s.degree = degree;
  s.tolerance = 2e-3;
  s.max_samples = 120;
  return cadinterp::runtime_test::open_synthetic(s);
}

// The integral by an independent route: the evaluated mesh and its field, summed here.
double reference_integral(cadinterp_workspace* ws, const double* x, int field, int region,
                          const cadinterp_asset* asset) {
  cadinterp_mesh m;
  EXPECT_EQ(cadinterp_eval(ws, x, &field, field >= 0 ? 1 : 0, &m), CADINTERP_OK);
  auto P = [&](std::uint32_t v, int c) { return double(m.positions[3 * v + c]); };
  double sum = 0.0;
  if (region < 0) {
    for (std::uint32_t t = 0; t < m.tet_count; ++t) {
      const std::uint32_t* v = m.tets + 4 * t;
      double e[3][3];
      for (int i = 0; i < 3; ++i)
        for (int c = 0; c < 3; ++c) e[i][c] = P(v[i + 1], c) - P(v[0], c);
      const double det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                         e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                         e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
      double f = 1.0;
      if (field == 0)
        f = 0.25 * (m.fields[0][v[0]] + m.fields[0][v[1]] + m.fields[0][v[2]] + m.fields[0][v[3]]);
      if (field == 1) f = m.fields[0][t];
      sum += det / 6.0 * f;
    }
    return sum;
  }
  cadinterp_region_info r;
  EXPECT_EQ(cadinterp_region(asset, region, &r), CADINTERP_OK);
  for (std::uint32_t i = 0; i < m.triangle_count; ++i) {
    bool in = false;
    for (int k = 0; k < r.face_tag_count; ++k) in = in || m.triangle_tags[i] == r.face_tags[k];
    if (!in) continue;
    const std::uint32_t* v = m.triangles + 3 * i;
    double a[3], b[3];
    for (int c = 0; c < 3; ++c) a[c] = P(v[1], c) - P(v[0], c), b[c] = P(v[2], c) - P(v[0], c);
    const double n[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]};
    const double f =
        field == 0 ? (m.fields[0][v[0]] + m.fields[0][v[1]] + m.fields[0][v[2]]) / 3.0 : 1.0;
    sum += 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) * f;
  }
  return sum;
}

void check_gradients(cadinterp::core::Degree degree, double h, double tol) {
  const auto o = open_synthetic(2, degree);
  // h large enough that the float rounding of the blended mesh (~1e-7) stays below tol.
  // 1/3 and 2/3 lie at least 2^-L / 3 from every point k / 2^L of level L (binary 0.0101...).
  const double x[2] = {1.0 / 3.0, 2.0 / 3.0};
  // (field, region): volume, temperature and stress over the solid; area, temperature and
  // stress over the tip region.
  const int cases[6][2] = {{-1, -1}, {0, -1}, {1, -1}, {-1, 1}, {0, 1}, {1, 1}};
  for (const auto& c : cases) {
    SCOPED_TRACE("field " + std::to_string(c[0]) + " region " + std::to_string(c[1]));
    double value = 0, grad[2] = {};
    ASSERT_EQ(cadinterp_eval_integral(o->ws, x, c[0], 0, c[1], &value, grad), CADINTERP_OK)
        << cadinterp_workspace_error(o->ws);
    EXPECT_GT(std::fabs(value), 0.0);
    if (c[0] != 1 || c[1] < 0) {  // the reference sums per-tet fields over the volume only
      EXPECT_NEAR(value, reference_integral(o->ws, x, c[0], c[1], o->asset),
                  1e-6 * std::fabs(value));  // float blends differ in rounding
    }
    for (int d = 0; d < 2; ++d) {
      double xp[2] = {x[0], x[1]}, xm[2] = {x[0], x[1]}, vp = 0, vm = 0;
      xp[d] += h;
      xm[d] -= h;
      ASSERT_EQ(cadinterp_eval_integral(o->ws, xp, c[0], 0, c[1], &vp, nullptr), CADINTERP_OK);
      ASSERT_EQ(cadinterp_eval_integral(o->ws, xm, c[0], 0, c[1], &vm, nullptr), CADINTERP_OK);
      const double fd = (vp - vm) / (2 * h);
      EXPECT_NEAR(grad[d], fd, tol * (std::fabs(fd) + std::fabs(value))) << "d = " << d;
    }
  }
}

TEST(Integral, CubicGradientsMatchCentralDifferences) {
  check_gradients(cadinterp::core::Degree::Cubic, 1e-3, 2e-4);
}

// Linear assets are C0: h small enough that the differences stay on one side of every kink
// (x is far from the dyadic points of the tree's levels, the kinks up to depth 8 at least
// 2^-8 / 3 away); the blend is polynomial between them.
TEST(Integral, LinearGradientsMatchCentralDifferences) {
  check_gradients(cadinterp::core::Degree::Linear, 2e-4, 2e-4);
}

TEST(Integral, VolumeAndAreaAgreeWithProperties) {
  const auto o = open_synthetic(3, cadinterp::core::Degree::Cubic);
  const double x[3] = {0.2, 0.5, 0.8}, dir[3] = {0, 0, 1};
  cadinterp_properties p, g[3];
  ASSERT_EQ(cadinterp_eval_properties(o->ws, x, 1.0, dir, &p, g), CADINTERP_OK);
  double v = 0, dv[3];
  ASSERT_EQ(cadinterp_eval_integral(o->ws, x, -1, 0, -1, &v, dv), CADINTERP_OK);
  EXPECT_NEAR(v, p.volume, 1e-12);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(dv[d], g[d].volume, 1e-9);
  double area = 0;
  for (int r = 0; r < cadinterp_region_count(o->asset); ++r) {
    double a = 0;
    ASSERT_EQ(cadinterp_eval_integral(o->ws, x, -1, 0, r, &a, nullptr), CADINTERP_OK);
    EXPECT_GT(a, 0.0);
    area += a;
  }
  EXPECT_LT(area, p.area);  // two of the box's six faces
}

TEST(Integral, RefusesBadArguments) {
  const auto o = open_synthetic(2, cadinterp::core::Degree::Linear);
  const double x[2] = {0.5, 0.5}, out_of_box[2] = {1.5, 0.5};
  double v = 7.0;
  EXPECT_EQ(cadinterp_eval_integral(nullptr, x, -1, 0, -1, &v, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_integral(o->ws, x, -1, 0, -1, nullptr, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_integral(o->ws, x, 2, 0, -1, &v, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_integral(o->ws, x, 0, 1, -1, &v, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(cadinterp_workspace_error(o->ws)).find("component 1"), std::string::npos);
  EXPECT_EQ(cadinterp_eval_integral(o->ws, x, 0, 0, 2, &v, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_eval_integral(o->ws, out_of_box, 0, 0, -1, &v, nullptr),
            CADINTERP_E_OUTSIDE_DOMAIN);
  EXPECT_EQ(v, 7.0) << "outputs untouched on failure";
}

}  // namespace
