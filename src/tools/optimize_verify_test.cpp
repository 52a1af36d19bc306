// The true side of `cadinterp optimize --verify` (optimize_verify.h) on a hand-made host sample
// whose quantities are known in closed form: a box [0, 1] x [0, 0.5] x [0, 0.25] of 48 tets with
// a per-vertex field equal to x and a per-tet field 1..48.
#include "optimize_verify.h"

#include <gtest/gtest.h>

#include <cmath>

#include "format/synthetic_asset.h"

namespace cadinterp::cli {
namespace {

mesh::Sample box_sample() {
  format::SyntheticSpec spec;
  spec.cells[0] = spec.cells[1] = spec.cells[2] = 2;
  const format::BoxMesh box = format::synthetic_box(spec);
  mesh::Sample s;
  s.feasible = true;
  s.vertices.assign(box.rest.begin(), box.rest.end());
  s.tets = box.tets;
  s.triangles = box.triangles;
  s.triangle_tags = box.tags;
  s.regions.push_back({"top", "force", {5}});  // the +z face
  mesh::Field t{"temperature", 0, 1, {}, "K"};
  for (std::size_t v = 0; v < s.vertex_count(); ++v) t.values.push_back(s.vertices[3 * v]);
  mesh::Field st{"stress", 1, 1, {}, "MPa"};
  for (std::size_t i = 0; i < s.tet_count(); ++i) st.values.push_back(static_cast<double>(i + 1));
  s.fields = {t, st};
  return s;
}

TEST(OptimizeVerify, ClosedFormQuantitiesOnTheHostSample) {
  OptimizeSpec spec;
  spec.minimize = "integral(temperature) + 2*volume";
  spec.subject_to = {"area <= 10",
                     "region_area(top) >= 0",
                     "region_integral(temperature, top) <= 1",
                     "mass(2) + centroid_x <= 9",
                     "max(stress) <= 1e9",
                     "max(stress, ks=0.5) <= 1e9"};
  const std::vector<TrueValue> v = values_on_sample(box_sample(), spec);
  ASSERT_EQ(v.size(), 7u);
  for (const TrueValue& t : v) ASSERT_TRUE(t.defined) << t.reason;
  const double volume = 0.125;
  EXPECT_NEAR(v[0].value, volume * 0.5 + 2 * volume, 1e-9);  // integral of x: volume * centroid
  EXPECT_NEAR(v[1].value, 2 * (0.5 + 0.25 + 0.125), 1e-9);
  EXPECT_NEAR(v[2].value, 0.5, 1e-9);
  EXPECT_NEAR(v[3].value, 0.5 * 0.5, 1e-9);  // integral of x over the top face
  EXPECT_NEAR(v[4].value, 2 * volume + 0.5, 1e-9);
  double pnorm = 0, ks = 0;
  for (int i = 1; i <= 48; ++i) {
    pnorm += std::pow(i / 48.0, 8.0);
    ks += std::exp(0.5 * (i - 48));
  }
  EXPECT_NEAR(v[5].value, 48 * std::pow(pnorm, 1.0 / 8), 1e-9);
  EXPECT_NEAR(v[6].value, 48 + std::log(ks) / 0.5, 1e-9);
}

TEST(OptimizeVerify, WhatTheSampleLacksIsNotAvailableWithTheReason) {
  OptimizeSpec spec;
  spec.minimize = "integral(von_mises)";
  spec.subject_to = {"volume <= 1", "region_area(clamp) >= 0"};
  const std::vector<TrueValue> v = values_on_sample(box_sample(), spec);
  ASSERT_EQ(v.size(), 3u);
  EXPECT_FALSE(v[0].defined);
  EXPECT_NE(v[0].reason.find("no field 'von_mises'"), std::string::npos) << v[0].reason;
  EXPECT_TRUE(v[1].defined);
  EXPECT_NEAR(v[1].value, 0.125, 1e-9);
  EXPECT_FALSE(v[2].defined);
  EXPECT_NE(v[2].reason.find("clamp"), std::string::npos) << v[2].reason;
}

TEST(OptimizeVerify, TheHostsOutputsAreItsExactValues) {
  mesh::Sample s = box_sample();
  s.outputs.push_back({"brep_volume", 0.123456789, "mm^3"});
  OptimizeSpec spec;
  spec.minimize = "output(brep_volume)";
  spec.subject_to = {"2*output(brep_volume) - volume <= 1", "output(compliance) <= 1"};
  const std::vector<TrueValue> v = values_on_sample(s, spec);
  ASSERT_EQ(v.size(), 3u);
  ASSERT_TRUE(v[0].defined) << v[0].reason;
  EXPECT_NEAR(v[0].value, 0.123456789, 1e-15);
  ASSERT_TRUE(v[1].defined) << v[1].reason;
  EXPECT_NEAR(v[1].value, 2 * 0.123456789 - 0.125, 1e-9);
  EXPECT_FALSE(v[2].defined);  // the host returned no such output
  EXPECT_NE(v[2].reason.find("compliance"), std::string::npos) << v[2].reason;
}

TEST(OptimizeVerify, AnInfeasibleSampleMakesNoAsset) {
  mesh::Sample s;
  s.message = "the host failed";
  EXPECT_THROW(sample_asset_bytes(s), std::runtime_error);
}

}  // namespace
}  // namespace cadinterp::cli
