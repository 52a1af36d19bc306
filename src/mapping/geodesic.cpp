#include "mapping/geodesic.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <queue>
#include <unordered_map>

namespace cadinterp::mapping {

namespace {

using Point = std::array<double, 3>;

// A traced path longer than this times its geodesic detours rather than zigzags about it, and is
// measured along its own edges (measure_traced_paths_along_geodesics).
constexpr double kDetour = 1.5;

double dist(const Point& p, const Point& q) {
  return std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]);
}

Point at(const double* x) { return {x[0], x[1], x[2]}; }

std::uint64_t edge_key(std::uint32_t u, std::uint32_t v) {
  return (std::uint64_t(std::min(u, v)) << 32) | std::max(u, v);
}

}  // namespace

std::vector<Point> corridor_geodesic(const Surface& s, const std::vector<int>& corridor,
                                     std::uint32_t a, std::uint32_t b, int steiner) {
  // Nodes: the corridor's vertices, then `steiner` points per corridor edge (shared by the two
  // triangles of the edge), numbered once.
  std::unordered_map<std::uint32_t, int> vertex_node;
  std::unordered_map<std::uint64_t, int> edge_first;  // first Steiner node of an edge
  std::vector<Point> node;
  auto vertex = [&](std::uint32_t v) {
    auto [it, fresh] = vertex_node.emplace(v, static_cast<int>(node.size()));
    if (fresh) node.push_back(at(s.position(v)));
    return it->second;
  };
  // The Steiner nodes of edge (u, v) in order from the lower vertex id to the higher.
  auto edge_nodes = [&](std::uint32_t u, std::uint32_t v) {
    auto [it, fresh] = edge_first.emplace(edge_key(u, v), static_cast<int>(node.size()));
    if (fresh) {
      const Point p = at(s.position(std::min(u, v))), q = at(s.position(std::max(u, v)));
      for (int k = 1; k <= steiner; ++k) {
        const double f = double(k) / (steiner + 1);
        node.push_back(
            {p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1]), p[2] + f * (q[2] - p[2])});
      }
    }
    return it->second;
  };
  std::vector<std::vector<int>> triangle_nodes;
  triangle_nodes.reserve(corridor.size());
  for (int f : corridor) {
    std::vector<int> nodes;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t u = s.from(3 * f + k), v = s.to(3 * f + k);
      nodes.push_back(vertex(u));
      const int first = edge_nodes(u, v);
      for (int i = 0; i < steiner; ++i) nodes.push_back(first + i);
    }
    triangle_nodes.push_back(std::move(nodes));
  }
  const auto ia = vertex_node.find(a), ib = vertex_node.find(b);
  if (ia == vertex_node.end() || ib == vertex_node.end()) return {};
  // Arcs: every pair of nodes on one triangle's border (a straight segment inside it; pairs on
  // one edge are joined along the edge by the same rule).
  std::vector<std::vector<std::pair<int, double>>> arcs(node.size());
  for (const std::vector<int>& nodes : triangle_nodes)
    for (std::size_t i = 0; i < nodes.size(); ++i)
      for (std::size_t j = i + 1; j < nodes.size(); ++j) {
        const int p = nodes[i], q = nodes[j];
        const double w = dist(node[std::size_t(p)], node[std::size_t(q)]);
        arcs[std::size_t(p)].emplace_back(q, w);
        arcs[std::size_t(q)].emplace_back(p, w);
      }
  std::vector<double> d(node.size(), std::numeric_limits<double>::infinity());
  std::vector<int> prev(node.size(), -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  d[std::size_t(ia->second)] = 0;
  queue.emplace(0.0, ia->second);
  while (!queue.empty()) {
    const auto [dn, n] = queue.top();
    queue.pop();
    if (dn > d[std::size_t(n)]) continue;
    if (n == ib->second) break;
    for (const auto& [m, w] : arcs[std::size_t(n)])
      if (dn + w < d[std::size_t(m)]) {
        d[std::size_t(m)] = dn + w;
        prev[std::size_t(m)] = n;
        queue.emplace(dn + w, m);
      }
  }
  if (!std::isfinite(d[std::size_t(ib->second)])) return {};
  std::vector<Point> path;
  for (int n = ib->second; n >= 0; n = prev[std::size_t(n)]) path.push_back(node[std::size_t(n)]);
  std::reverse(path.begin(), path.end());
  return path;
}

std::vector<double> arc_length_on(const Surface& s, const std::vector<std::uint32_t>& chain,
                                  const std::vector<Point>& polyline) {
  std::vector<double> along(polyline.size(), 0.0);
  for (std::size_t i = 1; i < polyline.size(); ++i)
    along[i] = along[i - 1] + dist(polyline[i - 1], polyline[i]);
  const double length = along.back();
  const std::size_t n = chain.size();
  std::vector<double> t(n, 0.0);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const Point x = at(s.position(chain[i]));
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k + 1 < polyline.size(); ++k) {
      const Point& p = polyline[k];
      const Point& q = polyline[k + 1];
      double e[3], l2 = 0, dot = 0;
      for (int c = 0; c < 3; ++c) {
        e[c] = q[std::size_t(c)] - p[std::size_t(c)];
        l2 += e[c] * e[c];
        dot += e[c] * (x[std::size_t(c)] - p[std::size_t(c)]);
      }
      const double f = l2 > 0 ? std::clamp(dot / l2, 0.0, 1.0) : 0.0;
      const Point y = {p[0] + f * e[0], p[1] + f * e[1], p[2] + f * e[2]};
      const double dd = dist(x, y);
      if (dd < best) {
        best = dd;
        t[i] = along[k] + f * (along[k + 1] - along[k]);
      }
    }
  }
  t[n - 1] = length;
  // Strictly increasing: at least a thousandth of the mean step, taken from the last ones.
  const double floor = 1e-3 * length / double(n - 1);
  for (std::size_t i = 1; i < n; ++i) t[i] = std::max(t[i], t[i - 1] + floor);
  if (t[n - 1] > length)  // the floors pushed the end out: scale back into [0, length]
    for (double& x : t) x *= length / t[n - 1];
  return t;
}

namespace {

// A traced path's neighbourhood on one side: the patches beside it and their triangles within
// `rings` rings of it.
struct Beside {
  const Surface& s;
  std::vector<int> patch_of;
  std::vector<std::vector<int>> triangles_of;
  Beside(const Surface& surface, const std::vector<Patch>& patches)
      : s(surface),
        patch_of(patch_of_triangles(surface, patches)),
        triangles_of(surface.sample->vertex_count()) {
    for (int f = 0; f < s.triangles(); ++f)
      for (int k = 0; k < 3; ++k) triangles_of[s.from(3 * f + k)].push_back(f);
  }
  std::vector<int> corridor(const std::vector<std::uint32_t>& chain, int rings) const {
    std::vector<int> beside;
    for (std::size_t i = 0; i + 1 < chain.size(); ++i)
      for (int f : triangles_of[chain[i]])
        for (int k = 0; k < 3; ++k)
          if (s.from(3 * f + k) == chain[i + 1] || s.to(3 * f + k) == chain[i + 1])
            beside.push_back(patch_of[std::size_t(f)]);
    std::sort(beside.begin(), beside.end());
    beside.erase(std::unique(beside.begin(), beside.end()), beside.end());
    std::vector<char> in_ring(s.sample->vertex_count(), 0);
    std::vector<std::uint32_t> ring(chain.begin(), chain.end());
    for (std::uint32_t v : ring) in_ring[v] = 1;
    std::vector<int> out;
    for (int r = 0; r < rings; ++r) {
      std::vector<std::uint32_t> next;
      for (std::uint32_t v : ring)
        for (int f : triangles_of[v]) {
          if (!std::binary_search(beside.begin(), beside.end(), patch_of[std::size_t(f)])) continue;
          out.push_back(f);
          for (int k = 0; k < 3; ++k) {
            const std::uint32_t w = s.from(3 * f + k);
            if (!in_ring[w]) {
              in_ring[w] = 1;
              next.push_back(w);
            }
          }
        }
      ring.swap(next);
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
};

}  // namespace

std::size_t measure_traced_paths_along_geodesics(
    const Surface& s, const std::vector<std::vector<std::uint32_t>>& traced,
    std::vector<Patch>& patches) {
  const Beside beside(s, patches);
  // Per undirected mesh edge of a re-measured path: its length along the geodesic.
  std::unordered_map<std::uint64_t, double> length_of;
  std::size_t measured = 0;
  for (const std::vector<std::uint32_t>& chain : traced) {
    if (chain.size() < 3) continue;  // a single edge is its own geodesic
    const std::vector<Point> g =
        corridor_geodesic(s, beside.corridor(chain, 2), chain.front(), chain.back());
    if (g.size() < 2) continue;
    const std::vector<double> t = arc_length_on(s, chain, g);
    // A path much longer than its geodesic does not zigzag about it (an edge path about a
    // straight line is at most ~1.2x as long) but detours, round a hole whose loop it may not
    // cross: the nearest points on the geodesic would crowd the whole detour into one point,
    // and every canonical vertex along it onto one source point (measured on the OpenCASCADE
    // hub: a slit 2.5x its geodesic round an obround bolt hole, 12 loop vertices within 0.3 mm
    // of arc, 26 triangles folded and 16 tets inverted). Such a path keeps its edges' lengths.
    double edges = 0;
    for (std::size_t i = 0; i + 1 < chain.size(); ++i)
      edges += distance(s.position(chain[i]), s.position(chain[i + 1]));
    if (edges > kDetour * t.back()) continue;
    for (std::size_t i = 0; i + 1 < chain.size(); ++i)
      length_of[edge_key(chain[i], chain[i + 1])] = t[i + 1] - t[i];
    ++measured;
  }
  if (length_of.empty()) return 0;
  for (Patch& p : patches) {
    const std::size_t n = p.loop.size();
    std::vector<double> s_new(n + 1, 0.0);
    bool changed = false;
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t u = p.loop[i], v = p.loop[(i + 1) % n];
      auto it = u == v ? length_of.end() : length_of.find(edge_key(u, v));
      changed = changed || it != length_of.end();
      s_new[i + 1] =
          s_new[i] + (it != length_of.end() ? it->second : p.loop_s[i + 1] - p.loop_s[i]);
    }
    if (!changed) continue;
    // Anchors sit at loop vertices: their arc lengths follow the loop's, piecewise linearly.
    for (double& a : p.anchor_s) {
      std::size_t i = static_cast<std::size_t>(
          std::upper_bound(p.loop_s.begin(), p.loop_s.end(), a) - p.loop_s.begin());
      i = std::min(n, i == 0 ? std::size_t(1) : i) - 1;
      const double len = p.loop_s[i + 1] - p.loop_s[i];
      const double f = len > 0 ? std::clamp((a - p.loop_s[i]) / len, 0.0, 1.0) : 0.0;
      a = s_new[i] + f * (s_new[i + 1] - s_new[i]);
    }
    p.loop_s = std::move(s_new);
  }
  return measured;
}

}  // namespace cadinterp::mapping
