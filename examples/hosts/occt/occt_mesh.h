// From a named B-rep to the tet mesh a sample carries: BRepMesh_IncrementalMesh tessellates the
// faces, the face triangulations are welded into one closed outward surface whose triangles are
// tagged with their B-rep face's stable tag, and TetGen fills it with tets (README.md, "Meshing").
#pragma once

#include <cstdint>
#include <vector>

#include "occt_naming.h"

namespace cadinterp::occt {

struct TetMeshData {
  std::vector<double> vertices;             ///< #V by 3
  std::vector<std::uint32_t> tets;          ///< #T by 4, positive
  std::vector<std::uint32_t> triangles;     ///< #F by 3, outward
  std::vector<std::int32_t> triangle_tags;  ///< #F, face_tag(label) of the B-rep face
};

struct MeshSettings {
  double mesh_size = 5.0;  ///< target tet edge length (mm)
  /// TetGen -Y: keep the surface triangles (BRepMesh's, split to mesh_size by us); without it
  /// TetGen splits them itself, which can leave sliver tets on curved faces.
  bool keep_surface = true;
  double quality = 1.414;  ///< TetGen -q: largest radius-edge ratio of a tet
  /// With keep_surface: the surface is improved (in-face flips, smoothing on the B-rep surfaces,
  /// bisection) until its triangles' angles reach this (degrees) or their edges h/4; 0: the
  /// bisected BRepMesh triangles as they are.
  double min_angle = 20;
  double angle = 0.3;  ///< BRepMesh angular deflection (radians per segment)
};

struct MeshTimes {
  double tessellate = 0, tetgen = 0;  ///< seconds
};

/// Tessellates (in place: the shape keeps its triangulation, which the references then read)
/// and tetrahedralizes. Throws Infeasible with the stage's message on failure.
TetMeshData mesh_shape(const NamedShape& s, const MeshSettings& settings, MeshTimes& times);

/// Sum of the tets' volumes.
double mesh_volume(const TetMeshData& m);

}  // namespace cadinterp::occt
