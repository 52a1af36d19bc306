// After warm-up (element decoded, workspace sized), eval, grad and vjp allocate nothing: counted
// with a replaced global operator new, which the shared library's calls resolve to as well.
#include <gtest/gtest.h>

#include "core/counting_new.h"

#include "cadinterp/cadinterp.h"
#include "format/synthetic_asset.h"

using cadinterp::testing::allocation_count;

namespace {

TEST(RuntimeAllocations, EvalGradVjpAllocateNothingAfterWarmUp) {
  cadinterp::format::SyntheticSpec spec;
  spec.K = 2;
  spec.max_samples = 40;
  const auto synthetic = cadinterp::format::make_synthetic_asset(spec);
  const auto bytes = cadinterp::format::write_asset(synthetic.content, {});
  cadinterp_asset* asset = nullptr;
  ASSERT_EQ(cadinterp_open_memory(bytes.data(), bytes.size(), 0, &asset), CADINTERP_OK);
  cadinterp_workspace* ws = nullptr;
  ASSERT_EQ(cadinterp_workspace_create(asset, &ws), CADINTERP_OK);
  const double x[2] = {0.31, 0.72};
  const int fields[2] = {0, 1};
  cadinterp_mesh m;
  cadinterp_mesh_grad g;
  double dx[2];
  const long at_start = allocation_count();
  ASSERT_EQ(cadinterp_eval(ws, x, fields, 2, &m), CADINTERP_OK);  // warm-up
  ASSERT_EQ(cadinterp_grad(ws, x, fields, 2, &g), CADINTERP_OK);
  ASSERT_EQ(cadinterp_vjp(ws, x, m.positions, nullptr, nullptr, 0, dx), CADINTERP_OK);
  const long before = allocation_count();
  // The warm-up decoded an element inside libcadinterp: the counter must have seen it, or this
  // test could not fail.
  ASSERT_GT(before - at_start, 0) << "the library's allocations are not counted";
  for (int i = 0; i < 100; ++i) {
    const double xi[2] = {0.31 + 1e-4 * i, 0.72};  // same element, moving x
    ASSERT_EQ(cadinterp_eval(ws, xi, fields, 2, &m), CADINTERP_OK);
    ASSERT_EQ(cadinterp_grad(ws, xi, fields, 2, &g), CADINTERP_OK);
    ASSERT_EQ(cadinterp_vjp(ws, xi, m.positions, nullptr, nullptr, 0, dx), CADINTERP_OK);
  }
  EXPECT_EQ(allocation_count() - before, 0) << "allocations in 100 warm eval+grad+vjp calls";
  cadinterp_workspace_destroy(ws);
  cadinterp_close(asset);
}

}  // namespace
