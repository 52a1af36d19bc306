// Mesh validation and the order-1/order-2 node layout of the FE discretization.
#include <algorithm>
#include <cmath>
#include <string>

#include "physics_internal.h"

namespace cadinterp::physics::detail {
namespace {

using Vec3 = std::array<double, 3>;

Vec3 vertex(const std::vector<double>& v, std::uint32_t i) {
  return {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
}
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

// Local corner pairs of the order-2 edge nodes (tet: 01 12 20 03 13 23; triangle: 01 12 20).
constexpr int kTetEdges[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
constexpr int kTriangleEdges[3][2] = {{0, 1}, {1, 2}, {2, 0}};

// The element order, the arrays' sizes, finite coordinates and indices in range.
void check_arrays(const TetMesh& mesh, int order) {
  if (order != 1 && order != 2) {
    throw Error("physics: element order " + std::to_string(order) + " is not 1 or 2");
  }
  if (mesh.vertices.empty() || mesh.tets.empty()) {
    throw Error("physics: empty mesh (" + std::to_string(mesh.vertices.size() / 3) + " vertices, " +
                std::to_string(mesh.tets.size() / 4) + " tets)");
  }
  if (mesh.vertices.size() % 3 != 0 || mesh.tets.size() % 4 != 0 ||
      mesh.triangles.size() % 3 != 0 || mesh.triangle_tags.size() * 3 != mesh.triangles.size()) {
    throw Error("physics: mismatched mesh array sizes (vertices " +
                std::to_string(mesh.vertices.size()) + " not 3*#V, or tets " +
                std::to_string(mesh.tets.size()) + " not 4*#T, or triangles " +
                std::to_string(mesh.triangles.size()) + " and triangle_tags " +
                std::to_string(mesh.triangle_tags.size()) + " not 3*#F and #F)");
  }
  const std::size_t nv = mesh.vertices.size() / 3;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (!std::isfinite(mesh.vertices[i])) {
      throw Error("physics: vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
    }
  }
  for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
    if (mesh.tets[i] >= nv) {
      throw Error("physics: tet " + std::to_string(i / 4) + " references vertex " +
                  std::to_string(mesh.tets[i]) + " of " + std::to_string(nv));
    }
  }
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    if (mesh.triangles[i] >= nv) {
      throw Error("physics: boundary triangle " + std::to_string(i / 3) + " references vertex " +
                  std::to_string(mesh.triangles[i]) + " of " + std::to_string(nv));
    }
  }
}

// Volumes: an inverted tet would give a negative-definite element matrix, a flat one a
// singular Jacobian; both are named rather than solved into garbage.
void check_volumes(const TetMesh& mesh) {
  const std::size_t nt = mesh.tets.size() / 4;
  for (std::size_t t = 0; t < nt; ++t) {
    const std::uint32_t* q = &mesh.tets[4 * t];
    const Vec3 p0 = vertex(mesh.vertices, q[0]);
    const Vec3 e1 = sub(vertex(mesh.vertices, q[1]), p0);
    const Vec3 e2 = sub(vertex(mesh.vertices, q[2]), p0);
    const Vec3 e3 = sub(vertex(mesh.vertices, q[3]), p0);
    const double six_v = dot(cross(e1, e2), e3);
    double longest = 0.0;
    for (const auto& [a, b] : kTetEdges) {
      const Vec3 e = sub(vertex(mesh.vertices, q[a]), vertex(mesh.vertices, q[b]));
      longest = std::max(longest, dot(e, e));
    }
    const double scale = longest * std::sqrt(longest);  // (longest edge)^3
    if (!(std::abs(six_v) > 1e-12 * scale)) {
      throw Error("physics: tet " + std::to_string(t) + " is degenerate (volume " +
                  std::to_string(six_v / 6) + ")");
    }
    if (six_v < 0) {
      throw Error("physics: tet " + std::to_string(t) + " is inverted (volume " +
                  std::to_string(six_v / 6) + ")");
    }
  }
}

// Every vertex belongs to a tet, and each boundary triangle is a face of a tet and points away
// from it: the loads (pressure along the normal) and the order-2 face nodes depend on it.
void check_boundary(const TetMesh& mesh) {
  const std::size_t nv = mesh.vertices.size() / 3;
  const std::size_t nf = mesh.triangle_tags.size();
  // Vertex -> tets (CSR), to check the boundary triangles and find unused vertices.
  std::vector<std::size_t> vt_start(nv + 1, 0);
  for (std::uint32_t v : mesh.tets) ++vt_start[v + 1];
  for (std::size_t v = 0; v < nv; ++v) {
    if (vt_start[v + 1] == 0) {
      // No tet: no stiffness, a singular system. Hosts compact their vertex arrays.
      throw Error("physics: vertex " + std::to_string(v) + " belongs to no tet");
    }
    vt_start[v + 1] += vt_start[v];
  }
  std::vector<std::uint32_t> vt(mesh.tets.size());
  {
    std::vector<std::size_t> fill(vt_start.begin(), vt_start.end() - 1);
    for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
      vt[fill[mesh.tets[i]]++] = static_cast<std::uint32_t>(i / 4);
    }
  }
  for (std::size_t f = 0; f < nf; ++f) {
    const std::uint32_t* tri = &mesh.triangles[3 * f];
    bool found = false;
    for (std::size_t k = vt_start[tri[0]]; k < vt_start[tri[0] + 1] && !found; ++k) {
      const std::uint32_t* q = &mesh.tets[4 * vt[k]];
      int shared = 0;
      std::uint32_t other = q[0];
      for (int c = 0; c < 4; ++c) {
        if (q[c] == tri[0] || q[c] == tri[1] || q[c] == tri[2]) {
          ++shared;
        } else {
          other = q[c];
        }
      }
      if (shared != 3 || tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
      found = true;
      const Vec3 p0 = vertex(mesh.vertices, tri[0]);
      const Vec3 n =
          cross(sub(vertex(mesh.vertices, tri[1]), p0), sub(vertex(mesh.vertices, tri[2]), p0));
      if (dot(n, sub(vertex(mesh.vertices, other), p0)) > 0) {
        throw Error("physics: boundary triangle " + std::to_string(f) +
                    " is not oriented outward (its tet lies on its normal side)");
      }
    }
    if (!found) {
      throw Error("physics: boundary triangle " + std::to_string(f) + " is not a tet face");
    }
  }
}

// Order 2: one node per unique edge, numbered after the vertices in sorted-key order, at the
// edge's midpoint; the elements' and faces' nodes are their corners, then their edges' nodes.
void quadratic_layout(const TetMesh& mesh, Discretization& d) {
  const std::size_t nv = mesh.vertices.size() / 3;
  const std::size_t nt = mesh.tets.size() / 4;
  const std::size_t nf = mesh.triangle_tags.size();
  std::vector<std::uint64_t> edges;
  edges.reserve(6 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    for (const auto& [a, b] : kTetEdges) {
      edges.push_back(edge_key(mesh.tets[4 * t + a], mesh.tets[4 * t + b]));
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  auto edge_node = [&](std::uint32_t a, std::uint32_t b, std::size_t face) {
    const std::uint64_t key = edge_key(a, b);
    auto it = std::lower_bound(edges.begin(), edges.end(), key);
    if (it == edges.end() || *it != key) {  // unreachable for a face checked above
      throw Error("physics: boundary triangle " + std::to_string(face) + " is not a tet face");
    }
    return static_cast<std::uint32_t>(nv + static_cast<std::size_t>(it - edges.begin()));
  };
  d.node_count = nv + edges.size();
  d.nodes.resize(3 * d.node_count);
  std::copy(mesh.vertices.begin(), mesh.vertices.end(), d.nodes.begin());
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const auto a = static_cast<std::uint32_t>(edges[e] >> 32);
    const auto b = static_cast<std::uint32_t>(edges[e] & 0xffffffffu);
    for (int c = 0; c < 3; ++c) {
      d.nodes[3 * (nv + e) + c] = 0.5 * (mesh.vertices[3 * a + c] + mesh.vertices[3 * b + c]);
    }
  }
  d.nodes_per_element = 10;
  d.elements.resize(10 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const std::uint32_t* q = &mesh.tets[4 * t];
    std::uint32_t* out = &d.elements[10 * t];
    std::copy(q, q + 4, out);
    for (int e = 0; e < 6; ++e) out[4 + e] = edge_node(q[kTetEdges[e][0]], q[kTetEdges[e][1]], 0);
  }
  d.nodes_per_face = 6;
  d.faces.resize(6 * nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const std::uint32_t* tri = &mesh.triangles[3 * f];
    std::uint32_t* out = &d.faces[6 * f];
    std::copy(tri, tri + 3, out);
    for (int e = 0; e < 3; ++e) {
      out[3 + e] = edge_node(tri[kTriangleEdges[e][0]], tri[kTriangleEdges[e][1]], f);
    }
  }
}

}  // namespace

Discretization discretize(const TetMesh& mesh, int order) {
  check_arrays(mesh, order);
  check_volumes(mesh);
  check_boundary(mesh);
  Discretization d;
  d.order = order;
  d.vertex_count = mesh.vertices.size() / 3;
  d.face_tags = mesh.triangle_tags;
  if (order == 1) {
    d.node_count = d.vertex_count;
    d.nodes = mesh.vertices;
    d.nodes_per_element = 4;
    d.elements = mesh.tets;
    d.nodes_per_face = 3;
    d.faces = mesh.triangles;
    return d;
  }
  quadratic_layout(mesh, d);
  return d;
}

std::vector<std::uint32_t> faces_with_tags(const Discretization& d,
                                           const std::vector<std::int32_t>& tags,
                                           const char* what) {
  std::vector<std::uint32_t> faces;
  for (std::int32_t tag : tags) {
    const std::size_t before = faces.size();
    for (std::size_t f = 0; f < d.face_count(); ++f) {
      if (d.face_tags[f] == tag) faces.push_back(static_cast<std::uint32_t>(f));
    }
    if (faces.size() == before) {
      throw Error(std::string("physics: ") + what + " region: tag " + std::to_string(tag) +
                  " is carried by no boundary triangle");
    }
  }
  if (tags.empty()) throw Error(std::string("physics: ") + what + " region lists no tags");
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  return faces;
}

NodeGraph node_graph(const Discretization& d) {
  const std::size_t n = d.node_count;
  const std::size_t ne = d.element_count();
  const int npe = d.nodes_per_element;
  // Node -> elements, then each node's neighbours are the union of its elements' nodes.
  std::vector<std::size_t> ne_start(n + 1, 0);
  for (std::uint32_t v : d.elements) ++ne_start[v + 1];
  for (std::size_t i = 0; i < n; ++i) ne_start[i + 1] += ne_start[i];
  std::vector<std::uint32_t> ne_list(d.elements.size());
  {
    std::vector<std::size_t> fill(ne_start.begin(), ne_start.end() - 1);
    for (std::size_t i = 0; i < d.elements.size(); ++i) {
      ne_list[fill[d.elements[i]]++] = static_cast<std::uint32_t>(i / npe);
    }
  }
  (void)ne;
  NodeGraph g;
  g.start.resize(n + 1, 0);
  g.neighbors.reserve(n * (npe == 4 ? 15 : 30));
  std::vector<std::uint32_t> scratch;
  for (std::size_t i = 0; i < n; ++i) {
    scratch.clear();
    for (std::size_t k = ne_start[i]; k < ne_start[i + 1]; ++k) {
      const std::uint32_t* el = &d.elements[static_cast<std::size_t>(ne_list[k]) * npe];
      scratch.insert(scratch.end(), el, el + npe);
    }
    std::sort(scratch.begin(), scratch.end());
    scratch.erase(std::unique(scratch.begin(), scratch.end()), scratch.end());
    g.neighbors.insert(g.neighbors.end(), scratch.begin(), scratch.end());
    g.start[i + 1] = g.neighbors.size();
  }
  return g;
}

}  // namespace cadinterp::physics::detail
