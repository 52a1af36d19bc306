#include "runtime/blend_multi.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "runtime/bandwidth_probe.h"

namespace {

// Each output equals blend_arrays with its own weights, for odd sizes and many array counts.
TEST(BlendMulti, EqualsSeparateBlends) {
  std::mt19937 rng(1);
  for (int m : {1, 3, 8, 27}) {
    for (std::size_t n : {std::size_t(1), std::size_t(511), std::size_t(513), std::size_t(3001)}) {
      std::vector<std::vector<float>> data(static_cast<std::size_t>(m), std::vector<float>(n));
      std::vector<const float*> arrays;
      for (auto& a : data) {
        for (float& v : a) v = std::uniform_real_distribution<float>(-2, 2)(rng);
        arrays.push_back(a.data());
      }
      const int nout = 4;
      std::vector<float> w(static_cast<std::size_t>(nout * m));
      for (float& v : w) v = std::uniform_real_distribution<float>(-1, 1)(rng);
      std::vector<std::vector<float>> outs(nout, std::vector<float>(n, 99.f));
      std::vector<float*> out_ptrs;
      for (auto& o : outs) out_ptrs.push_back(o.data());
      cadinterp::runtime::blend_arrays_multi(arrays.data(), w.data(), m, n, nout, out_ptrs.data());
      for (int o = 0; o < nout; ++o) {
        std::vector<float> ref(n);
        cadinterp::runtime::blend_arrays(arrays.data(), w.data() + o * m, m, n, ref.data());
        for (std::size_t i = 0; i < n; ++i)
          ASSERT_NEAR(outs[static_cast<std::size_t>(o)][i], ref[i], 1e-5 * m);
      }
    }
  }
}

}  // namespace
