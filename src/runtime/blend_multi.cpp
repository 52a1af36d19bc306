#include "runtime/blend_multi.h"

#include <algorithm>

namespace cadinterp::runtime {

void blend_arrays_multi(const float* const* arrays, const float* weights, int m, std::size_t n,
                        int nout, float* const* outs) {
  // Blocks small enough that one block of an input and of every output stay in L1 while the
  // input block is applied to all outputs: memory traffic is m reads + nout writes per element.
  constexpr std::size_t kBlock = 512;
  for (std::size_t i0 = 0; i0 < n; i0 += kBlock) {
    const std::size_t len = std::min(kBlock, n - i0);
    for (int o = 0; o < nout; ++o) std::fill(outs[o] + i0, outs[o] + i0 + len, 0.0f);
    for (int j = 0; j < m; ++j) {
      const float* a = arrays[j] + i0;
      for (int o = 0; o < nout; ++o) {
        const float w = weights[o * m + j];
        float* out = outs[o] + i0;
        for (std::size_t i = 0; i < len; ++i) out[i] += w * a[i];
      }
    }
  }
}

}  // namespace cadinterp::runtime
