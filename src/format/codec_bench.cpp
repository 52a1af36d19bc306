// Size, error and speed of every codec on a ~100k-vertex tet mesh (codec.h).
//
// Data: a 60 x 40 x 40 box (102,541 vertices, 576,000 tets, 25,600 boundary triangles), bent
// (codec_test_data.h). Float arrays: the canonical positions (no reference), a sample's positions
// coded against the canonical ones, a scalar field; each lossless and lossy with
// max_abs_error = 1e-4 * bbox diagonal (positions) or 1e-4 * value range (field).
// Throughput is raw float32 (or uint32 index) bytes per second, for encode and decode.
// Counters: ratio = encoded / raw bytes; max_err = largest |decoded - original|;
// err_per_bound = max_err / max_abs_error.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "format/codec.h"
#include "format/codec_test_data.h"

namespace {
using namespace cadinterp::format;

constexpr Codec kCodecs[] = {Codec::Raw, Codec::QuantDeltaZstd, Codec::Meshopt, Codec::Draco};

struct BenchData {
  explicit BenchData(testdata::Layout layout)
      : mesh(testdata::make_box_mesh(60, 40, 40, 0.05, layout)),
        diag(testdata::bbox_diagonal(mesh.canonical)) {
    const auto [lo, hi] = std::minmax_element(mesh.field.begin(), mesh.field.end());
    field_range = static_cast<double>(*hi) - static_cast<double>(*lo);
  }
  testdata::BoxMesh mesh;
  double diag;
  double field_range;
};

const BenchData& data(testdata::Layout layout) {
  static const BenchData grid(testdata::Layout::Grid);
  static const BenchData irregular(testdata::Layout::Irregular);
  return layout == testdata::Layout::Grid ? grid : irregular;
}

const char* layout_name(testdata::Layout layout) {
  return layout == testdata::Layout::Grid ? "grid" : "irregular";
}

struct FloatArray {
  const char* name;
  const std::vector<float>* values;
  const std::vector<float>* ref;
  int comps;
  double lossy_error;
};

std::vector<FloatArray> float_arrays(testdata::Layout layout) {
  const BenchData& d = data(layout);
  return {{"positions", &d.mesh.canonical, nullptr, 3, 1e-4 * d.diag},
          {"sample_vs_canonical", &d.mesh.sample, &d.mesh.canonical, 3, 1e-4 * d.diag},
          {"field", &d.mesh.field, nullptr, 1, 1e-4 * d.field_range}};
}

void float_counters(benchmark::State& state, Codec codec, const FloatArray& a, double e,
                    const std::vector<std::uint8_t>& blob) {
  const std::size_t n = a.values->size(), rows = n / a.comps;
  std::vector<float> out(n);
  decode_floats(codec, blob.data(), blob.size(), rows, a.comps, a.ref ? a.ref->data() : nullptr,
                out.data());
  double max_err = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    max_err = std::max(max_err, std::fabs(double(out[i]) - double((*a.values)[i])));
  }
  state.counters["ratio"] = double(blob.size()) / double(n * 4);
  state.counters["max_err"] = max_err;
  state.counters["err_per_bound"] = e > 0 ? max_err / e : 0.0;
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * n * 4));
}

void encode_floats_bm(benchmark::State& state, Codec codec, FloatArray a, double e) {
  const std::size_t rows = a.values->size() / a.comps;
  const float* ref = a.ref ? a.ref->data() : nullptr;
  std::vector<std::uint8_t> blob;
  try {
    for (auto _ : state) {
      blob = encode_floats(codec, a.values->data(), rows, a.comps, ref, FloatParams{e});
      benchmark::DoNotOptimize(blob.data());
    }
  } catch (const CodecError& err) {
    state.SkipWithError(err.what());
    return;
  }
  float_counters(state, codec, a, e, blob);
}

void decode_floats_bm(benchmark::State& state, Codec codec, FloatArray a, double e) {
  const std::size_t rows = a.values->size() / a.comps;
  const float* ref = a.ref ? a.ref->data() : nullptr;
  std::vector<std::uint8_t> blob;
  try {
    blob = encode_floats(codec, a.values->data(), rows, a.comps, ref, FloatParams{e});
  } catch (const CodecError& err) {
    state.SkipWithError(err.what());
    return;
  }
  std::vector<float> out(a.values->size());
  for (auto _ : state) {
    decode_floats(codec, blob.data(), blob.size(), rows, a.comps, ref, out.data());
    benchmark::DoNotOptimize(out.data());
  }
  float_counters(state, codec, a, e, blob);
}

void index_bm(benchmark::State& state, testdata::Layout layout, Codec codec, int per_row,
              bool decode) {
  const auto& m = data(layout).mesh;
  const auto& idx = per_row == 3 ? m.tris : m.tets;
  const std::size_t rows = idx.size() / per_row;
  const auto vc = static_cast<std::uint32_t>(m.vertex_count());
  std::vector<std::uint8_t> blob;
  std::vector<std::uint32_t> out(idx.size());
  try {
    blob = encode_indices(codec, idx.data(), rows, per_row, vc);
    for (auto _ : state) {
      if (decode) {
        decode_indices(codec, blob.data(), blob.size(), rows, per_row, vc, out.data());
        benchmark::DoNotOptimize(out.data());
      } else {
        blob = encode_indices(codec, idx.data(), rows, per_row, vc);
        benchmark::DoNotOptimize(blob.data());
      }
    }
  } catch (const CodecError& err) {
    state.SkipWithError(err.what());
    return;
  }
  state.counters["ratio"] = double(blob.size()) / double(idx.size() * 4);
  state.counters["bytes_per_row"] = double(blob.size()) / double(rows);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * idx.size() * 4));
}

void register_layout(testdata::Layout layout);

int register_all() {
  for (testdata::Layout layout : {testdata::Layout::Irregular, testdata::Layout::Grid}) {
    register_layout(layout);
  }
  return 0;
}

void register_layout(testdata::Layout layout) {
  const std::string prefix = std::string("/") + layout_name(layout) + "/";
  for (const FloatArray& a : float_arrays(layout)) {
    for (bool lossy : {false, true}) {
      for (Codec c : kCodecs) {
        if (lossy && c == Codec::Raw) continue;
        const double e = lossy ? a.lossy_error : 0.0;
        const std::string name =
            prefix + a.name + (lossy ? "/lossy/" : "/lossless/") + codec_name(c);
        benchmark::RegisterBenchmark(("encode" + name).c_str(), encode_floats_bm, c, a, e)
            ->Unit(benchmark::kMillisecond);
        benchmark::RegisterBenchmark(("decode" + name).c_str(), decode_floats_bm, c, a, e)
            ->Unit(benchmark::kMillisecond);
      }
    }
  }
  for (int per_row : {4, 3}) {
    for (Codec c : kCodecs) {
      if (c == Codec::Draco && per_row == 4) continue;  // Unsupported
      const std::string name = prefix + (per_row == 4 ? "tets/" : "triangles/") + codec_name(c);
      benchmark::RegisterBenchmark(("encode" + name).c_str(), index_bm, layout, c, per_row, false)
          ->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark(("decode" + name).c_str(), index_bm, layout, c, per_row, true)
          ->Unit(benchmark::kMillisecond);
    }
  }
}

const int registered = register_all();

}  // namespace

BENCHMARK_MAIN();
