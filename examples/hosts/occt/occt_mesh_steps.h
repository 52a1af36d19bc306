// The steps of mesh_shape (occt_mesh.h) after BRepMesh: improving the welded surface on the B-rep
// geometry, and TetGen on the closed tagged surface. Shared by occt_mesh.cpp, occt_surface.cpp
// and occt_tetgen.cpp only.
#pragma once

#include <Geom_Surface.hxx>

#include <cstdint>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "occt_mesh.h"

namespace cadinterp::occt {

/// Six times the signed volume of tet (a, b, c, d) of the #V by 3 points v.
double orient(const double* v, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d);

using Edge = std::pair<std::uint32_t, std::uint32_t>;
// Mesh edges on a B-rep edge (between two faces, or a periodic face's seam): a refinement splits
// them, a flip never removes them, so every face keeps its border.
using EdgeSet = std::set<Edge>;

/// Longest-edge bisection of the surface triangles (occt_surface.cpp). Returns whether anything
/// was split.
bool refine_surface(std::vector<double>& pts, std::vector<std::uint32_t>& tris,
                    std::vector<int>& tri_face, EdgeSet& locked, double h, double skinny = 0,
                    double h_min = 0);

/// Flips, smoothing on the B-rep surfaces and bisection until the triangles' angles reach
/// `min_angle` degrees (occt_surface.cpp).
void improve_surface(std::vector<double>& pts, std::vector<std::uint32_t>& tris,
                     std::vector<int>& tri_face, EdgeSet& edges,
                     const std::vector<Handle(Geom_Surface)>& surfaces, double h, double min_angle,
                     std::uint32_t first_new);

/// TetGen on the closed tagged surface; false with `why` when it fails or leaves a sliver
/// (occt_tetgen.cpp).
bool tetrahedralize_surface(const std::vector<double>& pts, const std::vector<std::uint32_t>& tris,
                            const std::vector<int>& tri_face, const std::vector<std::int32_t>& tags,
                            const MeshSettings& settings, double h, double diag, TetMeshData& m,
                            std::string& why);

}  // namespace cadinterp::occt
