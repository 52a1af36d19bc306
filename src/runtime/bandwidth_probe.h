// The memory-bound reference kernel of evaluation: an element's mesh at x is a weighted sum of
// the m stored meshes of its samples (P(x) = sum_k psi_k(x) p_k, DESIGN.md), so no eval kernel
// can beat blend_arrays() on the same bytes. Benchmarks of the runtime's eval report against it
// (bandwidth_probe_bench.cpp).
#pragma once

#include <cstddef>

namespace cadinterp::runtime {

/// out[i] = sum_j weights[j] * arrays[j][i], i < n, accumulated in float.
///
/// Error: every out[i] is within gamma_m * sum_j |weights[j] * arrays[j][i]| of the exact value,
/// gamma_m = m u / (1 - m u), u = 2^-24 (the dot-product bound; the kernel sums each element's m
/// products in a fixed order). With cancelling weights (cubic B-spline weights can be negative)
/// that bound is relative to sum |w a|, not to |out|; see blend_arrays_f64acc().
///
/// @param[in]  arrays   m pointers, each to n floats; no alignment required
/// @param[in]  weights  m weights
/// @param[in]  m        number of arrays, >= 0 (m == 0 writes zeros)
/// @param[in]  n        floats per array
/// @param[out] out      n floats; must not overlap any arrays[j] (written while they are read)
/// Thread-safety: pure; concurrent calls with distinct out are safe.
void blend_arrays(const float* const* arrays, const float* weights, int m, std::size_t n,
                  float* out);

/// As blend_arrays(), accumulating in double: each product w * a is exact in double (24 + 24
/// bits < 53), the sum carries at most gamma_m(2^-53) * sum |w a| of error, and the one rounding
/// to float adds at most 2^-24 |out|. So out[i] is the correctly rounded exact value unless the
/// cancellation sum |w a| / |out| exceeds about 2^29 / m. Measured cost over blend_arrays() is in
/// bandwidth_probe_bench.cpp (BM_BlendArraysF64Acc).
void blend_arrays_f64acc(const float* const* arrays, const float* weights, int m, std::size_t n,
                         float* out);

}  // namespace cadinterp::runtime
