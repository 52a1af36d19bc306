// Control points and paths of a named, tessellated B-rep (cadinterp_builder.h ID scheme).
#pragma once

#include <vector>

#include "occt_host.h"
#include "occt_naming.h"

namespace cadinterp::occt {

/// Appends the control points of every vertex and of every edge's hierarchical subdivision to
/// `levels` levels (levels + 1 rows: 1, 2, 4, ... interior points), and the paths between
/// consecutive control points along each edge. The shape must be tessellated (mesh_shape).
void add_references(const NamedShape& s, int levels, std::vector<ControlPoint>& points,
                    std::vector<Path>& paths);

}  // namespace cadinterp::occt
