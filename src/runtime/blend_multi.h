// Several blends of the same arrays in one pass: the value and the K derivative arrays of an
// evaluated mesh (Eq. 3 and Eq. 13) read every stored sample array once instead of K + 1 times.
#pragma once

#include <cstddef>

namespace cadinterp::runtime {

/// outs[o][i] = sum_j weights[o * m + j] * arrays[j][i] for o < nout, i < n, accumulated in float
/// (the error bound of blend_arrays, bandwidth_probe.h, applies per output).
/// @param[in]  arrays   m pointers to n floats
/// @param[in]  weights  nout by m
/// @param[out] outs     nout pointers to n floats, not overlapping any input
/// Thread-safety: pure.
void blend_arrays_multi(const float* const* arrays, const float* weights, int m, std::size_t n,
                        int nout, float* const* outs);

}  // namespace cadinterp::runtime
