// Runtime performance against the in-repo bandwidth probe, measured in the same run
// (targets: eval <= 1.2x probe, eval+grad <= 1.5x eval, one scalar field <= 1.4x, cell
// switch <= 5 ms with the fast codec, open independent of blob bytes).
//
// Fixture: the synthetic box at 80 x 40 x 30 cells (103,361 vertices, 576,000 tets), K = 3,
// linear, refined once in every direction: 8 elements of 8 samples each. The probe blends the
// same 8 decoded position arrays the eval blends (blend_arrays, bandwidth_probe.h).
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include "cadinterp/cadinterp.h"
#include "format/asset_reader.h"
#include "format/synthetic_asset.h"
#include "runtime/bandwidth_probe.h"

namespace {

using namespace cadinterp;

struct Big {
  std::vector<std::uint8_t> bytes;  // fast codec, lossless
  std::vector<std::uint8_t> draco, meshopt, raw;
  std::string path, small_path;
  cadinterp_asset* asset = nullptr;
};

const Big& big() {
  static const std::unique_ptr<Big> b = [] {
    auto r = std::make_unique<Big>();
    format::SyntheticSpec spec = format::benchmark_fixture_spec();
    const format::SyntheticAsset a = format::make_synthetic_asset(spec);
    format::WriteOptions o;
    r->bytes = format::write_asset(a.content, o);
    o.float_codec = o.index_codec = format::Codec::Meshopt;
    r->meshopt = format::write_asset(a.content, o);
    o.float_codec = o.index_codec = format::Codec::Draco;
    r->draco = format::write_asset(a.content, o);
    o.float_codec = o.index_codec = format::Codec::Raw;
    r->raw = format::write_asset(a.content, o);
    r->path = (std::filesystem::temp_directory_path() / "cadinterp_bench_big.cadi").string();
    std::ofstream(r->path, std::ios::binary)
        .write(reinterpret_cast<const char*>(r->bytes.data()),
               static_cast<std::streamsize>(r->bytes.size()));
    spec.cells[0] = 2;
    spec.cells[1] = spec.cells[2] = 1;
    const auto small = format::write_asset(format::make_synthetic_asset(spec).content, {});
    r->small_path =
        (std::filesystem::temp_directory_path() / "cadinterp_bench_small.cadi").string();
    std::ofstream(r->small_path, std::ios::binary)
        .write(reinterpret_cast<const char*>(small.data()),
               static_cast<std::streamsize>(small.size()));
    if (cadinterp_open(r->path.c_str(), &r->asset) != CADINTERP_OK) std::abort();
    return r;
  }();
  return *b;
}

const double kX[3] = {0.3, 0.6, 0.2};

// Seconds per call of the probe on the arrays the eval at kX blends.
double probe_seconds() {
  static const double s = [] {
    const auto reader =
        format::AssetReader::open_memory(big().bytes.data(), big().bytes.size(), false);
    const int e = reader->basis().locate(kX);
    const format::DecodedElement d = reader->decode_element(e);
    std::vector<const float*> arrays;
    std::vector<float> w;
    for (const auto& p : d.positions) {
      arrays.push_back(p.data());
      w.push_back(1.0f / static_cast<float>(d.positions.size()));
    }
    std::vector<float> out(d.positions[0].size());
    const int reps = 200;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < reps; ++i) {
      runtime::blend_arrays(arrays.data(), w.data(), static_cast<int>(arrays.size()), out.size(),
                            out.data());
      benchmark::DoNotOptimize(out.data());
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
  }();
  return s;
}

// Runs `call` in the benchmark loop and reports time per call relative to the probe.
template <class F>
void against_probe(benchmark::State& state, F&& call) {
  call();  // warm: the element is decoded and cached
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) call();
  const double per = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() /
                     static_cast<double>(state.iterations());
  state.counters["x_probe"] = per / probe_seconds();
  state.counters["probe_us"] = probe_seconds() * 1e6;
}

void BM_Probe(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(probe_seconds());
  state.counters["probe_us"] = probe_seconds() * 1e6;
  state.counters["GBps"] = 9.0 * 4.0 * 3.0 * 103361.0 / probe_seconds() / 1e9;  // 8 read + 1 write
}

void BM_EvalWarm(benchmark::State& state) {
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(big().asset, &ws);
  cadinterp_mesh m;
  against_probe(state, [&] { benchmark::DoNotOptimize(cadinterp_eval(ws, kX, nullptr, 0, &m)); });
  cadinterp_workspace_destroy(ws);
}

void BM_EvalScalarField(benchmark::State& state) {
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(big().asset, &ws);
  cadinterp_mesh m;
  const int field = 0;  // temperature, per vertex
  against_probe(state, [&] { benchmark::DoNotOptimize(cadinterp_eval(ws, kX, &field, 1, &m)); });
  cadinterp_workspace_destroy(ws);
}

void BM_EvalPlusGrad(benchmark::State& state) {
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(big().asset, &ws);
  cadinterp_mesh m;
  cadinterp_mesh_grad g;
  (void)m;
  // cadinterp_grad returns the positions and their K derivatives in one pass.
  against_probe(state, [&] { benchmark::DoNotOptimize(cadinterp_grad(ws, kX, nullptr, 0, &g)); });
  cadinterp_workspace_destroy(ws);
}

void BM_Vjp(benchmark::State& state) {
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(big().asset, &ws);
  std::vector<float> adj(3 * 103361, 1.0f);
  double out[3];
  against_probe(state, [&] {
    benchmark::DoNotOptimize(cadinterp_vjp(ws, kX, adj.data(), nullptr, nullptr, 0, out));
  });
  cadinterp_workspace_destroy(ws);
}

// Cell switch: what moving x into another element costs, by codec (range(0): 0 raw,
// 1 quant-delta-zstd, 2 meshopt, 3 draco), on the public paths a switch takes. Element kX and
// kXNeighbour are neighbours with the same topology (the synthetic mesh never changes
// combinatorics, so the writer stores the topology once). Decoding is multi-threaded: times are
// wall-clock (UseRealTime). Counters: minor page faults per iteration (fresh memory costs a fault
// per 4 KiB page), decoded MB per iteration.
const double kXNeighbour[3] = {0.7, 0.6, 0.2};

const std::vector<std::uint8_t>& codec_bytes(std::int64_t codec) {
  const Big& b = big();
  const std::vector<std::uint8_t>* bytes[4] = {&b.raw, &b.bytes, &b.meshopt, &b.draco};
  return *bytes[codec];
}

long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}

// Runs the loop, then sets the common counters.
template <class F>
void switch_loop(benchmark::State& state, double decoded_mb, F&& body) {
  const auto& file = codec_bytes(state.range(0));
  const long faults0 = minor_faults();
  for (auto _ : state) body();
  const double n = static_cast<double>(state.iterations());
  state.counters["faults"] = static_cast<double>(minor_faults() - faults0) / n;
  state.counters["decoded_MB"] = decoded_mb;
  state.counters["asset_MB"] = static_cast<double>(file.size()) / 1e6;
  state.counters["ratio_to_raw"] =
      static_cast<double>(file.size()) / static_cast<double>(big().raw.size());
  state.SetLabel(format::codec_name(static_cast<format::Codec>(state.range(0))));
}

double mb(const format::DecodedElement& d) { return static_cast<double>(d.bytes()) / 1e6; }

// (a) The switch between neighbouring elements, through the reader: the neighbour's decoded
// element is still alive (a workspace or the cache holds it), so its topology is shared and only
// the canonical and per-term positions are decoded.
void BM_CellSwitch(benchmark::State& state) {
  const auto& file = codec_bytes(state.range(0));
  const auto reader = format::AssetReader::open_memory(file.data(), file.size(), false);
  const int e = reader->basis().locate(kX), neighbour = reader->basis().locate(kXNeighbour);
  if (e == neighbour) std::abort();
  const format::DecodedElement held = reader->decode_element(neighbour);
  double decoded = 0.0;
  {
    const format::DecodedElement probe = reader->decode_element(e);
    if (probe.topology != held.topology) std::abort();  // the benchmark's premise
    decoded = mb(probe);
  }
  switch_loop(state, decoded, [&] { benchmark::DoNotOptimize(reader->decode_element(e)); });
}

// (b) The same element with nothing holding its topology: topology, canonical and positions are
// all decoded (the first visit of a model, or a switch to an element of another topology).
void BM_CellSwitchFromScratch(benchmark::State& state) {
  const auto& file = codec_bytes(state.range(0));
  const auto reader = format::AssetReader::open_memory(file.data(), file.size(), false);
  const int e = reader->basis().locate(kX);
  double decoded = 0.0;
  {  // released before the loop: nothing may hold the topology, or it would be shared
    const format::DecodedElement probe = reader->decode_element(e);
    decoded = mb(probe) + static_cast<double>(probe.topology->bytes()) / 1e6;
  }
  switch_loop(state, decoded, [&] {
    const format::DecodedElement d = reader->decode_element(e);
    if (d.topology.use_count() != 1) std::abort();  // decoded here, not shared
    benchmark::DoNotOptimize(d.positions.data());
  });
}

// (c) The field arrays, decoded when a call first asks for a field after a switch (the runtime's
// lazy path calls exactly this).
void BM_CellSwitchFields(benchmark::State& state) {
  const auto& file = codec_bytes(state.range(0));
  const auto reader = format::AssetReader::open_memory(file.data(), file.size(), false);
  const int e = reader->basis().locate(kX);
  double decoded = 0.0;
  for (const auto& f : reader->decode_fields(e))
    decoded += static_cast<double>(f.size() * sizeof(float)) / 1e6;
  switch_loop(state, decoded, [&] { benchmark::DoNotOptimize(reader->decode_fields(e)); });
}

// (a) and (c) end to end through the C ABI: one workspace evaluating alternately at kX and
// kXNeighbour with a cache budget that holds one element, so every call misses the cache and
// decodes (sharing the topology the workspace still holds), then blends. range(1) = 0: shape
// only; 1: also field 0 (temperature), whose arrays the call then decodes. Includes the eval's
// blend (BM_EvalWarm, BM_EvalScalarField for the cost without a switch).
void BM_CellSwitchEval(benchmark::State& state) {
  const auto& file = codec_bytes(state.range(0));
  cadinterp_asset* asset = nullptr;
  cadinterp_workspace* ws = nullptr;
  if (cadinterp_open_memory(file.data(), file.size(), 0, &asset) != CADINTERP_OK ||
      cadinterp_set_cache_budget(asset, 1) != CADINTERP_OK ||
      cadinterp_workspace_create(asset, &ws) != CADINTERP_OK)
    std::abort();
  const int field = 0;
  const int nfields = static_cast<int>(state.range(1));
  cadinterp_mesh m;
  int i = 0;
  auto call = [&] {
    if (cadinterp_eval(ws, (i++ & 1) ? kXNeighbour : kX, &field, nfields, &m) != CADINTERP_OK)
      std::abort();
  };
  call();
  call();
  switch_loop(state, 0.0, call);
  state.counters.erase("decoded_MB");
  state.SetLabel(std::string(format::codec_name(static_cast<format::Codec>(state.range(0)))) +
                 (nfields ? " +field" : " shape"));
  cadinterp_workspace_destroy(ws);
  cadinterp_close(asset);
}

void BM_Open(benchmark::State& state) {
  const std::string& path = state.range(0) ? big().path : big().small_path;
  for (auto _ : state) {
    cadinterp_asset* a = nullptr;
    if (cadinterp_open(path.c_str(), &a) != CADINTERP_OK) state.SkipWithError("open failed");
    cadinterp_close(a);
  }
  state.counters["file_MB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
}

BENCHMARK(BM_Probe)->Unit(benchmark::kMicrosecond)->Iterations(1);
BENCHMARK(BM_EvalWarm)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EvalScalarField)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EvalPlusGrad)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Vjp)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CellSwitch)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CellSwitchFromScratch)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CellSwitchFields)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CellSwitchEval)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Open)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
