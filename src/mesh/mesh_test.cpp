// Samples on their own: lossless serialization, validation's named refusals, and the surface
// distance index against brute force (the refinement test's geometric error, paper §4.2). The
// sample is the synthetic deformed box (format/synthetic_asset.h) written straight into a Sample;
// the host adapter that fills samples through a host's callbacks is tested with the builder.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "format/synthetic_asset.h"
#include "mesh/sample.h"
#include "mesh/surface_distance.h"

namespace {

using namespace cadinterp;
using mesh::Sample;

// The synthetic box at x (K = 2), with a per-vertex and a per-tet field, as a host would write it.
Sample box_sample(const double* x) {
  format::SyntheticSpec spec;
  spec.K = 2;
  spec.cells[0] = 3;
  spec.cells[1] = 2;
  spec.cells[2] = 2;
  const format::BoxMesh box = format::synthetic_box(spec);
  std::vector<float> pos, fld;
  EXPECT_TRUE(format::synthetic_host(spec, box, x, pos, fld));
  Sample s;
  s.feasible = true;
  s.vertices.assign(pos.begin(), pos.end());
  s.tets = box.tets;
  s.triangles = box.triangles;
  s.triangle_tags = box.tags;
  const auto nv = static_cast<long>(box.vertex_count);
  s.fields.push_back(
      {"temperature", 0, 1, std::vector<double>(fld.begin(), fld.begin() + nv), "K"});
  s.fields.push_back({"stress", 1, 1, std::vector<double>(fld.begin() + nv, fld.end()), ""});
  return s;
}

TEST(Sample, SerializesLosslesslyAndValidates) {
  const double x[2] = {0.3, 0.7};
  const Sample s = box_sample(x);
  const auto bytes = mesh::serialize(s);
  const Sample t = mesh::deserialize(bytes.data(), bytes.size());
  EXPECT_EQ(mesh::serialize(t), bytes);
  EXPECT_EQ(t.vertices, s.vertices);
  EXPECT_EQ(t.fields.size(), 2u);
  EXPECT_EQ(t.fields[0].unit, "K");
  for (std::size_t n = 0; n < bytes.size(); n += 7)
    EXPECT_THROW(mesh::deserialize(bytes.data(), n), std::runtime_error) << n;

  EXPECT_EQ(mesh::validate(s), "");
  Sample bad = s;
  std::swap(bad.tets[0], bad.tets[1]);  // odd permutation: inverted
  EXPECT_NE(mesh::validate(bad).find("inverted"), std::string::npos);
  bad = s;
  bad.vertices[5] = std::nan("");
  EXPECT_NE(mesh::validate(bad).find("non-finite"), std::string::npos);
  bad = s;
  bad.triangles[2] = static_cast<std::uint32_t>(s.vertex_count());
  EXPECT_NE(mesh::validate(bad).find("out of range"), std::string::npos);
  bad = s;
  bad.fields[1].values.pop_back();
  EXPECT_NE(mesh::validate(bad).find("stress"), std::string::npos);
}

TEST(Sample, OutputsSerializeAndOlderVersionsStillRead) {
  const double x[2] = {0.3, 0.7};
  Sample s = box_sample(x);
  const auto bytes_without = mesh::serialize(s);
  s.outputs.push_back({"brep_volume", 1.25, "mm^3"});
  s.outputs.push_back({"compliance", -3.5e-7, ""});
  EXPECT_EQ(mesh::validate(s), "");
  const auto bytes = mesh::serialize(s);
  const Sample t = mesh::deserialize(bytes.data(), bytes.size());
  ASSERT_EQ(t.outputs.size(), 2u);
  EXPECT_EQ(t.outputs[0].name, "brep_volume");
  EXPECT_EQ(t.outputs[0].value, 1.25);
  EXPECT_EQ(t.outputs[0].unit, "mm^3");
  EXPECT_EQ(t.outputs[1].value, -3.5e-7);

  // A version 2 store (written before outputs existed) is the version 3 bytes without the
  // trailing output count: it still reads, with no outputs.
  std::vector<std::uint8_t> v2(bytes_without.begin(), bytes_without.end() - 8);
  ASSERT_EQ(v2[4], 3);
  v2[4] = 2;
  const Sample old = mesh::deserialize(v2.data(), v2.size());
  EXPECT_TRUE(old.outputs.empty());
  EXPECT_EQ(old.fields[0].unit, "K");
  v2[4] = 4;  // a version from the future is refused
  EXPECT_THROW(mesh::deserialize(v2.data(), v2.size()), std::runtime_error);

  Sample bad = s;
  bad.outputs[1].name = "brep_volume";
  EXPECT_NE(mesh::validate(bad).find("given twice"), std::string::npos);
  bad = s;
  bad.outputs[0].value = std::numeric_limits<double>::infinity();
  EXPECT_NE(mesh::validate(bad).find("not finite"), std::string::npos);
}

// Triangle t of F alone.
std::vector<std::uint32_t> triangle(const std::vector<std::uint32_t>& F, std::size_t t) {
  return {F[3 * t], F[3 * t + 1], F[3 * t + 2]};
}

// The distance from p to the surface (V, F), one triangle at a time: no grid to prune with.
double brute_distance(const std::vector<double>& V, const std::vector<std::uint32_t>& F,
                      const double* p) {
  double d = std::numeric_limits<double>::infinity();
  for (std::size_t t = 0; t < F.size() / 3; ++t)
    d = std::min(d, mesh::SurfaceIndex(V, triangle(F, t)).distance(p));
  return d;
}

TEST(SurfaceDistance, MatchesBruteForceAndKnownDistances) {
  // Two unit squares 0.25 apart: Hausdorff 0.25.
  const std::vector<double> A = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  std::vector<double> B = A;
  for (std::size_t i = 2; i < B.size(); i += 3) B[i] = 0.25;
  const std::vector<std::uint32_t> F = {0, 1, 2, 0, 2, 3};
  EXPECT_NEAR(mesh::symmetric_hausdorff(A, F, B, F), 0.25, 1e-15);

  // A box surface against random points: the grid query equals the brute force over all
  // triangles, inside, outside and far away.
  const double x[2] = {0.5, 0.5};
  const Sample s = box_sample(x);
  const mesh::SurfaceIndex index(s.vertices, s.triangles);
  const mesh::SurfaceIndex empty(s.vertices, {});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int i = 0; i < 300; ++i) {
    const double p[3] = {u(rng), u(rng), u(rng) * (i % 3 == 0 ? 10 : 1)};
    const double brute = brute_distance(s.vertices, s.triangles, p);
    EXPECT_NEAR(index.distance(p), brute, 1e-12 * (1 + brute)) << i;
  }
  EXPECT_TRUE(std::isinf(empty.distance(x)));
}

TEST(SurfaceDistance, MatchesBruteForceNearAFineSurface) {
  // A wavy 40 x 40 height field (3,200 triangles, many grid cells) and points within a few
  // triangle sizes of it, where the query stops early: the same distance as every triangle
  // tried, and a triangle at that distance.
  const int n = 40;
  std::vector<double> V;
  std::vector<std::uint32_t> F;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double a = double(i) / n, b = double(j) / n;
      V.insert(V.end(), {a, b, 0.1 * std::sin(6 * a) * std::cos(4 * b)});
    }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const std::uint32_t v = static_cast<std::uint32_t>(i * (n + 1) + j);
      F.insert(F.end(), {v, v + n + 1, v + 1, v + 1, v + n + 1, v + n + 2});
    }
  const mesh::SurfaceIndex index(V, F);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.05, 1.05), dz(-0.06, 0.06);
  for (int i = 0; i < 400; ++i) {
    double p[3] = {u(rng), u(rng), 0};
    p[2] = 0.1 * std::sin(6 * p[0]) * std::cos(4 * p[1]) + dz(rng);
    const double brute = brute_distance(V, F, p);
    std::size_t t = F.size();
    EXPECT_EQ(index.distance(p, &t), brute) << i;
    ASSERT_LT(t, F.size() / 3);
    EXPECT_EQ(mesh::SurfaceIndex(V, triangle(F, t)).distance(p), brute) << i;
  }
}

}  // namespace
