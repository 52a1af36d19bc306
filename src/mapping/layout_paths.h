// Shortest-path candidates of the common layout (paper §6.2, Kraevoy–Sheffer style): a CAD edge
// that exists in one sample only (a face split in one, merged in the other) is kept as a layout
// path when both its end vertices are anchored; the other sample gets the shortest path between
// the corresponding anchors along its surface edges, so that both layouts split the face the
// same way. Candidates are taken by increasing length and a path may not touch an earlier cut
// (no crossings, no separation of anchors by a later path).
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "mapping/correspondence.h"
#include "mapping/surface.h"

namespace cadinterp::mapping {

/// A CAD edge of one side only, with the anchors at its two end vertices.
struct OneSidedEdge {
  bool in_source = false;  ///< the edge is the source's (else the canonical's)
  Id key;
  double length = 0;  ///< along its paths
  int anchor[2] = {-1, -1};
};

/// One-sided edges whose two ends are anchors, by increasing length then key.
std::vector<OneSidedEdge> one_sided_edges(const mesh::Sample& source, const mesh::Sample& canonical,
                                          const Correspondence& corr, double source_tolerance,
                                          double canonical_tolerance);

/// The vertex of the surface within `tolerance` of p, or -1.
int vertex_at(const Surface& s, const double* p, double tolerance);

/// Dijkstra along surface edges from a to b, whose inner vertices avoid every vertex that a cut
/// half-edge touches; with `patch_of`, only along edges of triangles of patch `patch`. The vertex
/// chain a..b, or empty when there is none.
/// With `touch_except` (per surface vertex: nonzero where the path may never pass, e.g. the
/// anchors), inner vertices may lie on cuts elsewhere, at a cost of 10x the edge length: a
/// path may then touch a loop (the patch is cut open there, patch_layout.h) but not cross it.
std::vector<std::uint32_t> shortest_path(const Surface& s, const std::vector<char>& cuts,
                                         std::uint32_t a, std::uint32_t b,
                                         const std::vector<int>* patch_of = nullptr, int patch = -1,
                                         const std::vector<char>* touch_except = nullptr);

/// Dijkstra along surface edges from a to the nearest vertex marked in `targets` (within patch
/// `patch` of `patch_of`), with inner vertices off every cut; the chain a..target, or empty.
std::vector<std::uint32_t> shortest_path_to_any(const Surface& s, const std::vector<char>& cuts,
                                                std::uint32_t a, const std::vector<char>& targets,
                                                const std::vector<int>& patch_of, int patch);

/// Per surface vertex, the length of shortest_path_to_any's path from a to it (infinity where
/// there is none): the search passes through no target, and reaches every one it can.
std::vector<double> path_lengths_from(const Surface& s, const std::vector<char>& cuts,
                                      std::uint32_t a, const std::vector<char>& targets,
                                      const std::vector<int>& patch_of, int patch);

/// One side of the cyclic-order check: the surface, its cuts before and after adding a layout
/// path, the path's end vertex, and per surface vertex its anchor index (-1 for none).
struct PathEnd {
  const Surface* surface = nullptr;
  const std::vector<char>* before = nullptr;
  const std::vector<char>* after = nullptr;
  std::uint32_t vertex = 0;
  const std::vector<int>* anchor_of = nullptr;
};

/// The layout paths leaving vertex v in cyclic order around it (the same rotation on both
/// samples, whose surfaces are oriented outward), each as the anchors it passes, in order:
/// followed along cut edges through vertices of cut degree 2, up to the first vertex of another
/// degree (a junction or a path's end). `half_edges` (may be null) gets each path's first
/// half-edge.
std::vector<std::vector<int>> paths_around(const Surface& s, const std::vector<char>& cuts,
                                           std::uint32_t v, const std::vector<int>& anchor_of,
                                           std::vector<int>* half_edges);

/// Kraevoy–Sheffer's cyclic-order condition at one end of a new layout path: the path's
/// neighbours in the cyclic order around its end (the far anchors of the previous and next
/// path) must be the same on both samples; otherwise the path passes the anchor on the other
/// side of an existing path on one sample and the patches it makes cannot correspond. True when
/// they agree (or the end has no other path).
bool cyclic_order_agrees(const PathEnd& a, const PathEnd& b);

/// Per surface vertex, the index of the anchor at it (-1 for none); anchors not at a vertex
/// within `tolerance` are left out.
std::vector<int> anchor_vertices(const Surface& s, const std::vector<const double*>& anchors,
                                 double tolerance);

/// Whether two sides' paths between the same anchors run alike. The patch keys cannot tell a
/// path that goes round a hole one way from one that goes round it the other way (the hole is
/// joined to the loop either way), yet the two disk maps then shear the region between the two
/// routes against each other (measured on the OpenCASCADE hub: a slit round one bolt hole on one
/// side and round its neighbour on the other, 4010 inverted tets over the flange). Both chains
/// are resampled at 17 equal arc-length fractions t; where the shapes differ only by the
/// parameter change, point t of `b` is point t of `a` moved as the ends moved (linearly in t), up
/// to the meshes' zigzag. True when no point is off by more than a quarter of the longer path,
/// or by no more than `slack` (from a caller that knows how far apart paths that differ in kind
/// run). Chains of fewer than two vertices never run alike.
bool paths_run_alike(const Surface& sa, const std::vector<std::uint32_t>& a, const Surface& sb,
                     const std::vector<std::uint32_t>& b, double slack = 0);

/// Marks both half-edges of every edge along `chain` as cut.
void cut_along(const Surface& s, const std::vector<std::uint32_t>& chain, std::vector<char>& cuts);

}  // namespace cadinterp::mapping
