// Control points and paths of a named, tessellated B-rep (the ID scheme of cadinterp_builder.h):
// a vertex { 0, vid, sorted adjacent edge ids }, an edge's interior samples
// { 1, eid, sorted end ids, -1, i_1..i_n } at the midpoints of the hierarchical subdivision of
// its parameter range oriented from the lower-id end, and paths along the edges between
// consecutive control points through the tessellation's edge nodes.
#include "occt_references.h"

#include <BRepAdaptor_Curve.hxx>
#include <BRep_Tool.hxx>
#include <Poly_PolygonOnTriangulation.hxx>
#include <Poly_Triangulation.hxx>
#include <TopExp.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Vertex.hxx>

#include <algorithm>
#include <utility>

namespace cadinterp::occt {
namespace {

// Parameters of the tessellation's nodes on an edge (from the first adjacent face that has a
// polygon on its triangulation), so paths follow the boundary mesh.
std::vector<double> edge_node_parameters(const TopoDS_Edge& e, const TopTools_ListOfShape& faces) {
  std::vector<double> out;
  for (const TopoDS_Shape& f : faces) {
    TopLoc_Location loc;
    const Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(TopoDS::Face(f), loc);
    if (tri.IsNull()) continue;
    const Handle(Poly_PolygonOnTriangulation) poly = BRep_Tool::PolygonOnTriangulation(e, tri, loc);
    if (poly.IsNull() || !poly->HasParameters()) continue;
    for (int i = 1; i <= poly->NbNodes(); ++i) out.push_back(poly->Parameter(i));
    break;
  }
  return out;
}

}  // namespace

void add_references(const NamedShape& s, int levels, std::vector<ControlPoint>& points,
                    std::vector<Path>& paths) {
  const LabelMap edge_names = edge_labels(s);
  const LabelMap vertex_names = vertex_labels(s);
  auto id_of = [](const LabelMap& m, const TopoDS_Shape& x) {
    const std::string* l = m.Seek(x);
    return entity_id(l ? *l : std::string("?"));
  };

  TopTools_IndexedDataMapOfShapeListOfShape vertex_edges, edge_faces;
  TopExp::MapShapesAndUniqueAncestors(s.shape, TopAbs_VERTEX, TopAbs_EDGE, vertex_edges);
  TopExp::MapShapesAndUniqueAncestors(s.shape, TopAbs_EDGE, TopAbs_FACE, edge_faces);

  // Vertices.
  NCollection_DataMap<TopoDS_Shape, std::vector<std::int64_t>, TopTools_ShapeMapHasher> vertex_id;
  for (int i = 1; i <= vertex_edges.Extent(); ++i) {
    const TopoDS_Vertex& v = TopoDS::Vertex(vertex_edges.FindKey(i));
    std::vector<std::int64_t> adj;
    for (const TopoDS_Shape& e : vertex_edges.FindFromIndex(i))
      if (!BRep_Tool::Degenerated(TopoDS::Edge(e))) adj.push_back(id_of(edge_names, e));
    std::sort(adj.begin(), adj.end());
    adj.erase(std::unique(adj.begin(), adj.end()), adj.end());
    ControlPoint cp;
    cp.id = {0, id_of(vertex_names, v)};
    cp.id.insert(cp.id.end(), adj.begin(), adj.end());
    if (cp.id.size() > 64) cp.id.resize(64);  // the builder's limit; never reached by a solid
    const gp_Pnt p = BRep_Tool::Pnt(v);
    cp.position[0] = p.X();
    cp.position[1] = p.Y();
    cp.position[2] = p.Z();
    vertex_id.Bind(v, cp.id);
    points.push_back(cp);
  }

  // Edges: interior samples and the paths between consecutive control points.
  for (int i = 1; i <= edge_faces.Extent(); ++i) {
    const TopoDS_Edge& e = TopoDS::Edge(edge_faces.FindKey(i));
    if (BRep_Tool::Degenerated(e)) continue;
    TopoDS_Vertex v1, v2;
    TopExp::Vertices(e, v1, v2);
    if (v1.IsNull() || v2.IsNull() || !vertex_id.IsBound(v1) || !vertex_id.IsBound(v2)) continue;
    BRepAdaptor_Curve c(e);
    double p1 = c.FirstParameter(), p2 = c.LastParameter();
    if (!v1.IsSame(v2)) {  // a closed edge runs over its whole range
      p1 = BRep_Tool::Parameter(v1, e);
      p2 = BRep_Tool::Parameter(v2, e);
    }
    const std::int64_t id1 = vertex_id(v1)[1], id2 = vertex_id(v2)[1];
    // Oriented from the lower-id end (the curve's direction when the ends are one vertex).
    const bool flip = id2 < id1;
    const double t_lo = flip ? p2 : p1, t_hi = flip ? p1 : p2;
    const std::vector<std::int64_t>& lo_id = vertex_id(flip ? v2 : v1);
    const std::vector<std::int64_t>& hi_id = vertex_id(flip ? v1 : v2);
    std::vector<std::int64_t> base{1, id_of(edge_names, e), std::min(id1, id2), std::max(id1, id2),
                                   -1};
    auto at = [&](double u, double* out) {
      const gp_Pnt p = c.Value(t_lo + u * (t_hi - t_lo));
      out[0] = p.X();
      out[1] = p.Y();
      out[2] = p.Z();
    };
    // (u, id) along the edge, ends included.
    std::vector<std::pair<double, std::vector<std::int64_t>>> along{{0.0, lo_id}, {1.0, hi_id}};
    for (int n = 0; n <= levels; ++n) {
      for (int bits = 0; bits < (1 << n); ++bits) {
        std::vector<std::int64_t> id = base;
        double lo = 0, hi = 1;
        for (int k = n - 1; k >= 0; --k) {
          const int bit = (bits >> k) & 1;
          id.push_back(bit);
          const double mid = 0.5 * (lo + hi);
          (bit ? lo : hi) = mid;
        }
        ControlPoint cp;
        cp.id.assign(id.begin(), id.end());
        const double u = 0.5 * (lo + hi);
        at(u, cp.position);
        points.push_back(cp);
        along.emplace_back(u, id);
      }
    }
    std::sort(along.begin(), along.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<double> nodes;
    for (double t : edge_node_parameters(e, edge_faces.FindFromIndex(i)))
      nodes.push_back((t - t_lo) / (t_hi - t_lo));
    std::sort(nodes.begin(), nodes.end());
    for (std::size_t k = 0; k + 1 < along.size(); ++k) {
      const double ua = along[k].first, ub = along[k + 1].first;
      Path path;
      path.a = along[k].second;
      path.b = along[k + 1].second;
      double p[3];
      at(ua, p);
      path.polyline.insert(path.polyline.end(), p, p + 3);
      for (double u : nodes) {
        if (u <= ua + 1e-9 || u >= ub - 1e-9) continue;
        at(u, p);
        path.polyline.insert(path.polyline.end(), p, p + 3);
      }
      at(ub, p);
      path.polyline.insert(path.polyline.end(), p, p + 3);
      paths.push_back(std::move(path));
    }
  }
}

}  // namespace cadinterp::occt
