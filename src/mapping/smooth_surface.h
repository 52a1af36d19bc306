// A smooth reconstruction of a sample's boundary for placing mapped vertices (paper §6.2 (surface
// mapping)). The source boundary is a chordal approximation of the CAD surface: a canonical vertex
// placed on the flat source triangles lies up to the chordal sag inside a convex face, and a thin
// "cap" tet of a finer canonical mesh (four vertices on one curved face, all in one source
// triangle) becomes flat there. Evaluating the same barycentric coordinates on Phong tessellation
// (Boubekeur & Alexa 2008) of the source keeps the convexity the points had on the true
// surface, and the mapped boundary follows curved faces (measured: the wrench's and bracket's
// Hausdorff distance drops by a third to a half). It does not repair inverted tets that lie across
// CAD edges; the mapper retries those on the flat triangles (docs/mapping-decisions.md, "Surface
// map").
//
// Smoothness is per B-rep face: vertex normals average only the triangles of one face tag, so a
// sharp CAD edge is never rounded. A point inside a triangle uses its face's normals; a point on
// a mesh edge between two faces uses the edge curve's tangents (the cross product of the two
// faces' normals) where the faces meet at an angle, and their mean normal where they are
// tangent. On a planar face (all normals equal) and a straight edge the reconstruction is the
// flat triangle / segment, so nothing changes there. The surface map's weights (`SurfacePoint`)
// keep their meaning: fields are still interpolated with them (field_transfer.h).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "mapping/surface.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

class SmoothSurface {
 public:
  /// `alpha`: Phong's shape factor (0: the flat triangles). 1/2 reproduces a circular arc
  /// through two vertices with exact normals to second order (the mid-chord lift is
  /// alpha R sin^2(t) cos(t) against the sag R (1 - cos(t)), t half the arc's angle); Boubekeur
  /// and Alexa's 3/4 overshoots it by half.
  explicit SmoothSurface(const mesh::Sample& s, double alpha = 0.5);

  /// The position of `p`: a point of a source triangle (three distinct vertices of one
  /// boundary triangle) on that triangle's Phong patch; a point of a boundary edge (two
  /// vertices, the third weight 0) on the edge's curve; a vertex at itself. Any other
  /// combination (not a triangle or edge of the boundary) stays at the flat combination.
  void position(const SurfacePoint& p, double* x) const;

 private:
  using Vec = std::array<double, 3>;
  const mesh::Sample* s_;
  double alpha_;
  // Per vertex, its normal for each face tag around it (angle-weighted).
  std::vector<std::vector<std::pair<std::int32_t, Vec>>> normals_;
  std::map<std::array<std::uint32_t, 3>, std::int32_t> triangle_tag_;  // sorted vertices -> tag
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::pair<std::int32_t, std::int32_t>>
      edge_tags_;  // sorted ends -> the tags of the two triangles along it
  const Vec* normal(std::uint32_t v, std::int32_t tag) const;
};

}  // namespace cadinterp::mapping
