// The boundary surface of a sample as a half-edge structure: which triangle lies across each
// triangle edge. Patch layout (§6.2) walks it to grow patches and trace their boundary loops.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mesh/sample.h"

namespace cadinterp::mapping {

/// A point of a surface (or of an edge of it) as a convex combination of up to three vertices;
/// unused slots have weight 0. The currency of the surface map: positions and per-vertex fields
/// of the source are interpolated with the same weights (requirement 5).
struct SurfacePoint {
  std::uint32_t v[3] = {0, 0, 0};
  double w[3] = {1, 0, 0};
};

/// Half-edge h = 3 f + k runs from triangles[3f+k] to triangles[3f+(k+1)%3].
struct Surface {
  const mesh::Sample* sample = nullptr;
  std::vector<int> twin;  ///< per half-edge: the opposite half-edge, -1 on an open border
  /// Vertex v's outgoing half-edges are out_edges[out_start[v] .. out_start[v + 1]).
  std::vector<int> out_start, out_edges;
  /// The boundary vertices (those of some triangle) once each, by x coordinate, then index:
  /// vertex_at (layout_paths.h) looks points up among them.
  std::vector<std::uint32_t> by_x;
  /// The half-edge from a to b, or -1.
  int half_edge(std::uint32_t a, std::uint32_t b) const {
    for (int i = out_start[a]; i < out_start[a + 1]; ++i)
      if (to(out_edges[static_cast<std::size_t>(i)]) == b)
        return out_edges[static_cast<std::size_t>(i)];
    return -1;
  }
  std::uint32_t from(int h) const { return sample->triangles[static_cast<std::size_t>(h)]; }
  std::uint32_t to(int h) const {
    const int f = h / 3, k = h % 3;
    return sample->triangles[static_cast<std::size_t>(3 * f + (k + 1) % 3)];
  }
  int triangles() const { return static_cast<int>(sample->triangle_count()); }
  const double* position(std::uint32_t v) const { return &sample->vertices[3 * std::size_t(v)]; }
};

/// Builds the adjacency. Fails (returns false, `why`) on an edge shared by more than two
/// triangles or used twice in the same direction: the boundary of a tet mesh is a closed
/// oriented 2-manifold, and patch tracing relies on it.
bool build_surface(const mesh::Sample& s, Surface& out, std::string& why);

/// Euclidean distance of two points (3 doubles each).
double distance(const double* a, const double* b);

}  // namespace cadinterp::mapping
