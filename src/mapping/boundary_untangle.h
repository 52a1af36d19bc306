// Untangling of tets whose vertices are all on the boundary (paper §6.2 (interior mapping),
// requirement 4). The surface map pins every boundary vertex, so a thin tet spanning two faces that
// meet at a sharp edge (two vertices on each face) can come out folded, and no interior solve can
// repair it: no vertex of it is free. Here such vertices move, but only within their own freedom on
// the source surface: a vertex inside a patch in the patch's 2-D parameter domain (its source disk,
// re-evaluated through the composed map onto the source triangles), a vertex on a patch boundary
// path along that path (1-D arc length), and control points (anchors) not at all. Every position
// this produces is a point of the source surface, so the surface map's Hausdorff bound holds.
//
// The objective per vertex is lexicographic: fewer degenerate/inverted incident tets first,
// then a larger minimum scaled Jacobian among them (the max-min untangling of Freitag and
// Plassmann, "Local optimization-based simplicial mesh untangling and improvement", 2000); it is
// optimized by a derivative-free compass search in the vertex's parameters, because the
// parameter-to-position map (point location in a disk, then a source triangle) is only piecewise
// linear and its derivative jumps at every source edge.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace cadinterp::mapping {

/// A boundary vertex's freedom.
struct BoundaryDof {
  std::uint32_t vertex = 0;  ///< mesh vertex
  int dims = 0;              ///< 0: fixed (anchor), 1: along a path, 2: within a patch
  double p[3] = {0, 0, 0};   ///< its parameters (arc length, or disk coordinates)
  double lo = 0, hi = 0;     ///< bounds of p[0] when dims == 1
  /// dims == 1: the dofs of the neighbours along the path (-1: none, the bound is lo / hi), on
  /// the same parametrization; p[0] stays strictly between theirs, so the order is kept.
  int prev = -1, next = -1;
  double step = 0;  ///< initial search step, in parameter units
  int patch = -1;   ///< for the caller's `place`
};

/// Writes the position of `dof` at parameters `p` into x (3 values); false when `p` is outside
/// the dof's domain (e.g. off the disk).
using PlaceFn = std::function<bool(const BoundaryDof& dof, const double* p, double* x)>;

/// The scaled Jacobian of tet t (min over corners of 6V / product of edge lengths, times
/// sqrt(2)): 1 for a regular tet, <= 0 inverted or flat.
double scaled_jacobian(const std::vector<double>& x, const std::uint32_t* t);

struct BoundaryUntangleResult {
  std::size_t inverted_before = 0, inverted_after = 0;
  std::size_t moved = 0;  ///< dofs whose parameters changed
};

/// Moves the dofs of vertices of inverted or flat tets (6V <= min_six_volume, mesh::validate's
/// rule) to untangle them, in `rounds` passes: a pass that fixes nothing widens the set to the
/// dofs of tets sharing a vertex with an inverted one (a neighbour may block the way). A move is
/// kept only when it lowers the number of inverted tets around that vertex, or keeps it and
/// raises their minimum scaled Jacobian: the total count never grows. `x` (#V by 3) gets the
/// moved positions and `dofs` their parameters; `dof_of[v]` is v's index in `dofs` or -1 (a
/// free interior vertex, or a vertex that may not move). With `free_vertex`, vertices marked
/// there (and without dof) are optimized too, freely in 3-D: the same search replaces the
/// interior's averaging untangler where that one is stuck. `moved` counts dofs only.
/// Deterministic: vertices in increasing order, directions in a fixed order.
BoundaryUntangleResult untangle_boundary(const std::vector<std::uint32_t>& tets,
                                         const std::vector<int>& dof_of,
                                         std::vector<BoundaryDof>& dofs, const PlaceFn& place,
                                         double min_six_volume, std::vector<double>& x,
                                         const std::vector<char>* free_vertex = nullptr,
                                         int rounds = 8);

}  // namespace cadinterp::mapping
