// Moves the canonical mesh's interior vertices to follow its mapped boundary (paper §6.2 (interior
// mapping), requirement 4): the displacement d = mapped - canonical is harmonic in the P1 (linear
// finite element) sense on the canonical tets, with the boundary displacement as Dirichlet data. P1
// harmonic extension reproduces affine maps exactly, which is the plate's case (samples differ
// by a scaling), and stays smooth otherwise; inverted tets are detected, never emitted.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cadinterp::mapping {

/// `vertices` (#V by 3) and `tets` (#T by 4) of the canonical mesh; `fixed[v]` marks boundary
/// vertices whose mapped position is already in `mapped` (#V by 3). Writes the interior rows of
/// `mapped`. Fails when the solve fails.
/// `stiffening` > 0 scales each tet's stiffness by (mean |V| / |V|)^stiffening: small tets
/// stiffer, so they move rigidly and the large ones absorb the deformation (the Jacobian-based
/// stiffening of mesh-motion solvers, Tezduyar et al.); 0 is the plain P1 Laplacian.
bool harmonic_interior(const std::vector<double>& vertices, const std::vector<std::uint32_t>& tets,
                       const std::vector<char>& fixed, std::vector<double>& mapped,
                       std::string& why, double stiffening = 0.0);

/// The same in `steps` increments (pseudo-elastic / incremental mesh motion): the boundary moves
/// by 1/steps of its displacement per step, and each step's stiffness is the current (already
/// moved) mesh's, so the solve sees the deformation accumulated so far. steps = 1 is
/// harmonic_interior.
bool incremental_interior(const std::vector<double>& vertices,
                          const std::vector<std::uint32_t>& tets, const std::vector<char>& fixed,
                          std::vector<double>& mapped, std::string& why, int steps,
                          double stiffening = 0.0);

/// 6 x the signed volume of the tet `t` (4 indices) with positions `x` (#V by 3).
double six_volume(const std::vector<double>& x, const std::uint32_t* t);

/// mesh::validate's bound for a flat tet: 6 V <= 1e-12 diag^3, diag the bbox diagonal of
/// `vertices`.
double min_six_volume(const std::vector<double>& vertices);

struct TetQuality {
  double min_scaled_jacobian = 1.0;  ///< 1 for a regular tet, <= 0 inverted or flat
  std::size_t inverted = 0;          ///< tets with 6 V <= 1e-12 diag^3 (mesh::validate's rule)
};

/// Scaled Jacobian: min over corners of 6 V / (product of the corner's edge lengths), times
/// sqrt(2) so that a regular tet scores 1.
TetQuality tet_quality(const std::vector<double>& vertices, const std::vector<std::uint32_t>& tets);

}  // namespace cadinterp::mapping
