// Blocked blend: for each block of kBlock elements, out[block] is initialised from the first
// array and then updated by the others, four arrays per sweep, so out stays in L1 while the m
// inputs stream through once. On the development VM it moves bytes at 85-105% of memcpy's rate
// while the inputs fit in cache (22-28 GB/s) and reads at the core's DRAM read rate beyond it
// (~10 GB/s).
// The alternatives measured against it (j-outer full sweeps, an element-outer loop, other block
// sizes, one or eight arrays per sweep, AVX2 code) and their numbers are in
// bandwidth_probe_bench.cpp.
#include "runtime/bandwidth_probe.h"

namespace cadinterp::runtime {
namespace {

// 1024 floats: out (4 KiB) plus the four current input blocks (16 KiB) stay within a 32 KiB L1d.
constexpr std::size_t kBlock = 1024;
// Tail blocks are processed in multiples of this, so every inner loop has a compile-time trip
// count that is a multiple of any vector width: GCC's -O2 cost model ("very cheap") only
// vectorizes loops that need no scalar epilogue.
constexpr std::size_t kChunk = 16;

// Each inner loop below is a separate restrict-qualified loop over L elements so the compiler
// vectorizes it without runtime alias checks.
template <typename Acc, std::size_t L>
void blend_block(const float* const* arrays, const float* weights, int m, std::size_t i0,
                 Acc* __restrict acc) {
  {
    const float* __restrict a = arrays[0] + i0;
    const Acc w = static_cast<Acc>(weights[0]);
    for (std::size_t k = 0; k < L; ++k) acc[k] = w * static_cast<Acc>(a[k]);
  }
  int j = 1;
  for (; j + 4 <= m; j += 4) {
    const float* __restrict a0 = arrays[j] + i0;
    const float* __restrict a1 = arrays[j + 1] + i0;
    const float* __restrict a2 = arrays[j + 2] + i0;
    const float* __restrict a3 = arrays[j + 3] + i0;
    const Acc w0 = static_cast<Acc>(weights[j]), w1 = static_cast<Acc>(weights[j + 1]);
    const Acc w2 = static_cast<Acc>(weights[j + 2]), w3 = static_cast<Acc>(weights[j + 3]);
    for (std::size_t k = 0; k < L; ++k)
      acc[k] = acc[k] + w0 * static_cast<Acc>(a0[k]) + w1 * static_cast<Acc>(a1[k]) +
               w2 * static_cast<Acc>(a2[k]) + w3 * static_cast<Acc>(a3[k]);
  }
  for (; j < m; ++j) {
    const float* __restrict a = arrays[j] + i0;
    const Acc w = static_cast<Acc>(weights[j]);
    for (std::size_t k = 0; k < L; ++k) acc[k] = acc[k] + w * static_cast<Acc>(a[k]);
  }
}

template <typename Acc, std::size_t L>
void blend_block_to(const float* const* arrays, const float* weights, int m, std::size_t i0,
                    float* __restrict out) {
  if constexpr (sizeof(Acc) == sizeof(float)) {
    blend_block<Acc, L>(arrays, weights, m, i0, out + i0);
  } else {
    Acc acc[L];
    blend_block<Acc, L>(arrays, weights, m, i0, acc);
    float* __restrict o = out + i0;
    for (std::size_t k = 0; k < L; ++k) o[k] = static_cast<float>(acc[k]);
  }
}

template <typename Acc>
void blend(const float* const* arrays, const float* weights, int m, std::size_t n,
           float* __restrict out) {
  if (m <= 0) {
    for (std::size_t i = 0; i < n; ++i) out[i] = 0.0f;
    return;
  }
  std::size_t i = 0;
  for (; i + kBlock <= n; i += kBlock) blend_block_to<Acc, kBlock>(arrays, weights, m, i, out);
  for (; i + kChunk <= n; i += kChunk) blend_block_to<Acc, kChunk>(arrays, weights, m, i, out);
  // Fewer than kChunk elements left: scalar, same summation order as the blocks.
  for (; i < n; ++i) {
    Acc s = static_cast<Acc>(weights[0]) * static_cast<Acc>(arrays[0][i]);
    int j = 1;
    for (; j + 4 <= m; j += 4)
      s = s + static_cast<Acc>(weights[j]) * static_cast<Acc>(arrays[j][i]) +
          static_cast<Acc>(weights[j + 1]) * static_cast<Acc>(arrays[j + 1][i]) +
          static_cast<Acc>(weights[j + 2]) * static_cast<Acc>(arrays[j + 2][i]) +
          static_cast<Acc>(weights[j + 3]) * static_cast<Acc>(arrays[j + 3][i]);
    for (; j < m; ++j) s = s + static_cast<Acc>(weights[j]) * static_cast<Acc>(arrays[j][i]);
    out[i] = static_cast<float>(s);
  }
}

}  // namespace

void blend_arrays(const float* const* arrays, const float* weights, int m, std::size_t n,
                  float* out) {
  blend<float>(arrays, weights, m, n, out);
}

void blend_arrays_f64acc(const float* const* arrays, const float* weights, int m, std::size_t n,
                         float* out) {
  blend<double>(arrays, weights, m, n, out);
}

}  // namespace cadinterp::runtime
