// Canonical refinement (paper §6, after step 4): the mapping keeps the canonical mesh's
// combinatorics, so where a source's boundary bends under a canonical triangle (a bolt hole's
// round wall where the canonical has a flat flank, a fillet of 39 mm under one of 7 mm) the
// mapped triangle is a chord of the source's surface, however exactly its corners lie on it.
// Only a finer canonical there lowers that error. This bisects the canonical's boundary edges
// where some source's mapped surface departs from that source's own boundary by more than a
// tolerance, and carries every source's map onto the refined mesh (or maps it again), for a
// few rounds.
//
// Bisection of an edge splits every tet and boundary triangle around it in two (conforming by
// construction, orientation kept, no interior vertex added), so one refined canonical serves
// every source mapped onto it, as an element's canonical mesh must (Eq. 3 blends vertex by
// vertex).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "mesh/mapper.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

/// `s` with every edge of `edges` (vertex pairs, each an edge of a boundary triangle of `s`)
/// split at its midpoint: the new vertex is appended, every tet and triangle holding the edge
/// becomes two (same orientation, same face tag), a per-vertex field takes the mean of the
/// edge's ends and a per-tet field is copied to both halves. Control points, paths and regions
/// are kept: paths are polylines, and a midpoint of a path's mesh edge lies on it. Pairs that
/// are not boundary edges (already split in this call, interior, indices out of range) are
/// skipped.
mesh::Sample bisect_edges(const mesh::Sample& s,
                          const std::vector<std::array<std::uint32_t, 2>>& edges);

struct RefineOptions {
  /// A boundary triangle is refined where, for some source, the mapped surface lies farther
  /// than this (relative to that source's bounding-box diagonal) from the source's boundary, at
  /// a source vertex whose closest mapped triangle it is, or at its own mapped centroid. Below
  /// the builder's default geometry tolerance (1e-3), so that the refined pairs meet it.
  double tolerance = 7e-4;
  /// Rounds of bisection; 0 refines nothing.
  int rounds = 3;
  /// After the first round's mapping, a source's map is carried onto the bisected mesh: its
  /// vertices keep their mapped positions and each new edge midpoint is moved onto the source's
  /// boundary (its face, or the CAD edge between two faces, lifted onto the smooth
  /// reconstruction). A source whose carried map would invert a tet is mapped again with the
  /// mapper, as is every source when this is false.
  bool carry_maps = true;
  /// No round that would take the canonical's vertex count beyond (1 + max_growth) times its
  /// original count (the asset stores every term on the refined mesh).
  double max_growth = 0.5;
  /// Sources mapped in parallel on this many threads (the result does not depend on it).
  int threads = 1;
  /// Asked before each source is mapped, on the thread that maps it (so it must be safe to call
  /// concurrently); once it returns true no further source is mapped and the round under way is
  /// not kept (RefineStats::stopped ends in "cancelled"). Empty: never.
  std::function<bool()> cancelled;
};

struct RefineStats {
  int rounds = 0;                  ///< rounds of bisection in the canonical kept
  std::size_t added_vertices = 0;  ///< canonical vertices they added
  double before = 0;  ///< max over sources of the departure on the original canonical (/ diag)
  double after = 0;   ///< the same on the refined canonical
  /// Maps onto a bisected mesh carried over from the round before, and mapped again.
  std::size_t carried = 0, remapped = 0;
  /// Why refinement stopped above the tolerance ("" when it did not): a round whose mapping
  /// failed, the growth limit, or the round limit.
  std::string stopped;
};

/// The largest departure (/ source diagonal) of `mapped_vertices` (`source` mapped onto
/// `canonical`, #V of the canonical by 3) from the source's boundary, measured as
/// refine_canonical does; the boundary triangles of `canonical` where it exceeds `tolerance` are
/// appended to `marked` when it is not null.
double mapped_departure(const mesh::Sample& source, const mesh::Sample& canonical,
                        const std::vector<double>& mapped_vertices, double tolerance,
                        std::vector<std::size_t>* marked);

/// Maps every source onto `canonical` with `mapper` and refines the canonical as above: each
/// round bisects, on every triangle marked for some source, the edges whose mapped midpoints lie
/// off that source's face by at least half the most of the triangle's edges, then carries every
/// source's map onto the bisected mesh (RefineOptions::carry_maps) or maps it again. Rounds go
/// on from the last mesh until none is marked, a mapping fails or a limit is reached; the round
/// with the smallest departure is kept. On success `refined` is the canonical kept (a copy of
/// `canonical` when nothing was refined) and `mapped[i]` is sources[i] mapped onto it. False with
/// `why` when a source cannot be mapped onto the original canonical; a refined canonical some
/// source cannot be mapped onto is never kept. `stats` may be null. When `mapped` holds one entry
/// per source on entry, those are taken as the sources already mapped onto `canonical` (the
/// builder's, which has them) instead of mapping them again.
bool refine_canonical(const std::vector<const mesh::Sample*>& sources,
                      const mesh::Sample& canonical, const mesh::Mapper& mapper,
                      mesh::Sample& refined, std::vector<mesh::MappedSample>& mapped,
                      std::string& why, RefineStats* stats = nullptr,
                      const RefineOptions& options = RefineOptions());

}  // namespace cadinterp::mapping
