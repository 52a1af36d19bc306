// Constructed tet meshes for the untangler's tests and benchmark (foldover_free_test.cpp,
// foldover_free_bench.cpp): the unit cube on an n^3 grid, each cell split into the 6 Kuhn tets
// around its main diagonal, all positively oriented, and its boundary twisted about the vertical
// axis, which tangles the harmonic interior.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "mapping/interior_solve.h"

namespace cadinterp::mapping {

struct KuhnCube {
  std::vector<double> x;            ///< #V by 3
  std::vector<std::uint32_t> tets;  ///< #T by 4
  std::vector<char> fixed;          ///< boundary vertices
  explicit KuhnCube(int n) {
    auto id = [n](int i, int j, int k) { return std::uint32_t((i * (n + 1) + j) * (n + 1) + k); };
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j)
        for (int k = 0; k <= n; ++k) {
          x.insert(x.end(), {double(i) / n, double(j) / n, double(k) / n});
          fixed.push_back(i == 0 || j == 0 || k == 0 || i == n || j == n || k == n);
        }
    const int order[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k)
          for (const auto& o : order) {
            int c[3] = {i, j, k};
            std::uint32_t t[4] = {id(i, j, k), 0, 0, 0};
            for (int s = 0; s < 3; ++s) {
              ++c[o[s]];
              t[s + 1] = id(c[0], c[1], c[2]);
            }
            if (six_volume(x, t) < 0) std::swap(t[2], t[3]);
            tets.insert(tets.end(), t, t + 4);
          }
  }
};

/// The cube's positions with its boundary turned about the vertical axis through its centre by
/// `degrees` times the height z, the interior unchanged.
inline std::vector<double> twisted_boundary(const KuhnCube& cube, double degrees) {
  std::vector<double> x = cube.x;
  const double turn = degrees * std::acos(-1.0) / 180.0;
  for (std::size_t v = 0; v < cube.fixed.size(); ++v) {
    if (!cube.fixed[v]) continue;
    const double a = turn * cube.x[3 * v + 2], px = cube.x[3 * v] - 0.5,
                 py = cube.x[3 * v + 1] - 0.5;
    x[3 * v] = 0.5 + std::cos(a) * px - std::sin(a) * py;
    x[3 * v + 1] = 0.5 + std::sin(a) * px + std::cos(a) * py;
  }
  return x;
}

}  // namespace cadinterp::mapping
