// Internal to hole_split.cpp and hole_new_anchors.cpp: one hole of a patch tried in one pass
// of a round of split_patches_with_holes (paper §6.2), and the ways to join it that place new
// anchors (hole_new_anchors.cpp).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "mapping/layout_paths.h"
#include "mapping/mapping_state.h"

namespace cadinterp::mapping {

inline double dist(const double* p, const double* q) {
  return std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]);
}

// One hole of the canonical patch `holed` (its source patch `sidx`) tried in one pass of a round.
struct HoleTry {
  MappingState& st;
  const Patch& c;  ///< st.cp[holed]
  std::size_t holed, sidx;
  const Loop& hole;  ///< c.holes[hole_index]
  std::size_t hole_index;
  double near;  ///< the hole's distance from the first loop (canonical)
  int pass;
  double slack;                     ///< paths_run_alike's slack
  bool short_only;                  ///< pass 0: short slits only
  std::vector<int> src_of, can_of;  ///< patch_of_triangles per side
  /// Per side, the vertices a path could leave the patch by (an uncut half-edge of it): an
  /// anchor whose only triangle in the patch lies between two loop edges (a one-triangle wedge,
  /// common at the hub's rim on both sides) has none, and candidates from it are skipped before
  /// tracing.
  std::vector<char> leaves[2];
  std::size_t& tried;  ///< candidates tried in the round (for the failure message)

  bool usable(int m) const {
    const int vs = st.src_anchor_of_all[static_cast<std::size_t>(m)];
    const int vc = st.can_anchor_of_all[static_cast<std::size_t>(m)];
    return vs >= 0 && vc >= 0 && leaves[0][static_cast<std::size_t>(vs)] &&
           leaves[1][static_cast<std::size_t>(vc)];
  }
  const double* canon_pos(int m) const {
    return st.corr.anchors[static_cast<std::size_t>(m)].canonical;
  }
  // The hole's anchor nearest anchor a (canonical), and its distance.
  std::pair<std::size_t, double> nearest_on_hole(int a) const {
    std::size_t nearest = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < hole.anchors.size(); ++k) {
      const double d = dist(canon_pos(hole.anchors[k]), canon_pos(a));
      if (d < best) {
        best = d;
        nearest = k;
      }
    }
    return std::make_pair(nearest, best);
  }
  bool same_vertex(int x, int y) const {
    const int u = vertex_at(st.cs, canon_pos(x), st.can_tol);
    return u >= 0 && u == vertex_at(st.cs, canon_pos(y), st.can_tol);
  }
};

/// The vertex of (vertex, fraction) pairs whose fraction is nearest `want` (the first such in
/// their order); -1 where there is none.
std::int64_t nearest_fraction(const std::vector<std::pair<std::uint32_t, double>>& at, double want);
/// (d): a slit to a hole without anchor, whose end becomes a new anchor; true where kept.
bool slit_anchorless_hole(HoleTry& t);
/// (c): a slit from a hole anchor to a new anchor on the first loop; true where kept.
bool slit_to_new_loop_anchor(HoleTry& t);

}  // namespace cadinterp::mapping
