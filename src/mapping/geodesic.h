// Geodesic refinement of the layout's traced paths (paper §6.2: "we refine paths to geodesic
// paths. Using geodesic paths smooths the boundary, making the paths on the target and source
// meshes more consistent. This is done only after the paths are selected"). A traced path runs
// along mesh edges (patch boundaries are mesh edges of each sample, and the canonical's
// combinatorics are fixed), zigzagging about the geodesic between its anchors, each sample's
// mesh its own way; arc length along the zigzag then pairs points that lie at different
// fractions of the geodesic on the two sides, and the composed disk maps shear along the path.
// So each traced path keeps its edges but is measured along its geodesic: every vertex of it
// gets the arc length of its nearest point on the geodesic, and the patch loops running along
// the path use those lengths (Patch::loop_s, anchor_s) for the boundary of their disks.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "mapping/patch_layout.h"
#include "mapping/surface.h"

namespace cadinterp::mapping {

/// An approximate geodesic of `s` from vertex a to vertex b through the triangles `corridor`
/// (Lanthier, Maheshwari and Sack's Steiner graph: `steiner` points on every corridor edge, and
/// straight segments between the points and vertices of each triangle; its length exceeds the
/// geodesic's by O(edge length / steiner)). Points in 3-D from a to b; empty when b cannot be
/// reached inside the corridor.
std::vector<std::array<double, 3>> corridor_geodesic(const Surface& s,
                                                     const std::vector<int>& corridor,
                                                     std::uint32_t a, std::uint32_t b,
                                                     int steiner = 3);

/// Per vertex of `chain`, the arc length along `polyline` of the point of it nearest that
/// vertex, from 0 at the first vertex to the polyline's length at the last, strictly increasing
/// (a vertex whose nearest point lies before its predecessor's is put just after it, the rest
/// spread so that the last still ends at the length).
std::vector<double> arc_length_on(const Surface& s, const std::vector<std::uint32_t>& chain,
                                  const std::vector<std::array<double, 3>>& polyline);

/// Measures every traced path of one side along its geodesic (corridor: the triangles within
/// two rings of the path, in the patches beside it) and re-measures the loops of `patches` that
/// run along them: loop_s and anchor_s change, nothing else. Paths whose geodesic cannot be
/// found keep their arc length, and so do paths more than 1.5 times as long as their geodesic:
/// those detour (round a hole) rather than zigzag about it, and their nearest points on it would
/// crowd the detour into one point. Returns the number of paths re-measured.
std::size_t measure_traced_paths_along_geodesics(
    const Surface& s, const std::vector<std::vector<std::uint32_t>>& traced,
    std::vector<Patch>& patches);

}  // namespace cadinterp::mapping
