// Distances between triangulated surfaces: the geometric error of the builder's refinement test
// (symmetric Hausdorff distance between the interpolated and the true boundary, §4.2) and of the
// end-to-end measurements.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace cadinterp::mesh {

/// Barycentric weights (w[0] + w[1] + w[2] = 1, all >= 0) of the point of triangle (a, b, c)
/// closest to p; a degenerate triangle gives its nearest corner.
void closest_point_weights(const double* p, const double* a, const double* b, const double* c,
                           double w[3]);

/// A triangle soup with a uniform grid over its triangles for closest-point queries.
class SurfaceIndex {
 public:
  /// V #V by 3, F #F by 3 (indices into V). Keeps copies.
  SurfaceIndex(const std::vector<double>& V, const std::vector<std::uint32_t>& F);
  /// Distance from p (3 values) to the closest point of the surface (infinity if it has no
  /// triangles).
  double distance(const double* p) const { return distance(p, nullptr); }
  /// The same, and the index of a closest triangle in *triangle (when not null; untouched if the
  /// surface has no triangles).
  double distance(const double* p, std::size_t* triangle) const;
  /// Triangle t's three vertex indices as given to the constructor (t < #F; an index returned
  /// by distance). Valid as long as this index lives.
  const std::uint32_t* triangle(std::size_t t) const { return &F_[3 * t]; }
  /// Vertex v's three coordinates (v < #V). Valid as long as this index lives.
  const double* vertex(std::uint32_t v) const { return &V_[3 * std::size_t(v)]; }

 private:
  std::vector<double> V_;
  std::vector<std::uint32_t> F_;
  double lo_[3] = {0, 0, 0}, cell_ = 1.0;
  int n_[3] = {1, 1, 1};
  std::vector<std::uint32_t> start_, items_;  // CSR: triangles per cell
  int cell_of(double v, int axis) const;
};

/// Vertex-sampled symmetric Hausdorff distance between surfaces A and B: the larger of the
/// largest distance from a vertex of A to B and from a vertex of B to A. It bounds the true
/// distance from below and approaches it as the triangles shrink; with both surfaces meshed at
/// the resolution of the model (the builder's case) the two differ by far less than the errors
/// being measured. With threads >= 2 the two directions of large surfaces run on two threads;
/// a caller that already runs many such distances on its own threads passes 1.
double symmetric_hausdorff(const std::vector<double>& VA, const std::vector<std::uint32_t>& FA,
                           const std::vector<double>& VB, const std::vector<std::uint32_t>& FB,
                           int threads = 2);

/// Distances from every vertex of A (those referenced by FA) to B: for percentiles.
std::vector<double> vertex_distances(const std::vector<double>& VA,
                                     const std::vector<std::uint32_t>& FA, const SurfaceIndex& B);

}  // namespace cadinterp::mesh
