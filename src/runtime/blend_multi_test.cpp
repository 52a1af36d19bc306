#include "runtime/blend_multi.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "runtime/bandwidth_probe.h"

namespace {

using cadinterp::runtime::blend_multi_kernels;
using cadinterp::runtime::BlendMultiFn;

struct Case {
  std::vector<std::vector<float>> data;  // m by n
  std::vector<const float*> arrays;
  std::vector<float> w;  // nout by m
};

Case make_case(std::mt19937& rng, int m, std::size_t n, int nout) {
  Case c;
  std::uniform_real_distribution<float> u(-2, 2);
  c.data.assign(static_cast<std::size_t>(m), std::vector<float>(n));
  for (auto& a : c.data) {
    for (float& v : a) v = u(rng);
    c.arrays.push_back(a.data());
  }
  c.w.resize(static_cast<std::size_t>(nout * m));
  for (float& v : c.w) v = u(rng);
  return c;
}

constexpr float kGuard = 12345.0f;

// Runs `fn` into nout outputs of n floats, each followed by guard values that must survive.
std::vector<std::vector<float>> run(BlendMultiFn fn, const Case& c, int m, std::size_t n,
                                    int nout) {
  constexpr std::size_t kPad = 64;
  std::vector<std::vector<float>> outs(static_cast<std::size_t>(nout),
                                       std::vector<float>(n + kPad, -99.f));
  std::vector<float*> ptrs;
  for (auto& o : outs) {
    std::fill(o.begin() + static_cast<std::ptrdiff_t>(n), o.end(), kGuard);
    ptrs.push_back(o.data());
  }
  fn(c.arrays.data(), c.w.data(), m, n, nout, ptrs.data());
  for (auto& o : outs) {
    for (std::size_t i = n; i < n + kPad; ++i) EXPECT_EQ(o[i], kGuard) << "write past n at " << i;
    o.resize(n);
  }
  return outs;
}

// Every kernel, against a double-precision reference, within the dot-product bound
// gamma_m * sum_j |w_j a_j| (bandwidth_probe.h). Sizes cover every tail path: below one 4- and
// 8-lane vector, between one vector and one full step (up to 32 elements), one partial block of
// elements, and two full blocks of 2048 plus a partial one and a tail, none a multiple of any
// vector width; m = 1 (no accumulation loop), within one group of 8 inputs, and several groups
// with a partial last one, up to 64 (the most terms a K = 3 cubic element can have); nout = 1..9
// (K + 1 for K up to kMaxDim = 8; two passes above 8).
TEST(BlendMulti, EveryKernelMatchesDoubleReference) {
  const auto kernels = blend_multi_kernels();
  ASSERT_GE(kernels.size(), 1u);
  EXPECT_STREQ(kernels.front().name, "portable");
  std::mt19937 rng(7);
  const double u = std::ldexp(1.0, -24);
  for (const auto& k : kernels) {
    for (int m : {1, 2, 5, 8, 9, 27, 64}) {
      for (std::size_t n :
           {std::size_t(1), std::size_t(3), std::size_t(7), std::size_t(9), std::size_t(31),
            std::size_t(33), std::size_t(67), std::size_t(1001), std::size_t(4099)}) {
        for (int nout = 1; nout <= 9; ++nout) {
          SCOPED_TRACE(std::string(k.name) + " m=" + std::to_string(m) + " n=" + std::to_string(n) +
                       " nout=" + std::to_string(nout));
          const Case c = make_case(rng, m, n, nout);
          const auto outs = run(k.fn, c, m, n, nout);
          const double gamma = m * u / (1.0 - m * u);
          for (int o = 0; o < nout; ++o)
            for (std::size_t i = 0; i < n; ++i) {
              double ref = 0.0, mag = 0.0;
              for (int j = 0; j < m; ++j) {
                const double p = double(c.w[static_cast<std::size_t>(o * m + j)]) *
                                 double(c.data[static_cast<std::size_t>(j)][i]);
                ref += p;
                mag += std::fabs(p);
              }
              ASSERT_LE(std::fabs(outs[static_cast<std::size_t>(o)][i] - ref), gamma * mag)
                  << "o=" << o << " i=" << i;
            }
        }
      }
    }
  }
}

TEST(BlendMulti, EveryKernelWritesZerosForNoArrays) {
  for (const auto& k : blend_multi_kernels()) {
    Case c;
    const auto outs = run(k.fn, c, 0, 37, 3);
    for (const auto& o : outs)
      for (float v : o) EXPECT_EQ(v, 0.0f) << k.name;
  }
}

TEST(BlendMulti, NoOutputsTouchesNothing) {
  std::mt19937 rng(3);
  for (const auto& k : blend_multi_kernels()) {
    const Case c = make_case(rng, 4, 100, 0);
    k.fn(c.arrays.data(), c.w.data(), 4, 100, 0, nullptr);
  }
}

// The dispatching entry point runs the last (preferred) kernel: bit-identical results.
TEST(BlendMulti, DispatchUsesPreferredKernel) {
  std::mt19937 rng(5);
  const int m = 8, nout = 4;
  const std::size_t n = 1037;
  const Case c = make_case(rng, m, n, nout);
  const auto expected = run(blend_multi_kernels().back().fn, c, m, n, nout);
  const auto got = run(cadinterp::runtime::blend_arrays_multi, c, m, n, nout);
  for (int o = 0; o < nout; ++o)
    EXPECT_EQ(0, std::memcmp(expected[static_cast<std::size_t>(o)].data(),
                             got[static_cast<std::size_t>(o)].data(), n * sizeof(float)));
}

// Each output equals blend_arrays with its own weights, for odd sizes and many array counts.
TEST(BlendMulti, EqualsSeparateBlends) {
  std::mt19937 rng(1);
  for (int m : {1, 3, 8, 27}) {
    for (std::size_t n : {std::size_t(1), std::size_t(511), std::size_t(513), std::size_t(3001)}) {
      const int nout = 4;
      const Case c = make_case(rng, m, n, nout);
      const auto outs = run(cadinterp::runtime::blend_arrays_multi, c, m, n, nout);
      for (int o = 0; o < nout; ++o) {
        std::vector<float> ref(n);
        cadinterp::runtime::blend_arrays(c.arrays.data(), c.w.data() + o * m, m, n, ref.data());
        // Both are within gamma_m * sum |w a| of the exact value.
        const double gamma = m * std::ldexp(1.0, -24) / (1.0 - m * std::ldexp(1.0, -24));
        for (std::size_t i = 0; i < n; ++i) {
          double mag = 0.0;
          for (int j = 0; j < m; ++j)
            mag += std::fabs(double(c.w[static_cast<std::size_t>(o * m + j)]) *
                             double(c.data[static_cast<std::size_t>(j)][i]));
          ASSERT_NEAR(outs[static_cast<std::size_t>(o)][i], ref[i], 2 * gamma * mag);
        }
      }
    }
  }
}

}  // namespace
