// Several blends of the same arrays in one pass: the value and the K derivative arrays of an
// evaluated mesh (Eq. 3 and Eq. 13) read every stored sample array once instead of K + 1 times.
#pragma once

#include <cstddef>
#include <vector>

namespace cadinterp::runtime {

/// outs[o][i] = sum_j weights[o * m + j] * arrays[j][i] for o < nout, i < n, accumulated in float
/// in the order j = 0, 1, ..., m - 1 (so the error bound of blend_arrays, bandwidth_probe.h,
/// applies per output; fused multiply-adds where the CPU has them only tighten it).
/// Runs the fastest kernel this CPU supports (blend_multi_kernels()), chosen on the first call.
/// Eval uses it with nout = 1 too: partial sums stay in registers across 8 inputs where
/// blend_arrays (bandwidth_probe.h) stores them after every 4, which measured 5-20% faster
/// (runtime_scale_bench.cpp).
/// @param[in]  arrays   m pointers to n floats; no alignment required
/// @param[in]  weights  nout by m
/// @param[in]  m        number of arrays, >= 0 (m == 0 writes zeros)
/// @param[in]  nout     number of outputs, >= 0
/// @param[out] outs     nout pointers to n floats, not overlapping any input or each other
/// Thread-safety: pure; concurrent calls with distinct outs are safe.
void blend_arrays_multi(const float* const* arrays, const float* weights, int m, std::size_t n,
                        int nout, float* const* outs);

using BlendMultiFn = void (*)(const float* const* arrays, const float* weights, int m,
                              std::size_t n, int nout, float* const* outs);

/// One implementation of blend_arrays_multi for one instruction set.
struct BlendMultiKernel {
  const char* name;  ///< "portable" (SSE2 on x86-64, the compiler's baseline elsewhere), "avx2"
  BlendMultiFn fn;
};

/// The kernels this CPU can run, portable first and the one blend_arrays_multi uses last.
/// Exposed so tests check every path the dispatch may take, not only the one the test machine
/// picks, and so benchmarks can compare them.
/// Thread-safety: pure.
std::vector<BlendMultiKernel> blend_multi_kernels();

}  // namespace cadinterp::runtime
