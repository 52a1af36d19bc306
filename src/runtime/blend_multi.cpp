// Register-blocked multi-blend. For a step of 8 to 32 elements, the accumulators of all outputs
// stay in registers while the inputs are applied one after another, and each output is stored
// once per group of kInputs inputs: per element m loads, ~2 nout m / kInputs L1 loads and stores
// of partial sums, and m nout multiply-adds, the minimum. The kernel this replaced (blocks of 512
// in L1, one axpy per input and output) loaded and stored every output block once per input: at
// K = 3 (8 inputs, 4 outputs) 92 loads and stores per element where this kernel needs 12, and it
// ran at 3.3-4.1x the time of eval, compute bound.
//
// Elements go in blocks of kBlock and, within a block, the inputs in groups of kInputs, so that
// only kInputs input streams are read at a time: with all 44 inputs of a cubic element at once
// the kernel ran 5-15% slower (hardware prefetchers follow a limited number of streams).
//
// The m nout multiply-adds per element remain, and with 128-bit SSE2 and no fused multiply-add
// (the x86-64 baseline the library is built for) they keep the kernel compute bound at four
// outputs, so on CPUs with AVX2 and FMA a 256-bit kernel is chosen at run time; the portable one
// remains for the others. Measurements: runtime_scale_bench.cpp.
#include "runtime/blend_multi.h"

#include <cstring>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define CADINTERP_BLEND_AVX2 1
#include <immintrin.h>
#define CADINTERP_TARGET_AVX2 __attribute__((target("avx2,fma")))
#endif

// A step is a few dozen instructions around the loop over the inputs; a call per step would cost
// about as much as the loop does at m = 8.
#define CADINTERP_ALWAYS_INLINE inline __attribute__((always_inline))

namespace cadinterp::runtime {
namespace {

// Up to this many outputs share one read of the inputs: 9 accumulators plus one input vector
// and one weight fill 11 of the 16 vector registers of SSE2 and AVX2, and the value and K
// derivatives of every K <= kMaxDim = 8 take one pass (two passes of 5 + 4 outputs measured
// 10-20% slower with AVX2 at K = 8, the same with SSE2).
constexpr int kMaxGroup = 9;

// Inputs per group and elements per block (a multiple of every step). A block's partial sums,
// nout x 8 KiB, are re-read from L1/L2 once per group; 4, 8 and 16 inputs with blocks of 512, 1024
// and 2048 were measured, and 8 x 2048 was best or within noise of it everywhere.
constexpr int kInputs = 8;
constexpr std::size_t kBlock = 2048;

// Vectors per output per step: enough independent accumulator chains (outputs x vectors >= 4-8)
// to hide the add / multiply-add latency, few enough to stay in 16 registers without spills.
template <int NOUT>
constexpr int vectors_per_step() {
  return NOUT <= 2 ? 4 : NOUT <= 4 ? 2 : 1;
}

using GroupFn = void (*)(const float* const* arrays, const float* w, int m, std::size_t n,
                         float* const* outs);

// The weights of inputs [j0, j1) for NOUT outputs, input-major (wt[(j - j0) * NOUT + o]): a step
// then reads every weight at a constant offset from one pointer instead of keeping NOUT row
// pointers in general registers (at NOUT = 9 those spilled, every step).
template <int NOUT>
inline void gather_weights(const float* w, int m, int j0, int j1, float* wt) {
  for (int j = j0; j < j1; ++j)
    for (int o = 0; o < NOUT; ++o) wt[(j - j0) * NOUT + o] = w[o * m + j];
}

// One element: inputs [j0, j1) added to the partial sums in outs (FIRST: j0 == 0, no partial
// sums yet), in the vector lanes' summation order.
template <int NOUT, bool FIRST>
inline void scalar_step(const float* const* arrays, const float* wt, int j0, int j1, std::size_t i,
                        float* const* outs) {
  float acc[NOUT];
  int j = j0;
  if (FIRST) {
    const float a = arrays[j][i];
    for (int o = 0; o < NOUT; ++o) acc[o] = wt[o] * a;
    ++j;
  } else {
    for (int o = 0; o < NOUT; ++o) acc[o] = outs[o][i];
  }
  for (; j < j1; ++j) {
    const float a = arrays[j][i];
    for (int o = 0; o < NOUT; ++o) acc[o] += wt[(j - j0) * NOUT + o] * a;
  }
  for (int o = 0; o < NOUT; ++o) outs[o][i] = acc[o];
}

// The loop structure shared by the kernels: blocks of elements, groups of inputs within a block,
// full steps of the block, then single vectors, then single elements. STEP<NOUT, VEC, FIRST> is
// the ISA's step over LANES * VEC elements. A macro, not a template, because the AVX2 steps only
// inline into a function compiled for AVX2 and a function template has one target attribute for
// all its instantiations.
#define CADINTERP_BLEND_GROUP_BODY(STEP, LANES)                                                    \
  constexpr int V = vectors_per_step<NOUT>();                                                      \
  constexpr std::size_t kStep = (LANES)*V;                                                         \
  float wt[kInputs * NOUT];                                                                        \
  for (std::size_t b0 = 0; b0 < n; b0 += kBlock) {                                                 \
    const std::size_t b1 = n - b0 < kBlock ? n : b0 + kBlock;                                      \
    for (int j0 = 0; j0 < m; j0 += kInputs) {                                                      \
      const int j1 = m - j0 < kInputs ? m : j0 + kInputs;                                          \
      gather_weights<NOUT>(w, m, j0, j1, wt);                                                      \
      std::size_t i = b0;                                                                          \
      if (j0 == 0) {                                                                               \
        for (; i + kStep <= b1; i += kStep) STEP<NOUT, V, true>(arrays, wt, j0, j1, i, outs);      \
        for (; i + (LANES) <= b1; i += (LANES)) STEP<NOUT, 1, true>(arrays, wt, j0, j1, i, outs);  \
        for (; i < b1; ++i) scalar_step<NOUT, true>(arrays, wt, j0, j1, i, outs);                  \
      } else {                                                                                     \
        for (; i + kStep <= b1; i += kStep) STEP<NOUT, V, false>(arrays, wt, j0, j1, i, outs);     \
        for (; i + (LANES) <= b1; i += (LANES)) STEP<NOUT, 1, false>(arrays, wt, j0, j1, i, outs); \
        for (; i < b1; ++i) scalar_step<NOUT, false>(arrays, wt, j0, j1, i, outs);                 \
      }                                                                                            \
    }                                                                                              \
  }

// ---- Portable: GCC/Clang vector extensions, 4 lanes (SSE2 on x86-64, NEON on AArch64). ----

typedef float F4 __attribute__((vector_size(16)));

inline F4 load4(const float* p) {
  F4 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

template <int NOUT, int VEC, bool FIRST>
CADINTERP_ALWAYS_INLINE void step_portable(const float* const* arrays, const float* wt, int j0,
                                           int j1, std::size_t i, float* const* outs) {
  F4 acc[NOUT][VEC];
  F4 x[VEC];
  int j = j0;
  if (FIRST) {
    const float* a = arrays[j] + i;
#pragma GCC unroll 8
    for (int v = 0; v < VEC; ++v) x[v] = load4(a + 4 * v);
#pragma GCC unroll 9
    for (int o = 0; o < NOUT; ++o)
#pragma GCC unroll 8
      for (int v = 0; v < VEC; ++v) acc[o][v] = wt[o] * x[v];
    ++j;
    wt += NOUT;
  } else {
#pragma GCC unroll 9
    for (int o = 0; o < NOUT; ++o)
#pragma GCC unroll 8
      for (int v = 0; v < VEC; ++v) acc[o][v] = load4(outs[o] + i + 4 * v);
  }
  for (; j < j1; ++j, wt += NOUT) {
    const float* a = arrays[j] + i;
#pragma GCC unroll 8
    for (int v = 0; v < VEC; ++v) x[v] = load4(a + 4 * v);
#pragma GCC unroll 9
    for (int o = 0; o < NOUT; ++o)
#pragma GCC unroll 8
      for (int v = 0; v < VEC; ++v) acc[o][v] += wt[o] * x[v];
  }
#pragma GCC unroll 9
  for (int o = 0; o < NOUT; ++o)
#pragma GCC unroll 8
    for (int v = 0; v < VEC; ++v) std::memcpy(outs[o] + i + 4 * v, &acc[o][v], sizeof(F4));
}

template <int NOUT>
void group_portable(const float* const* arrays, const float* w, int m, std::size_t n,
                    float* const* outs) {
  CADINTERP_BLEND_GROUP_BODY(step_portable, 4)
}

constexpr GroupFn kPortable[kMaxGroup] = {group_portable<1>, group_portable<2>, group_portable<3>,
                                          group_portable<4>, group_portable<5>, group_portable<6>,
                                          group_portable<7>, group_portable<8>, group_portable<9>};

// ---- AVX2 + FMA: 8 lanes, one rounding per multiply-add. ----
#ifdef CADINTERP_BLEND_AVX2

template <int NOUT, int VEC, bool FIRST>
CADINTERP_TARGET_AVX2 CADINTERP_ALWAYS_INLINE void step_avx2(const float* const* arrays,
                                                             const float* wt, int j0, int j1,
                                                             std::size_t i, float* const* outs) {
  __m256 acc[NOUT][VEC];
  __m256 x[VEC];
  int j = j0;
  if (FIRST) {
    const float* a = arrays[j] + i;
#pragma GCC unroll 8
    for (int v = 0; v < VEC; ++v) x[v] = _mm256_loadu_ps(a + 8 * v);
#pragma GCC unroll 9
    for (int o = 0; o < NOUT; ++o) {
      const __m256 wo = _mm256_set1_ps(wt[o]);
#pragma GCC unroll 8
      for (int v = 0; v < VEC; ++v) acc[o][v] = _mm256_mul_ps(wo, x[v]);
    }
    ++j;
    wt += NOUT;
  } else {
#pragma GCC unroll 9
    for (int o = 0; o < NOUT; ++o)
#pragma GCC unroll 8
      for (int v = 0; v < VEC; ++v) acc[o][v] = _mm256_loadu_ps(outs[o] + i + 8 * v);
  }
  for (; j < j1; ++j, wt += NOUT) {
    const float* a = arrays[j] + i;
#pragma GCC unroll 8
    for (int v = 0; v < VEC; ++v) x[v] = _mm256_loadu_ps(a + 8 * v);
#pragma GCC unroll 9
    for (int o = 0; o < NOUT; ++o) {
      const __m256 wo = _mm256_set1_ps(wt[o]);
#pragma GCC unroll 8
      for (int v = 0; v < VEC; ++v) acc[o][v] = _mm256_fmadd_ps(wo, x[v], acc[o][v]);
    }
  }
#pragma GCC unroll 9
  for (int o = 0; o < NOUT; ++o)
#pragma GCC unroll 8
    for (int v = 0; v < VEC; ++v) _mm256_storeu_ps(outs[o] + i + 8 * v, acc[o][v]);
}

template <int NOUT>
CADINTERP_TARGET_AVX2 void group_avx2(const float* const* arrays, const float* w, int m,
                                      std::size_t n, float* const* outs) {
  CADINTERP_BLEND_GROUP_BODY(step_avx2, 8)
}

constexpr GroupFn kAvx2[kMaxGroup] = {group_avx2<1>, group_avx2<2>, group_avx2<3>,
                                      group_avx2<4>, group_avx2<5>, group_avx2<6>,
                                      group_avx2<7>, group_avx2<8>, group_avx2<9>};

#endif

// Splits the outputs into the fewest groups of at most kMaxGroup, of near-equal size (10 outputs
// as 5 + 5 rather than 9 + 1, so neither pass runs with few accumulators).
void blend_groups(const GroupFn* groups, const float* const* arrays, const float* weights, int m,
                  std::size_t n, int nout, float* const* outs) {
  if (m <= 0) {
    for (int o = 0; o < nout; ++o)
      for (std::size_t i = 0; i < n; ++i) outs[o][i] = 0.0f;
    return;
  }
  for (int o = 0; o < nout;) {
    const int left = nout - o, passes = (left + kMaxGroup - 1) / kMaxGroup;
    const int g = (left + passes - 1) / passes;
    groups[g - 1](arrays, weights + o * m, m, n, outs + o);
    o += g;
  }
}

void blend_multi_portable(const float* const* arrays, const float* weights, int m, std::size_t n,
                          int nout, float* const* outs) {
  blend_groups(kPortable, arrays, weights, m, n, nout, outs);
}

#ifdef CADINTERP_BLEND_AVX2
void blend_multi_avx2(const float* const* arrays, const float* weights, int m, std::size_t n,
                      int nout, float* const* outs) {
  blend_groups(kAvx2, arrays, weights, m, n, nout, outs);
}

bool cpu_has_avx2_fma() {
  // libgcc's check includes the OS's XSAVE support for the 256-bit registers.
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}
#endif

}  // namespace

std::vector<BlendMultiKernel> blend_multi_kernels() {
  std::vector<BlendMultiKernel> k = {{"portable", blend_multi_portable}};
#ifdef CADINTERP_BLEND_AVX2
  if (cpu_has_avx2_fma()) k.push_back({"avx2", blend_multi_avx2});
#endif
  return k;
}

void blend_arrays_multi(const float* const* arrays, const float* weights, int m, std::size_t n,
                        int nout, float* const* outs) {
  // Resolved once (a function-local static is initialised thread-safely), without allocating:
  // warm eval/grad calls allocate nothing (runtime_alloc_test.cpp).
  static const BlendMultiFn fn = [] {
#ifdef CADINTERP_BLEND_AVX2
    if (cpu_has_avx2_fma()) return blend_multi_avx2;
#endif
    return blend_multi_portable;
  }();
  fn(arrays, weights, m, n, nout, outs);
}

}  // namespace cadinterp::runtime
