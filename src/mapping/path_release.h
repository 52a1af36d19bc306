// Relaxation of a surface map across the layout's traced paths (paper §6.2, surface mapping).
// Traced paths (shortest paths between anchors, and slits to holes) are a device of the
// parametrization, not CAD edges: the two samples' paths between the same anchors are traced on
// different meshes, so they zigzag differently, and the composed disk maps of the patches on either
// side shear against each other along them. Measured on the OpenCASCADE hub: every inverted tet of
// the pairs with a few left touched a traced path. Here the vertices near those paths move on the
// source surface towards the canonical's own local shape, as the in-patch relaxation does
// inside a patch, but across the path.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "mapping/surface.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

/// Jacobi sweeps over the canonical vertices `movable` (the caller's choice: near traced paths,
/// on no CAD edge, no anchor): each moves by 0.8 of the way towards the canonical mean-value
/// average (Floater's weights, from the canonical's surface triangles) of its surface
/// neighbours' mapped positions `x`, and that point is projected to the nearest point of the
/// source surface (mesh::closest_point_weights) among the triangles within 3 rings of its
/// current ones (`where`), in the same B-rep face (triangle tag). `where` and `x` are updated for
/// the movable vertices, `x` through `place` (the caller's position of a surface point, e.g. on a
/// smooth reconstruction).
void release_traced_paths(const mesh::Sample& source, const Surface& source_surface,
                          const mesh::Sample& canonical, const std::vector<std::uint32_t>& movable,
                          int sweeps, std::vector<SurfacePoint>& where,
                          const std::function<void(const SurfacePoint&, double*)>& place,
                          std::vector<double>& x);

}  // namespace cadinterp::mapping
