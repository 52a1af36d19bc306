// The builder's concurrent parts under ThreadSanitizer (label `concurrency`): host evaluations
// on the executor's threads, the wave's refinement tests answered in parallel, the sample store
// written from the delivering thread, and the same asset whatever the thread count.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "analytic_host.h"
#include "builder/build.h"
#include "builder/builder_e2e.h"
#include "mesh/host_call.h"
#include "mesh/mapper.h"
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

// The map cache (cadinterp_build_options.map_cache_bytes) drops its least recently used maps
// when full, while other threads may still read them, and the pairs needed again are mapped
// again: a cubic foldplate across its topology change (its elements' terms mapped by the
// refinement's tests, then by the element stage) built on 3 threads with the default cache and
// with 256 KiB (a few of its maps) gives the same bytes. The default maps each pair once; the
// small one maps the same pairs, about half of them again, and counts those.
TEST(BuilderThreads, ASmallMapCacheMapsAgainAndGivesTheSameAsset) {
  const char* err = nullptr;
  const cadinterp_host* host = cadinterp_host_entry("foldplate", "edge=20", &err);
  ASSERT_NE(host, nullptr) << err;
  const std::string dir = std::filesystem::temp_directory_path().string() + "/cadinterp_btc_" +
                          std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.degree = 3;
  o.max_samples = 40;
  o.threads = 3;
  std::vector<std::vector<char>> assets;
  std::vector<cadinterp_build_stages> stages;
  for (std::uint64_t bytes : {std::uint64_t{0}, std::uint64_t{262144}}) {
    o.map_cache_bytes = bytes;
    const std::string out = dir + "/a" + std::to_string(bytes) + ".cadi";
    const auto r = cadinterp::builder::build_asset(*host, o, out);
    ASSERT_EQ(r.status, CADINTERP_OK) << r.error;
    assets.push_back(bytes_of(out));
    stages.push_back(r.stages);
    std::printf("[ figures ] map cache of %llu bytes: %d maps, %d again\n",
                static_cast<unsigned long long>(bytes), r.stages.maps, r.stages.maps_again);
  }
  EXPECT_GT(stages[0].maps, 0);
  EXPECT_EQ(stages[0].maps_again, 0);
  EXPECT_GT(stages[1].maps_again, 0);
  EXPECT_EQ(stages[1].maps - stages[1].maps_again, stages[0].maps);
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

// The builder's mesh mapper, counting its calls per (source, canonical) pair of samples.
class CountingMapper final : public cadinterp::mesh::Mapper {
 public:
  bool map(const cadinterp::mesh::Sample& source, const cadinterp::mesh::Sample& canonical,
           cadinterp::mesh::MappedSample& out, std::string& why) const override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      ++calls_[std::make_pair(&source, &canonical)];
    }
    return cadinterp::builder::default_mapper().map(source, canonical, out, why);
  }
  const char* name() const override { return cadinterp::builder::default_mapper().name(); }
  int calls() const {
    int n = 0;
    for (const auto& c : calls_) n += c.second;
    return n;
  }
  int pairs() const { return static_cast<int>(calls_.size()); }

 private:
  mutable std::mutex mu_;
  // The build's rows are samples it holds until it ends, so their addresses name them.
  mutable std::map<std::pair<const void*, const void*>, int> calls_;
};

// Each pair of samples is mapped once however many threads ask for it: a thread that finds a
// pair being mapped waits for it, and a wave of fewer tests than threads maps its tests' terms
// on the spare threads. A cubic foldplate across its B-rep topology change, at a budget where
// some waves hold a single test of 80-90 terms: its build maps the same pairs on 1 and 3
// threads, each once, and gives the same elements.
TEST(BuilderThreads, EachPairIsMappedOnceOnAnyThreadCount) {
  const char* err = nullptr;
  const cadinterp_host* h = cadinterp_host_entry("foldplate", "edge=30", &err);
  ASSERT_NE(h, nullptr) << err;
  const cadinterp::mesh::Host host(*h);
  std::vector<cadinterp::builder::BuildResult> results;
  std::vector<int> calls, pairs;
  for (int threads : {1, 3}) {
    CountingMapper mapper;
    cadinterp::builder::BuildOptions o;
    o.degree = cadinterp::core::Degree::Cubic;
    o.encode_elements = false;  // the positions are compared below
    o.max_samples = 100;
    o.threads = threads;
    o.mapper = &mapper;
    results.push_back(cadinterp::builder::build(host, o));
    calls.push_back(mapper.calls());
    pairs.push_back(mapper.pairs());
    EXPECT_EQ(results.back().details.maps, calls.back());
    EXPECT_EQ(results.back().details.maps_again, 0);
    std::printf("[ figures ] cubic foldplate, %d threads: %d mappings of %d pairs\n", threads,
                calls.back(), pairs.back());
  }
  EXPECT_GT(pairs[0], 0);
  EXPECT_EQ(calls[0], pairs[0]);
  EXPECT_EQ(calls[1], pairs[1]);
  EXPECT_EQ(pairs[0], pairs[1]);
  ASSERT_EQ(results[0].content.elements.size(), results[1].content.elements.size());
  for (std::size_t e = 0; e < results[0].content.elements.size(); ++e)
    EXPECT_EQ(results[0].content.elements[e].positions, results[1].content.elements[e].positions);
}

}  // namespace
