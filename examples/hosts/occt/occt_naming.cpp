// Persistent naming through the feature history (occt_naming.h).
#include "occt_naming.h"

#include <BRepAdaptor_Curve.hxx>
#include <BRepAdaptor_Surface.hxx>
#include <BRepBndLib.hxx>
#include <BRepGProp.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <GProp_GProps.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopTools_ListOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Vertex.hxx>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <utility>

namespace cadinterp::occt {
namespace {

using Key = std::array<double, 3>;

Key face_key(const TopoDS_Shape& f) {
  GProp_GProps props;
  BRepGProp::SurfaceProperties(f, props);
  const gp_Pnt c = props.CentreOfMass();
  return {c.X(), c.Y(), c.Z()};
}

Key edge_key(const TopoDS_Shape& e) {
  BRepAdaptor_Curve c(TopoDS::Edge(e));
  const gp_Pnt p = c.Value(0.5 * (c.FirstParameter() + c.LastParameter()));
  return {p.X(), p.Y(), p.Z()};
}

Key vertex_key(const TopoDS_Shape& v) {
  const gp_Pnt p = BRep_Tool::Pnt(TopoDS::Vertex(v));
  return {p.X(), p.Y(), p.Z()};
}

// Geometric order with a tolerance, so that round-off never swaps two entities.
bool key_less(const Key& a, const Key& b) {
  for (int i = 0; i < 3; ++i) {
    const double d = a[static_cast<std::size_t>(i)] - b[static_cast<std::size_t>(i)];
    if (std::abs(d) > 1e-6) return d < 0;
  }
  return false;
}

template <class KeyFn>
void sort_geometric(std::vector<TopoDS_Shape>& shapes, KeyFn key) {
  std::vector<std::pair<Key, std::size_t>> keyed;
  for (std::size_t i = 0; i < shapes.size(); ++i) keyed.emplace_back(key(shapes[i]), i);
  std::stable_sort(keyed.begin(), keyed.end(),
                   [](const auto& a, const auto& b) { return key_less(a.first, b.first); });
  std::vector<TopoDS_Shape> out;
  for (const auto& k : keyed) out.push_back(shapes[k.second]);
  shapes.swap(out);
}

std::string join(const std::set<std::string>& parts, const char* sep) {
  std::string s;
  for (const auto& p : parts) {
    if (!s.empty()) s += sep;
    s += p;
  }
  return s;
}

// Labels of entities of `type` from the labels of their adjacent faces.
LabelMap adjacency_labels(const NamedShape& s, TopAbs_ShapeEnum type, const char* prefix,
                          Key (*key)(const TopoDS_Shape&)) {
  TopTools_IndexedDataMapOfShapeListOfShape adj;
  TopExp::MapShapesAndUniqueAncestors(s.shape, type, TopAbs_FACE, adj);
  std::map<std::string, std::vector<TopoDS_Shape>> groups;
  for (int i = 1; i <= adj.Extent(); ++i) {
    std::set<std::string> names;
    for (const TopoDS_Shape& f : adj.FindFromIndex(i)) {
      const FaceName* n = s.faces.Seek(f);
      names.insert(n ? n->label : std::string("?"));
    }
    groups[std::string(prefix) + "[" + join(names, "|") + "]"].push_back(adj.FindKey(i));
  }
  LabelMap out;
  for (auto& g : groups) {
    if (g.second.size() == 1) {
      out.Bind(g.second[0], g.first);
      continue;
    }
    sort_geometric(g.second, key);
    for (std::size_t k = 0; k < g.second.size(); ++k)
      out.Bind(g.second[k], g.first + "#" + std::to_string(k));
  }
  return out;
}

void add_name(FaceNameMap& map, const TopoDS_Shape& face, const std::string& label,
              const std::vector<std::string>& roots) {
  FaceName* existing = map.ChangeSeek(face);
  if (!existing) {
    map.Bind(face, FaceName{label, roots});
    return;
  }
  // Two input faces became one (a merge): the name lists both, deterministically.
  std::set<std::string> labels{existing->label, label};
  std::set<std::string> all(existing->roots.begin(), existing->roots.end());
  all.insert(roots.begin(), roots.end());
  existing->label = join(labels, "+");
  existing->roots.assign(all.begin(), all.end());
}

}  // namespace

NamedShape name_by_geometry(const TopoDS_Shape& primitive, int feature, const std::string& prefix) {
  Bnd_Box box;
  BRepBndLib::AddOptimal(primitive, box, false, false);
  double lo[3], hi[3];
  box.Get(lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
  NamedShape out;
  out.shape = primitive;
  const char* axes[3][2] = {{"xmin", "xmax"}, {"ymin", "ymax"}, {"zmin", "zmax"}};
  std::map<std::string, std::vector<TopoDS_Shape>> groups;
  for (TopExp_Explorer ex(primitive, TopAbs_FACE); ex.More(); ex.Next()) {
    const TopoDS_Face& f = TopoDS::Face(ex.Current());
    std::string role = "lateral";
    BRepAdaptor_Surface surf(f);
    if (surf.GetType() == GeomAbs_Plane) {
      const Key c = face_key(f);
      const gp_Dir n = surf.Plane().Axis().Direction();
      for (int a = 0; a < 3; ++a) {
        if (std::abs(n.Coord(a + 1)) < 0.999) continue;
        const double d = hi[a] - lo[a];
        role = (c[static_cast<std::size_t>(a)] - lo[a] < 0.5 * d) ? axes[a][0] : axes[a][1];
      }
    }
    groups["f" + std::to_string(feature) + ":" + prefix + "." + role].push_back(f);
  }
  // Faces of equal role (the sides of a rotated box) are told apart by position.
  for (auto& g : groups) {
    sort_geometric(g.second, face_key);
    for (std::size_t k = 0; k < g.second.size(); ++k) {
      const std::string label = g.second.size() == 1 ? g.first : g.first + "#" + std::to_string(k);
      add_name(out.faces, g.second[k], label, {label});
    }
  }
  return out;
}

NamedShape propagate(BRepBuilderAPI_MakeShape& op, int feature,
                     const std::vector<const NamedShape*>& inputs) {
  NamedShape out;
  out.shape = op.Shape();
  TopTools_IndexedMapOfShape result_faces;
  TopExp::MapShapes(out.shape, TopAbs_FACE, result_faces);
  const std::string f = "f" + std::to_string(feature) + ":";

  for (const NamedShape* in : inputs) {
    // Faces: modified (kept or split), or unchanged; generated faces are named after them.
    for (FaceNameMap::Iterator it(in->faces); it.More(); it.Next()) {
      const TopoDS_Shape& face = it.Key();
      const FaceName& name = it.Value();
      std::vector<TopoDS_Shape> mods;
      for (const TopoDS_Shape& m : op.Modified(face))
        if (m.ShapeType() == TopAbs_FACE && result_faces.Contains(m)) mods.push_back(m);
      if (mods.empty() && !op.IsDeleted(face) && result_faces.Contains(face)) mods.push_back(face);
      sort_geometric(mods, face_key);
      for (std::size_t k = 0; k < mods.size(); ++k)
        add_name(out.faces, mods[k],
                 mods.size() == 1 ? name.label : name.label + "#" + std::to_string(k), name.roots);
      std::vector<TopoDS_Shape> gens;
      for (const TopoDS_Shape& g : op.Generated(face))
        if (g.ShapeType() == TopAbs_FACE && result_faces.Contains(g)) gens.push_back(g);
      sort_geometric(gens, face_key);
      for (std::size_t k = 0; k < gens.size(); ++k) {
        const std::string label = f + "from(" + name.label + ")#" + std::to_string(k);
        add_name(out.faces, gens[k], label, {label});
      }
    }
    // Edges and vertices generate faces in fillets and blends: name them after the entity.
    for (const LabelMap& labels : {edge_labels(*in), vertex_labels(*in)}) {
      for (LabelMap::Iterator it(labels); it.More(); it.Next()) {
        std::vector<TopoDS_Shape> gens;
        for (const TopoDS_Shape& g : op.Generated(it.Key()))
          if (g.ShapeType() == TopAbs_FACE && result_faces.Contains(g) && !out.faces.IsBound(g))
            gens.push_back(g);
        sort_geometric(gens, face_key);
        for (std::size_t k = 0; k < gens.size(); ++k) {
          const std::string label =
              f + "blend(" + it.Value() + ")" + (gens.size() == 1 ? "" : "#" + std::to_string(k));
          add_name(out.faces, gens[k], label, {label});
        }
      }
    }
  }
  std::vector<TopoDS_Shape> orphans;
  for (int i = 1; i <= result_faces.Extent(); ++i)
    if (!out.faces.IsBound(result_faces(i))) orphans.push_back(result_faces(i));
  sort_geometric(orphans, face_key);
  for (std::size_t k = 0; k < orphans.size(); ++k) {
    const std::string label = f + "new#" + std::to_string(k);
    add_name(out.faces, orphans[k], label, {label});
  }
  return out;
}

LabelMap edge_labels(const NamedShape& s) {
  return adjacency_labels(s, TopAbs_EDGE, "E", edge_key);
}

LabelMap vertex_labels(const NamedShape& s) {
  return adjacency_labels(s, TopAbs_VERTEX, "V", vertex_key);
}

std::vector<TopoDS_Shape> edges_between(const NamedShape& s, const std::string& a,
                                        const std::string& b) {
  TopTools_IndexedDataMapOfShapeListOfShape adj;
  TopExp::MapShapesAndUniqueAncestors(s.shape, TopAbs_EDGE, TopAbs_FACE, adj);
  std::vector<TopoDS_Shape> out;
  auto has = [&](const TopoDS_Shape& f, const std::string& root) {
    const FaceName* n = s.faces.Seek(f);
    return n && std::find(n->roots.begin(), n->roots.end(), root) != n->roots.end();
  };
  for (int i = 1; i <= adj.Extent(); ++i) {
    bool ha = false, hb = false;
    for (const TopoDS_Shape& f : adj.FindFromIndex(i)) {
      ha = ha || has(f, a);
      hb = hb || has(f, b);
    }
    if (ha && hb) out.push_back(adj.FindKey(i));
  }
  sort_geometric(out, edge_key);
  return out;
}

std::int64_t entity_id(const std::string& label) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : label) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return static_cast<std::int64_t>(h & 0x7fffffffffffffffull);
}

std::int32_t face_tag(const std::string& label) {
  const std::uint64_t h = static_cast<std::uint64_t>(entity_id(label));
  return static_cast<std::int32_t>((h ^ (h >> 31)) & 0x7fffffffu);
}

}  // namespace cadinterp::occt
