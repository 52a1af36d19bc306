// blend_arrays() and blend_arrays_f64acc() against a straightforward double loop, over odd sizes,
// unaligned pointers and m = 0..70.
#include "runtime/bandwidth_probe.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

namespace cadinterp::runtime {
namespace {

constexpr double kU = 1.0 / 16777216.0;  // 2^-24, unit roundoff of float

struct Inputs {
  std::vector<std::vector<float>> storage;
  std::vector<const float*> arrays;
  std::vector<float> weights;
};

// m arrays of n floats, each starting at a different misalignment. `cancelling` makes the
// arrays nearly equal and the weights sum to 0, so |out| << sum |w a|.
Inputs make_inputs(int m, std::size_t n, std::mt19937_64& rng, bool cancelling) {
  Inputs in;
  std::uniform_real_distribution<float> value(-100.0f, 100.0f), weight(-1.0f, 1.0f);
  std::uniform_int_distribution<std::size_t> offset(0, 7);
  std::vector<float> base(n);
  for (float& v : base) v = value(rng);
  in.storage.resize(static_cast<std::size_t>(m));
  for (int j = 0; j < m; ++j) {
    const std::size_t off = offset(rng);
    auto& s = in.storage[static_cast<std::size_t>(j)];
    s.assign(n + off, 0.0f);
    for (std::size_t i = 0; i < n; ++i)
      s[off + i] = cancelling ? base[i] * (1.0f + 1e-4f * static_cast<float>(j)) : value(rng);
    in.arrays.push_back(s.data() + off);
    in.weights.push_back(weight(rng));
  }
  if (cancelling && m >= 2) {
    float sum = 0.0f;
    for (int j = 0; j + 1 < m; ++j) sum += in.weights[static_cast<std::size_t>(j)];
    in.weights.back() = -sum;
  }
  return in;
}

// The exact blend, in long double where it is wider than double, else double (the products of
// two floats are exact in double; the sum of up to 70 of them carries <= 70 * 2^-53 relative
// to sum |w a|, far below the float bounds checked).
void reference(const Inputs& in, int m, std::size_t n, std::vector<long double>& exact,
               std::vector<double>& abs_sum) {
  exact.assign(n, 0.0L);
  abs_sum.assign(n, 0.0);
  for (int j = 0; j < m; ++j)
    for (std::size_t i = 0; i < n; ++i) {
      const double p = static_cast<double>(in.weights[static_cast<std::size_t>(j)]) *
                       static_cast<double>(in.arrays[static_cast<std::size_t>(j)][i]);
      exact[i] += static_cast<long double>(p);
      abs_sum[i] += std::fabs(p);
    }
}

const std::size_t kSizes[] = {0, 1, 3, 15, 16, 17, 100, 1023, 1024, 1025, 2047, 3 * 1024 + 5, 5001};

TEST(BlendArrays, WithinFloatDotProductBound) {
  std::mt19937_64 rng(1);
  std::vector<long double> exact;
  std::vector<double> abs_sum;
  for (int m = 0; m <= 70; ++m) {
    for (std::size_t n : kSizes) {
      for (bool cancelling : {false, true}) {
        const Inputs in = make_inputs(m, n, rng, cancelling);
        reference(in, m, n, exact, abs_sum);
        // Guard words around out catch writes past either end.
        std::vector<float> buf(n + 2, 12345.0f);
        std::vector<float> buf64(n + 2, 12345.0f);
        blend_arrays(in.arrays.data(), in.weights.data(), m, n, buf.data() + 1);
        blend_arrays_f64acc(in.arrays.data(), in.weights.data(), m, n, buf64.data() + 1);
        ASSERT_EQ(buf.front(), 12345.0f);
        ASSERT_EQ(buf.back(), 12345.0f);
        ASSERT_EQ(buf64.front(), 12345.0f);
        ASSERT_EQ(buf64.back(), 12345.0f);
        const double gamma = m * kU / (1.0 - m * kU);
        for (std::size_t i = 0; i < n; ++i) {
          const double want = static_cast<double>(exact[i]);
          const double got = buf[i + 1];
          ASSERT_LE(std::fabs(got - want), gamma * abs_sum[i])
              << "m=" << m << " n=" << n << " i=" << i << " cancelling=" << cancelling;
          // Double accumulation: one float rounding plus a double-precision sum error.
          const double got64 = buf64[i + 1];
          ASSERT_LE(std::fabs(got64 - want),
                    kU * std::fabs(want) + 2.0 * m * 0x1p-53 * abs_sum[i] + 1e-300)
              << "m=" << m << " n=" << n << " i=" << i << " cancelling=" << cancelling;
        }
      }
    }
  }
}

// Errors on interpolation-like inputs, printed for the record: m meshes with coordinates of
// magnitude ~1000 that differ by small per-sample offsets, blended with a partition of unity,
// either nonnegative (linear B-splines) or with negative lobes (cubic weights near the domain
// boundary; sum |w| ~ 3). Error in units of u |exact| (u = 2^-24, half an ulp).
TEST(BlendArrays, ErrorOnInterpolationLikeInputs) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<float> coord(-1000.0f, 1000.0f), offset(-1.0f, 1.0f);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const std::size_t n = 30000;
  for (int m : {8, 27, 64}) {
    for (bool negative : {false, true}) {
      std::vector<float> base(n);
      for (float& v : base) v = coord(rng);
      std::vector<std::vector<float>> storage(static_cast<std::size_t>(m), std::vector<float>(n));
      std::vector<const float*> arrays;
      for (auto& a : storage) {
        for (std::size_t i = 0; i < n; ++i) a[i] = base[i] + offset(rng);
        arrays.push_back(a.data());
      }
      std::vector<double> w(static_cast<std::size_t>(m));
      double sum = 0.0;
      for (std::size_t j = 0; j < w.size(); ++j) {
        w[j] = unit(rng);
        if (negative && j % 3 == 0) w[j] = -w[j];
        sum += w[j];
      }
      std::vector<float> weights;
      double abs_w = 0.0;
      for (double v : w) {
        weights.push_back(static_cast<float>(v / sum));
        abs_w += std::fabs(v / sum);
      }
      std::vector<float> out(n), out64(n);
      blend_arrays(arrays.data(), weights.data(), m, n, out.data());
      blend_arrays_f64acc(arrays.data(), weights.data(), m, n, out64.data());
      double worst = 0.0, worst64 = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        long double exact = 0.0L;
        for (int j = 0; j < m; ++j)
          exact +=
              static_cast<long double>(static_cast<double>(weights[static_cast<std::size_t>(j)]) *
                                       static_cast<double>(arrays[static_cast<std::size_t>(j)][i]));
        const double e = static_cast<double>(exact);
        // Away from 0, where every |a| is within 2% of |exact| (offsets are <= 1).
        if (std::fabs(e) < 100.0) continue;
        worst = std::max(worst, std::fabs(out[i] - e) / (kU * std::fabs(e)));
        worst64 = std::max(worst64, std::fabs(out64[i] - e) / (kU * std::fabs(e)));
      }
      std::printf(
          "m=%2d %-12s sum|w|=%.2f  max error / (u |exact|): float acc %.2f, double acc %.2f\n", m,
          negative ? "with w < 0" : "w >= 0", abs_w, worst, worst64);
      // Double accumulation: one rounding to float, plus far less than that from the sum.
      EXPECT_LE(worst64, 1.01) << m;
      // Float accumulation: within the a priori bound gamma_m sum |w a| <= m u sum|w| max|a|.
      EXPECT_LE(worst, m * abs_w * 1.03) << m;
    }
  }
}

// Small integers with power-of-two weights: every product and partial sum is exact in float, so
// both kernels must reproduce the double loop bit for bit (a dropped array, element or block
// shows up as a difference, not as rounding).
TEST(BlendArrays, ExactWhenArithmeticIsExact) {
  std::mt19937_64 rng(2);
  std::uniform_int_distribution<int> value(-64, 64), exponent(-3, 3);
  for (int m = 1; m <= 70; ++m) {
    for (std::size_t n : kSizes) {
      std::vector<std::vector<float>> storage(static_cast<std::size_t>(m), std::vector<float>(n));
      std::vector<const float*> arrays;
      std::vector<float> weights;
      for (auto& s : storage) {
        for (float& v : s) v = static_cast<float>(value(rng));
        arrays.push_back(s.data());
        weights.push_back(std::ldexp(1.0f, exponent(rng)));
      }
      std::vector<float> out(n), out64(n);
      blend_arrays(arrays.data(), weights.data(), m, n, out.data());
      blend_arrays_f64acc(arrays.data(), weights.data(), m, n, out64.data());
      for (std::size_t i = 0; i < n; ++i) {
        double want = 0.0;
        for (int j = 0; j < m; ++j)
          want += static_cast<double>(weights[static_cast<std::size_t>(j)]) *
                  static_cast<double>(arrays[static_cast<std::size_t>(j)][i]);
        ASSERT_EQ(static_cast<double>(out[i]), want) << "m=" << m << " n=" << n << " i=" << i;
        ASSERT_EQ(static_cast<double>(out64[i]), want) << "m=" << m << " n=" << n << " i=" << i;
      }
    }
  }
}

// Every element is summed in the same order whether it falls in a full block, a tail chunk or
// the scalar remainder, so results do not depend on n or on where an element sits.
TEST(BlendArrays, ResultDoesNotDependOnPosition) {
  std::mt19937_64 rng(3);
  for (int m : {1, 3, 4, 5, 8, 27, 64}) {
    const std::size_t n = 3 * 1024 + 37;
    const Inputs in = make_inputs(m, n, rng, false);
    std::vector<float> whole(n);
    blend_arrays(in.arrays.data(), in.weights.data(), m, n, whole.data());
    for (std::size_t start : {std::size_t{0}, std::size_t{1}, std::size_t{1000}, n - 20}) {
      std::vector<const float*> shifted;
      for (const float* a : in.arrays) shifted.push_back(a + start);
      const std::size_t len = n - start;
      std::vector<float> part(len);
      blend_arrays(shifted.data(), in.weights.data(), m, len, part.data());
      for (std::size_t i = 0; i < len; ++i)
        ASSERT_EQ(part[i], whole[start + i]) << "m=" << m << " start=" << start << " i=" << i;
    }
  }
}

TEST(BlendArrays, ZeroArraysWritesZeros) {
  std::vector<float> out(37, 5.0f);
  blend_arrays(nullptr, nullptr, 0, out.size(), out.data());
  for (float v : out) EXPECT_EQ(v, 0.0f);
  std::vector<float> out64(37, 5.0f);
  blend_arrays_f64acc(nullptr, nullptr, 0, out64.size(), out64.data());
  for (float v : out64) EXPECT_EQ(v, 0.0f);
}

TEST(BlendArrays, NaNPropagates) {
  std::vector<float> a(40, 1.0f), b(40, 2.0f);
  b[33] = std::nanf("");
  const float* arrays[] = {a.data(), b.data()};
  const float weights[] = {0.5f, 0.25f};
  std::vector<float> out(40);
  blend_arrays(arrays, weights, 2, out.size(), out.data());
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (i == 33)
      EXPECT_TRUE(std::isnan(out[i]));
    else
      EXPECT_EQ(out[i], 1.0f);
  }
}

}  // namespace
}  // namespace cadinterp::runtime
