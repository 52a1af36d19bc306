// Improving the welded BRepMesh surface on the B-rep geometry before TetGen (occt_mesh_steps.h):
// longest-edge bisection, in-face Delaunay flips and tangential smoothing, every new vertex
// projected onto its face's surface.
#include <BRep_Tool.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <Geom_Surface.hxx>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <unordered_map>
#include <vector>

#include "occt_mesh_steps.h"

namespace cadinterp::occt {

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

namespace {

double dist(const std::vector<double>& p, std::uint32_t a, std::uint32_t b) {
  const double dx = p[3 * a] - p[3 * b], dy = p[3 * a + 1] - p[3 * b + 1],
               dz = p[3 * a + 2] - p[3 * b + 2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

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

}  // namespace

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
                    std::vector<int>& tri_face, EdgeSet& locked, double h, double skinny,
                    double h_min) {
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

namespace {

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

}  // namespace

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

}  // namespace cadinterp::occt
