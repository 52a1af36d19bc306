#include "mapping/layout_paths.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <queue>

namespace cadinterp::mapping {

namespace {

// Edges of `mine` whose key the other sample lacks, with their vertex ends.
void collect(const mesh::Sample& mine, const std::set<Id>& common, bool in_source,
             const Correspondence& corr, double tolerance, std::vector<OneSidedEdge>& out) {
  std::map<Id, const double*> point;
  for (const mesh::ControlPoint& p : mine.points) point.emplace(p.id, p.position);
  struct Acc {
    double length = 0;
    std::vector<const double*> ends;
  };
  std::map<Id, Acc> edges;
  for (const mesh::Path& p : mine.paths) {
    const Id key = path_edge_key(p);
    if (common.count(key)) continue;
    Acc& acc = edges[key];
    for (std::size_t i = 0; i + 3 < p.polyline.size(); i += 3)
      acc.length += distance(&p.polyline[i], &p.polyline[i + 3]);
    for (const Id* end : {&p.a, &p.b}) {
      if (end->empty() || (*end)[0] != 0) continue;
      auto it = point.find(*end);
      if (it != point.end()) acc.ends.push_back(it->second);
    }
  }
  for (const auto& [key, acc] : edges) {
    if (acc.ends.size() != 2) continue;  // closed, or ends not given as B-rep vertices
    OneSidedEdge e;
    e.in_source = in_source;
    e.key = key;
    e.length = acc.length;
    for (int k = 0; k < 2; ++k)
      for (std::size_t m = 0; m < corr.anchors.size() && e.anchor[k] < 0; ++m) {
        const double* q = in_source ? corr.anchors[m].source : corr.anchors[m].canonical;
        if (distance(q, acc.ends[static_cast<std::size_t>(k)]) <= tolerance)
          e.anchor[k] = static_cast<int>(m);
      }
    if (e.anchor[0] >= 0 && e.anchor[1] >= 0 && e.anchor[0] != e.anchor[1]) out.push_back(e);
  }
}

}  // namespace

std::vector<OneSidedEdge> one_sided_edges(const mesh::Sample& source, const mesh::Sample& canonical,
                                          const Correspondence& corr, double source_tolerance,
                                          double canonical_tolerance) {
  std::vector<OneSidedEdge> out;
  collect(source, corr.common_edges, true, corr, source_tolerance, out);
  collect(canonical, corr.common_edges, false, corr, canonical_tolerance, out);
  std::sort(out.begin(), out.end(), [](const OneSidedEdge& a, const OneSidedEdge& b) {
    if (a.length != b.length) return a.length < b.length;
    if (a.in_source != b.in_source) return a.in_source;
    return a.key < b.key;
  });
  return out;
}

int vertex_at(const Surface& s, const double* p, double tolerance) {
  int best = -1;
  double best_d = tolerance;
  // The nearest vertex within the tolerance, the smallest index among equally near ones (the
  // same whatever order the candidates come in).
  auto consider = [&](std::uint32_t v) {
    const double d = distance(s.position(v), p);
    if (d <= best_d && (best < 0 || d < best_d || static_cast<int>(v) < best)) {
      best_d = d;
      best = static_cast<int>(v);
    }
  };
  if (s.by_x.empty()) {
    for (std::uint32_t v : s.sample->triangles) consider(v);
    return best;
  }
  // Candidates: the vertices whose x lies within the tolerance of p's, with twice its width
  // (plus rounding) as margin, since a vertex within the tolerance in 3-D is within it in x.
  const double reach = 2 * tolerance + 1e-12 * (std::fabs(p[0]) + tolerance);
  const auto x_of = [&s](std::uint32_t v) { return s.sample->vertices[3 * std::size_t(v)]; };
  auto it = std::lower_bound(s.by_x.begin(), s.by_x.end(), p[0] - reach,
                             [&](std::uint32_t v, double x) { return x_of(v) < x; });
  for (; it != s.by_x.end() && x_of(*it) <= p[0] + reach; ++it) consider(*it);
  return best;
}

namespace {

// Dijkstra over the half-edges of `s` (of triangles in `patch` when patch_of is given) from a to
// the first vertex popped for which is_target holds. Vertices touched by `cuts` are blocked:
// never passed through, entered only when they are a target, or, when touch_except is given,
// entered (not a target, not marked in it) at 10x the cost and passed through. With `lengths`,
// the search does not stop at a target (nor pass through it) and every vertex's path length
// goes there (infinity where unreached).
template <typename IsTarget>
std::vector<std::uint32_t> dijkstra(const Surface& s, const std::vector<char>& cuts,
                                    std::uint32_t a, const IsTarget& is_target,
                                    const std::vector<int>* patch_of, int patch,
                                    const std::vector<char>* touch_except,
                                    std::vector<double>* lengths = nullptr) {
  const std::size_t V = s.sample->vertex_count();
  const int H = 3 * s.triangles();
  std::vector<char> blocked(V, 0);
  for (int h = 0; h < H; ++h)
    if (cuts[static_cast<std::size_t>(h)]) blocked[s.from(h)] = blocked[s.to(h)] = 1;
  std::vector<std::vector<int>> out_edges(V);
  for (int h = 0; h < H; ++h)
    if (!patch_of || (*patch_of)[static_cast<std::size_t>(h / 3)] == patch)
      out_edges[s.from(h)].push_back(h);
  std::vector<double> dist(V, std::numeric_limits<double>::infinity());
  std::vector<std::int64_t> prev(V, -1);
  using Item = std::pair<double, std::uint32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  dist[a] = 0;
  queue.emplace(0.0, a);
  std::int64_t found = -1;
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist[v]) continue;
    if (is_target(v)) {
      if (lengths) continue;
      found = v;
      break;
    }
    if (v != a && blocked[v] && !touch_except) continue;
    for (int h : out_edges[v]) {
      if (cuts[static_cast<std::size_t>(h)]) continue;
      const std::uint32_t w = s.to(h);
      double cost = distance(s.position(v), s.position(w));
      if (blocked[w] && !is_target(w)) {
        if (!touch_except || (*touch_except)[w]) continue;
        cost *= 10;
      }
      const double nd = d + cost;
      if (nd < dist[w]) {
        dist[w] = nd;
        prev[w] = v;
        queue.emplace(nd, w);
      }
    }
  }
  if (lengths) *lengths = std::move(dist);
  if (found < 0) return {};
  std::vector<std::uint32_t> chain{static_cast<std::uint32_t>(found)};
  while (chain.back() != a) chain.push_back(static_cast<std::uint32_t>(prev[chain.back()]));
  std::reverse(chain.begin(), chain.end());
  return chain;
}

}  // namespace

std::vector<std::uint32_t> shortest_path(const Surface& s, const std::vector<char>& cuts,
                                         std::uint32_t a, std::uint32_t b,
                                         const std::vector<int>* patch_of, int patch,
                                         const std::vector<char>* touch_except) {
  return dijkstra(
      s, cuts, a, [b](std::uint32_t v) { return v == b; }, patch_of, patch, touch_except);
}

std::vector<double> path_lengths_from(const Surface& s, const std::vector<char>& cuts,
                                      std::uint32_t a, const std::vector<char>& targets,
                                      const std::vector<int>& patch_of, int patch) {
  std::vector<double> lengths;
  dijkstra(
      s, cuts, a, [a, &targets](std::uint32_t v) { return v != a && targets[v]; }, &patch_of, patch,
      nullptr, &lengths);
  return lengths;
}

std::vector<std::uint32_t> shortest_path_to_any(const Surface& s, const std::vector<char>& cuts,
                                                std::uint32_t a, const std::vector<char>& targets,
                                                const std::vector<int>& patch_of, int patch) {
  return dijkstra(
      s, cuts, a, [a, &targets](std::uint32_t v) { return v != a && targets[v]; }, &patch_of, patch,
      nullptr);
}

void cut_along(const Surface& s, const std::vector<std::uint32_t>& chain, std::vector<char>& cuts) {
  for (std::size_t i = 0; i + 1 < chain.size(); ++i)
    for (const int h : {s.half_edge(chain[i], chain[i + 1]), s.half_edge(chain[i + 1], chain[i])})
      if (h >= 0) cuts[static_cast<std::size_t>(h)] = 1;
}

}  // namespace cadinterp::mapping

namespace cadinterp::mapping {

std::vector<int> anchor_vertices(const Surface& s, const std::vector<const double*>& anchors,
                                 double tolerance) {
  std::vector<int> of(s.sample->vertex_count(), -1);
  for (std::size_t m = 0; m < anchors.size(); ++m) {
    const int v = vertex_at(s, anchors[m], tolerance);
    if (v >= 0 && of[static_cast<std::size_t>(v)] < 0)
      of[static_cast<std::size_t>(v)] = static_cast<int>(m);
  }
  return of;
}

namespace {

// The outgoing half-edges of v in rotation order: from h (in triangle f), the half-edge into v
// in f is prev(h); across it lies the next outgoing one. Empty on an open border.
std::vector<int> outgoing_around(const Surface& s, const std::vector<int>& first_out,
                                 std::uint32_t v) {
  const int first = first_out[v];
  const int H = 3 * s.triangles();
  std::vector<int> ring;
  if (first < 0) return ring;
  int h = first;
  do {
    ring.push_back(h);
    const int prev = 3 * (h / 3) + (h % 3 + 2) % 3;
    h = s.twin[static_cast<std::size_t>(prev)];
    if (h < 0 || ring.size() > static_cast<std::size_t>(H)) return {};
  } while (h != first);
  return ring;
}

}  // namespace

std::vector<std::vector<int>> paths_around(const Surface& s, const std::vector<char>& cuts,
                                           std::uint32_t v, const std::vector<int>& anchor_of,
                                           std::vector<int>* half_edges) {
  std::vector<std::vector<int>> far;
  if (half_edges) half_edges->clear();
  std::vector<int> first_out(s.sample->vertex_count(), -1);
  for (int h = 3 * s.triangles() - 1; h >= 0; --h) first_out[s.from(h)] = h;
  for (int h : outgoing_around(s, first_out, v)) {
    if (!cuts[static_cast<std::size_t>(h)]) continue;
    if (half_edges) half_edges->push_back(h);
    std::uint32_t prev = v, cur = s.to(h);
    std::vector<int> passed;
    for (std::size_t steps = 0; steps <= s.sample->vertex_count() && cur != v; ++steps) {
      if (anchor_of[cur] >= 0) passed.push_back(anchor_of[cur]);
      std::uint32_t next = cur;
      int degree = 0;
      for (int g : outgoing_around(s, first_out, cur))
        if (cuts[static_cast<std::size_t>(g)]) {
          ++degree;
          if (s.to(g) != prev) next = s.to(g);
        }
      if (degree != 2 || next == cur) break;
      prev = cur;
      cur = next;
    }
    far.push_back(std::move(passed));
  }
  return far;
}

bool cyclic_order_agrees(const PathEnd& a, const PathEnd& b) {
  // The new path's neighbours around its end on one side: the anchors along the previous and
  // the next path.
  using Anchors = std::vector<int>;
  auto neighbours = [](const PathEnd& e, std::pair<Anchors, Anchors>& out) {
    std::vector<int> hs;
    const std::vector<Anchors> far =
        paths_around(*e.surface, *e.after, e.vertex, *e.anchor_of, &hs);
    std::size_t i = 0;
    while (i < hs.size() && (*e.before)[static_cast<std::size_t>(hs[i])]) ++i;
    if (i == hs.size() || hs.size() < 3) return false;  // nothing to compare with
    out = {far[(i + hs.size() - 1) % hs.size()], far[(i + 1) % hs.size()]};
    return true;
  };
  std::pair<Anchors, Anchors> na, nb;
  if (!neighbours(a, na) || !neighbours(b, nb)) return true;
  // Two paths are the same layout path when they pass a common anchor (one sample may have
  // anchors along a path that the other lacks, e.g. the ends of a one-sided edge); a path
  // without anchors (ending at a junction) matches anything: only named anchors can disagree.
  auto same = [](const Anchors& x, const Anchors& y) {
    if (x.empty() || y.empty()) return true;
    for (int p : x)
      if (std::find(y.begin(), y.end(), p) != y.end()) return true;
    return false;
  };
  return same(na.first, nb.first) && same(na.second, nb.second);
}

namespace {

// `chain`'s points at kAlikeSamples + 1 equal arc-length fractions, and its length.
constexpr int kAlikeSamples = 16;
std::vector<std::array<double, 3>> resample_chain(const Surface& s,
                                                  const std::vector<std::uint32_t>& chain,
                                                  double& length) {
  std::vector<double> at(chain.size(), 0.0);
  for (std::size_t i = 1; i < chain.size(); ++i)
    at[i] = at[i - 1] + distance(s.position(chain[i - 1]), s.position(chain[i]));
  length = at.back();
  std::vector<std::array<double, 3>> points(kAlikeSamples + 1);
  std::size_t seg = 0;
  for (int k = 0; k <= kAlikeSamples; ++k) {
    const double want = length * k / kAlikeSamples;
    while (seg + 2 < chain.size() && at[seg + 1] < want) ++seg;
    const double span = at[seg + 1] - at[seg];
    const double f = span > 0 ? std::clamp((want - at[seg]) / span, 0.0, 1.0) : 0.0;
    const double* x = s.position(chain[seg]);
    const double* y = s.position(chain[seg + 1]);
    for (std::size_t d = 0; d < 3; ++d) points[std::size_t(k)][d] = x[d] + f * (y[d] - x[d]);
  }
  return points;
}

}  // namespace

bool paths_run_alike(const Surface& sa, const std::vector<std::uint32_t>& a, const Surface& sb,
                     const std::vector<std::uint32_t>& b, double slack) {
  if (a.size() < 2 || b.size() < 2) return false;
  double la = 0, lb = 0;
  const auto pa = resample_chain(sa, a, la), pb = resample_chain(sb, b, lb);
  double worst = 0;
  for (int k = 0; k <= kAlikeSamples; ++k) {
    const double t = double(k) / kAlikeSamples;
    double off2 = 0;
    for (std::size_t d = 0; d < 3; ++d) {
      const double moved =
          (1 - t) * (pb[0][d] - pa[0][d]) + t * (pb[kAlikeSamples][d] - pa[kAlikeSamples][d]);
      const double off = pb[std::size_t(k)][d] - pa[std::size_t(k)][d] - moved;
      off2 += off * off;
    }
    worst = std::max(worst, std::sqrt(off2));
  }
  return worst <= std::max(0.25 * std::max(la, lb), slack);
}

}  // namespace cadinterp::mapping
