// The state one mapping (map_sample, paper §6) carries from stage to stage, and the stages'
// entry points. Internal to cadinterp_mapping. Each stage reads what the stages before it wrote
// and writes its own part; map_sample (mesh_mapper.cpp) calls them in the order of §6.2's
// paragraphs (CAD referencing, surface mapping, interior mapping):
//   match_anchors     correspondence.cpp  anchors: control points with equal IDs
//   build_layout      layout_build.cpp    common layout; patches with holes cut into disks in
//                                         hole_split.cpp, hole_new_anchors.cpp
//   map_surface       surface_map.cpp     canonical boundary onto the source surface
//   solve_interior    interior_solve.cpp  harmonic interior, locally untangled
//   untangle_mapping  untangling.cpp      what stays inverted: release, boundary, whole
// One state belongs to one call of map_sample on one thread; it holds references to the call's
// samples, options, output and message, which must outlive it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "mapping/boundary_untangle.h"
#include "mapping/correspondence.h"
#include "mapping/interior_solve.h"
#include "mapping/mean_value_param.h"
#include "mapping/mesh_mapper.h"
#include "mapping/patch_layout.h"
#include "mapping/smooth_surface.h"
#include "mapping/surface.h"
#include "mesh/mapper.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

struct MappingState {
  MappingState(const mesh::Sample& source_, const mesh::Sample& canonical_,
               const MapOptions& options_, mesh::MappedSample& out_, std::string& why_)
      : source(source_), canonical(canonical_), options(options_), out(out_), why(why_) {}

  // The call's inputs and outputs. Every stage that fails writes its reason to `why`.
  const mesh::Sample& source;
  const mesh::Sample& canonical;
  const MapOptions& options;
  mesh::MappedSample& out;
  std::string& why;
  Surface ss, cs;  ///< the source's and the canonical's boundary surfaces

  // §6.2, CAD referencing (match_anchors). Points and paths are placed on the mesh
  // (cadinterp_builder.h); the tolerances only absorb rounding.
  double src_tol = 0, can_tol = 0;
  Correspondence corr;
  std::size_t dropped_anchors = 0;  ///< matched points not at a mesh vertex on both sides

  // §6.2, surface mapping: the common patch layout (build_layout). The anchors' positions per side
  // (pointers into corr.anchors, renewed by refresh_anchors whenever an anchor is added or
  // removed).
  std::vector<const double*> src_anchor, can_anchor;
  std::set<Id> src_keys, can_keys;                                 ///< CAD edges cut, per side
  std::vector<std::vector<std::uint32_t>> src_traced, can_traced;  ///< paths traced, per side
  /// Per side and half-edge, the borders of faces separated again: cut whatever the keys say.
  std::vector<char> src_face_cuts, can_face_cuts;
  /// Per surface vertex, the anchor there (-1: none); and per anchor, its vertex (-1: none).
  std::vector<int> src_anchor_of, can_anchor_of;
  std::vector<int> src_anchor_of_all, can_anchor_of_all;
  std::vector<char> src_cuts, can_cuts;  ///< the layout's cut half-edges, per side
  std::vector<Patch> sp, cp;             ///< the layout's patches, per side
  std::vector<int> source_of;            ///< per canonical patch, its source patch
  std::size_t rejected_paths = 0;        ///< one-sided edges dropped (MapStats)
  std::size_t subdivided = 0;            ///< paths added to subdivide patches (MapStats)

  /// The cuts of the layout on surface `s` (ss or cs) with CAD edges `keys` and traced paths.
  std::vector<char> cuts_of(const Surface& s, const std::set<Id>& keys,
                            const std::vector<std::vector<std::uint32_t>>& traced,
                            double tol) const;
  /// Whether the layouts with these cuts (and the anchors as they are now) have the same patch
  /// keys on both sides, and (unless `new_anchorless`) no more loops without anchor than sp and
  /// cp: what every candidate split or slit must keep.
  bool layouts_agree(const std::vector<char>& try_src, const std::vector<char>& try_can,
                     bool new_anchorless = false) const;
  /// A new anchor (a Steiner point of the layout, as Kraevoy and Sheffer add) at source vertex
  /// ps and canonical vertex pc, entered in every table of anchors; returns its index.
  /// pop_anchor takes the last one out again.
  int push_anchor(std::uint32_t ps, std::uint32_t pc);
  void pop_anchor();
  void refresh_anchors();
  /// A new anchor at the ends of two slits traced alike, chain_s on the source and chain_c on
  /// the canonical: kept, with the slits cut, when both layouts still have the same patch keys.
  bool add_new_anchor(const std::vector<std::uint32_t>& chain_s,
                      const std::vector<std::uint32_t>& chain_c);

  // §6.2, surface mapping (map_surface).
  std::size_t V = 0;                       ///< canonical vertices
  std::vector<char> on_surface, assigned;  ///< per canonical vertex
  std::vector<SurfacePoint> where;         ///< per canonical boundary vertex, on the source
  /// Each boundary vertex's freedom on the source surface, for the boundary untangling
  /// (boundary_untangle.h): anchors fixed, loop vertices along their source path (arc length
  /// within their segment between two anchors, and between their loop neighbours so the order
  /// along the path is kept), inner vertices in their patch's source disk.
  std::vector<BoundaryDof> dofs;
  std::vector<int> dof_of;
  std::vector<std::unique_ptr<DiskMap>> source_disks;  ///< per canonical patch (null: no inner)
  std::vector<std::unique_ptr<DiskLocator>> source_locators;
  std::size_t planar_patches = 0;         ///< (MapStats)
  std::unique_ptr<SmoothSurface> smooth;  ///< null: the flat source triangles
  /// The 3-D position of a surface point: on `smooth` where there is one, else on the source's
  /// flat triangles.
  void place_point(const SurfacePoint& pt, double* x) const;

  // §6.2, interior mapping (solve_interior, untangle_mapping).
  std::vector<double> surface_map;  ///< out.vertices as the surface map left them
  TetQuality q;                     ///< of out.vertices
  /// More than MapOptions::untangle_max_fraction of the tets inverted after the first solve:
  /// the surface map itself folds, and no boundary untangling or flat retry is tried.
  bool folded = false;
  int foldover_budget = 0;  ///< energy evaluations left to untangle_foldover_free
  std::size_t boundary_moved = 0;
  /// The state before the path release, where the release left fewer inverted tets but some.
  struct Unreleased {
    std::vector<double> surface_map, vertices;
    std::vector<SurfacePoint> where;
    std::vector<BoundaryDof> dofs;
    TetQuality q;
  };
  std::unique_ptr<Unreleased> unreleased;
};

// The stages, in §6 order; each returns false with st.why where the mapping fails.
bool match_anchors(MappingState& st);
bool build_layout(MappingState& st);
bool split_patches_with_holes(MappingState& st);  // build_layout's hole rounds (hole_split.cpp)
bool map_surface(MappingState& st);
bool solve_interior(MappingState& st, TetQuality& q);
bool untangle_mapping(MappingState& st);

// Shared by the stages.
/// The source surface point at disk coordinates uv (sd's triangle containing it).
SurfacePoint disk_point(const DiskMap& sd, const DiskLocator& locator, const double* uv,
                        int* triangle = nullptr);
/// The point at arc length s along a patch's loop, as a combination of two loop vertices.
SurfacePoint loop_point(const Patch& p, double s);
/// The position of p on the flat triangles of s.
void position_of(const mesh::Sample& s, const SurfacePoint& p, double* x);
/// Whether v occurs exactly once on `loop`.
bool occurs_once(const std::vector<std::uint32_t>& loop, std::uint32_t v);
/// The untangling of the interior near tets still inverted, as a whole (foldover_free.h), within
/// st.foldover_budget; q updated where fewer stay inverted.
void untangle_whole(MappingState& st, TetQuality& q);

}  // namespace cadinterp::mapping
