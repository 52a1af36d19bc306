// Faces shared by two leaves of a K-d tree, and the per-element multilinear interpolant used as
// the baseline that shows jumps at T-junctions (paper §5.1, Figure 8).
#pragma once

#include <vector>

#include "core/basis.h"
#include "core/kdtree.h"

namespace cadinterp::core {

/// A (K-1)-dimensional face shared by leaves `lower` and `upper` (lower.hi[dir] == upper.lo[dir]);
/// `box` is their intersection (degenerate in `dir`).
struct SharedFace {
  int lower = -1, upper = -1, dir = -1;
  IBox box;
  /// True when the two leaves differ in level in some direction other than `dir`, i.e. the face
  /// is not a whole face of both (a T-junction / hanging face).
  bool t_junction = false;
};

/// All shared faces with positive (K-1)-dimensional measure, ordered by (lower, upper).
std::vector<SharedFace> shared_faces(const KdTree& tree);

/// Per-element multilinear interpolation of sample values from the 2^K corners of `leaf` at unit
/// point u. `value(k)` returns sample k's (scalar) value.
template <class Value>
double multilinear_in_element(const Basis& basis, int leaf, const double* u, Value&& value) {
  const int K = basis.dim();
  const IBox& b = basis.tree().node(leaf).box;
  double s = 0.0;
  for (int mask = 0; mask < (1 << K); ++mask) {
    IPoint p{};
    double w = 1.0;
    for (int d = 0; d < K; ++d) {
      const double lo = to_unit(b.lo[d]), hi = to_unit(b.hi[d]);
      const double t = (u[d] - lo) / (hi - lo);
      const bool up = (mask >> d) & 1;
      p[d] = up ? b.hi[d] : b.lo[d];
      w *= up ? t : 1.0 - t;
    }
    s += w * value(basis.find_sample(p));
  }
  return s;
}

}  // namespace cadinterp::core
