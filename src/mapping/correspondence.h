// Correspondence between two samples' references (paper §6.2 (CAD referencing), requirement 1):
// control points are matched ONLY by equal IDs, and a CAD edge exists in both samples when its
// paths carry the same edge key. Face-tag borders that lie on an edge of only one sample are not
// cut by the common layout, so faces that split or merge across the parameter box become one patch
// on both sides.
#pragma once

#include <cstdint>
#include <set>
#include <utility>
#include <vector>

#include "mapping/surface.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

using Id = std::vector<std::int64_t>;

/// A point known on both sides: a control point with the same ID in both samples, or the end
/// of a CAD edge present in both ({edge key..., -2, 0 or 1}: the edge's lower- or higher-id end,
/// the parameter 0 or 1 of the ID scheme's edge parametrization). The latter keeps a corner
/// anchored when the corner's own ID changes because another edge appeared at it.
struct Anchor {
  Id id;
  double source[3], canonical[3];
};

struct Correspondence {
  std::vector<Anchor> anchors;     ///< in increasing ID order
  std::size_t matched_points = 0;  ///< of which control points with equal IDs
  /// Edge keys (path_edge_key) that occur in both samples.
  std::set<Id> common_edges;
};

Correspondence correspond(const mesh::Sample& source, const mesh::Sample& canonical);

/// The CAD edge a path lies on: the edge part of an edge-sample ID at either end ({1, edge id,
/// end vertex ids...}, the prefix before -1), else (a path between two B-rep vertices, i.e. a
/// whole edge) {2, |a|, a..., b...} with a <= b.
Id path_edge_key(const mesh::Path& p);

/// Per half-edge of `s`: 1 where the common patch layout cuts the surface. A half-edge between
/// triangles of different face tags is cut unless it lies (within `tolerance`) on a path whose
/// edge key is not common: a CAD edge that exists in one sample only. Half-edges inside a face
/// are cut only along a common path there (a periodic face's seam: build_patches then opens
/// the face along it).
std::vector<char> layout_cuts(const Surface& s, const std::set<Id>& common_edges, double tolerance);

/// Distance from p to segment [a, b], and the fraction t along it of the closest point.
double point_segment_distance(const double* p, const double* a, const double* b, double& t);

}  // namespace cadinterp::mapping
