// One asset, 8 threads with a workspace each, evaluating (and decoding through the shared
// element cache, with a budget small enough to force evictions): results equal a serial run.
// Run under the tsan preset (label 'concurrency').
#include <gtest/gtest.h>

#include <random>
#include <thread>

#include "cadinterp/cadinterp.h"
#include "format/synthetic_asset.h"

namespace {

TEST(RuntimeThreads, EightThreadsShareOneAsset) {
  cadinterp::format::SyntheticSpec spec;
  spec.K = 3;
  spec.max_samples = 150;
  const auto synthetic = cadinterp::format::make_synthetic_asset(spec);
  const std::vector<std::uint8_t> bytes = cadinterp::format::write_asset(synthetic.content, {});
  cadinterp_asset* asset = nullptr;
  ASSERT_EQ(cadinterp_open_memory(bytes.data(), bytes.size(), 0, &asset), CADINTERP_OK);
  ASSERT_EQ(cadinterp_set_cache_budget(asset, 64 * 1024), CADINTERP_OK);

  constexpr int kPoints = 400, kThreads = 8;
  std::mt19937_64 rng(3);
  std::vector<double> xs(kPoints * 3);
  for (double& x : xs) x = std::uniform_real_distribution<double>(0, 1)(rng);
  auto run = [&](int begin, int step, std::vector<double>& out) {
    cadinterp_workspace* ws = nullptr;
    ASSERT_EQ(cadinterp_workspace_create(asset, &ws), CADINTERP_OK);
    const int fields[2] = {0, 1};
    for (int i = begin; i < kPoints; i += step) {
      cadinterp_mesh m;
      ASSERT_EQ(cadinterp_eval(ws, &xs[static_cast<std::size_t>(i) * 3], fields, 2, &m),
                CADINTERP_OK);
      double s = 0;
      for (std::uint32_t v = 0; v < m.vertex_count * 3; ++v) s += double(m.positions[v]) * (v + 1);
      for (std::uint32_t k = 0; k < m.tet_count; ++k) s += m.fields[1][k];
      double g[3];
      ASSERT_EQ(cadinterp_vjp(ws, &xs[static_cast<std::size_t>(i) * 3], m.positions, nullptr,
                              nullptr, 0, g),
                CADINTERP_OK);
      out[static_cast<std::size_t>(i)] = s + g[0] + g[1] + g[2];
    }
    cadinterp_workspace_destroy(ws);
  };
  std::vector<double> serial(kPoints), parallel(kPoints);
  run(0, 1, serial);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) threads.emplace_back(run, t, kThreads, std::ref(parallel));
  for (auto& t : threads) t.join();
  EXPECT_EQ(serial, parallel);
  cadinterp_close(asset);
}

}  // namespace
