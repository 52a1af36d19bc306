// The analytic host as the builder sees it: the entry point (linked statically and loaded from
// the shared library), and the callbacks writing real samples through the builder's C ABI in a
// tiny build, including the fail region.
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>

#include "analytic_host.h"
#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_builder.h"

#ifndef ANALYTIC_HOST_SO
#error "ANALYTIC_HOST_SO must name the shared library under test"
#endif

namespace {

TEST(AnalyticEntry, HostsAndErrors) {
  const char* error = nullptr;
  const cadinterp_host* bracket = cadinterp_host_entry(nullptr, nullptr, &error);
  ASSERT_NE(bracket, nullptr) << error;
  EXPECT_EQ(bracket->struct_size, sizeof(cadinterp_host));
  EXPECT_STREQ(bracket->name, "analytic");
  EXPECT_STREQ(bracket->identity, "analytic bracket v1 (cells=4, levels=2, fail_region=0)");
  EXPECT_EQ(bracket->parameter_count, 4);
  EXPECT_STREQ(bracket->parameters[3].name, "bend_angle");
  EXPECT_STREQ(bracket->parameters[3].unit, "deg");
  EXPECT_EQ(bracket->thread_safe, 1);
  EXPECT_NE(bracket->regenerate, nullptr);
  EXPECT_NE(bracket->references, nullptr);
  EXPECT_NE(bracket->simulate, nullptr);
  EXPECT_EQ(analytic_host_model(bracket), bracket->user);

  // Equal requests share a host; others get their own.
  EXPECT_EQ(cadinterp_host_entry("bracket", "", &error), bracket);
  const cadinterp_host* plate = cadinterp_host_entry("plate", "edge=4", &error);
  ASSERT_NE(plate, nullptr) << error;
  EXPECT_NE(plate, bracket);
  EXPECT_EQ(plate->parameter_count, 3);
  EXPECT_EQ(cadinterp_host_entry("plate", "edge=4.000", &error), plate);

  error = nullptr;
  EXPECT_EQ(cadinterp_host_entry("gearbox", nullptr, &error), nullptr);
  ASSERT_NE(error, nullptr);
  EXPECT_NE(std::string(error).find("unknown model"), std::string::npos);
  error = nullptr;
  EXPECT_EQ(cadinterp_host_entry("plate", "edge=fast", &error), nullptr);
  ASSERT_NE(error, nullptr);
  EXPECT_NE(std::string(error).find("edge"), std::string::npos);
  EXPECT_EQ(cadinterp_host_entry("plate", "edge=fast", nullptr), nullptr);

  cadinterp_host other = *bracket;
  other.regenerate = nullptr;
  EXPECT_EQ(analytic_host_model(&other), nullptr);
  EXPECT_EQ(analytic_host_model(nullptr), nullptr);
}

// sleep_ms and kill_after change no result: the identity (and so a store or an asset) is the
// same, but the host is another one (its callbacks behave differently).
TEST(AnalyticEntry, RunTimeOptionsKeepTheIdentity) {
  const char* error = nullptr;
  const cadinterp_host* plain = cadinterp_host_entry("plate", "edge=8", &error);
  const cadinterp_host* slow = cadinterp_host_entry("plate", "edge=8,sleep_ms=30", &error);
  const cadinterp_host* fragile = cadinterp_host_entry("plate", "kill_after=0,edge=8", &error);
  ASSERT_NE(plain, nullptr);
  ASSERT_NE(slow, nullptr) << error;
  ASSERT_NE(fragile, nullptr) << error;
  EXPECT_STREQ(slow->identity, plain->identity);
  EXPECT_STREQ(fragile->identity, plain->identity);
  EXPECT_NE(slow, plain);
  EXPECT_NE(fragile, plain);
  EXPECT_NE(fragile, slow);
  EXPECT_EQ(cadinterp_host_entry("plate", "sleep_ms=30,edge=8", &error), slow);
  for (const char* bad : {"sleep_ms=-1", "sleep_ms=3600001", "sleep_ms=1,sleep_ms=2",
                          "kill_after=x", "kill_after=-1", "kill_after="}) {
    error = nullptr;
    EXPECT_EQ(cadinterp_host_entry("plate", bad, &error), nullptr) << bad;
    ASSERT_NE(error, nullptr) << bad;
  }

  // sleep_ms sleeps in every regenerate.
  const double x[3] = {60, 40, 6};
  void* bytes = nullptr;
  std::size_t size = 0;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(cadinterp_host_evaluate_serialized(slow, x, &bytes, &size), CADINTERP_OK);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(30));
  cadinterp_bytes_free(bytes);

  // kill_after=0: the first regenerate kills the process with SIGKILL.
  EXPECT_EXIT(
      {
        void* never = nullptr;
        std::size_t n = 0;
        cadinterp_host_evaluate_serialized(fragile, x, &never, &n);
        std::exit(0);
      },
      ::testing::KilledBySignal(SIGKILL), "");
}

TEST(AnalyticEntry, LoadsFromTheSharedLibrary) {
  void* lib = dlopen(ANALYTIC_HOST_SO, RTLD_NOW | RTLD_LOCAL);
  ASSERT_NE(lib, nullptr) << dlerror();
  auto entry = reinterpret_cast<cadinterp_host_entry_fn>(dlsym(lib, CADINTERP_HOST_ENTRY_NAME));
  ASSERT_NE(entry, nullptr) << dlerror();
  // Only the entry is exported: the model functions stay inside.
  EXPECT_EQ(dlsym(lib, "analytic_model_create"), nullptr);
  const char* error = nullptr;
  const cadinterp_host* host = entry("plate", "edge=10", &error);
  ASSERT_NE(host, nullptr) << error;
  EXPECT_STREQ(host->identity, "analytic plate v1 (edge=10000 um, levels=2, fail_region=0)");
  EXPECT_EQ(host->thread_safe, 1);
  // The library's own copy, not the statically linked one.
  EXPECT_EQ(analytic_host_model(host), nullptr);
  dlclose(lib);
}

struct Build {
  cadinterp_status status = CADINTERP_E_INTERNAL;
  cadinterp_build_report report{};
  std::string error;
};

Build build(const cadinterp_host* host, const std::string& path) {
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.geometry_tolerance = 1e-2;
  o.field_tolerance = 5e-2;
  o.max_samples = 12;
  o.max_depth = 2;
  o.threads = 2;
  Build b;
  cadinterp_builder* builder = nullptr;
  b.status = cadinterp_builder_create(host, &o, &builder);
  if (b.status != CADINTERP_OK) {
    b.error = cadinterp_builder_create_error();
    return b;
  }
  b.status = cadinterp_builder_run(builder, path.c_str());
  b.error = cadinterp_builder_error(builder);
  b.report.struct_size = sizeof b.report;
  cadinterp_builder_report(builder, &b.report);
  cadinterp_builder_destroy(builder);
  return b;
}

// Per process, so that builds of other configurations running at the same time do not collide.
std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          (name + "_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
           ".cadi"))
      .string();
}

TEST(AnalyticEntry, BracketBuildsThroughTheSharedLibrary) {
  void* lib = dlopen(ANALYTIC_HOST_SO, RTLD_NOW | RTLD_LOCAL);
  ASSERT_NE(lib, nullptr) << dlerror();
  auto entry = reinterpret_cast<cadinterp_host_entry_fn>(dlsym(lib, CADINTERP_HOST_ENTRY_NAME));
  ASSERT_NE(entry, nullptr);
  const char* error = nullptr;
  const cadinterp_host* host = entry("bracket", "cells=2", &error);
  ASSERT_NE(host, nullptr) << error;
  const std::string path = temp_path("analytic_bracket");
  const Build b = build(host, path);
  ASSERT_EQ(b.status, CADINTERP_OK) << b.error;
  EXPECT_GT(b.report.samples, 0);
  EXPECT_EQ(b.report.infeasible_points, 0);

  cadinterp_asset* asset = nullptr;
  ASSERT_EQ(cadinterp_open(path.c_str(), &asset), CADINTERP_OK) << cadinterp_open_error();
  EXPECT_EQ(cadinterp_parameter_count(asset), 4);
  EXPECT_EQ(cadinterp_field_count(asset), 2);
  int index = -1;
  EXPECT_EQ(cadinterp_find_field(asset, "von_mises", &index), CADINTERP_OK);
  EXPECT_EQ(cadinterp_region_count(asset), 2);
  cadinterp_close(asset);
  std::remove(path.c_str());
  dlclose(lib);
}

TEST(AnalyticEntry, FailRegionMakesPointsInfeasible) {
  const char* error = nullptr;
  const cadinterp_host* host = cadinterp_host_entry("bracket", "cells=1,fail_region=1", &error);
  ASSERT_NE(host, nullptr) << error;
  const std::string path = temp_path("analytic_bracket_fail");
  const Build b = build(host, path);
  ASSERT_EQ(b.status, CADINTERP_OK) << b.error;
  // The box's upper corner lies in the fail region, and the builder samples the corners.
  EXPECT_GT(b.report.infeasible_points, 0);
  EXPECT_GT(b.report.samples, b.report.infeasible_points);
  std::remove(path.c_str());
}

// The bracket's per-sample output "exact_volume" (closed form, written by the references
// callback) against that closed form and against the interpolated mesh's volume at random
// points: the output is interpolated from exact values, the mesh volume carries the bend's
// chords and the mesh interpolation.
TEST(AnalyticEntry, BracketExactVolumeOutput) {
  const char* error = nullptr;
  const cadinterp_host* host = cadinterp_host_entry("bracket", "cells=2", &error);
  ASSERT_NE(host, nullptr) << error;
  const std::string path = temp_path("analytic_bracket_outputs");
  const Build b = build(host, path);
  ASSERT_EQ(b.status, CADINTERP_OK) << b.error;
  cadinterp_asset* asset = nullptr;
  ASSERT_EQ(cadinterp_open(path.c_str(), &asset), CADINTERP_OK) << cadinterp_open_error();
  int index = -1;
  ASSERT_EQ(cadinterp_find_output(asset, "exact_volume", &index), CADINTERP_OK);
  const char *name = nullptr, *unit = nullptr;
  ASSERT_EQ(cadinterp_output(asset, index, &name, &unit), CADINTERP_OK);
  EXPECT_STREQ(unit, "mm^3");
  cadinterp_workspace* ws = nullptr;
  ASSERT_EQ(cadinterp_workspace_create(asset, &ws), CADINTERP_OK);
  std::mt19937_64 rng(11);
  double out_err = 0, mesh_err = 0;
  for (int i = 0; i < 20; ++i) {
    double x[4];
    for (int d = 0; d < 4; ++d)
      x[d] = std::uniform_real_distribution<double>(host->parameters[d].lower,
                                                    host->parameters[d].upper)(rng);
    const double pi = std::acos(-1.0);
    const double exact = 30.0 * x[2] * (x[0] + x[1] + 1.5 * x[2] * x[3] * pi / 180.0);
    double v = 0;
    ASSERT_EQ(cadinterp_eval_outputs(ws, x, &index, 1, &v, nullptr), CADINTERP_OK);
    cadinterp_properties p;
    const double z[3] = {0, 0, 1};
    ASSERT_EQ(cadinterp_eval_properties(ws, x, 1.0, z, &p, nullptr), CADINTERP_OK);
    out_err = std::max(out_err, std::abs(v - exact) / exact);
    mesh_err = std::max(mesh_err, std::abs(p.volume - exact) / exact);
  }
  std::printf(
      "[outputs] bracket cells=2, %d samples, max error %.3g of target: relative volume "
      "error at 20 random points, output exact_volume %.2e, mesh volume %.2e\n",
      b.report.samples, b.report.max_error, out_err, mesh_err);
  // The build holds outputs to field_tolerance (5e-2 here) of their magnitude at its check
  // points, scaled by the report's max_error where the sample budget ran out.
  EXPECT_LT(out_err, 5e-2 * std::max(1.0, b.report.max_error));
  cadinterp_workspace_destroy(ws);
  cadinterp_close(asset);
  std::remove(path.c_str());
}

}  // namespace
