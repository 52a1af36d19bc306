// Global untangling of the interior (paper §6.2 (interior mapping), requirement 4: no inverted
// tets). The harmonic solve (interior_solve.h) places every interior vertex at once but knows
// nothing of orientation; where the boundary moves far (a fillet 38.5 mm on one side, 8.1 mm on the
// other) it folds whole regions over, and then no single vertex has a place that untangles its
// star: the local untanglers (interior_solve.cpp, boundary_untangle.h) find none.
//
// Here all free vertices move together, minimising the regularised elastic energy of Garanzha,
// Kaporin, Kudryavtseva, Protais, Ray and Sokolov ("Foldover-free maps in 50 lines of code",
// 2021). Per tet, J is the map from its reference shape (the canonical tet, scaled to the mapped
// volume) to its current shape, and
//   f(J) = 1/2 tr(J^T J) / (3 chi(det J)^(2/3)) + 1/2 (det J^2 + 1) / (2 chi(det J)),
//   chi(D) = (D + sqrt(eps^2 + D^2)) / 2,
// a shape term and a volume term that are 1 at J = I and finite for inverted tets, since chi > 0
// for eps > 0. As eps -> 0, chi(D) -> max(D, 0) and f becomes a barrier against inversion; the
// paper's schedule lowers eps after each minimisation from the smallest det J and the energy's
// decrease (foldover_free.cpp: with a higher floor), so the minimiser slides from a tangled mesh to
// a valid one without ever needing a valid start. Each minimisation is limited-memory BFGS (Nocedal
// and Wright, Alg. 7.4) with a backtracking line search.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace cadinterp::mapping {

struct FoldoverFreeOptions {
  /// eps updates (each followed by one minimisation).
  int outer_iterations = 40;
  /// L-BFGS iterations per minimisation.
  int inner_iterations = 100;
  /// An attempt stops after this many eps updates without fewer inverted elements.
  int stall_iterations = 6;
  /// ... or after this many energy evaluations (0: no limit).
  int max_evaluations = 0;
  /// Free vertices: those not fixed within this many vertex rings of an inverted element (-1:
  /// all not fixed).
  int rings = 4;
};

struct FoldoverFreeResult {
  std::size_t inverted_before = 0, inverted_after = 0;
  std::size_t free_vertices = 0;
  int evaluations = 0;  ///< energy (and gradient) evaluations
};

/// Moves the vertices not marked in `fixed` so that the tets `tets` (#T by 4) with positions `x`
/// (#V by 3) are oriented, their shapes kept near those of `reference` (#V by 3, the canonical
/// mesh's positions). A tet counts as inverted where 6 V <= `min_six_volume` (mesh::validate's
/// rule). `x` is changed only when the result has fewer inverted tets than the input; tets whose
/// four vertices are all fixed cannot change and are counted as they are. Deterministic
/// (sequential, fixed order).
FoldoverFreeResult untangle_foldover_free(const std::vector<double>& reference,
                                          const std::vector<std::uint32_t>& tets,
                                          const std::vector<char>& fixed, double min_six_volume,
                                          std::vector<double>& x,
                                          const FoldoverFreeOptions& options = {});

/// The energy untangle_foldover_free minimises, at positions `x` with this eps: summed over the
/// tets with a vertex not in `fixed`, the reference scaled to their volume at `x`. With `gradient`,
/// also dF/dx (#V by 3, 0 at fixed vertices). For checking the derivative against differences:
/// the scale depends on `x` only through the fixed vertices (the tets' signed volume is fixed by
/// the boundary of their union), so moving free vertices leaves it unchanged.
double foldover_free_energy(const std::vector<double>& reference,
                            const std::vector<std::uint32_t>& tets, const std::vector<char>& fixed,
                            const std::vector<double>& x, double eps,
                            std::vector<double>* gradient = nullptr);

/// The same in the plane: `x` (#V by 2) positions of the triangles `triangles` (#F by 3,
/// counter-clockwise when valid), each triangle's reference shape that of the same triangle in
/// `reference` (#V by 3, in its own plane). A triangle counts as inverted where 2 A <=
/// `min_two_area`.
FoldoverFreeResult untangle_foldover_free_planar(const std::vector<double>& reference,
                                                 const std::vector<std::uint32_t>& triangles,
                                                 const std::vector<char>& fixed,
                                                 double min_two_area, std::vector<double>& x,
                                                 const FoldoverFreeOptions& options = {});

}  // namespace cadinterp::mapping
