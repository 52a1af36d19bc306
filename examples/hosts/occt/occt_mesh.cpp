// Tessellation (BRepMesh) and tetrahedralization (TetGen) of a named B-rep (occt_mesh.h).
#include "occt_mesh.h"

#include <BRepBndLib.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <Geom_Surface.hxx>
#include <Poly_Triangulation.hxx>
#include <TopExp_Explorer.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>

#define TETLIBRARY
#include <tetgen.h>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <unordered_map>

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

double orient(const double* v, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
  double e[3][3];
  for (int k = 0; k < 3; ++k) {
    e[0][k] = v[3 * b + k] - v[3 * a + k];
    e[1][k] = v[3 * c + k] - v[3 * a + k];
    e[2][k] = v[3 * d + k] - v[3 * a + k];
  }
  return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
         e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
         e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
}

double dist(const std::vector<double>& p, std::uint32_t a, std::uint32_t b) {
  const double dx = p[3 * a] - p[3 * b], dy = p[3 * a + 1] - p[3 * b + 1],
               dz = p[3 * a + 2] - p[3 * b + 2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

using Edge = std::pair<std::uint32_t, std::uint32_t>;
// Mesh edges on a B-rep edge (between two faces, or a periodic face's seam): a refinement splits
// them, a flip never removes them, so every face keeps its border.
using EdgeSet = std::set<Edge>;

// The smallest angle of triangle (a, b, c), radians.
double min_angle(const std::vector<double>& p, const std::uint32_t* v) {
  const double l[3] = {dist(p, v[1], v[2]), dist(p, v[2], v[0]), dist(p, v[0], v[1])};
  double best = M_PI;
  for (int k = 0; k < 3; ++k) {
    const double a = l[k], b = l[(k + 1) % 3], c = l[(k + 2) % 3];
    const double cosine = (b * b + c * c - a * a) / (2 * b * c);
    best = std::min(best, std::acos(std::clamp(cosine, -1.0, 1.0)));
  }
  return best;
}

// Splits surface triangles by longest-edge bisection (Rivara): every triangle whose longest edge
// is longer than h, and every triangle with an angle under `skinny` whose longest edge is longer
// than h_min. A triangle is only ever cut through the midpoint of its longest edge, which keeps
// its angles bounded away from 0 (skinny input triangles make TetGen fail under -Y, and a
// boundary triangle with a small angle makes every tet on it flat at that corner). Every split
// edge's midpoint is shared by both its triangles, so the surface stays closed; the midpoints lie
// on the triangles, so the polyhedron and its volume are unchanged. BRepMesh alone leaves planar
// faces as a few long triangles, and TetGen -Y adds no boundary points: without this, mesh_size
// would not reach the boundary. Returns whether anything was split.
bool refine_surface(std::vector<double>& pts, std::vector<std::uint32_t>& tris,
                    std::vector<int>& tri_face, EdgeSet& locked, double h, double skinny = 0,
                    double h_min = 0) {
  auto longest = [&](const std::uint32_t* v) {
    int best = 0;
    double len = -1;
    for (int k = 0; k < 3; ++k) {
      const double l = dist(pts, v[k], v[(k + 1) % 3]);
      // Ties broken by the vertex indices, so both neighbours of an edge agree.
      if (l > len * (1 + 1e-12) ||
          (l >= len * (1 - 1e-12) &&
           std::minmax(v[k], v[(k + 1) % 3]) < std::minmax(v[best], v[(best + 1) % 3]))) {
        best = k;
        len = l;
      }
    }
    return best;
  };
  bool split_any = false;
  for (int pass = 0; pass < 40; ++pass) {
    std::map<Edge, std::uint32_t> mid;
    for (std::size_t t = 0; t < tris.size(); t += 3) {
      const int k = longest(&tris[t]);
      const std::uint32_t a = tris[t + static_cast<std::size_t>(k)],
                          b = tris[t + static_cast<std::size_t>((k + 1) % 3)];
      const double l = dist(pts, a, b);
      if (l > h || (l > h_min && skinny > 0 && min_angle(pts, &tris[t]) < skinny))
        mid.emplace(std::minmax(a, b), 0u);
    }
    if (mid.empty()) return split_any;
    split_any = true;
    // Closure: a triangle with any split edge splits its longest edge too.
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t t = 0; t < tris.size(); t += 3) {
        const std::uint32_t* v = &tris[t];
        bool any = false;
        for (int k = 0; k < 3; ++k) any = any || mid.count(std::minmax(v[k], v[(k + 1) % 3]));
        const int k = longest(v);
        if (any && mid.emplace(std::minmax(v[k], v[(k + 1) % 3]), 0u).second) changed = true;
      }
    }
    for (auto& m : mid) {
      m.second = static_cast<std::uint32_t>(pts.size() / 3);
      for (std::size_t c = 0; c < 3; ++c)
        pts.push_back(0.5 * (pts[3 * m.first.first + c] + pts[3 * m.first.second + c]));
      if (locked.erase(m.first)) {
        locked.insert(std::minmax(m.first.first, m.second));
        locked.insert(std::minmax(m.first.second, m.second));
      }
    }
    std::vector<std::uint32_t> out;
    std::vector<int> out_face;
    auto emit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c, int f) {
      out.insert(out.end(), {a, b, c});
      out_face.push_back(f);
    };
    auto split_at = [&](std::uint32_t a, std::uint32_t b) {
      auto it = mid.find(std::minmax(a, b));
      return it == mid.end() ? UINT32_MAX : it->second;
    };
    for (std::size_t t = 0; t < tris.size(); t += 3) {
      const int f = tri_face[t / 3];
      const int k = longest(&tris[t]);
      // (a, b) the longest edge, c opposite; counter-clockwise as the input.
      const std::uint32_t a = tris[t + static_cast<std::size_t>(k)],
                          b = tris[t + static_cast<std::size_t>((k + 1) % 3)],
                          c = tris[t + static_cast<std::size_t>((k + 2) % 3)];
      const std::uint32_t p = split_at(a, b);
      if (p == UINT32_MAX) {
        emit(a, b, c, f);
        continue;
      }
      const std::uint32_t q = split_at(b, c), r = split_at(c, a);
      if (q == UINT32_MAX) {
        emit(p, b, c, f);
      } else {
        emit(p, b, q, f);
        emit(p, q, c, f);
      }
      if (r == UINT32_MAX) {
        emit(a, p, c, f);
      } else {
        emit(a, p, r, f);
        emit(p, c, r, f);
      }
    }
    tris.swap(out);
    tri_face.swap(out_face);
  }
  return split_any;
}

// Delaunay edge flips inside each B-rep face: an edge whose two triangles' opposite angles sum
// to more than pi is replaced by the other diagonal of their quad. Only where the two triangles
// are coplanar within `max_bend` radians (a plane, or a strip between two rulings of a cylinder
// or cone, whose quads are planar), so the surface moves by at most that sag; never across a
// locked (B-rep) edge. BRepMesh's fans on planar faces become near-equilateral this way, which
// bisection alone cannot do. Returns the number of flips.
std::size_t flip_surface(const std::vector<double>& pts, std::vector<std::uint32_t>& tris,
                         const std::vector<int>& tri_face, const EdgeSet& locked, double max_bend) {
  auto key = [](std::uint32_t a, std::uint32_t b) {
    const auto m = std::minmax(a, b);
    return (std::uint64_t(m.first) << 32) | m.second;
  };
  // Edge -> its two triangles (a closed surface has exactly two).
  std::unordered_map<std::uint64_t, std::array<std::uint32_t, 2>> owner;
  owner.reserve(tris.size());
  for (std::uint32_t t = 0; 3 * std::size_t(t) < tris.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      auto& o = owner
                    .try_emplace(key(tris[3 * t + k], tris[3 * t + (k + 1) % 3]),
                                 std::array<std::uint32_t, 2>{UINT32_MAX, UINT32_MAX})
                    .first->second;
      o[o[0] == UINT32_MAX ? 0 : 1] = t;
    }
  auto normal = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c, double* n) {
    double u[3], w[3];
    for (int d = 0; d < 3; ++d) {
      u[d] = pts[3 * b + d] - pts[3 * a + d];
      w[d] = pts[3 * c + d] - pts[3 * a + d];
    }
    n[0] = u[1] * w[2] - u[2] * w[1];
    n[1] = u[2] * w[0] - u[0] * w[2];
    n[2] = u[0] * w[1] - u[1] * w[0];
    return std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  };
  auto angle_at = [&](std::uint32_t apex, std::uint32_t a, std::uint32_t b) {
    const double x = dist(pts, apex, a), y = dist(pts, apex, b), z = dist(pts, a, b);
    return std::acos(std::clamp((x * x + y * y - z * z) / (2 * x * y), -1.0, 1.0));
  };
  const double cos_bend = std::cos(max_bend);
  std::size_t flips = 0;
  for (int sweep = 0; sweep < 50; ++sweep) {
    std::size_t this_sweep = 0;
    for (std::uint32_t t1 = 0; 3 * std::size_t(t1) < tris.size(); ++t1)
      for (int k = 0; k < 3; ++k) {
        std::uint32_t* v1 = &tris[3 * std::size_t(t1)];
        const std::uint32_t a = v1[k], b = v1[(k + 1) % 3], c = v1[(k + 2) % 3];
        if (locked.count(std::minmax(a, b))) continue;
        const auto& o = owner.at(key(a, b));
        const std::uint32_t t2 = o[0] == t1 ? o[1] : o[0];
        if (t2 == UINT32_MAX || tri_face[t1] != tri_face[t2]) continue;
        std::uint32_t* v2 = &tris[3 * std::size_t(t2)];
        std::uint32_t d = UINT32_MAX;
        for (int j = 0; j < 3; ++j)
          if (v2[j] != a && v2[j] != b) d = v2[j];
        if (d == UINT32_MAX || d == c || owner.count(key(c, d))) continue;
        if (angle_at(c, a, b) + angle_at(d, a, b) <= M_PI + 1e-9) continue;
        double n1[3], n2[3], na[3], nb[3];
        const double l1 = normal(a, b, c, n1), l2 = normal(b, a, d, n2);
        const double la = normal(c, a, d, na), lb = normal(d, b, c, nb);
        if (!(l1 > 0 && l2 > 0 && la > 0 && lb > 0)) continue;
        auto cosine = [](const double* x, const double* y, double lx, double ly) {
          return (x[0] * y[0] + x[1] * y[1] + x[2] * y[2]) / (lx * ly);
        };
        // Coplanar before, and both new triangles facing the same way (a convex quad).
        if (cosine(n1, n2, l1, l2) < cos_bend || cosine(na, n1, la, l1) < cos_bend ||
            cosine(nb, n1, lb, l1) < cos_bend)
          continue;
        // (a, b, c) + (b, a, d) -> (c, a, d) + (d, b, c).
        v1[0] = c, v1[1] = a, v1[2] = d;
        v2[0] = d, v2[1] = b, v2[2] = c;
        owner.erase(key(a, b));
        owner[key(c, d)] = {t1, t2};
        for (auto& e : {std::pair<std::uint64_t, std::array<std::uint32_t, 2>>{key(a, d), {t2, t1}},
                        {key(b, c), {t1, t2}}}) {
          auto& x = owner.at(e.first);
          for (auto& t : x)
            if (t == e.second[0]) t = e.second[1];
        }
        ++this_sweep;
      }
    flips += this_sweep;
    if (this_sweep == 0) break;
  }
  return flips;
}

// The unit normal of triangle v (zero for a degenerate one).
void unit_normal(const std::vector<double>& pts, const std::uint32_t* v, double* n) {
  double u[3], w[3];
  for (int d = 0; d < 3; ++d) {
    u[d] = pts[3 * v[1] + d] - pts[3 * v[0] + d];
    w[d] = pts[3 * v[2] + d] - pts[3 * v[0] + d];
  }
  n[0] = u[1] * w[2] - u[2] * w[1];
  n[1] = u[2] * w[0] - u[0] * w[2];
  n[2] = u[0] * w[1] - u[1] * w[0];
  const double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  for (int d = 0; d < 3; ++d) n[d] /= l > 0 ? l : 1;
}

// Tangential smoothing of the vertices inside one B-rep face (not on a locked edge): each moves
// to the mean of its neighbours, projected back onto its face's surface, and the move is kept
// only where the smallest angle of its triangles grows and none of them turns by more than
// 30 degrees. Returns the number of moves.
std::size_t smooth_surface(std::vector<double>& pts, const std::vector<std::uint32_t>& tris,
                           const std::vector<int>& tri_face, const EdgeSet& locked,
                           const std::vector<Handle(Geom_Surface)>& surfaces) {
  const std::size_t nv = pts.size() / 3;
  std::vector<std::vector<std::uint32_t>> star(nv);
  std::vector<int> face_of(nv, -1);
  std::vector<char> fixed(nv, 0);
  for (std::uint32_t t = 0; 3 * std::size_t(t) < tris.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = tris[3 * std::size_t(t) + std::size_t(k)];
      star[v].push_back(t);
      if (face_of[v] != -1 && face_of[v] != tri_face[t]) fixed[v] = 1;
      face_of[v] = tri_face[t];
    }
  for (const Edge& e : locked) fixed[e.first] = fixed[e.second] = 1;
  auto normal = [&](const std::uint32_t* v, double* n) { unit_normal(pts, v, n); };
  std::size_t moves = 0;
  for (std::uint32_t v = 0; v < nv; ++v) {
    if (fixed[v] || star[v].empty() || face_of[v] < 0) continue;
    const Handle(Geom_Surface)& surface = surfaces[std::size_t(face_of[v])];
    if (surface.IsNull()) continue;
    double c[3] = {0, 0, 0};
    int n = 0;
    double before = M_PI;
    std::vector<std::array<double, 3>> normals;
    for (std::uint32_t t : star[v]) {
      const std::uint32_t* tv = &tris[3 * std::size_t(t)];
      before = std::min(before, min_angle(pts, tv));
      std::array<double, 3> nn;
      normal(tv, nn.data());
      normals.push_back(nn);
      for (int k = 0; k < 3; ++k)
        if (tv[k] != v) {
          for (int d = 0; d < 3; ++d) c[d] += pts[3 * tv[k] + d];
          ++n;
        }
    }
    GeomAPI_ProjectPointOnSurf proj(gp_Pnt(c[0] / n, c[1] / n, c[2] / n), surface);
    if (!proj.IsDone() || proj.NbPoints() == 0) continue;
    const gp_Pnt q = proj.NearestPoint();
    const double old[3] = {pts[3 * v], pts[3 * v + 1], pts[3 * v + 2]};
    pts[3 * v] = q.X(), pts[3 * v + 1] = q.Y(), pts[3 * v + 2] = q.Z();
    double after = M_PI;
    bool ok = true;
    for (std::size_t i = 0; i < star[v].size() && ok; ++i) {
      const std::uint32_t* tv = &tris[3 * std::size_t(star[v][i])];
      after = std::min(after, min_angle(pts, tv));
      double nn[3];
      normal(tv, nn);
      ok = nn[0] * normals[i][0] + nn[1] * normals[i][1] + nn[2] * normals[i][2] > 0.866;
    }
    if (ok && after > before) {
      ++moves;
    } else {
      pts[3 * v] = old[0], pts[3 * v + 1] = old[1], pts[3 * v + 2] = old[2];
    }
  }
  return moves;
}

// Moves the surface vertices from index `first` on (midpoints of the bisection, which lie on
// chords) onto the B-rep geometry: a vertex inside one face onto its surface, a vertex on a
// B-rep edge between two faces onto their intersection (alternating projections onto the two
// surfaces), a seam vertex onto its one surface. Without this a curved edge bisected down to
// h/4 keeps its new vertices inside the curve by the chord's sag (measured on the hub: its cavity
// floor's rim 0.16 mm, 9e-4 of the diagonal, inside the cylinder), which every sample, mapping
// and field carries. A move is skipped where it would turn a triangle by more than 30 degrees.
void project_onto_brep(std::vector<double>& pts, std::uint32_t first,
                       const std::vector<std::uint32_t>& tris, const std::vector<int>& tri_face,
                       const std::vector<Handle(Geom_Surface)>& surfaces) {
  const std::uint32_t nv = static_cast<std::uint32_t>(pts.size() / 3);
  if (first >= nv) return;
  std::vector<std::vector<std::uint32_t>> star(nv - first);
  for (std::size_t t = 0; 3 * t < tris.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (tris[3 * t + std::size_t(k)] >= first)
        star[tris[3 * t + std::size_t(k)] - first].push_back(static_cast<std::uint32_t>(t));
  auto normal = [&](std::uint32_t t, double* n) { unit_normal(pts, &tris[3 * std::size_t(t)], n); };
  for (std::uint32_t v = first; v < nv; ++v) {
    const std::vector<std::uint32_t>& around = star[v - first];
    std::vector<int> faces;
    for (std::uint32_t t : around) faces.push_back(tri_face[t]);
    std::sort(faces.begin(), faces.end());
    faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
    if (faces.empty() || faces.size() > 2) continue;
    bool known = true;
    for (int f : faces) known = known && f >= 0 && !surfaces[std::size_t(f)].IsNull();
    if (!known) continue;
    gp_Pnt q(pts[3 * v], pts[3 * v + 1], pts[3 * v + 2]);
    for (int it = 0; it < (faces.size() == 1 ? 1 : 8); ++it)
      for (int f : faces) {
        GeomAPI_ProjectPointOnSurf proj(q, surfaces[std::size_t(f)]);
        if (proj.IsDone() && proj.NbPoints() > 0) q = proj.NearestPoint();
      }
    std::vector<std::array<double, 3>> before;
    for (std::uint32_t t : around) {
      std::array<double, 3> n;
      normal(t, n.data());
      before.push_back(n);
    }
    const double old[3] = {pts[3 * v], pts[3 * v + 1], pts[3 * v + 2]};
    pts[3 * v] = q.X(), pts[3 * v + 1] = q.Y(), pts[3 * v + 2] = q.Z();
    bool ok = true;
    for (std::size_t i = 0; i < around.size() && ok; ++i) {
      double n[3];
      normal(around[i], n);
      ok = n[0] * before[i][0] + n[1] * before[i][1] + n[2] * before[i][2] > 0.866;
    }
    if (!ok) pts[3 * v] = old[0], pts[3 * v + 1] = old[1], pts[3 * v + 2] = old[2];
  }
}

// BRepMesh triangulates for sag, not shape: planar faces become fans and curved faces long
// strips, most of whose triangles have an angle under 15 degrees, and every tet on such a
// triangle is flat at that corner (measured: 40-75 % of the surface, and 5-40 % of the tets with
// a scaled Jacobian under 0.05, many with all four vertices on the boundary, which no mapping of
// the interior can keep valid). Rounds of in-face Delaunay flips and tangential smoothing on the
// B-rep surfaces, then longest-edge bisection of the triangles still under `min_angle` degrees
// down to edges of h/4, until nothing is split; every vertex the bisection adds (here and in the
// refinement to h before, from `first_new` on) is projected onto the B-rep geometry.
void improve_surface(std::vector<double>& pts, std::vector<std::uint32_t>& tris,
                     std::vector<int>& tri_face, EdgeSet& edges,
                     const std::vector<Handle(Geom_Surface)>& surfaces, double h, double min_angle,
                     std::uint32_t first_new) {
  // Flips may bend the surface by up to 5 degrees (the sag of a chord under 1/20 of its length).
  const double bend = 5 * M_PI / 180;
  project_onto_brep(pts, first_new, tris, tri_face, surfaces);
  for (int round = 0;; ++round) {
    flip_surface(pts, tris, tri_face, edges, bend);
    for (int it = 0; it < 5; ++it) {
      smooth_surface(pts, tris, tri_face, edges, surfaces);
      flip_surface(pts, tris, tri_face, edges, bend);
    }
    const std::uint32_t before = static_cast<std::uint32_t>(pts.size() / 3);
    if (round == 5 ||
        !refine_surface(pts, tris, tri_face, edges, h, min_angle * M_PI / 180, 0.25 * h))
      break;
    project_onto_brep(pts, before, tris, tri_face, surfaces);
  }
}

// TetGen keeps global state in its exact predicates' initialisation; one call at a time.
std::mutex g_tetgen_lock;

// What a TetGen run returns (copied out of its tetgenio).
struct TetGenOutput {
  std::vector<double> points;
  std::vector<int> tets, trifaces, markers;
};

bool write_all(int fd, const void* data, std::size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

template <class T>
bool write_vec(int fd, const T* data, std::size_t n) {
  const std::uint64_t count = n;
  return write_all(fd, &count, sizeof count) && (n == 0 || write_all(fd, data, n * sizeof(T)));
}

template <class T>
bool read_vec(const std::vector<char>& buf, std::size_t& at, std::vector<T>& out) {
  std::uint64_t count = 0;
  if (buf.size() - at < sizeof count) return false;
  std::memcpy(&count, buf.data() + at, sizeof count);
  at += sizeof count;
  if (count > (buf.size() - at) / sizeof(T)) return false;
  out.resize(static_cast<std::size_t>(count));
  if (count) std::memcpy(out.data(), buf.data() + at, static_cast<std::size_t>(count) * sizeof(T));
  at += static_cast<std::size_t>(count) * sizeof(T);
  return true;
}

// Sanitizer runtimes (GCC 12) do not make their allocators safe across fork(): a child forked
// while another thread holds the allocator's lock deadlocks. There TetGen runs in-process.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define OCCT_HOST_FORK_TETGEN 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define OCCT_HOST_FORK_TETGEN 0
#endif
#endif
#ifndef OCCT_HOST_FORK_TETGEN
#define OCCT_HOST_FORK_TETGEN 1
#endif

void copy_output(const tetgenio& out, TetGenOutput& result) {
  result.points.assign(out.pointlist, out.pointlist + 3 * out.numberofpoints);
  result.tets.assign(out.tetrahedronlist,
                     out.tetrahedronlist + out.numberofcorners * out.numberoftetrahedra);
  result.trifaces.assign(out.trifacelist, out.trifacelist + 3 * out.numberoftrifaces);
  if (out.trifacemarkerlist)
    result.markers.assign(out.trifacemarkerlist, out.trifacemarkerlist + out.numberoftrifaces);
}

// Runs TetGen in a child process: TetGen 1.5 stops on some inputs with assert(0) (segment
// recovery under -Y), which would abort the whole build; in a child it only loses that point.
// The child inherits the input, runs TetGen, writes the output to a pipe and _exits.
bool run_tetgen(tetgenio& in, const char* switches, TetGenOutput& result, std::string& why) {
  if (!OCCT_HOST_FORK_TETGEN) {
    try {
      tetgenio out;
      tetrahedralize(const_cast<char*>(switches), &in, &out);
      copy_output(out, result);
      return true;
    } catch (...) {
      why = "TetGen failed on the tessellated surface (self-intersecting or degenerate facets)";
      return false;
    }
  }
  int fds[2];
  if (::pipe(fds) != 0) {
    why = "TetGen: cannot create a pipe";
    return false;
  }
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    why = "TetGen: cannot fork";
    return false;
  }
  if (pid == 0) {
    ::close(fds[0]);
    // TetGen's assertion messages would only repeat what the parent reports.
    const int devnull = ::open("/dev/null", O_WRONLY);
    if (devnull >= 0) ::dup2(devnull, 2);
    int code = 0;
    try {
      tetgenio out;
      tetrahedralize(const_cast<char*>(switches), &in, &out);
      const bool ok =
          write_vec(fds[1], out.pointlist, 3 * static_cast<std::size_t>(out.numberofpoints)) &&
          write_vec(fds[1], out.tetrahedronlist,
                    static_cast<std::size_t>(out.numberofcorners) *
                        static_cast<std::size_t>(out.numberoftetrahedra)) &&
          write_vec(fds[1], out.trifacelist, 3 * static_cast<std::size_t>(out.numberoftrifaces)) &&
          write_vec(fds[1], out.trifacemarkerlist,
                    out.trifacemarkerlist ? static_cast<std::size_t>(out.numberoftrifaces) : 0);
      code = ok ? 0 : 3;
    } catch (...) {
      code = 2;  // TetGen reports errors by throwing an int code (TETLIBRARY)
    }
    ::close(fds[1]);
    ::_exit(code);
  }
  ::close(fds[1]);
  std::vector<char> buf;
  char chunk[1 << 16];
  for (;;) {
    const ssize_t r = ::read(fds[0], chunk, sizeof chunk);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    buf.insert(buf.end(), chunk, chunk + r);
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    why = "TetGen crashed (signal " + std::to_string(WTERMSIG(status)) +
          ", an internal assertion) on the tessellated surface";
    return false;
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    why = "TetGen failed on the tessellated surface (self-intersecting or degenerate facets)";
    return false;
  }
  std::size_t at = 0;
  if (!read_vec(buf, at, result.points) || !read_vec(buf, at, result.tets) ||
      !read_vec(buf, at, result.trifaces) || !read_vec(buf, at, result.markers)) {
    why = "TetGen: truncated output from the child process";
    return false;
  }
  return true;
}

// TetGen on the closed tagged surface; false with `why` when it fails or leaves a sliver.
bool tetrahedralize_surface(const std::vector<double>& pts, const std::vector<std::uint32_t>& tris,
                            const std::vector<int>& tri_face, const std::vector<std::int32_t>& tags,
                            const MeshSettings& settings, double h, double diag, TetMeshData& m,
                            std::string& why) {
  tetgenio in;
  in.firstnumber = 0;
  in.numberofpoints = static_cast<int>(pts.size() / 3);
  in.pointlist = new REAL[pts.size()];
  std::copy(pts.begin(), pts.end(), in.pointlist);
  const int nf = static_cast<int>(tris.size() / 3);
  in.numberoffacets = nf;
  in.facetlist = new tetgenio::facet[static_cast<std::size_t>(nf)];
  in.facetmarkerlist = new int[static_cast<std::size_t>(nf)];
  for (int i = 0; i < nf; ++i) {
    const std::size_t fi = static_cast<std::size_t>(i);
    tetgenio::facet& fc = in.facetlist[i];
    tetgenio::init(&fc);
    fc.numberofpolygons = 1;
    fc.polygonlist = new tetgenio::polygon[1];
    tetgenio::init(&fc.polygonlist[0]);
    fc.polygonlist[0].numberofvertices = 3;
    fc.polygonlist[0].vertexlist = new int[3];
    for (std::size_t k = 0; k < 3; ++k)
      fc.polygonlist[0].vertexlist[k] = static_cast<int>(tris[3 * fi + k]);
    // Markers are 1-based face indices: TetGen uses 0 for "no marker".
    in.facetmarkerlist[i] = tri_face[fi] + 1;
  }
  // p: a piecewise linear complex; q: radius-edge ratio / smallest dihedral angle (10 degrees,
  // without which TetGen leaves slivers the builder rejects as degenerate); a: the volume of a
  // regular tet of edge h; z: zero-based; Q: quiet; Y: no Steiner points on the boundary.
  char switches[128];
  std::snprintf(switches, sizeof switches, "pq%.4g/10a%.6gzQ%s", settings.quality,
                h * h * h / (6 * std::sqrt(2.0)), settings.keep_surface ? "Y" : "");
  TetGenOutput out;
  {
    std::lock_guard<std::mutex> lock(g_tetgen_lock);
    if (!run_tetgen(in, switches, out, why)) return false;
  }
  if (out.tets.empty() || out.tets.size() % 4 != 0 || out.points.empty()) {
    why = "TetGen produced no tets";
    return false;
  }
  const std::size_t nv = out.points.size() / 3;
  for (int idx : out.tets)
    if (idx < 0 || static_cast<std::size_t>(idx) >= nv) {
      why = "TetGen produced an out-of-range vertex index";
      return false;
    }

  m.vertices = std::move(out.points);
  const double* v = m.vertices.data();
  m.tets.reserve(out.tets.size());
  // Boundary faces of the tets, outward (the face opposite vertex k, seen from outside).
  std::map<std::array<std::uint32_t, 3>, std::array<std::uint32_t, 3>> boundary;
  const int faces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  for (std::size_t t = 0; t < out.tets.size(); t += 4) {
    std::uint32_t q[4];
    for (std::size_t k = 0; k < 4; ++k) q[k] = static_cast<std::uint32_t>(out.tets[t + k]);
    const double det = orient(v, q[0], q[1], q[2], q[3]);
    // 1.5 times the builder's threshold (sample.h: volume above 1e-12 of the bbox diagonal
    // cubed, whose bbox is the mesh's, at most ours), so that what passes here passes there.
    if (std::abs(det) / 6 <= 1.5e-12 * diag * diag * diag) {
      char b[160];
      std::snprintf(b, sizeof b,
                    "TetGen produced a degenerate (sliver) tet: volume %.3g of the bounding "
                    "box diagonal cubed",
                    std::abs(det) / 6 / (diag * diag * diag));
      why = b;
      return false;
    }
    if (det < 0) std::swap(q[2], q[3]);
    m.tets.insert(m.tets.end(), q, q + 4);
    for (const auto& f : faces) {
      std::array<std::uint32_t, 3> tri{q[f[0]], q[f[1]], q[f[2]]};
      std::array<std::uint32_t, 3> key = tri;
      std::sort(key.begin(), key.end());
      auto it = boundary.find(key);
      if (it == boundary.end())
        boundary.emplace(key, tri);
      else
        boundary.erase(it);
    }
  }
  // TetGen's boundary faces carry the marker of the input facet they lie on.
  const std::size_t ntri = out.trifaces.size() / 3;
  for (std::size_t i = 0; i < ntri; ++i) {
    std::array<std::uint32_t, 3> key;
    for (std::size_t k = 0; k < 3; ++k)
      key[k] = static_cast<std::uint32_t>(out.trifaces[3 * i + k]);
    std::sort(key.begin(), key.end());
    auto it = boundary.find(key);
    if (it == boundary.end()) continue;  // an interior face (none expected for one solid)
    const int marker = i < out.markers.size() ? out.markers[i] : 0;
    if (marker < 1 || marker > static_cast<int>(tags.size())) {
      why = "TetGen lost the face marker of a boundary triangle";
      return false;
    }
    m.triangles.insert(m.triangles.end(), it->second.begin(), it->second.end());
    m.triangle_tags.push_back(tags[static_cast<std::size_t>(marker - 1)]);
    boundary.erase(it);
  }
  if (!boundary.empty()) {
    why =
        "TetGen's boundary has " + std::to_string(boundary.size()) + " faces without a B-rep face";
    return false;
  }
  return true;
}

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
