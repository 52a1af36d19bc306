// Test support for the runtime's C ABI tests: an asset written from content and opened from
// memory, with one workspace, closed together when the test is done.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "format/asset_writer.h"
#include "format/synthetic_asset.h"

namespace cadinterp::runtime_test {

/// The written bytes (which the asset reads in place, so they live as long as it does), the open
/// asset and a workspace on it.
struct Opened {
  std::vector<std::uint8_t> bytes;
  cadinterp_asset* asset = nullptr;
  cadinterp_workspace* ws = nullptr;
  Opened() = default;
  Opened(const Opened&) = delete;
  Opened& operator=(const Opened&) = delete;
  ~Opened() {
    cadinterp_workspace_destroy(ws);
    cadinterp_close(asset);
  }
};

/// Writes `content`, opens it and creates a workspace; a step that fails is a test failure (the
/// asset or workspace pointer then stays NULL).
inline std::unique_ptr<Opened> open_content(const format::AssetContent& content) {
  auto o = std::make_unique<Opened>();
  o->bytes = format::write_asset(content, {});
  EXPECT_EQ(cadinterp_open_memory(o->bytes.data(), o->bytes.size(), 0, &o->asset), CADINTERP_OK)
      << cadinterp_open_error();
  if (o->asset) {
    EXPECT_EQ(cadinterp_workspace_create(o->asset, &o->ws), CADINTERP_OK);
  }
  return o;
}

/// A small synthetic asset of K parameters and degree g: tolerance 2e-3, at most 200 samples.
inline format::SyntheticSpec small_synthetic_spec(int K, core::Degree g) {
  format::SyntheticSpec s;
  s.K = K;
  s.degree = g;
  s.tolerance = 2e-3;
  s.max_samples = 200;
  return s;
}

/// open_content of the synthetic asset of `spec` (format/synthetic_asset.h).
inline std::unique_ptr<Opened> open_synthetic(const format::SyntheticSpec& spec) {
  return open_content(format::make_synthetic_asset(spec).content);
}

}  // namespace cadinterp::runtime_test
