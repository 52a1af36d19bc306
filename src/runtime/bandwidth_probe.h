// The memory-bound reference kernel of evaluation: an element's mesh at x is a weighted sum of
// the m stored meshes of its samples (P(x) = sum_k psi_k(x) p_k, DESIGN.md), and the time to
// stream those bytes is the floor of any eval kernel. blend_arrays() is kept simple so that it
// measures the machine, not the kernel: eval's own register-blocked kernel (blend_multi.h) runs
// at 0.75-0.95 of it. Benchmarks of the runtime's eval report against it
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
/// bits < 53), the sum adds at most gamma_m(2^-53) * sum_j |w_j a_j|, and the final rounding to
/// float at most 2^-24 |out|. So the result is within one float rounding of the exact value
/// unless the cancellation sum |w a| / |out| exceeds about 2^29 / m.
///
/// Is it needed? On interpolation-like inputs (coordinates ~1000 that differ per sample,
/// partition-of-unity weights, with or without negative lobes) the float kernel's worst error
/// measured 3 / 5 / 9 u |out| for m = 8 / 27 / 64 and this one's 1 u |out|
/// (bandwidth_probe_test.cpp, ErrorOnInterpolationLikeInputs, u = 2^-24): a few float ulps,
/// ~0.5 um on a 1 m part at m = 64, against up to 1 u for storing each sample as float at all. Use
/// this where that matters or where weights cancel strongly. Cost: ~0.6x the float kernel's
/// throughput while inputs are in cache (two-lane SSE2 doubles make it compute-bound), 0.8-0.9x
/// beyond cache (bandwidth_probe_bench.cpp).
void blend_arrays_f64acc(const float* const* arrays, const float* weights, int m, std::size_t n,
                         float* out);

}  // namespace cadinterp::runtime
