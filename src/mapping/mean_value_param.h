// Floater's mean-value parametrization of a disk patch onto the unit disk (paper §6.2 (surface
// mapping), requirement 3): the boundary loop is fixed on the circle, every interior vertex is the
// mean-value-weighted average of its neighbours. With a convex boundary the result is a valid
// (fold-free) embedding (Floater 2003), which is what lets one disk be located in the other.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "mapping/patch_layout.h"
#include "mapping/surface.h"

namespace cadinterp::mapping {

struct DiskMap {
  std::vector<std::uint32_t> vertices;  ///< per local vertex (Patch::local_vertices) its surface
                                        ///< vertex: a seam's vertices occur twice
  std::vector<double> uv;               ///< per local vertex, 2 values
  std::vector<int> triangles;           ///< local indices, 3 per patch triangle
};

/// One triangle's share of Floater's mean-value weights at its corner xi (Floater 2003, Eq. 5.1):
/// tan(alpha / 2) / |xj - xi| for neighbour xj and tan(alpha / 2) / |xk - xi| for xk, alpha the
/// corner's angle. False for a zero-length edge.
bool mean_value_corner_weights(const double* xi, const double* xj, const double* xk, double& wj,
                               double& wk);

/// `loop_uv` holds 2 values per patch.loop vertex (on the unit circle, counter-clockwise).
/// Fails when the sparse solve fails (a degenerate patch).
bool mean_value_parametrize(const Surface& s, const Patch& patch,
                            const std::vector<double>& loop_uv, DiskMap& out, std::string& why);

/// Point location among a disk map's triangles (uniform grid over the disk).
class DiskLocator {
 public:
  explicit DiskLocator(const DiskMap& m);
  /// The triangle containing (u, v) with barycentric weights; a point outside every triangle
  /// (rounding at the circle) gets the nearest one, weights clamped to it.
  void locate(double u, double v, int& triangle, double w[3]) const;

 private:
  const DiskMap& m_;
  int n_ = 1;
  std::vector<int> start_, items_;
  void weights(int t, double u, double v, double w[3]) const;
  int cell(double x) const;
};

}  // namespace cadinterp::mapping
