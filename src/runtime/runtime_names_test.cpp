// The deprecated names of the C ABI (cadinterp.h, "Deprecated names") and of the C++ wrapper
// still work for their one release, and answer exactly as the names that replace them.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp.hpp"
#include "format/synthetic_asset.h"

// The old names are called on purpose: their deprecation warnings would fail -Werror builds.
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"

namespace {

cadinterp::Asset synthetic_asset() {
  cadinterp::format::SyntheticSpec s;
  s.K = 2;
  s.degree = cadinterp::core::Degree::Cubic;
  s.tolerance = 2e-3;
  s.max_samples = 100;
  const auto bytes =
      cadinterp::format::write_asset(cadinterp::format::make_synthetic_asset(s).content, {});
  return cadinterp::Asset::open_memory(bytes.data(), bytes.size(), true);
}

bool same_bytes(const cadinterp_properties& a, const cadinterp_properties& b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

TEST(RuntimeNames, DimIsParameterCount) {
  const cadinterp::Asset a = synthetic_asset();
  EXPECT_EQ(cadinterp_parameter_count(a.get()), 2);
  EXPECT_EQ(cadinterp_dim(a.get()), cadinterp_parameter_count(a.get()));
  EXPECT_EQ(cadinterp_dim(nullptr), 0);
  EXPECT_EQ(cadinterp_parameter_count(nullptr), 0);
  EXPECT_EQ(a.dim(), a.parameter_count());
}

TEST(RuntimeNames, GetProvenanceIsAssetProvenance) {
  const cadinterp::Asset a = synthetic_asset();
  cadinterp_provenance p{}, q{};
  ASSERT_EQ(cadinterp_asset_provenance(a.get(), &p), CADINTERP_OK);
  ASSERT_EQ(cadinterp_get_provenance(a.get(), &q), CADINTERP_OK);
  EXPECT_EQ(p.builder_version, q.builder_version);  // the same strings of the asset
  EXPECT_EQ(p.host, q.host);
  EXPECT_EQ(p.options, q.options);
  EXPECT_STREQ(p.host, "synthetic box");
  EXPECT_EQ(cadinterp_get_provenance(a.get(), nullptr), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_get_provenance(nullptr, &q), CADINTERP_E_INVALID_ARGUMENT);
}

TEST(RuntimeNames, PropertiesEvalIsEvalProperties) {
  const cadinterp::Asset a = synthetic_asset();
  cadinterp_workspace* ws = nullptr;
  ASSERT_EQ(cadinterp_workspace_create(a.get(), &ws), CADINTERP_OK);
  const double x[2] = {0.3, 0.6}, dir[3] = {0.0, 0.0, 1.0};
  cadinterp_properties p, q, gp[2], gq[2];
  std::memset(&p, 0, sizeof p);
  std::memset(&q, 0x5a, sizeof q);
  ASSERT_EQ(cadinterp_eval_properties(ws, x, 7.8, dir, &p, gp), CADINTERP_OK);
  ASSERT_EQ(cadinterp_properties_eval(ws, x, 7.8, dir, &q, gq), CADINTERP_OK);
  EXPECT_TRUE(same_bytes(p, q));
  EXPECT_TRUE(same_bytes(gp[0], gq[0]));
  EXPECT_TRUE(same_bytes(gp[1], gq[1]));
  EXPECT_GT(p.volume, 0);

  // The same failures, with the same message.
  const double outside[2] = {2.0, 0.5};
  EXPECT_EQ(cadinterp_properties_eval(ws, outside, 1.0, dir, &q, nullptr),
            CADINTERP_E_OUTSIDE_DOMAIN);
  const std::string old_message = cadinterp_workspace_error(ws);
  EXPECT_EQ(cadinterp_eval_properties(ws, outside, 1.0, dir, &p, nullptr),
            CADINTERP_E_OUTSIDE_DOMAIN);
  EXPECT_EQ(old_message, cadinterp_workspace_error(ws));
  EXPECT_FALSE(old_message.empty());
  EXPECT_EQ(cadinterp_properties_eval(ws, x, 1.0, nullptr, &q, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_properties_eval(nullptr, x, 1.0, dir, &q, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  cadinterp_workspace_destroy(ws);
}

}  // namespace
