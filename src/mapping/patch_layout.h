// The common patch layout of two boundary surfaces (paper §6.2, requirement 2). Patches are the
// faces of the layout: connected sets of triangles bounded by layout cuts (CAD paths present in
// both samples, correspondence.h). Each must be a disk whose boundary loop carries matched
// control points (anchors); patches of the two samples correspond when their anchors agree
// in cyclic order.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "mapping/correspondence.h"
#include "mapping/surface.h"

namespace cadinterp::mapping {

/// A boundary loop of a patch, the patch on its left seen from outside.
struct Loop {
  std::vector<std::uint32_t> vertices;  ///< surface vertices; a seam's appear twice
  std::vector<int> local;               ///< the same loop in Patch::local_vertices' numbering
  std::vector<double> s;         ///< arc length at vertices[i]; size()+1 values (last: length)
  std::vector<int> anchors;      ///< indices into Correspondence::anchors, in loop order,
                                 ///< starting at the smallest
  std::vector<double> anchor_s;  ///< arc length of each anchor along the loop
};

struct Patch {
  std::vector<int> triangles;       ///< triangle indices of the surface, increasing
  std::vector<std::uint32_t> loop;  ///< the boundary loop (of a disk; else the first loop)
  std::vector<double> loop_s;       ///< as Loop::s
  std::vector<int> anchors;         ///< as Loop::anchors
  std::vector<double> anchor_s;     ///< as Loop::anchor_s
  std::vector<Loop> holes;          ///< further loops (build_patches with allow_holes), ordered
                                    ///< by their smallest anchor; loops without any anchor last
  /// Handles (build_patches with allow_holes): 0 for a sphere with holes. Faces merged across a
  /// topology change can join two faces by several tubes (the OpenCASCADE hub's flange: floor
  /// and bottom joined by the walls of bolt holes whose shape changed), see separate_faces.
  int genus = 0;
  /// The patch cut open along every cut inside it (a periodic face's seam): a surface vertex
  /// on such a cut has one local copy per side. `local_vertices[l]` is local vertex l's surface
  /// vertex, `corner_local` the local vertex of each triangle corner (3 per `triangles` entry,
  /// in the surface's corner order), `loop_local` the local vertex of each `loop` entry.
  std::vector<std::uint32_t> local_vertices;
  std::vector<int> corner_local;
  std::vector<int> loop_local;
  /// What pairs patches across the samples: each loop's anchors in cyclic order.
  std::vector<int> key() const;
};

/// Patches of one side. `anchor_positions[m]` is anchor m's position on this side. A cut whose
/// two sides lie in the same patch (the seam of a periodic B-rep face: a cylinder's lateral face
/// between its two circles) is part of that patch's boundary, which then runs along it twice,
/// once per side, with the seam's vertices duplicated in the patch's local numbering. Fails
/// when a patch has a pinched boundary (after that cutting), a loop without anchor, or is not a
/// disk: with `allow_holes`, any bordered surface is accepted (its handles in `genus`), its loops
/// other than the first go to `holes`, for the caller to cut (§6.2's subdivision), and loops
/// without anchor are holes too (the first loop has anchors whenever any loop has).
bool build_patches(const Surface& s, const std::vector<char>& cuts,
                   const std::vector<const double*>& anchor_positions, double tolerance,
                   bool allow_holes, std::vector<Patch>& out, std::string& why);

/// Cuts, inside every patch whose triangles carry more than one face tag, the border between
/// the triangles whose tag is in `group` (sorted) and the others: faces merged across CAD edges
/// of one side only (layout_cuts), separated again (layout_build.cpp, which keeps such a cut only
/// where both samples' layouts still agree). Returns the edges cut.
std::size_t separate_faces(const Surface& s, const std::vector<Patch>& patches,
                           const std::vector<std::int32_t>& group, std::vector<char>& cuts);

/// Per triangle of the surface, the index of its patch.
std::vector<int> patch_of_triangles(const Surface& s, const std::vector<Patch>& patches);

/// For each canonical patch, its source patch (same anchors in the same cyclic order). Fails
/// naming the first canonical patch without a counterpart.
bool pair_patches(const std::vector<Patch>& source, const std::vector<Patch>& canonical,
                  std::vector<int>& source_of, std::string& why);

}  // namespace cadinterp::mapping
