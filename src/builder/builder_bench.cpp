// The builder's own time on 1 and 2 threads (target: parallel efficiency >= 0.8 on 2 threads),
// with an analytic host so fast that the builder, not the host, is what is timed:
//   bracket  the builder figures' bracket (cells=6, 400 samples, cadinterp-builder-figures)
//   refined  the bracket at two mesh resolutions across its bend angle (SplitHost), whose
//            elements across the split refine their canonical mesh (§6, canonical_refine.h)
//   cubic    the foldplate (edge=20, 100 samples), cubic: its B-rep topology changes across
//            the fold, so a refinement test there maps up to 4^K terms, and many of its waves
//            hold a single test, whose terms the spare thread then helps map
// BM_Speedup/<model> builds the model on 1 then 2 threads per iteration and reports
//   speedup = wall(1 thread) / wall(2 threads), efficiency = speedup / 2,
//   cpu_per_wall = process CPU time / wall time of the 2-thread build (2 at best),
// and the 2-thread build's stage times. Wall speed-ups mean something only on a quiet machine:
//   nice -n 10 build/release/src/builder/builder_bench --benchmark_filter=Speedup
//     --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <time.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "analytic_host.h"
#include "builder/build.h"
#include "builder/builder_e2e.h"
#include "cadinterp/cadinterp_builder.h"

namespace {

using namespace cadinterp;

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

const cadinterp_host* analytic(const char* model, const char* options) {
  const char* err = nullptr;
  const cadinterp_host* h = cadinterp_host_entry(model, options, &err);
  if (!h) throw std::runtime_error(std::string(model) + ": " + (err ? err : "?"));
  return h;
}

// The model's host and build options (the same as the figures and the thread tests).
struct Model {
  cadinterp_host host{};
  cadinterp_build_options options{};
  builder::SplitHost split;  // the refined model's two resolutions
};

const Model& model(int which) {
  static Model bracket, refined, cubic;
  static bool made = false;
  if (!made) {
    bracket.host = *analytic("bracket", "cells=6");
    cadinterp_build_options_init(&bracket.options);
    bracket.options.max_samples = 400;
    refined.split.below = analytic("bracket", "cells=3");
    refined.split.above = analytic("bracket", "cells=6");
    refined.split.parameter = 3;  // the bend angle
    refined.split.split = 120.0;
    refined.split.identity = "bracket, cells=3 up to a 120 degree bend, cells=6 beyond";
    refined.host = refined.split.host();
    cadinterp_build_options_init(&refined.options);
    refined.options.geometry_tolerance = 3e-3;
    refined.options.field_tolerance = 1.0;
    refined.options.max_samples = 20;
    cubic.host = *analytic("foldplate", "edge=20");
    cadinterp_build_options_init(&cubic.options);
    cubic.options.degree = 3;
    cubic.options.max_samples = 100;
    made = true;
  }
  return which == 0 ? bracket : which == 1 ? refined : cubic;
}

struct Timed {
  double wall = 0, cpu = 0;
  builder::BuildOutcome outcome;
};

Timed build(const Model& m, int threads) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "cadinterp_builder_bench.cadi").string();
  cadinterp_build_options o = m.options;
  o.threads = threads;
  Timed t;
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  t.outcome = builder::build_asset(m.host, o, path);
  t.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  t.cpu = process_cpu_seconds() - cpu0;
  std::filesystem::remove(path);
  if (t.outcome.status != CADINTERP_OK) throw std::runtime_error("build: " + t.outcome.error);
  return t;
}

void BM_Build(benchmark::State& state) {
  const Model& m = model(static_cast<int>(state.range(0)));
  const int threads = static_cast<int>(state.range(1));
  Timed t;
  for (auto _ : state) t = build(m, threads);
  state.counters["cpu_per_wall"] = t.cpu / t.wall;
  state.counters["sampling_s"] = t.outcome.stages.sampling_seconds;
  state.counters["refinement_s"] = t.outcome.stages.refinement_seconds;
  state.counters["elements_s"] = t.outcome.stages.elements_seconds;
}

void BM_Speedup(benchmark::State& state) {
  const Model& m = model(static_cast<int>(state.range(0)));
  double one = 0, two = 0, cpu = 0;
  Timed t;
  for (auto _ : state) {
    one += build(m, 1).wall;
    t = build(m, 2);
    two += t.wall;
    cpu += t.cpu;
  }
  state.counters["speedup"] = one / two;
  state.counters["efficiency"] = one / two / 2;
  state.counters["cpu_per_wall"] = cpu / two;
  state.counters["refinement_s"] = t.outcome.stages.refinement_seconds;
  state.counters["elements_s"] = t.outcome.stages.elements_seconds;
}

// What a build holds of its elements (BuildOptions::encode_elements): each element encoded as
// it is built, against the reference of the same build holding its raw arrays, in the same run:
//   raw_MB, held_MB = the elements' bytes either way; held_over_raw (target: < 0.5);
//   asset_MB = the asset's size (its blobs deduplicated).
// Both builds write the same asset byte for byte (error: otherwise).
//   build/release/src/builder/builder_bench --benchmark_filter=ElementMemory
void BM_ElementMemory(benchmark::State& state) {
  const Model& m = model(static_cast<int>(state.range(0)));
  const mesh::Host host(m.host);
  builder::BuildOptions o;
  o.degree = m.options.degree == 3 ? core::Degree::Cubic : core::Degree::Linear;
  o.geometry_tolerance = m.options.geometry_tolerance;
  o.field_tolerance = m.options.field_tolerance;
  o.max_samples = m.options.max_samples;
  o.threads = 2;
  double raw = 0, held = 0, asset = 0;
  for (auto _ : state) {
    o.encode_elements = false;
    const builder::BuildResult r = builder::build(host, o);
    o.encode_elements = true;
    const builder::BuildResult h = builder::build(host, o);
    raw = held = 0;
    for (const format::ElementData& ed : r.content.elements)
      raw += static_cast<double>(format::element_array_bytes(ed));
    for (const format::ElementData& ed : h.content.elements)
      held += ed.encoded ? static_cast<double>(ed.encoded->bytes()) : 0.0;
    const format::WriteOptions w = builder::asset_write_options(o);
    const std::vector<std::uint8_t> bytes = format::write_asset(h.content, w);
    if (bytes != format::write_asset(r.content, w)) {
      state.SkipWithError("the encoded elements write another asset");
      return;
    }
    asset = static_cast<double>(bytes.size());
  }
  state.counters["raw_MB"] = raw / 1e6;
  state.counters["held_MB"] = held / 1e6;
  state.counters["held_over_raw"] = held / raw;
  state.counters["asset_MB"] = asset / 1e6;
}

// One run per model (range(0): 0 bracket, 1 refined, 2 cubic), a single iteration in wall-clock
// seconds.
void each_model(benchmark::internal::Benchmark* b) {
  b->ArgName("model")
      ->Arg(0)
      ->Arg(1)
      ->Arg(2)
      ->Unit(benchmark::kSecond)
      ->UseRealTime()
      ->Iterations(1);
}

// range(0): 0 bracket, 1 refined, 2 cubic; range(1): threads.
BENCHMARK(BM_Build)
    ->ArgNames({"model", "threads"})
    ->ArgsProduct({{0, 1, 2}, {1, 2}})
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);
BENCHMARK(BM_Speedup)->Apply(each_model);
BENCHMARK(BM_ElementMemory)->Apply(each_model);

}  // namespace

BENCHMARK_MAIN();
