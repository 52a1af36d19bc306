#include "runtime/blend_multi.h"

namespace cadinterp::runtime {

namespace {

// One block of L elements: every input block is applied to all outputs while it is in L1, so
// memory traffic is m reads + nout writes per element. L is a compile-time constant and the
// pointers are restrict-qualified so that GCC's -O2 cost model vectorizes the inner loops
// (the same reasons as blend_arrays in bandwidth_probe.cpp).
// restrict on parameters (GCC honours it there, not on local pointers).
template <std::size_t L>
inline void scale_block(float* __restrict out, const float* __restrict a, float w) {
  for (std::size_t k = 0; k < L; ++k) out[k] = w * a[k];
}
template <std::size_t L>
inline void axpy_block(float* __restrict out, const float* __restrict a, float w) {
  for (std::size_t k = 0; k < L; ++k) out[k] += w * a[k];
}

template <std::size_t L>
void multi_block(const float* const* arrays, const float* weights, int m, int nout, std::size_t i0,
                 float* const* outs) {
  for (int o = 0; o < nout; ++o) scale_block<L>(outs[o] + i0, arrays[0] + i0, weights[o * m]);
  for (int j = 1; j < m; ++j)
    for (int o = 0; o < nout; ++o) axpy_block<L>(outs[o] + i0, arrays[j] + i0, weights[o * m + j]);
}

}  // namespace

void blend_arrays_multi(const float* const* arrays, const float* weights, int m, std::size_t n,
                        int nout, float* const* outs) {
  if (m <= 0) {
    for (int o = 0; o < nout; ++o)
      for (std::size_t i = 0; i < n; ++i) outs[o][i] = 0.0f;
    return;
  }
  constexpr std::size_t kBlock = 512, kChunk = 16;
  std::size_t i = 0;
  for (; i + kBlock <= n; i += kBlock) multi_block<kBlock>(arrays, weights, m, nout, i, outs);
  for (; i + kChunk <= n; i += kChunk) multi_block<kChunk>(arrays, weights, m, nout, i, outs);
  for (; i < n; ++i) multi_block<1>(arrays, weights, m, nout, i, outs);
}

}  // namespace cadinterp::runtime
