// Runtime at scale, against the in-repo bandwidth probe measured in the same run (targets:
// a K = 3 cubic eval within 1.5x of bytes / bandwidth, eval+grad <= 1.5x eval, open <= 5 ms and
// independent of blob bytes), and the blend kernels of blend_multi.h against the probe.
//
// Every timed call alternates with a probe call on arrays of the same count and size (for evals:
// a second decoding of the element the eval blends, as in runtime_bench.cpp), and the ratios are
// of the sums, so load from other processes on the machine slows both sides alike instead of
// skewing the ratio.
//
//   bytes(eval) = terms * #V * 12 read + #V * 12 written
//   bytes(grad) = terms * #V * 12 read + (K + 1) * #V * 12 written
//   bandwidth   = (terms + 1) * #V * 12 / probe time   (blend_arrays, bandwidth_probe.h)
//   x_bytes_over_bw = time / (bytes / bandwidth)
//
// Times are this thread's CPU time (see cpu_seconds), except for open, which waits for the disk.
//
// Fixtures: the synthetic box of runtime_bench.cpp (80 x 40 x 30 cells, 103,361 vertices), K = 3:
// linear and cubic refined once in every direction (8 terms per element either way), and cubic
// refined to 60 samples (26-44 terms; the element with 44). Open: raw-codec files of ~10 MB and
// ~1 GB with the same index, in the temp directory, written on the first run and reused.
// Results: see the end of this file.
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "format/asset_reader.h"
#include "format/synthetic_asset.h"
#include "runtime/bandwidth_probe.h"
#include "runtime/blend_multi.h"

namespace {

using namespace cadinterp;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// This thread's CPU time: the machine the figures come from is shared, and CPU time leaves out
// the time other processes hold the core (on a quiet machine it equals wall time here: nothing
// timed waits for I/O).
double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Runs the calls in turn, each once per iteration, after one warm-up round (decoded element
// cached, workspace sized, pages touched). The benchmark's time is the first call's (manual
// time, CPU seconds). Returns the mean CPU seconds of each call.
std::vector<double> alternate(benchmark::State& state,
                              const std::vector<std::function<void()>>& calls) {
  for (const auto& c : calls) c();
  std::vector<double> t(calls.size(), 0.0);
  for (auto _ : state) {
    double first = 0.0;
    for (std::size_t i = 0; i < calls.size(); ++i) {
      const double t0 = cpu_seconds();
      calls[i]();
      const double dt = cpu_seconds() - t0;
      t[i] += dt;
      if (i == 0) first = dt;
    }
    state.SetIterationTime(first);
  }
  for (double& v : t) v /= static_cast<double>(state.iterations());
  return t;
}

// ---- Blend kernels against the probe ------------------------------------------------------

constexpr std::size_t kN = 103361 * 3;  // the positions of the fixture's box

struct Arrays {
  std::vector<std::vector<float>> storage;
  std::vector<const float*> ptrs;
  std::vector<float> weights;  // 9 rows of m
  std::vector<std::vector<float>> outs;
  std::vector<float*> out_ptrs;
};

Arrays& arrays(int m) {
  static std::vector<std::unique_ptr<Arrays>> cache(65);
  auto& slot = cache[static_cast<std::size_t>(m)];
  if (!slot) {
    slot = std::make_unique<Arrays>();
    std::mt19937 rng(static_cast<unsigned>(m));
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (int j = 0; j < m; ++j) {
      slot->storage.emplace_back(kN);
      for (float& v : slot->storage.back()) v = u(rng);
      slot->ptrs.push_back(slot->storage.back().data());
    }
    for (int j = 0; j < 9 * m; ++j) slot->weights.push_back(u(rng) / static_cast<float>(m));
    for (int o = 0; o < 9; ++o) {
      slot->outs.emplace_back(kN, 0.0f);
      slot->out_ptrs.push_back(slot->outs.back().data());
    }
  }
  return *slot;
}

// The kernel blend_multi.cpp replaced (blocks of 512 kept in L1, one axpy per input and
// output; restrict on parameters, where GCC honours it), kept to re-check the choice on other
// machines.
template <std::size_t L>
inline void previous_scale(float* __restrict out, const float* __restrict a, float w) {
  for (std::size_t k = 0; k < L; ++k) out[k] = w * a[k];
}
template <std::size_t L>
inline void previous_axpy(float* __restrict out, const float* __restrict a, float w) {
  for (std::size_t k = 0; k < L; ++k) out[k] += w * a[k];
}
template <std::size_t L>
void previous_block(const float* const* arrays, const float* weights, int m, int nout,
                    std::size_t i0, float* const* outs) {
  for (int o = 0; o < nout; ++o) previous_scale<L>(outs[o] + i0, arrays[0] + i0, weights[o * m]);
  for (int j = 1; j < m; ++j)
    for (int o = 0; o < nout; ++o)
      previous_axpy<L>(outs[o] + i0, arrays[j] + i0, weights[o * m + j]);
}
void previous_blend_multi(const float* const* arrays, const float* weights, int m, std::size_t n,
                          int nout, float* const* outs) {
  std::size_t i = 0;
  for (; i + 512 <= n; i += 512) previous_block<512>(arrays, weights, m, nout, i, outs);
  for (; i + 16 <= n; i += 16) previous_block<16>(arrays, weights, m, nout, i, outs);
  for (; i < n; ++i) previous_block<1>(arrays, weights, m, nout, i, outs);
}

// Args: kernel (0..: blend_multi_kernels(), then the previous kernel), m, nout.
void BM_BlendMulti(benchmark::State& state) {
  const auto kernels = runtime::blend_multi_kernels();
  const auto k = static_cast<std::size_t>(state.range(0));
  const int m = static_cast<int>(state.range(1)), nout = static_cast<int>(state.range(2));
  if (k > kernels.size()) {
    state.SkipWithError("kernel not supported on this CPU");
    return;
  }
  const runtime::BlendMultiFn fn = k < kernels.size() ? kernels[k].fn : previous_blend_multi;
  state.SetLabel(k < kernels.size() ? kernels[k].name : "previous");
  Arrays& a = arrays(m);
  const auto t = alternate(
      state, {[&] {
                fn(a.ptrs.data(), a.weights.data(), m, kN, nout, a.out_ptrs.data());
                benchmark::ClobberMemory();
              },
              [&] {
                runtime::blend_arrays(a.ptrs.data(), a.weights.data(), m, kN, a.outs[0].data());
                benchmark::ClobberMemory();
              }});
  const double tc = t[0], tp = t[1];
  const double bytes = 4.0 * static_cast<double>(kN) * (m + nout);
  const double bw = 4.0 * static_cast<double>(kN) * (m + 1) / tp;
  state.counters["GBps"] = bytes / tc / 1e9;
  state.counters["probe_GBps"] = bw / 1e9;
  state.counters["x_bytes_over_bw"] = tc / (bytes / bw);
}

void kernel_args(benchmark::internal::Benchmark* b) {
  const int kernels = static_cast<int>(runtime::blend_multi_kernels().size()) + 1;
  for (int m : {8, 44})
    for (int nout : {1, 4, 9})
      for (int k = 0; k < kernels; ++k) b->Args({k, m, nout});
}

// ---- Assets ---------------------------------------------------------------------------------

// The box of runtime_bench.cpp, K = 3, positions only (the figures are about position arrays).
format::SyntheticSpec box_spec(core::Degree degree) {
  format::SyntheticSpec spec;
  spec.K = 3;
  spec.degree = degree;
  spec.cells[0] = 80;
  spec.cells[1] = 40;
  spec.cells[2] = 30;
  spec.fields = false;
  spec.max_samples = 1000;
  spec.tolerance = 1e9;  // refined once in every direction, then accepted
  spec.check_face_centres = false;
  return spec;
}

// Refined once per direction, a cubic element has only the 8 terms of a linear one (the level-1
// B-splines centred outside the box are folded onto the corners, basis.h). A tolerance no element
// meets, stopped by a budget of 60 samples, gives 22 elements of 26-44 terms: a cubic element with
// many terms.
format::SyntheticSpec deep_cubic_spec() {
  format::SyntheticSpec spec = box_spec(core::Degree::Cubic);
  spec.tolerance = 1e-12;
  spec.max_samples = 60;
  return spec;
}

// The open benchmark's assets: the same tree (linear, refined once: 8 elements of 8 terms, 27
// samples, so the same index) on boxes of ~9.5 k and ~860 k vertices, with both fields. The
// writer stores each distinct blob once, so the file holds 27 samples' positions and fields and
// one topology: ~1.2 kB per vertex.
format::SyntheticSpec open_spec(bool big) {
  format::SyntheticSpec spec = box_spec(core::Degree::Linear);
  spec.fields = true;
  const int cells[2][3] = {{34, 17, 14}, {160, 80, 66}};
  for (int d = 0; d < 3; ++d) spec.cells[d] = cells[big][d];
  return spec;
}

enum FileId { kDeepCubicFile = 0, kOpen10MB = 1, kOpen1GB = 2 };

struct AssetFile {
  std::string path;
  std::uintmax_t bytes = 0;
};

// Raw codec: generation is bound by the adaptive driver and the write, not by compression.
// Written once to the temp directory and reused; regenerated when missing or of a size outside
// the expected range (written by another version). write_asset_file renames a complete file
// into place, so an interrupted run leaves no file to reuse.
const AssetFile& asset_file(int id) {
  static std::unique_ptr<AssetFile> cache[3];
  auto& a = cache[id];
  if (a) return *a;
  a = std::make_unique<AssetFile>();
  const char* const names[3] = {"cubic60", "open_10MB", "open_1GB"};
  const double mb[3][2] = {{80, 160}, {8, 14}, {800, 1400}};
  a->path = (std::filesystem::temp_directory_path() /
             (std::string("cadinterp_scale_") + names[id] + ".cadi"))
                .string();
  std::error_code ec;
  auto size = std::filesystem::file_size(a->path, ec);
  const auto in_range = [&] {
    const double m = static_cast<double>(size) / 1e6;
    return !ec && m >= mb[id][0] && m <= mb[id][1];
  };
  if (!in_range()) {
    const auto t0 = Clock::now();
    format::WriteOptions o;
    o.float_codec = o.index_codec = format::Codec::Raw;
    const format::SyntheticSpec spec =
        id == kDeepCubicFile ? deep_cubic_spec() : open_spec(id == kOpen1GB);
    format::write_asset_file(format::make_synthetic_asset(spec).content, o, a->path);
    ec.clear();
    size = std::filesystem::file_size(a->path, ec);
    std::fprintf(stderr, "wrote %s: %.1f MB in %.1f s\n", a->path.c_str(),
                 static_cast<double>(size) / 1e6, seconds_since(t0));
    if (!in_range())
      std::fprintf(stderr, "  (outside the expected %g-%g MB)\n", mb[id][0], mb[id][1]);
  }
  a->bytes = size;
  return *a;
}

// ---- Eval and eval+grad at scale -----------------------------------------------------------

enum FixtureId { kLinear = 0, kCubicOnce = 1, kCubicDeep = 2 };
const char* const kFixtureNames[] = {"linear, 8 terms", "cubic refined once, 8 terms",
                                     "cubic, 60 samples, most terms"};

struct Fixture {
  std::vector<std::uint8_t> bytes;  // in-memory assets; the deep one is mapped from its file
  cadinterp_asset* asset = nullptr;
  double x[3] = {0.3, 0.6, 0.2};
  decltype(format::DecodedElement::positions) positions;  // the decoded meshes, for the probe
  std::size_t vertices = 0;
  int K = 0;
  Fixture() = default;
  Fixture(const Fixture&) = delete;
  Fixture& operator=(const Fixture&) = delete;
  ~Fixture() { cadinterp_close(asset); }
};

const Fixture& fixture(int id) {
  static std::unique_ptr<Fixture> cache[3];
  auto& f = cache[id];
  if (f) return *f;
  f = std::make_unique<Fixture>();
  std::unique_ptr<format::AssetReader> reader;
  if (id == kCubicDeep) {
    const std::string& path = asset_file(kDeepCubicFile).path;
    if (cadinterp_open(path.c_str(), &f->asset) != CADINTERP_OK) std::abort();
    reader = format::AssetReader::open_file(path);
    // x at the centre of the element with the most terms.
    const core::CompiledBasis& b = reader->basis();
    int best = 0, most = 0;
    for (int e = 0; e < b.element_count(); ++e) {
      int n = 0;
      b.element_samples(e, &n);
      if (n > most) most = n, best = e;
    }
    double lo[3], hi[3];
    b.element_box(best, lo, hi);
    for (int d = 0; d < 3; ++d) f->x[d] = 0.5 * (lo[d] + hi[d]);
  } else {
    const auto a = format::make_synthetic_asset(
        box_spec(id == kCubicOnce ? core::Degree::Cubic : core::Degree::Linear));
    f->bytes = format::write_asset(a.content, {});
    if (cadinterp_open_memory(f->bytes.data(), f->bytes.size(), 0, &f->asset) != CADINTERP_OK)
      std::abort();
    reader = format::AssetReader::open_memory(f->bytes.data(), f->bytes.size(), false);
  }
  format::DecodedElement d = reader->decode_element(reader->basis().locate(f->x));
  f->positions = std::move(d.positions);
  f->vertices = d.vertex_count;
  f->K = reader->basis().dim();
  return *f;
}

// The probe on the arrays the eval at f.x blends.
struct Probe {
  std::vector<const float*> arrays;
  std::vector<float> w, out;
  explicit Probe(const Fixture& f) {
    for (const auto& p : f.positions) {
      arrays.push_back(p.data());
      w.push_back(1.0f / static_cast<float>(f.positions.size()));
    }
    out.resize(f.vertices * 3);
  }
  void operator()() {
    runtime::blend_arrays(arrays.data(), w.data(), static_cast<int>(arrays.size()), out.size(),
                          out.data());
    benchmark::ClobberMemory();
  }
};

void report(benchmark::State& state, const Fixture& f, double t, double t_probe, int outputs) {
  const double terms = static_cast<double>(f.positions.size());
  const double v12 = 12.0 * static_cast<double>(f.vertices);
  const double bw = (terms + 1) * v12 / t_probe;
  const double bytes = (terms + outputs) * v12;
  state.counters["terms"] = terms;
  state.counters["MB_moved"] = bytes / 1e6;
  state.counters["probe_GBps"] = bw / 1e9;
  state.counters["x_bytes_over_bw"] = t / (bytes / bw);
  state.SetLabel(kFixtureNames[state.range(0)]);
}

// Seconds per eval of each fixture, for the grad / eval ratio (BM_ScaleEval runs first).
double g_eval_seconds[3] = {0.0, 0.0, 0.0};

// Arg: FixtureId.
void BM_ScaleEval(benchmark::State& state) {
  const Fixture& f = fixture(static_cast<int>(state.range(0)));
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(f.asset, &ws);
  cadinterp_mesh m;
  Probe probe(f);
  const auto t =
      alternate(state, {[&] { benchmark::DoNotOptimize(cadinterp_eval(ws, f.x, nullptr, 0, &m)); },
                        [&] { probe(); }});
  report(state, f, t[0], t[1], 1);
  g_eval_seconds[state.range(0)] = t[0];
  cadinterp_workspace_destroy(ws);
}

// Eval+grad: positions and their K derivatives in one call. Only the grad alternates with the
// probe (a third call in the loop would evict the probe's arrays at 44 terms and flatter the
// ratio); x_eval divides by BM_ScaleEval's time for the same fixture.
void BM_ScaleEvalPlusGrad(benchmark::State& state) {
  const Fixture& f = fixture(static_cast<int>(state.range(0)));
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(f.asset, &ws);
  cadinterp_mesh_grad g;
  Probe probe(f);
  const auto t =
      alternate(state, {[&] { benchmark::DoNotOptimize(cadinterp_grad(ws, f.x, nullptr, 0, &g)); },
                        [&] { probe(); }});
  report(state, f, t[0], t[1], f.K + 1);
  if (g_eval_seconds[state.range(0)] > 0)
    state.counters["x_eval"] = t[0] / g_eval_seconds[state.range(0)];
  cadinterp_workspace_destroy(ws);
}

// ---- Open -----------------------------------------------------------------------------------

long page_faults_so_far() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt + u.ru_majflt;
}

void drop_from_page_cache(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
  ::close(fd);
}

// Args: 0 ~10 MB, 1 ~1 GB; cold (1: the file's pages are dropped from the page cache before
// every open, so whatever open reads comes from the disk).
void BM_Open(benchmark::State& state) {
  const AssetFile& a = asset_file(state.range(0) ? kOpen1GB : kOpen10MB);
  const bool cold = state.range(1) != 0;
  long faults = 0;
  int elements = 0;
  for (auto _ : state) {
    if (cold) {
      state.PauseTiming();
      drop_from_page_cache(a.path);
      state.ResumeTiming();
    }
    const long f0 = page_faults_so_far();
    cadinterp_asset* asset = nullptr;
    if (cadinterp_open(a.path.c_str(), &asset) != CADINTERP_OK) {
      state.SkipWithError(cadinterp_open_error());
      break;
    }
    elements = cadinterp_element_count(asset);
    cadinterp_close(asset);
    faults += page_faults_so_far() - f0;
  }
  state.counters["file_MB"] = static_cast<double>(a.bytes) / 1e6;
  state.counters["elements"] = elements;
  // Pages faulted in by one open: the header and the index, not the blobs.
  state.counters["page_faults"] =
      static_cast<double>(faults) /
      static_cast<double>(std::max<benchmark::IterationCount>(1, state.iterations()));
  state.SetLabel(cold ? "cold page cache" : "warm page cache");
}

// What a cold open costs at the least, and why it costs more: one access to the first 4 KiB
// of a file whose pages were dropped from the page cache. Args: as BM_Open; mode 0: pread,
// 1: first touch of a read-only mapping (what open does), 2: the same after
// madvise(MADV_RANDOM), which turns off the kernel's read-around of mapped files.
void BM_ColdFirstPage(benchmark::State& state) {
  const AssetFile& a = asset_file(state.range(0) ? kOpen1GB : kOpen10MB);
  const int mode = static_cast<int>(state.range(1));
  const auto size = static_cast<std::size_t>(a.bytes);
  for (auto _ : state) {
    state.PauseTiming();
    drop_from_page_cache(a.path);
    const int fd = ::open(a.path.c_str(), O_RDONLY | O_CLOEXEC);
    void* map =
        mode == 0 || fd < 0 ? MAP_FAILED : mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (map != MAP_FAILED && mode == 2) madvise(map, size, MADV_RANDOM);
    state.ResumeTiming();
    char page[4096];
    bool ok = false;
    if (mode == 0) {
      ok = fd >= 0 && pread(fd, page, sizeof page, 0) == sizeof page;
    } else if (map != MAP_FAILED) {
      benchmark::DoNotOptimize(*static_cast<const volatile char*>(map));
      ok = true;
    }
    state.PauseTiming();
    if (map != MAP_FAILED) munmap(map, size);
    if (fd >= 0) ::close(fd);
    state.ResumeTiming();
    if (!ok) {
      state.SkipWithError("cannot read the asset");
      break;
    }
  }
  state.counters["file_MB"] = static_cast<double>(a.bytes) / 1e6;
  const char* const labels[] = {"pread", "mmap fault", "mmap fault, MADV_RANDOM"};
  state.SetLabel(labels[mode]);
}

BENCHMARK(BM_BlendMulti)->Apply(kernel_args)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScaleEval)->DenseRange(0, 2)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScaleEvalPlusGrad)->DenseRange(0, 2)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Open)->Args({0, 0})->Args({1, 0})->Args({0, 1})->Args({1, 1})->Unit(
    benchmark::kMicrosecond);
BENCHMARK(BM_ColdFirstPage)->ArgsProduct({{0, 1}, {0, 1, 2}})->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();

// Measured on the development VM (2 vCPU Intel Xeon with AVX2 and AVX-512, GCC 12,
// RelWithDebInfo = -O2, x86-64 baseline ISA) while other engineers' builds and benchmarks ran
// (load 2-3 on 2 cores): two runs each, low-high.
//
// BM_BlendMulti, n = 310,083 floats, x_bytes_over_bw (time / the probe's time for the same bytes):
//                    m = 8 inputs                      m = 44 inputs
//   nout          1          4          9           1          4          9
//   portable   0.86-0.87  1.34-1.60  2.44-2.50   0.95-0.96  1.93-2.01  3.06-3.53
//   avx2       0.76-0.84  0.91-0.92  1.13-1.22   0.85-0.91  1.24-1.26  2.13-2.35
//   previous   1.07-1.13  2.35-2.44  3.49-3.72   1.44-1.48  3.02-3.20  4.39-4.41
// With AVX2 the value and 3 derivatives (nout = 4) move bytes at the probe's rate at 8 inputs;
// at 44 the 176 multiply-adds per element cost ~25%, and at K = 8 (nout = 9) compute dominates.
// The portable kernel (SSE2, no FMA) is compute bound from 4 outputs on.
//
// BM_ScaleEval / BM_ScaleEvalPlusGrad: time, x_bytes_over_bw and (grad) x_eval. "before" is
// libcadinterp with the previous multi-blend kernel and eval on blend_arrays (the probe's
// kernel), run with the same benchmark binary through LD_LIBRARY_PATH; one run of it.
//   eval                 before          after
//   linear, 8 terms      399 us  0.98    363-381 us  0.73-0.91
//   cubic once, 8 terms  409 us  0.97    366-376 us  0.78-0.93
//   cubic, 44 terms      3.02 ms 0.99    2.0-3.1 ms  0.75-0.84
//   eval+grad            before               after
//   linear, 8 terms      1627 us 3.00 (4.1)   500-528 us  0.74-0.89 (1.37-1.42)
//   cubic once, 8 terms  1686 us 3.12 (4.1)   490-549 us  0.80-0.93 (1.34-1.43)
//   cubic, 44 terms      14.5 ms 2.89 (4.8)   2.8-5.2 ms  0.90-0.96 (0.9-1.9)
// The 44-term fixture's 55 MB (twice: the runtime's decoded copy and the probe's) shares the L3
// with the other processes, hence its spread; its ratios to the probe, timed alternately, vary
// far less than its times.
//
// BM_Open: 21-25 us with the file in the page cache for both 11 MB and 1092 MB, one page fault
// per open (header and index; no blob byte is touched). From a dropped page cache 3.9-4.7 ms for
// both sizes, which is the kernel's read-around on the first fault of the mapping, not the
// reader's work: this VM's disk has read_ahead_kb = 8192, so that fault reads up to 8 MB
// (BM_ColdFirstPage: first touch of a mapping 3.3-4.6 ms; after madvise(MADV_RANDOM) 70-84 us,
// the same as a 4 KiB pread, 72-104 us). The reader maps with MADV_RANDOM (and asks for
// each blob's pages when it decodes it): a cold open takes 0.48-0.52 ms for both sizes, 4 page
// faults; warm 42-43 us wall, 26 us CPU (same run, 2026-11-21).
