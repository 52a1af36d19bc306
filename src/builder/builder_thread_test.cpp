// The builder's concurrent parts under ThreadSanitizer (label `concurrency`): host evaluations
// on the executor's threads, the wave's refinement tests answered in parallel, the sample store
// written from the delivering thread, and the same asset whatever the thread count.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "analytic_host.h"
#include "builder/builder_e2e.h"
#include "mesh/host_call.h"
#include "mesh/sample.h"

namespace {

std::vector<char> bytes_of(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(f), {});
}

TEST(BuilderThreads, ParallelBuildsAreRaceFreeAndIdentical) {
  const char* err = nullptr;
  const cadinterp_host* host = cadinterp_host_entry("bracket", "cells=1", &err);
  ASSERT_NE(host, nullptr) << err;
  const std::string dir = std::filesystem::temp_directory_path().string() + "/cadinterp_bt_" +
                          std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 90;
  std::vector<std::vector<char>> assets;
  for (int threads : {1, 3}) {
    o.threads = threads;
    const std::string store = dir + "/s" + std::to_string(threads) + ".sqlite";
    o.store_path = store.c_str();
    const std::string out = dir + "/a" + std::to_string(threads) + ".cadi";
    const auto r = cadinterp::builder::build_asset(*host, o, out);
    ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
    EXPECT_GT(r.report.host_evaluations, 0);
    assets.push_back(bytes_of(out));
  }
  EXPECT_EQ(assets[0], assets[1]);
  std::filesystem::remove_all(dir);
}

// The mesh mapper (paper §6) runs in the parallel refinement tests, each (sample, element) pair
// mapped on whichever thread asks first: the asset must still be the same bytes.
TEST(BuilderThreads, MappedBuildsAreRaceFreeAndIdentical) {
  const char* err = nullptr;
  const cadinterp_host* host = cadinterp_host_entry("foldplate", "edge=20", &err);
  ASSERT_NE(host, nullptr) << err;
  const std::string dir = std::filesystem::temp_directory_path().string() + "/cadinterp_btm_" +
                          std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  // Small enough for CI under ASan/TSan (coarse mesh, 24 samples). The box's corners are
  // samples of every build, and their meshes differ (the fold's topology change), so the
  // refinement tests do run the mapper.
  o.max_samples = 24;
  {
    const cadinterp::mesh::Host h(*host);
    const cadinterp::mesh::Sample lo = h.evaluate(h.lower().data());
    const cadinterp::mesh::Sample hi = h.evaluate(h.upper().data());
    ASSERT_TRUE(lo.feasible && hi.feasible);
    EXPECT_FALSE(cadinterp::mesh::same_combinatorics(lo, hi));
  }
  std::vector<std::vector<char>> assets;
  for (int threads : {1, 3}) {
    o.threads = threads;
    const std::string out = dir + "/a" + std::to_string(threads) + ".cadi";
    const auto r = cadinterp::builder::build_asset(*host, o, out);
    ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
    EXPECT_EQ(r.report.infeasible_elements, 0);
    assets.push_back(bytes_of(out));
  }
  EXPECT_EQ(assets[0], assets[1]);
  std::filesystem::remove_all(dir);
}

// Elements are built on the executor's threads, and canonical refinement (mapping/
// canonical_refine.h) maps and measures an element's terms on them too: a bracket at two
// resolutions across its bend angle, where elements across the split refine their canonical
// mesh, gives the same bytes and the same element counts on 1 and 3 threads.
TEST(BuilderThreads, RefinedCanonicalBuildsAreRaceFreeAndIdentical) {
  const char* err = nullptr;
  cadinterp::builder::SplitHost two;
  two.below = cadinterp_host_entry("bracket", "cells=3", &err);
  two.above = cadinterp_host_entry("bracket", "cells=6", &err);
  ASSERT_NE(two.below, nullptr) << err;
  ASSERT_NE(two.above, nullptr) << err;
  two.parameter = 3;
  two.split = 120.0;
  two.identity = "bracket, cells=3 up to a 120 degree bend, cells=6 beyond";
  const cadinterp_host host = two.host();
  const std::string dir = std::filesystem::temp_directory_path().string() + "/cadinterp_btr_" +
                          std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.geometry_tolerance = 3e-3;
  o.field_tolerance = 1.0;
  o.max_samples = 20;
  std::vector<std::vector<char>> assets;
  std::vector<cadinterp::builder::BuildOutcome> outcomes;
  for (int threads : {1, 3}) {
    o.threads = threads;
    const std::string out = dir + "/a" + std::to_string(threads) + ".cadi";
    outcomes.push_back(cadinterp::builder::build_asset(host, o, out));
    const auto& r = outcomes.back();
    ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
    EXPECT_GT(r.stages.refined_elements, 0);
    assets.push_back(bytes_of(out));
  }
  for (std::size_t i = 1; i < assets.size(); ++i) {
    EXPECT_EQ(assets[0], assets[i]);
    EXPECT_EQ(outcomes[0].stages.refined_elements, outcomes[i].stages.refined_elements);
    EXPECT_EQ(outcomes[0].stages.refined_vertices, outcomes[i].stages.refined_vertices);
    EXPECT_EQ(outcomes[0].report.stored_meshes, outcomes[i].report.stored_meshes);
    EXPECT_EQ(outcomes[0].report.infeasible_elements, outcomes[i].report.infeasible_elements);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
