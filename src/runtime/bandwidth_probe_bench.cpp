// Roofline of evaluation: blend_arrays() on n = 300,000 floats (100k vertices x 3) for m = 8, 27,
// 64 stored meshes, against memcpy of the same number of bytes. Bytes processed count what the
// kernel must move: m * n * 4 read + n * 4 written (memcpy: the same total, half read, half
// written). The BM_Alt_* entries are the alternatives measured while choosing the kernel; they
// stay so the choice can be re-checked on other machines. Results and the choice: see the end
// of this file.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "runtime/bandwidth_probe.h"

namespace cadinterp::runtime {
namespace {

constexpr std::size_t kN = 300000;

struct Data {
  std::vector<std::vector<float>> storage;
  std::vector<const float*> arrays;
  std::vector<float> weights;
  std::vector<float> out;
};

const Data& data(int m, std::size_t n) {
  static std::map<std::pair<int, std::size_t>, std::unique_ptr<Data>> cache;
  auto& slot = cache[{m, n}];
  if (!slot) {
    slot = std::make_unique<Data>();
    std::mt19937 rng(static_cast<unsigned>(m));
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    slot->storage.resize(static_cast<std::size_t>(m));
    for (auto& s : slot->storage) {
      s.resize(n);
      for (float& v : s) v = u(rng);
      slot->arrays.push_back(s.data());
      slot->weights.push_back(u(rng) / static_cast<float>(m));
    }
    slot->out.assign(n, 0.0f);
  }
  return *slot;
}

void set_bytes(benchmark::State& state, int m, std::size_t n) {
  state.SetBytesProcessed(
      static_cast<std::int64_t>(state.iterations()) *
      static_cast<std::int64_t>((static_cast<std::size_t>(m) + 1) * n * sizeof(float)));
  state.counters["working_set_MiB"] =
      static_cast<double>((static_cast<std::size_t>(m) + 1) * n * sizeof(float)) / (1 << 20);
}

using Kernel = void (*)(const float* const*, const float*, int, std::size_t, float*);

void run(benchmark::State& state, Kernel kernel, std::size_t n) {
  const int m = static_cast<int>(state.range(0));
  const Data& d = data(m, n);
  float* out = const_cast<float*>(d.out.data());
  for (auto _ : state) {
    kernel(d.arrays.data(), d.weights.data(), m, n, out);
    benchmark::DoNotOptimize(out);
    benchmark::ClobberMemory();
  }
  set_bytes(state, m, n);
}

void BM_BlendArrays(benchmark::State& state) { run(state, blend_arrays, kN); }
void BM_BlendArraysF64Acc(benchmark::State& state) { run(state, blend_arrays_f64acc, kN); }

// memcpy of (m + 1) * n * 4 / 2 bytes: the same bytes moved as the blend of m arrays.
void BM_Memcpy(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0));
  const std::size_t bytes = (static_cast<std::size_t>(m) + 1) * kN * sizeof(float) / 2;
  std::vector<char> src(bytes, 1), dst(bytes, 0);
  for (auto _ : state) {
    std::memcpy(dst.data(), src.data(), bytes);
    benchmark::DoNotOptimize(dst.data());
    benchmark::ClobberMemory();
  }
  set_bytes(state, m, kN);
}

// One sequential read stream over (m + 1) * n * 4 bytes (an integer sum: integer addition
// reassociates, so the fixed-length inner loop vectorizes). Not a bound on the blend, which
// reads 4 streams at a time and gets more out of the prefetchers; it shows how much of the
// blend's rate comes from that concurrency.
std::uint32_t read_sum(const std::uint32_t* p, std::size_t words) {
  std::uint32_t s = 0;
  std::size_t i = 0;
  for (; i + 1024 <= words; i += 1024) {
    std::uint32_t b = 0;
    for (std::size_t k = 0; k < 1024; ++k) b += p[i + k];
    s += b;
  }
  for (; i < words; ++i) s += p[i];
  return s;
}
void read_only(benchmark::State& state, std::size_t n) {
  const int m = static_cast<int>(state.range(0));
  const std::size_t words = (static_cast<std::size_t>(m) + 1) * n;
  std::vector<std::uint32_t> src(words, 1u);
  for (auto _ : state) benchmark::DoNotOptimize(read_sum(src.data(), words));
  set_bytes(state, m, n);
}
void BM_ReadOnly(benchmark::State& state) { read_only(state, kN); }

// The same kernel and memcpy on a working set of 1 GiB, beyond any last-level cache.
constexpr std::size_t kBigN = 4u << 20;
void BM_BlendArraysBeyondCache(benchmark::State& state) { run(state, blend_arrays, kBigN); }
void BM_BlendArraysF64AccBeyondCache(benchmark::State& state) {
  run(state, blend_arrays_f64acc, kBigN);
}
void BM_ReadOnlyBeyondCache(benchmark::State& state) { read_only(state, kBigN); }
void BM_MemcpyBeyondCache(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0));
  const std::size_t bytes = (static_cast<std::size_t>(m) + 1) * kBigN * sizeof(float) / 2;
  std::vector<char> src(bytes, 1), dst(bytes, 0);
  for (auto _ : state) {
    std::memcpy(dst.data(), src.data(), bytes);
    benchmark::DoNotOptimize(dst.data());
    benchmark::ClobberMemory();
  }
  set_bytes(state, m, kBigN);
}

// ---------------------------------------------------------------------------------------------
// Alternatives. All but the two marked "runtime length" run their inner loops with compile-time
// trip counts (full blocks, then 16-element chunks, then single elements), as the shipped kernel
// does: GCC 12 at -O2 vectorizes only loops that need no scalar epilogue, so without this the
// comparison would be of scalar code against vector code rather than of loop structures.

// Calls K::template block<L>(arrays, weights, m, i0, out + i0) over [0, n): full blocks of B,
// then 16-element chunks, then single elements.
template <std::size_t B, typename K>
void blocked(const float* const* arrays, const float* weights, int m, std::size_t n, float* out) {
  std::size_t i = 0;
  for (; i + B <= n; i += B) K::template block<B>(arrays, weights, m, i, out + i);
  for (; i + 16 <= n; i += 16) K::template block<16>(arrays, weights, m, i, out + i);
  for (; i < n; ++i) K::template block<1>(arrays, weights, m, i, out + i);
}

// o[k] (= or +=) w * a[k], k < L.
template <std::size_t L>
void axpy(const float* __restrict a, float w, bool first, float* __restrict o) {
  if (first)
    for (std::size_t k = 0; k < L; ++k) o[k] = w * a[k];
  else
    for (std::size_t k = 0; k < L; ++k) o[k] = o[k] + w * a[k];
}

// j outer: one full sweep over out per array, so out (1.2 MB here, L2-sized at best) is
// re-read and re-written m times.
void alt_j_outer(const float* const* arrays, const float* weights, int m, std::size_t n,
                 float* out) {
  for (int j = 0; j < m; ++j) {
    std::size_t i = 0;
    for (; i + 1024 <= n; i += 1024) axpy<1024>(arrays[j] + i, weights[j], j == 0, out + i);
    for (; i + 16 <= n; i += 16) axpy<16>(arrays[j] + i, weights[j], j == 0, out + i);
    for (; i < n; ++i) axpy<1>(arrays[j] + i, weights[j], j == 0, out + i);
  }
}

// Element outer, as one would first write it: each out[i] summed over the m arrays in a
// register. Runtime length; the j loop over m pointers does not vectorize.
void alt_element_outer(const float* const* arrays, const float* weights, int m, std::size_t n,
                       float* __restrict out) {
  for (std::size_t i = 0; i < n; ++i) {
    float s = 0.0f;
    for (int j = 0; j < m; ++j) s += weights[j] * arrays[j][i];
    out[i] = s;
  }
}

// Blocks of B, R arrays per sweep over the block (R = 1, 4, 8). R = 4, B = 1024 is the shipped
// kernel's structure.
template <std::size_t L>
void sweep4(const float* const* arrays, const float* weights, int j, std::size_t i0,
            float* __restrict o) {
  const float* __restrict b0 = arrays[j] + i0;
  const float* __restrict b1 = arrays[j + 1] + i0;
  const float* __restrict b2 = arrays[j + 2] + i0;
  const float* __restrict b3 = arrays[j + 3] + i0;
  const float w0 = weights[j], w1 = weights[j + 1], w2 = weights[j + 2], w3 = weights[j + 3];
  for (std::size_t k = 0; k < L; ++k)
    o[k] = o[k] + w0 * b0[k] + w1 * b1[k] + w2 * b2[k] + w3 * b3[k];
}
template <std::size_t L>
void sweep8(const float* const* arrays, const float* weights, int j, std::size_t i0,
            float* __restrict o) {
  const float* __restrict b0 = arrays[j] + i0;
  const float* __restrict b1 = arrays[j + 1] + i0;
  const float* __restrict b2 = arrays[j + 2] + i0;
  const float* __restrict b3 = arrays[j + 3] + i0;
  const float* __restrict b4 = arrays[j + 4] + i0;
  const float* __restrict b5 = arrays[j + 5] + i0;
  const float* __restrict b6 = arrays[j + 6] + i0;
  const float* __restrict b7 = arrays[j + 7] + i0;
  const float w0 = weights[j], w1 = weights[j + 1], w2 = weights[j + 2], w3 = weights[j + 3];
  const float w4 = weights[j + 4], w5 = weights[j + 5], w6 = weights[j + 6];
  const float w7 = weights[j + 7];
  for (std::size_t k = 0; k < L; ++k)
    o[k] = o[k] + w0 * b0[k] + w1 * b1[k] + w2 * b2[k] + w3 * b3[k] + w4 * b4[k] + w5 * b5[k] +
           w6 * b6[k] + w7 * b7[k];
}
template <int R>
struct BlockR {
  template <std::size_t L>
  static void block(const float* const* arrays, const float* weights, int m, std::size_t i0,
                    float* o) {
    axpy<L>(arrays[0] + i0, weights[0], true, o);
    int j = 1;
    if constexpr (R == 4)
      for (; j + 4 <= m; j += 4) sweep4<L>(arrays, weights, j, i0, o);
    if constexpr (R == 8)
      for (; j + 8 <= m; j += 8) sweep8<L>(arrays, weights, j, i0, o);
    for (; j < m; ++j) axpy<L>(arrays[j] + i0, weights[j], false, o);
  }
};
template <std::size_t B, int R>
void alt_block(const float* const* arrays, const float* weights, int m, std::size_t n, float* out) {
  blocked<B, BlockR<R>>(arrays, weights, m, n, out);
}

// The shipped structure with runtime loop lengths: the same code as alt_block<1024, 4> but
// left to the compiler's cost model.
void alt_block4_runtime_length(const float* const* arrays, const float* weights, int m,
                               std::size_t n, float* __restrict out) {
  constexpr std::size_t B = 1024;
  for (std::size_t i0 = 0; i0 < n; i0 += B) {
    const std::size_t len = n - i0 < B ? n - i0 : B;
    float* __restrict o = out + i0;
    const float* __restrict a0 = arrays[0] + i0;
    for (std::size_t k = 0; k < len; ++k) o[k] = weights[0] * a0[k];
    int j = 1;
    for (; j + 4 <= m; j += 4) {
      const float* __restrict b0 = arrays[j] + i0;
      const float* __restrict b1 = arrays[j + 1] + i0;
      const float* __restrict b2 = arrays[j + 2] + i0;
      const float* __restrict b3 = arrays[j + 3] + i0;
      const float w0 = weights[j], w1 = weights[j + 1], w2 = weights[j + 2], w3 = weights[j + 3];
      for (std::size_t k = 0; k < len; ++k)
        o[k] = o[k] + w0 * b0[k] + w1 * b1[k] + w2 * b2[k] + w3 * b3[k];
    }
    for (; j < m; ++j) {
      const float* __restrict a = arrays[j] + i0;
      const float w = weights[j];
      for (std::size_t k = 0; k < len; ++k) o[k] += w * a[k];
    }
  }
}

// The shipped structure compiled for AVX2 + FMA (256-bit vectors, fused multiply-add) instead
// of the x86-64 baseline the library is built for (SSE2, 128-bit).
#if defined(__x86_64__) && defined(__GNUC__)
#define CADINTERP_HAVE_AVX2_ALT 1
template <std::size_t L>
__attribute__((target("avx2,fma"))) inline void avx2_block(const float* const* arrays,
                                                           const float* weights, int m,
                                                           std::size_t i0, float* __restrict o) {
  const float* __restrict a0 = arrays[0] + i0;
  for (std::size_t k = 0; k < L; ++k) o[k] = weights[0] * a0[k];
  int j = 1;
  for (; j + 4 <= m; j += 4) {
    const float* __restrict b0 = arrays[j] + i0;
    const float* __restrict b1 = arrays[j + 1] + i0;
    const float* __restrict b2 = arrays[j + 2] + i0;
    const float* __restrict b3 = arrays[j + 3] + i0;
    const float w0 = weights[j], w1 = weights[j + 1], w2 = weights[j + 2], w3 = weights[j + 3];
    for (std::size_t k = 0; k < L; ++k)
      o[k] = o[k] + w0 * b0[k] + w1 * b1[k] + w2 * b2[k] + w3 * b3[k];
  }
  for (; j < m; ++j) {
    const float* __restrict a = arrays[j] + i0;
    const float w = weights[j];
    for (std::size_t k = 0; k < L; ++k) o[k] = o[k] + w * a[k];
  }
}
__attribute__((target("avx2,fma"))) void alt_avx2(const float* const* arrays, const float* weights,
                                                  int m, std::size_t n, float* out) {
  std::size_t i = 0;
  for (; i + 1024 <= n; i += 1024) avx2_block<1024>(arrays, weights, m, i, out + i);
  for (; i + 16 <= n; i += 16) avx2_block<16>(arrays, weights, m, i, out + i);
  for (; i < n; ++i) avx2_block<1>(arrays, weights, m, i, out + i);
}
#endif

void BM_Alt_JOuter(benchmark::State& state) { run(state, alt_j_outer, kN); }
void BM_Alt_ElementOuter(benchmark::State& state) { run(state, alt_element_outer, kN); }
template <std::size_t B, int R>
void BM_Alt_Block(benchmark::State& state) {
  run(state, alt_block<B, R>, kN);
}
void BM_Alt_Block4RuntimeLength(benchmark::State& state) {
  run(state, alt_block4_runtime_length, kN);
}
template <std::size_t B, int R>
void BM_Alt_BlockBeyondCache(benchmark::State& state) {
  run(state, alt_block<B, R>, kBigN);
}
void BM_Alt_JOuterBeyondCache(benchmark::State& state) { run(state, alt_j_outer, kBigN); }
#ifdef CADINTERP_HAVE_AVX2_ALT
void BM_Alt_Avx2(benchmark::State& state) {
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) {
    state.SkipWithError("no AVX2/FMA on this CPU");
    return;
  }
  run(state, alt_avx2, kN);
}
#endif

#define CADINTERP_M_ARGS ->Arg(8)->Arg(27)->Arg(64)->Unit(benchmark::kMicrosecond)

BENCHMARK(BM_BlendArrays) CADINTERP_M_ARGS;
BENCHMARK(BM_BlendArraysF64Acc) CADINTERP_M_ARGS;
BENCHMARK(BM_Memcpy) CADINTERP_M_ARGS;
BENCHMARK(BM_ReadOnly) CADINTERP_M_ARGS;
BENCHMARK(BM_BlendArraysBeyondCache)->Arg(64)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BlendArraysF64AccBeyondCache)->Arg(64)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MemcpyBeyondCache)->Arg(64)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadOnlyBeyondCache)->Arg(64)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Alt_JOuter) CADINTERP_M_ARGS;
BENCHMARK(BM_Alt_ElementOuter) CADINTERP_M_ARGS;
BENCHMARK_TEMPLATE(BM_Alt_Block, 256, 1) CADINTERP_M_ARGS;
BENCHMARK_TEMPLATE(BM_Alt_Block, 1024, 1) CADINTERP_M_ARGS;
BENCHMARK_TEMPLATE(BM_Alt_Block, 4096, 1) CADINTERP_M_ARGS;
BENCHMARK_TEMPLATE(BM_Alt_Block, 256, 4) CADINTERP_M_ARGS;
BENCHMARK_TEMPLATE(BM_Alt_Block, 1024, 4) CADINTERP_M_ARGS;
BENCHMARK_TEMPLATE(BM_Alt_Block, 4096, 4) CADINTERP_M_ARGS;
BENCHMARK_TEMPLATE(BM_Alt_Block, 16384, 4) CADINTERP_M_ARGS;
BENCHMARK_TEMPLATE(BM_Alt_Block, 1024, 8) CADINTERP_M_ARGS;
BENCHMARK(BM_Alt_Block4RuntimeLength) CADINTERP_M_ARGS;
BENCHMARK(BM_Alt_JOuterBeyondCache)->Arg(64)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_Alt_BlockBeyondCache, 1024, 1)->Arg(64)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_Alt_BlockBeyondCache, 4096, 4)->Arg(64)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_Alt_BlockBeyondCache, 16384, 4)->Arg(64)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_Alt_BlockBeyondCache, 65536, 4)->Arg(64)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_Alt_BlockBeyondCache, 16384, 8)->Arg(64)->Unit(benchmark::kMillisecond);
#ifdef CADINTERP_HAVE_AVX2_ALT
BENCHMARK(BM_Alt_Avx2) CADINTERP_M_ARGS;
#endif

}  // namespace
}  // namespace cadinterp::runtime

BENCHMARK_MAIN();

// Measured on the development VM (2 vCPU Intel Xeon 2.3 GHz with AVX-512, L1d 48 KiB,
// L2 2 MiB, L3 260 MiB reported; GCC 12, RelWithDebInfo = -O2, x86-64 baseline ISA), GB/s of
// bytes read + written, single thread, median of 5 in each of two quiet runs (low - high).
// Other engineers' builds shared the VM; runs under load varied by about +-10%, so differences
// below that are noise.
//
//                         m = 8        m = 27       m = 64
//   BM_BlendArrays         22.2-24.5    23.6-27.6    22.2-25.8   (blocks of 1024, 4 arrays/sweep)
//   BM_BlendArraysF64Acc   12.4-15.1    15.3-15.7    13.7-13.9
//   BM_Memcpy              26.0-26.1    25.8-26.1    26.1
//   BM_ReadOnly            18.6         17.1          9.5        (one stream; one run)
// n = 300,000 puts all m = 64 inputs (74 MiB) in this VM's L3, so these are cache figures: the
// blend runs at 85-105% of memcpy's rate.
// Beyond cache (n = 4 Mi, m = 64, 1 GiB): blend 9.5-10.9, f64acc 8.4-8.8, memcpy 19.3-20.7, one
// read stream 7.7. memcpy's figure counts its writes; it reads at ~10 GB/s, the rate the blend
// reads at, which is this core's DRAM read bandwidth as far as any variant below could tell.
//
// Alternatives (same VM, other runs; all within the +-10% band unless stated):
// - j outer (full sweep over out per array): 17 / 16 / 14 in cache, 7.4 beyond: out (1.2 MB)
//   goes to L2/L3 and back m times.
// - element outer (scalar, m pointers per element): 8 / 5 / 3.7: no vectorization, and m
//   streams advanced 4 bytes at a time.
// - one array per sweep over a block (B = 256, 1024, 4096): 19-22 at m = 8, 15-18 at m = 64:
//   out is loaded and stored once per array instead of once per 4.
// - 4 arrays per sweep, B = 256 / 4096 / 16384; 8 arrays per sweep, B = 1024; AVX2+FMA code
//   for the shipped structure; the shipped structure with runtime loop lengths (which GCC -O2
//   does not vectorize, yet matches: the loop is memory-bound even as scalar code here): all
//   22-28 in cache, 10.8-11.2 beyond (B up to 64 Ki), none consistently ahead of the shipped
//   kernel. The shipped one keeps compile-time trip counts so it stays vectorized on machines
//   where the loop is not memory-bound, and B = 1024 keeps out plus four input blocks in 20 KiB
//   of L1.
// - double accumulation costs 35-45% in cache (2-lane SSE2 doubles make it compute-bound),
//   10-20% beyond cache.
