// Helpers shared by the core's tests: random split sequences and brute-force references that do
// not reuse the code under test (global B-spline sums, neighbourhoods from raw geometry).
#pragma once

#include <random>
#include <vector>

#include "core/basis.h"
#include "core/compiled_basis.h"

namespace cadinterp::core::testing {

/// Applies `splits` random splits (random leaf, random direction below max_level) to `basis`.
inline void random_splits(Basis& basis, std::mt19937_64& rng, int splits, int max_level) {
  const int K = basis.dim();
  for (int s = 0; s < splits; ++s) {
    const auto& leaves = basis.tree().leaves();
    const int leaf = leaves[std::uniform_int_distribution<std::size_t>(0, leaves.size() - 1)(rng)];
    std::vector<int> dirs;
    for (int d = 0; d < K; ++d)
      if (basis.tree().node(leaf).level[d] < max_level) dirs.push_back(d);
    if (dirs.empty()) continue;
    basis.refine(leaf, dirs[std::uniform_int_distribution<std::size_t>(0, dirs.size() - 1)(rng)]);
  }
}

/// A uniformly random point of the closed box b, in unit coordinates.
inline std::vector<double> random_point(const IBox& b, int K, std::mt19937_64& rng) {
  std::vector<double> u(static_cast<std::size_t>(K));
  for (int d = 0; d < K; ++d)
    u[d] = std::uniform_real_distribution<double>(to_unit(b.lo[d]), to_unit(b.hi[d]))(rng);
  return u;
}

/// psi_k(u) for every sample k, summed over every live B-spline (Eq. 6) with no use of the tree
/// or of element data. u must not lie on a knot of a linear B-spline if derivatives matter.
inline std::vector<double> global_psi(const Basis& basis, const double* u) {
  std::vector<double> psi(static_cast<std::size_t>(basis.sample_count()), 0.0);
  const int K = basis.dim();
  basis.for_each_bspline([&](const BsplineKey& key, const std::vector<Coefficient>& coeffs) {
    double phi = 1.0;
    for (int d = 0; d < K; ++d) {
      double v, dv;
      const double w = to_unit(width_at(key.level[d]));
      bspline_1d(basis.degree(), (u[d] - to_unit(key.centre[d])) / w, false, &v, &dv);
      phi *= v;
    }
    for (const auto& [k, a] : coeffs) psi[static_cast<std::size_t>(k)] += a * phi;
  });
  return psi;
}

/// B(e) from raw geometry: every sample in the closed box of `leaf`.
inline std::vector<int> brute_element_samples(const Basis& basis, int leaf) {
  std::vector<int> out;
  for (int k = 0; k < basis.sample_count(); ++k)
    if (box_contains(basis.tree().node(leaf).box, basis.sample(k), basis.dim())) out.push_back(k);
  return out;
}

/// B(e) (linear) or Bbar(e) (cubic) from raw geometry, by scanning all leaves and samples.
inline std::vector<bool> brute_neighbourhood(const Basis& basis, int leaf) {
  const int K = basis.dim();
  std::vector<bool> in(static_cast<std::size_t>(basis.sample_count()), false);
  const IBox& e = basis.tree().node(leaf).box;
  for (int m : basis.tree().leaves()) {
    const IBox& mb = basis.tree().node(m).box;
    const bool adjacent = basis.degree() == Degree::Cubic ? boxes_touch(mb, e, K) : m == leaf;
    if (!adjacent) continue;
    for (int k = 0; k < basis.sample_count(); ++k)
      if (box_contains(mb, basis.sample(k), K)) in[static_cast<std::size_t>(k)] = true;
  }
  return in;
}

/// Unit-domain compile of `basis`.
inline CompiledBasis compile_unit(const Basis& basis) {
  const std::vector<double> lo(static_cast<std::size_t>(basis.dim()), 0.0);
  const std::vector<double> hi(static_cast<std::size_t>(basis.dim()), 1.0);
  return CompiledBasis::compile(basis, lo, hi);
}

}  // namespace cadinterp::core::testing
