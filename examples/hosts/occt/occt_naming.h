// Persistent names of B-rep entities derived from the feature history (README.md, "IDs").
//
// Faces are named as features create them: a primitive names each of its faces by a role
// ("f2:handle.xmin"), and every later feature carries the names through its history
// (BRepBuilderAPI_MakeShape::Modified / Generated / IsDeleted): a modified face keeps its name, a
// face split into pieces gets "#k" suffixes in geometric order, a face generated from an edge (a
// fillet) is named after the feature and that edge. Edges and vertices are named by the sorted
// names of the faces around them. So a name depends on what the features did, never on the order
// in which OCCT enumerates sub-shapes, and an entity far from a topology change keeps its name.
#pragma once

#include <BRepBuilderAPI_MakeShape.hxx>
#include <NCollection_DataMap.hxx>
#include <TopTools_ShapeMapHasher.hxx>
#include <TopoDS_Shape.hxx>

#include <cstdint>
#include <string>
#include <vector>

namespace cadinterp::occt {

/// The name of one face: its full label and the primitive roles it descends from (regions are
/// selected by role, so a region survives splits and merges of its faces).
struct FaceName {
  std::string label;
  std::vector<std::string> roots;  ///< sorted, unique
};

using FaceNameMap = NCollection_DataMap<TopoDS_Shape, FaceName, TopTools_ShapeMapHasher>;
using LabelMap = NCollection_DataMap<TopoDS_Shape, std::string, TopTools_ShapeMapHasher>;

/// A shape with a name for every face.
struct NamedShape {
  TopoDS_Shape shape;
  FaceNameMap faces;
};

/// Names every face of a freshly built primitive by `prefix` + a role from its geometry relative
/// to the shape's bounding box: "xmin", "xmax", "ymin", ..., or "lateral" for a curved face.
NamedShape name_by_geometry(const TopoDS_Shape& primitive, int feature, const std::string& prefix);

/// Carries the names of `inputs` through `op` (already done) onto op.Shape(); faces with no
/// history (none expected) are named "f<feature>:new#k" in geometric order.
NamedShape propagate(BRepBuilderAPI_MakeShape& op, int feature,
                     const std::vector<const NamedShape*>& inputs);

/// Edge labels "E[a|b]" (sorted adjacent face labels; "#k" in geometric order when several
/// edges share the same faces) and vertex labels "V[a|b|c]" likewise.
LabelMap edge_labels(const NamedShape& s);
LabelMap vertex_labels(const NamedShape& s);

/// The edges whose adjacent faces descend from roots `a` and `b` (e.g. the fillet edges).
std::vector<TopoDS_Shape> edges_between(const NamedShape& s, const std::string& a,
                                        const std::string& b);

/// FNV-1a 64 of a label, masked to a non-negative int64 (the entity id of the ID scheme).
std::int64_t entity_id(const std::string& label);
/// A non-negative int32 face tag from a face label.
std::int32_t face_tag(const std::string& label);

}  // namespace cadinterp::occt
