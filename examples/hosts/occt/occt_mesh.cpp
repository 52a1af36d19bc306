// Tessellation (BRepMesh) and tetrahedralization (TetGen) of a named B-rep (occt_mesh.h): the
// faces tessellated and welded here, the surface improved in occt_surface.cpp, TetGen run in
// occt_tetgen.cpp.
#include "occt_mesh.h"

#include <BRepBndLib.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <Geom_Surface.hxx>
#include <Poly_Triangulation.hxx>
#include <TopExp_Explorer.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <unordered_map>

#include "occt_mesh_steps.h"
#include "occt_models.h"

namespace cadinterp::occt {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Welds coincident nodes of neighbouring face triangulations: BRepMesh discretizes a shared
// edge once, so both faces' nodes agree to round-off; a grid of cell `eps` finds them.
class Welder {
 public:
  explicit Welder(double eps) : eps_(eps) {}
  std::uint32_t add(const gp_Pnt& p) {
    const std::array<long long, 3> c = cell(p);
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          auto it = grid_.find(hash({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == grid_.end()) continue;
          for (std::uint32_t i : it->second)
            if (std::abs(points_[3 * i] - p.X()) <= eps_ &&
                std::abs(points_[3 * i + 1] - p.Y()) <= eps_ &&
                std::abs(points_[3 * i + 2] - p.Z()) <= eps_)
              return i;
        }
    const auto i = static_cast<std::uint32_t>(points_.size() / 3);
    points_.insert(points_.end(), {p.X(), p.Y(), p.Z()});
    grid_[hash(c)].push_back(i);
    return i;
  }
  const std::vector<double>& points() const { return points_; }

 private:
  std::array<long long, 3> cell(const gp_Pnt& p) const {
    return {std::llround(p.X() / eps_), std::llround(p.Y() / eps_), std::llround(p.Z() / eps_)};
  }
  static std::uint64_t hash(const std::array<long long, 3>& c) {
    std::uint64_t h = 1469598103934665603ull;
    for (long long v : c) {
      h ^= static_cast<std::uint64_t>(v);
      h *= 1099511628211ull;
    }
    return h;
  }
  double eps_;
  std::vector<double> points_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid_;
};

}  // namespace

TetMeshData mesh_shape(const NamedShape& s, const MeshSettings& settings, MeshTimes& times) {
  if (!(settings.mesh_size > 0)) throw Infeasible("mesh size must be positive");
  auto t0 = Clock::now();
  Bnd_Box bb;
  BRepBndLib::Add(s.shape, bb);
  const double diag = std::sqrt(bb.SquareExtent());
  // Sag 1/10 of the element size and at most ~17 degrees per segment on curved faces (a
  // 21-gon keeps 98.5% of a circle's area).
  BRepMesh_IncrementalMesh mesher(s.shape, 0.1 * settings.mesh_size, false, settings.angle, false);
  if (!mesher.IsDone()) throw Infeasible("tessellation (BRepMesh) failed");

  Welder weld(1e-7 * diag);
  std::vector<std::uint32_t> tris;
  std::vector<int> tri_face;  // index into `tags`
  std::vector<std::int32_t> tags;
  std::map<std::int32_t, std::string> tag_owner;
  EdgeSet locked;
  std::vector<Handle(Geom_Surface)> surfaces;  // per entry of `tags`, in the shape's frame
  for (TopExp_Explorer ex(s.shape, TopAbs_FACE); ex.More(); ex.Next()) {
    const TopoDS_Face& f = TopoDS::Face(ex.Current());
    const FaceName* name = s.faces.Seek(f);
    if (!name) throw Infeasible("a face has no name (naming failed)");
    const std::int32_t tag = face_tag(name->label);
    auto owner = tag_owner.emplace(tag, name->label);
    if (!owner.first->second.empty() && owner.first->second != name->label)
      throw Infeasible("face tags of '" + name->label + "' and '" + owner.first->second +
                       "' collide");
    TopLoc_Location loc;
    const Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(f, loc);
    if (tri.IsNull() || tri->NbTriangles() == 0)
      throw Infeasible("tessellation left face '" + name->label + "' empty");
    const gp_Trsf trsf = loc.Transformation();
    std::vector<std::uint32_t> node(static_cast<std::size_t>(tri->NbNodes()) + 1);
    for (int i = 1; i <= tri->NbNodes(); ++i)
      node[static_cast<std::size_t>(i)] = weld.add(tri->Node(i).Transformed(trsf));
    const bool reversed = f.Orientation() == TopAbs_REVERSED;
    tags.push_back(tag);
    {
      TopLoc_Location sloc;
      Handle(Geom_Surface) surface = BRep_Tool::Surface(f, sloc);
      if (!surface.IsNull() && !sloc.IsIdentity())
        surface = Handle(Geom_Surface)::DownCast(surface->Transformed(sloc.Transformation()));
      surfaces.push_back(surface);
    }
    // The border of the face's own triangulation (its edges used once, in the face's node
    // numbering, where a seam's two sides are distinct nodes) lies on its B-rep edges.
    std::map<std::pair<int, int>, int> uses;
    for (int i = 1; i <= tri->NbTriangles(); ++i) {
      int n[3];
      tri->Triangle(i).Get(n[0], n[1], n[2]);
      for (int k = 0; k < 3; ++k) ++uses[std::minmax(n[k], n[(k + 1) % 3])];
    }
    for (const auto& u : uses) {
      const std::uint32_t a = node[static_cast<std::size_t>(u.first.first)],
                          b = node[static_cast<std::size_t>(u.first.second)];
      if (u.second == 1 && a != b) locked.insert(std::minmax(a, b));
    }
    for (int i = 1; i <= tri->NbTriangles(); ++i) {
      int n1, n2, n3;
      tri->Triangle(i).Get(n1, n2, n3);
      if (reversed) std::swap(n2, n3);
      const std::uint32_t a = node[static_cast<std::size_t>(n1)],
                          b = node[static_cast<std::size_t>(n2)],
                          c = node[static_cast<std::size_t>(n3)];
      if (a == b || b == c || a == c) continue;  // collapsed by the weld (a degenerate sliver)
      tris.insert(tris.end(), {a, b, c});
      tri_face.push_back(static_cast<int>(tags.size()) - 1);
    }
  }
  // A closed, consistently oriented surface has every directed edge exactly once.
  {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
    for (std::size_t t = 0; t < tris.size(); t += 3)
      for (int k = 0; k < 3; ++k)
        ++directed[{tris[t + static_cast<std::size_t>(k)],
                    tris[t + static_cast<std::size_t>((k + 1) % 3)]}];
    for (const auto& e : directed)
      if (e.second != 1 || !directed.count({e.first.second, e.first.first}))
        throw Infeasible("the tessellation is not a closed oriented surface");
  }
  times.tessellate = since(t0);

  // TetGen can fail on a surface (segment recovery with -Y, slivers without it); a slightly
  // smaller element size gives it another surface to work with. The sequence is fixed, so the
  // result stays a deterministic function of x.
  std::string why;
  for (double scale : {1.0, 0.9, 0.8}) {
    t0 = Clock::now();
    std::vector<double> pts = weld.points();
    std::vector<std::uint32_t> t = tris;
    std::vector<int> tf = tri_face;
    if (settings.keep_surface) {
      EdgeSet edges = locked;
      const double h = scale * settings.mesh_size;
      const std::uint32_t welded = static_cast<std::uint32_t>(pts.size() / 3);
      refine_surface(pts, t, tf, edges, h);
      if (settings.min_angle > 0)
        improve_surface(pts, t, tf, edges, surfaces, h, settings.min_angle, welded);
    }
    times.tessellate += since(t0);
    t0 = Clock::now();
    TetMeshData m;
    const bool ok = tetrahedralize_surface(pts, t, tf, tags, settings, scale * settings.mesh_size,
                                           diag, m, why);
    times.tetgen += since(t0);
    if (ok) return m;
  }
  throw Infeasible(why);
}

double mesh_volume(const TetMeshData& m) {
  double vol = 0;
  for (std::size_t t = 0; t < m.tets.size(); t += 4)
    vol += orient(m.vertices.data(), m.tets[t], m.tets[t + 1], m.tets[t + 2], m.tets[t + 3]) / 6;
  return vol;
}

}  // namespace cadinterp::occt
