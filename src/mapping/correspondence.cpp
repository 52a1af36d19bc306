#include "mapping/correspondence.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <set>
#include <utility>

#include "mapping/layout_paths.h"
#include "mapping/mapping_state.h"

namespace cadinterp::mapping {

namespace {

// Edge-end points of a sample: for each path between a B-rep vertex and a point of an edge,
// {edge key, -2, t} -> the vertex's position, t = 0 at the edge's lower-id end, 1 at the other.
std::map<Id, const double*> edge_ends(const mesh::Sample& s) {
  std::map<Id, const double*> out;
  std::map<Id, const double*> by_id;
  for (const mesh::ControlPoint& p : s.points) by_id.emplace(p.id, p.position);
  for (const mesh::Path& p : s.paths) {
    const Id key = path_edge_key(p);
    if (key.size() < 4 || key[0] != 1) continue;
    for (const Id* end : {&p.a, &p.b}) {
      if (end->size() < 2 || (*end)[0] != 0) continue;
      const std::int64_t vertex = (*end)[1];
      const bool lower = vertex == key[2], upper = vertex == key[3];
      if (!(lower || upper) || (lower && upper)) continue;  // a closed edge: no distinct ends
      auto it = by_id.find(*end);
      if (it == by_id.end()) continue;
      Id id = key;
      id.push_back(-2);
      id.push_back(lower ? 0 : 1);
      out.emplace(id, it->second);
    }
  }
  return out;
}

}  // namespace

Correspondence correspond(const mesh::Sample& source, const mesh::Sample& canonical) {
  Correspondence c;
  std::map<Id, std::pair<const double*, const double*>> all;
  std::map<Id, const double*> in_source;
  for (const mesh::ControlPoint& p : source.points) in_source.emplace(p.id, p.position);
  for (const mesh::ControlPoint& p : canonical.points) {
    auto it = in_source.find(p.id);
    if (it != in_source.end()) all.emplace(p.id, std::make_pair(it->second, p.position));
  }
  c.matched_points = all.size();
  const std::map<Id, const double*> src_ends = edge_ends(source);
  for (const auto& [id, q] : edge_ends(canonical)) {
    auto it = src_ends.find(id);
    if (it != src_ends.end()) all.emplace(id, std::make_pair(it->second, q));
  }
  for (const auto& [id, pq] : all) {
    Anchor a;
    a.id = id;
    std::copy(pq.first, pq.first + 3, a.source);
    std::copy(pq.second, pq.second + 3, a.canonical);
    c.anchors.push_back(std::move(a));
  }
  std::set<Id> a, b;
  for (const mesh::Path& p : source.paths) a.insert(path_edge_key(p));
  for (const mesh::Path& p : canonical.paths) b.insert(path_edge_key(p));
  std::set_intersection(a.begin(), a.end(), b.begin(), b.end(),
                        std::inserter(c.common_edges, c.common_edges.end()));
  return c;
}

Id path_edge_key(const mesh::Path& p) {
  for (const Id* end : {&p.a, &p.b}) {
    if (!end->empty() && (*end)[0] == 1) {
      const auto stop = std::find(end->begin(), end->end(), -1);
      return Id(end->begin(), stop);
    }
  }
  const Id& lo = std::min(p.a, p.b);
  const Id& hi = std::max(p.a, p.b);
  Id key{2, static_cast<std::int64_t>(lo.size())};
  key.insert(key.end(), lo.begin(), lo.end());
  key.insert(key.end(), hi.begin(), hi.end());
  return key;
}

double point_segment_distance(const double* p, const double* a, const double* b, double& t) {
  double ab[3], ap[3], len2 = 0, dot = 0;
  for (int k = 0; k < 3; ++k) {
    ab[k] = b[k] - a[k];
    ap[k] = p[k] - a[k];
    len2 += ab[k] * ab[k];
    dot += ab[k] * ap[k];
  }
  t = len2 > 0 ? std::clamp(dot / len2, 0.0, 1.0) : 0.0;
  double d2 = 0;
  for (int k = 0; k < 3; ++k) {
    const double e = a[k] + t * ab[k] - p[k];
    d2 += e * e;
  }
  return std::sqrt(d2);
}

namespace {

using Edge = std::pair<std::uint32_t, std::uint32_t>;

// The mesh edges of `s` to cut along seams (layout_cuts), as (smaller, larger) vertex pairs.
std::set<Edge> seam_edges(const Surface& s, const std::set<Id>& common_edges,
                          const std::vector<Id>& keys, double tolerance) {
  const mesh::Sample& m = *s.sample;
  const int H = 3 * s.triangles();
  // Seams: a common CAD edge with the same face on both sides (a periodic face's seam, e.g. a
  // cylinder's: the OpenCASCADE host emits its paths like any edge's). Its mesh edges are the
  // pairs of consecutive polyline nodes (paths run through mesh vertices, cadinterp_builder.h);
  // cutting them opens an annulus into a disk the same way on both sides (§6.2).
  std::vector<std::uint32_t> by_x(m.vertex_count());
  for (std::size_t v = 0; v < by_x.size(); ++v) by_x[v] = static_cast<std::uint32_t>(v);
  std::sort(by_x.begin(), by_x.end(), [&](std::uint32_t a, std::uint32_t b) {
    return m.vertices[3 * std::size_t(a)] < m.vertices[3 * std::size_t(b)];
  });
  auto vertex_near = [&](const double* p) -> std::int64_t {
    auto it = std::lower_bound(
        by_x.begin(), by_x.end(), p[0] - tolerance,
        [&](std::uint32_t v, double x) { return m.vertices[3 * std::size_t(v)] < x; });
    for (; it != by_x.end() && m.vertices[3 * std::size_t(*it)] <= p[0] + tolerance; ++it) {
      if (distance(p, &m.vertices[3 * std::size_t(*it)]) <= tolerance) return *it;
    }
    return -1;
  };
  // Edges inside a face; a CAD edge is a seam only when every piece of it runs along them (a
  // partial cut would leave a slit with a loop of its own).
  std::set<Edge> inner;
  for (int h = 0; h < H; ++h) {
    const int t = s.twin[static_cast<std::size_t>(h)];
    if (t >= 0 && m.triangle_tags[static_cast<std::size_t>(h / 3)] ==
                      m.triangle_tags[static_cast<std::size_t>(t / 3)])
      inner.emplace(std::min(s.from(h), s.to(h)), std::max(s.from(h), s.to(h)));
  }
  std::vector<std::vector<std::uint32_t>> inner_next(inner.empty() ? 0 : m.vertex_count());
  for (const Edge& e : inner) {
    inner_next[e.first].push_back(e.second);
    inner_next[e.second].push_back(e.first);
  }
  // The mesh edges along the polyline piece `piece` (nodes, 3 doubles each) from vertex u to
  // vertex v: the edge itself, or a chain of inner edges through vertices on the piece, each
  // nearer v (a host may split a segment after emitting the path: the OpenCASCADE host bisects
  // long or skinny surface triangles, seams included).
  auto piece_edges = [&](std::uint32_t u, std::uint32_t v, const std::vector<const double*>& piece,
                         std::vector<Edge>& out) {
    const double* b = &m.vertices[3 * std::size_t(v)];
    auto to_v = [&](std::uint32_t w) { return distance(&m.vertices[3 * std::size_t(w)], b); };
    auto on_piece = [&](std::uint32_t w) {
      for (std::size_t i = 0; i + 1 < piece.size(); ++i) {
        double t;
        if (point_segment_distance(&m.vertices[3 * std::size_t(w)], piece[i], piece[i + 1], t) <=
            tolerance)
          return true;
      }
      return false;
    };
    for (std::uint32_t cur = u, steps = 0; cur != v; ++steps) {
      if (steps > 256) return false;
      std::uint32_t next = UINT32_MAX;
      for (std::uint32_t w : inner_next[cur]) {
        if (w == v || (to_v(w) < to_v(cur) && on_piece(w))) {
          next = w;
          if (w == v) break;
        }
      }
      if (next == UINT32_MAX) return false;
      out.emplace_back(std::min(cur, next), std::max(cur, next));
      cur = next;
    }
    return true;
  };
  // A seam is cut as a whole CAD edge: its paths (one per pair of consecutive edge samples, all
  // with the edge's key) chained end to end. A path end need not be a mesh vertex (an edge sample
  // the mesher did not keep: the OpenCASCADE hub's rim seam, coarsely meshed, has a vertex at
  // its midpoint in one sample and not in another), so the chained nodes that are vertices are
  // joined through the polyline between them; only the edge's own ends must be vertices.
  auto same = [&](const double* p, const double* q) { return distance(p, q) <= tolerance; };
  std::map<Id, std::vector<std::size_t>> paths_of_edge;
  for (std::size_t q = 0; q < m.paths.size() && !inner.empty(); ++q)
    if (common_edges.count(keys[q]) && m.paths[q].polyline.size() >= 6)
      paths_of_edge[keys[q]].push_back(q);
  std::set<Edge> seam;
  for (const auto& [key, qs] : paths_of_edge) {
    (void)key;
    std::vector<char> used(qs.size(), 0);
    for (std::size_t first = 0; first < qs.size(); ++first) {
      if (used[first]) continue;
      // Chain: grow at either end by an unused path with an end there.
      std::deque<const double*> chain;
      auto nodes_of = [&](std::size_t k) {
        const std::vector<double>& pl = m.paths[qs[k]].polyline;
        std::vector<const double*> n;
        for (std::size_t i = 0; i + 2 < pl.size(); i += 3) n.push_back(&pl[i]);
        return n;
      };
      for (const double* p : nodes_of(first)) chain.push_back(p);
      used[first] = 1;
      for (bool grew = true; grew;) {
        grew = false;
        for (std::size_t k = 0; k < qs.size(); ++k) {
          if (used[k]) continue;
          std::vector<const double*> n = nodes_of(k);
          if (!same(n.front(), chain.back()) && !same(n.back(), chain.back()) &&
              !same(n.front(), chain.front()) && !same(n.back(), chain.front()))
            continue;
          const bool at_back = same(n.front(), chain.back()) || same(n.back(), chain.back());
          const double* joint = at_back ? chain.back() : chain.front();
          if (!same(n.front(), joint)) std::reverse(n.begin(), n.end());
          if (at_back)
            chain.insert(chain.end(), n.begin() + 1, n.end());
          else
            chain.insert(chain.begin(), n.rbegin(), n.rend() - 1);
          used[k] = 1;
          grew = true;
        }
      }
      std::vector<Edge> mine;
      std::int64_t prev = vertex_near(chain.front());
      std::size_t prev_node = 0;
      bool whole = prev >= 0 && vertex_near(chain.back()) >= 0;
      for (std::size_t i = 1; i < chain.size() && whole; ++i) {
        const std::int64_t v = vertex_near(chain[i]);
        if (v < 0) continue;
        const std::vector<const double*> piece(chain.begin() + std::ptrdiff_t(prev_node),
                                               chain.begin() + std::ptrdiff_t(i) + 1);
        whole = v != prev && piece_edges(static_cast<std::uint32_t>(prev),
                                         static_cast<std::uint32_t>(v), piece, mine);
        prev = v;
        prev_node = i;
      }
      if (whole) seam.insert(mine.begin(), mine.end());
    }
  }
  return seam;
}

// The axis-aligned box of a polyline (3 doubles per node); empty (lo > hi) without nodes.
struct Box {
  double lo[3], hi[3];
};

Box box_of(const std::vector<double>& polyline) {
  Box b;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = std::numeric_limits<double>::infinity();
    b.hi[k] = -std::numeric_limits<double>::infinity();
  }
  for (std::size_t i = 0; i + 2 < polyline.size(); i += 3)
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = std::min(b.lo[k], polyline[i + std::size_t(k)]);
      b.hi[k] = std::max(b.hi[k], polyline[i + std::size_t(k)]);
    }
  return b;
}

// Distance from p to box b (infinity for an empty box): a lower bound of the distance to any
// segment between the box's nodes.
double box_distance(const Box& b, const double* p) {
  double d2 = 0;
  for (int k = 0; k < 3; ++k) {
    if (b.lo[k] > b.hi[k]) return std::numeric_limits<double>::infinity();
    const double e = std::max({b.lo[k] - p[k], 0.0, p[k] - b.hi[k]});
    d2 += e * e;
  }
  return std::sqrt(d2);
}

}  // namespace

std::vector<char> layout_cuts(const Surface& s, const std::set<Id>& common_edges,
                              double tolerance) {
  const mesh::Sample& m = *s.sample;
  const int H = 3 * s.triangles();
  std::vector<char> cut(static_cast<std::size_t>(H), 0);
  std::vector<Id> keys;
  keys.reserve(m.paths.size());
  for (const mesh::Path& p : m.paths) keys.push_back(path_edge_key(p));
  const std::set<Edge> seam = seam_edges(s, common_edges, keys, tolerance);
  std::vector<Box> boxes;
  boxes.reserve(m.paths.size());
  for (const mesh::Path& p : m.paths) boxes.push_back(box_of(p.polyline));
  for (int h = 0; h < H; ++h) {
    const int t = s.twin[static_cast<std::size_t>(h)];
    if (t < 0) {
      cut[static_cast<std::size_t>(h)] = 1;
      continue;
    }
    if (m.triangle_tags[static_cast<std::size_t>(h / 3)] ==
        m.triangle_tags[static_cast<std::size_t>(t / 3)]) {
      const std::uint32_t a = s.from(h), b = s.to(h);
      if (!seam.empty() && seam.count({std::min(a, b), std::max(a, b)}))
        cut[static_cast<std::size_t>(h)] = 1;
      continue;
    }
    if (t < h) {  // decided once per edge, from its first half-edge
      cut[static_cast<std::size_t>(h)] = cut[static_cast<std::size_t>(t)];
      continue;
    }
    double mid[3];
    const double* a = s.position(s.from(h));
    const double* b = s.position(s.to(h));
    for (int k = 0; k < 3; ++k) mid[k] = 0.5 * (a[k] + b[k]);
    // The path nearest to the edge's midpoint names the CAD edge it lies on. The edge lies on a
    // CAD edge (its two sides are different faces), but not always on the path's polyline: a
    // host may add mesh vertices on the curve between the polyline's nodes (the OpenCASCADE
    // host's bisection, projected onto the B-rep), whose edges' midpoints are off the polyline's
    // segment by up to its sag, under a tenth of its length for arcs up to 45 degrees.
    double best = std::numeric_limits<double>::infinity(), best_length = 0;
    std::size_t best_path = m.paths.size();
    for (std::size_t q = 0; q < m.paths.size(); ++q) {
      // No segment of a path whose box lies farther than `best` can replace it (the scan keeps
      // the first of equal distances), so the path is skipped without changing the result.
      if (box_distance(boxes[q], mid) > best * (1 + 1e-12)) continue;
      const std::vector<double>& pl = m.paths[q].polyline;
      for (std::size_t i = 0; i + 3 < pl.size(); i += 3) {
        double u;
        const double d = point_segment_distance(mid, &pl[i], &pl[i + 3], u);
        if (d < best) {
          best = d;
          best_path = q;
          best_length = distance(&pl[i], &pl[i + 3]);
        }
      }
    }
    const bool on_unshared_edge = best_path < m.paths.size() &&
                                  best <= tolerance + 0.1 * best_length &&
                                  !common_edges.count(keys[best_path]);
    cut[static_cast<std::size_t>(h)] = on_unshared_edge ? 0 : 1;
  }
  return cut;
}

// §6.2, CAD referencing: correspondence by equal IDs only; the anchors are the matched points
// that are mesh vertices on both sides.
bool match_anchors(MappingState& st) {
  const auto& source = st.source;
  const auto& canonical = st.canonical;
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  auto& why = st.why;
  auto& corr = st.corr;
  auto& src_tol = st.src_tol;
  auto& can_tol = st.can_tol;
  auto& dropped_anchors = st.dropped_anchors;
  corr = correspond(source, canonical);
  if (corr.matched_points == 0) {
    why = "mapping: the samples have no control point with the same ID";
    return false;
  }
  // Points and paths are placed on the mesh (cadinterp_builder.h); the tolerance only absorbs
  // rounding.
  src_tol = 1e-6 * source.bbox_diagonal();
  can_tol = 1e-6 * canonical.bbox_diagonal();
  // An anchor must be a mesh vertex on both sides: one that is a vertex on one side only would
  // sit on a patch loop there and not on the other, and no patch could be paired (measured on
  // the OpenCASCADE host, whose mesher may move the boundary off a control point). Such
  // anchors are dropped on both sides; the others still fix the layout.
  const std::size_t before_drop = corr.anchors.size();
  corr.anchors.erase(std::remove_if(corr.anchors.begin(), corr.anchors.end(),
                                    [&](const Anchor& a) {
                                      return vertex_at(ss, a.source, src_tol) < 0 ||
                                             vertex_at(cs, a.canonical, can_tol) < 0;
                                    }),
                     corr.anchors.end());
  dropped_anchors = before_drop - corr.anchors.size();
  if (corr.anchors.empty()) {
    why = "mapping: no matched control point is a mesh vertex in both samples";
    return false;
  }
  return true;
}

}  // namespace cadinterp::mapping
