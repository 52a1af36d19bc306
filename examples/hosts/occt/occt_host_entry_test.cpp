// The OCCT host as the builder and the CLI see it: the entry point (linked statically and from
// the shared library), and one small end-to-end `cadinterp build` through the shared library,
// whose asset is then compared with the host's own regeneration.
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_builder.h"
#include "occt_host.h"

#ifndef OCCT_HOST_SO
#error "OCCT_HOST_SO must name the shared library under test"
#endif
#ifndef OCCT_CLI
#error "OCCT_CLI must name the cadinterp command"
#endif

namespace {

std::string temp_path(const std::string& name, const char* ext) {
  return (std::filesystem::temp_directory_path() /
          (name + "_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
           std::to_string(::getpid()) + ext))
      .string();
}

TEST(OcctEntry, HostsAndErrors) {
  const char* error = nullptr;
  const cadinterp_host* wrench = cadinterp_host_entry(nullptr, nullptr, &error);
  ASSERT_NE(wrench, nullptr) << error;
  EXPECT_EQ(wrench->struct_size, sizeof(cadinterp_host));
  EXPECT_STREQ(wrench->name, "occt");
  EXPECT_EQ(std::string(wrench->identity).rfind("occt wrench v2 (mesh_size=4,", 0), 0u)
      << wrench->identity;
  EXPECT_EQ(wrench->parameter_count, 4);
  EXPECT_STREQ(wrench->parameters[3].name, "load_angle");
  EXPECT_STREQ(wrench->parameters[3].unit, "deg");
  EXPECT_NE(cadinterp::occt::host_model(wrench), nullptr);
  EXPECT_EQ(cadinterp_host_entry("wrench", "", &error), wrench);  // equal requests share

  const cadinterp_host* press = cadinterp_host_entry("press", "mesh_size=20", &error);
  ASSERT_NE(press, nullptr) << error;
  EXPECT_EQ(press->parameter_count, 5);
  const cadinterp_host* mount = cadinterp_host_entry("mount", "", &error);
  ASSERT_NE(mount, nullptr) << error;
  EXPECT_EQ(mount->parameter_count, 6);

  error = nullptr;
  EXPECT_EQ(cadinterp_host_entry("gearbox", nullptr, &error), nullptr);
  ASSERT_NE(error, nullptr);
  EXPECT_NE(std::string(error).find("unknown model"), std::string::npos);
  EXPECT_EQ(cadinterp_host_entry("hub", "mesh_size=fast", &error), nullptr);
  EXPECT_NE(std::string(error).find("mesh_size"), std::string::npos);
  EXPECT_EQ(cadinterp_host_entry("hub", "mesh_size=fast", nullptr), nullptr);

  cadinterp_host other = *wrench;
  other.regenerate = nullptr;
  EXPECT_EQ(cadinterp::occt::host_model(&other), nullptr);
}

TEST(OcctEntry, LoadsFromTheSharedLibrary) {
  void* lib = dlopen(OCCT_HOST_SO, RTLD_NOW | RTLD_LOCAL);
  ASSERT_NE(lib, nullptr) << dlerror();
  auto entry = reinterpret_cast<cadinterp_host_entry_fn>(dlsym(lib, CADINTERP_HOST_ENTRY_NAME));
  ASSERT_NE(entry, nullptr) << dlerror();
  const char* error = nullptr;
  const cadinterp_host* host = entry("hub", "mesh_size=16", &error);
  ASSERT_NE(host, nullptr) << error;
  EXPECT_EQ(std::string(host->identity).rfind("occt hub v2 (mesh_size=16,", 0), 0u);
  EXPECT_EQ(host->parameter_count, 3);
  // The library's own copy, not the statically linked one.
  EXPECT_EQ(cadinterp::occt::host_model(host), nullptr);
  dlclose(lib);
}

// `cadinterp build` through the shared library, the asset opened; fails the test on error.
cadinterp_asset* cli_build(const std::string& options, const std::string& extra,
                           const std::string& asset_path, std::string* output) {
  const std::string log = asset_path + ".log";
  const std::string cmd = std::string(OCCT_CLI) + " build --host " + OCCT_HOST_SO +
                          " --model wrench --host-options " + options + " " + extra +
                          " -j 2 -q -o " + asset_path + " > " + log + " 2>&1";
  const int rc = std::system(cmd.c_str());
  std::ifstream in(log);
  std::stringstream out;
  out << in.rdbuf();
  *output = out.str();
  std::remove(log.c_str());
  EXPECT_EQ(rc, 0) << cmd << "\n" << out.str();
  cadinterp_asset* asset = nullptr;
  EXPECT_EQ(cadinterp_open(asset_path.c_str(), &asset), CADINTERP_OK) << cadinterp_open_error();
  return asset;
}

// The asset against the host's own regeneration at x: the geometry (the load angle does not
// change it, so the host's mesh vertex for vertex) and, with the FEM, the displacement within
// `tolerance` of its range.
void expect_matches_host(cadinterp_asset* asset, const cadinterp::occt::Model& truth,
                         const double* x, double tolerance) {
  const cadinterp::occt::Evaluation e = truth.evaluate(x);
  ASSERT_TRUE(e.ok) << e.message;
  cadinterp_workspace* ws = nullptr;
  ASSERT_EQ(cadinterp_workspace_create(asset, &ws), CADINTERP_OK);
  int fields[2] = {-1, -1};
  const bool physics = cadinterp::occt::Model::has_physics();
  if (physics) {
    ASSERT_EQ(cadinterp_field_count(asset), 3);  // von_mises, displacement, traction
    ASSERT_EQ(cadinterp_find_field(asset, "von_mises", &fields[0]), CADINTERP_OK);
    ASSERT_EQ(cadinterp_find_field(asset, "displacement", &fields[1]), CADINTERP_OK);
  }
  cadinterp_mesh m{};
  ASSERT_EQ(cadinterp_eval(ws, x, fields, physics ? 2 : 0, &m), CADINTERP_OK)
      << cadinterp_workspace_error(ws);
  ASSERT_EQ(m.vertex_count, e.vertices.size() / 3);
  for (std::size_t i = 0; i < e.vertices.size(); ++i)
    ASSERT_NEAR(m.positions[i], e.vertices[i], 1e-4 * (1 + std::abs(e.vertices[i])));
  if (physics) {
    const cadinterp::occt::Fields f = truth.simulate(x, e);
    double lo = 1e300, hi = -1e300, err = 0;
    for (std::size_t i = 0; i < f.displacement.size(); ++i) {
      lo = std::min(lo, f.displacement[i]);
      hi = std::max(hi, f.displacement[i]);
      err = std::max(err, std::abs(m.fields[1][i] - f.displacement[i]));
    }
    EXPECT_LT(err / (hi - lo), tolerance) << "x = " << x[0];
  }
  cadinterp_workspace_destroy(ws);
}

// `cadinterp build` through the shared library on the wrench's load angle alone (the other
// parameters held at the centre), so every sample has one mesh and the build needs no mesh
// mapping; then the asset against the host at a point between samples.
TEST(OcctEntry, CliBuildsTheWrenchThroughTheSharedLibrary) {
  const std::string asset_path = temp_path("occt_wrench", ".cadi");
  const std::string options = "mesh_size=10,order=1,vary=load_angle";
  std::string out;
  cadinterp_asset* asset =
      cli_build(options, "--max-samples 5 --max-depth 2 --field-tol 0.02", asset_path, &out);
  ASSERT_NE(asset, nullptr);
  EXPECT_NE(out.find("build summary"), std::string::npos) << out;
  // Two threads regenerate at once (-j 2): every point must still regenerate (the modelling
  // stage is serialized, occt_host.cpp).
  EXPECT_NE(out.find("infeasible 0)"), std::string::npos) << out;
  EXPECT_EQ(cadinterp_parameter_count(asset), 1);
  EXPECT_EQ(cadinterp_region_count(asset), 2);
  const cadinterp::occt::Model truth("wrench", options);
  const double x[] = {12.5};
  expect_matches_host(asset, truth, x, 0.05);
  cadinterp_close(asset);
  std::remove(asset_path.c_str());
}

// The same model cubic (--degree 3, C2 Hermite-type basis): built end to end and checked
// against the host at random points between its samples.
TEST(OcctEntry, CliBuildsTheWrenchCubic) {
  const std::string asset_path = temp_path("occt_wrench_cubic", ".cadi");
  const std::string options = "mesh_size=10,order=1,vary=load_angle";
  std::string out;
  cadinterp_asset* asset = cli_build(
      options, "--degree 3 --max-samples 12 --max-depth 2 --field-tol 0.02", asset_path, &out);
  ASSERT_NE(asset, nullptr);
  EXPECT_NE(out.find("infeasible 0)"), std::string::npos) << out;
  const cadinterp::occt::Model truth("wrench", options);
  std::mt19937 rng(::testing::UnitTest::GetInstance()->random_seed());
  std::uniform_real_distribution<double> angle(-30, 30);
  for (int i = 0; i < 3; ++i) {
    const double x[] = {angle(rng)};
    expect_matches_host(asset, truth, x, 0.02);
  }
  cadinterp_close(asset);
  std::remove(asset_path.c_str());
}

}  // namespace
