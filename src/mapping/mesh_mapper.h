// The mesh mapper (paper §6): a source sample's geometry and fields in the combinatorics of an
// element's canonical mesh, through their references (mesh/mapper.h). map_sample
// (mesh_mapper.cpp) runs the stages of §6.2 in order on one state (mapping_state.h):
//   correspondence.cpp    CAD referencing: control points matched by equal IDs; CAD edges in both
//   layout_build.cpp      surface mapping: the common layout, patches bounded by common CAD paths,
//                         paired by anchors (patch_layout.cpp, layout_paths.cpp, geodesic.cpp);
//                         patches with holes cut into disks (hole_split.cpp, hole_new_anchors.cpp)
//   surface_map.cpp       surface mapping: both sides of a patch onto one disk (Floater's
//                         mean_value_param.cpp), composed, relaxed; placed on the smooth source
//                         (smooth_surface.cpp)
//   interior_solve.cpp    interior mapping: P1-harmonic with the surface map as Dirichlet data
//   untangling.cpp        interior mapping, what stays inverted: traced paths released
//                         (path_release.cpp), boundary moved on the source
//                         (boundary_untangle.cpp), the interior untangled as a whole
//                         (foldover_free.cpp)
//   field_transfer.cpp    per-vertex / per-tet fields at the mapped points
// and, after a mapping, canonical_refine.cpp: the canonical's boundary bisected where a mapped
// term departs from its own boundary (the builder's canonical_refinement).
// Deterministic (no threads, no hash-order iteration) and const: safe from several threads.
#pragma once

#include <cstddef>
#include <string>

#include "mesh/mapper.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

/// What one mapping found (for the report command and the tests).
struct MapStats {
  std::size_t matched_points = 0;
  std::size_t patches = 0;
  std::size_t rejected_paths = 0;   ///< one-sided edges dropped by the cyclic-order check
  std::size_t dropped_anchors = 0;  ///< matched points not at a mesh vertex on both sides
  std::size_t subdivided = 0;  ///< paths added to subdivide patches (MapOptions::subdivide_ratio)
  std::size_t planar_patches = 0;  ///< flat patches laid into their plane (MapOptions)
  double min_scaled_jacobian = 0;  ///< of the mapped canonical tets
  std::size_t inverted = 0;        ///< mapped tets inverted or flat (a failure when > 0)
  std::size_t boundary_moved = 0;  ///< boundary vertices moved by the boundary untangling
  bool smoothed = false;  ///< boundary on the smooth reconstruction (false: flat triangles)
};

/// Tuning of one mapping (defaults are the builder's).
struct MapOptions {
  /// Sweeps of the in-patch relaxation (surface_map.cpp): 0 keeps the composed disk maps.
  int relax_iterations = 30;
  /// Interior solve (interior_solve.h): boundary increments, and the stiffening exponent.
  int interior_steps = 1;
  double stiffening = 0.0;
  /// Where tets stay inverted after that (and the untangling), the solve once more with these
  /// (0 steps: no second solve).
  int fallback_steps = 4;
  double fallback_stiffening = 1.0;
  /// Flat patches whose composed surface map folds triangles are laid into their plane by the
  /// canonical's mean-value weights instead, where that folds fewer (surface_map.cpp,
  /// planar_placement).
  bool planar_patches = true;

  /// Where tets stay inverted after that: passes of boundary untangling (boundary_untangle.h,
  /// boundary vertices moved within the source surface) each followed by the interior solve
  /// (0: none).
  int boundary_untangle_passes = 3;
  /// Where more than this fraction of the tets is inverted after the interior solve, the
  /// surface map itself folds and neither the boundary untangling nor the flat retry is tried:
  /// measured on the OpenCASCADE hub, pairs with 4-5 % inverted kept 1.2-2.5 % after minutes of
  /// untangling, while every pair the untangling rescued (mount, press) had under 0.3 %.
  double untangle_max_fraction = 0.01;
  /// Where tets stay inverted after the interior solve, the release and the boundary
  /// untangling (below): the interior near them untangled as a whole (foldover_free.h), within this
  /// many energy evaluations (0: no limit), so that a pair it cannot rescue is refused in bounded
  /// time.
  bool foldover_free = true;
  int foldover_free_evaluations = 6000;
  /// The untangling inside every interior solve instead (steps 4a and 4b then start from the
  /// untangled interior). map_sample retries with it where the mapping fails otherwise; the
  /// retry skips the flat-triangle retry (smooth_alpha), which makes its own.
  bool foldover_free_early = false;
  /// Where tets stay inverted after the interior solve: Jacobi sweeps relaxing the surface map
  /// across the layout's traced paths (kept only if then no tet is inverted; 0: none).
  int release_sweeps = 20;
  /// Canonical boundary vertices are placed on the source's Phong reconstruction per B-rep face
  /// (smooth_surface.h) with this shape factor; 0 places them on the flat source triangles.
  /// 1/2 reproduces a circular arc to second order (the chord's sag), so the mapped points
  /// lie on the CAD surface as closely as the canonical's own vertices do. Where tets stay
  /// inverted, the mapping is redone on the flat triangles and kept if that succeeds.
  double smooth_alpha = 0.5;
  /// Patches subdivided by a path between two anchors of their loop that is shorter than this
  /// fraction of the way round the loop between them (§6.2; 0: none).
  double subdivide_ratio = 0;
  /// Where tets stay inverted after every retry above and subdivide_ratio is 0, the whole
  /// mapping once more with subdivide_ratio at this value (0: no such retry). A long thin
  /// patch (the side face of a bent plate 3 mm thick and 90 mm round) crowds its middle onto
  /// a chord of its disk, and two samples crowd it differently: their composed maps pressed
  /// the OpenCASCADE mount's vertices 0.3 mm inside an edge to 2e-4 mm of it, and a tet across
  /// the edge stayed flat; paths across the narrows cut the strip into disks that do not
  /// crowd. A retry, not the default: on pairs that map without it subdivision changes no
  /// measured result and costs 1.9x the time (docs/mapping-decisions.md). One run, without the
  /// flat and early retries of its own, so that a pair refused anyway costs one run more.
  double subdivide_retry_ratio = 0.3;
  /// Traced layout paths measured along their geodesics (geodesic.h) for the boundary of the
  /// patches' disks; false: along their mesh edges.
  bool geodesic_paths = true;
};

/// Maps `source` onto `canonical`'s combinatorics. False with `why` when the references do not
/// allow it (no common control points, a patch that is not a disk, patches without
/// counterpart) or when the result would contain inverted tets. `stats` may be null.
bool map_sample(const mesh::Sample& source, const mesh::Sample& canonical, mesh::MappedSample& out,
                std::string& why, MapStats* stats = nullptr,
                const MapOptions& options = MapOptions());

class MeshMapper final : public mesh::Mapper {
 public:
  bool map(const mesh::Sample& source, const mesh::Sample& canonical, mesh::MappedSample& out,
           std::string& why) const override {
    return map_sample(source, canonical, out, why, nullptr);
  }
  // Recorded in every asset's provenance: it names the mapping's results, so it changes (the
  // number goes up) exactly when some mapping's output does, and never otherwise.
  const char* name() const override { return "mesh-v10"; }
};

}  // namespace cadinterp::mapping
