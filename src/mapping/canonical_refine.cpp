#include "mapping/canonical_refine.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <set>
#include <utility>

#include "mapping/mapping_state.h"
#include "mapping/parallel_for.h"
#include "mapping/smooth_surface.h"
#include "mapping/surface.h"
#include "mesh/surface_distance.h"

namespace cadinterp::mapping {

namespace {

double squared_length(const std::vector<double>& V, std::uint32_t a, std::uint32_t b) {
  double d = 0;
  for (int k = 0; k < 3; ++k) {
    const double q = V[3 * std::size_t(a) + k] - V[3 * std::size_t(b) + k];
    d += q * q;
  }
  return d;
}

}  // namespace

mesh::Sample bisect_edges(const mesh::Sample& s,
                          const std::vector<std::array<std::uint32_t, 2>>& edges) {
  mesh::Sample r = s;
  // Per vertex, the tets and triangles holding it, kept up to date as elements split, so that
  // each edge finds its elements without a scan of the mesh.
  std::vector<std::vector<std::uint32_t>> tets_of(r.vertex_count()), tris_of(r.vertex_count());
  for (std::size_t t = 0; t < r.tet_count(); ++t)
    for (int k = 0; k < 4; ++k) tets_of[r.tets[4 * t + k]].push_back(static_cast<std::uint32_t>(t));
  for (std::size_t t = 0; t < r.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k)
      tris_of[r.triangles[3 * t + k]].push_back(static_cast<std::uint32_t>(t));
  auto holds = [](const std::uint32_t* e, int n, std::uint32_t v) {
    return std::find(e, e + n, v) != e + n;
  };
  auto drop = [](std::vector<std::uint32_t>& list, std::uint32_t x) {
    list.erase(std::find(list.begin(), list.end(), x));
  };
  // Splits element `t` (n vertex indices at elems[n*t]) across edge (a, b) at m: the element
  // keeps a and takes m for b; its copy takes m for a. Replacing a corner by a point strictly
  // between it and another corner keeps the orientation's sign.
  auto split = [&](std::vector<std::uint32_t>& elems, std::vector<std::vector<std::uint32_t>>& of,
                   int n, std::uint32_t t, std::uint32_t a, std::uint32_t b, std::uint32_t m) {
    const std::size_t copy = elems.size() / static_cast<std::size_t>(n);
    for (int k = 0; k < n; ++k) {
      const std::uint32_t v = elems[std::size_t(n) * t + k];
      elems.push_back(v == a ? m : v);
      if (v != a && v != b) of[v].push_back(static_cast<std::uint32_t>(copy));
    }
    std::replace(elems.begin() + std::ptrdiff_t(n) * t, elems.begin() + std::ptrdiff_t(n) * (t + 1),
                 b, m);
    drop(of[b], t);
    of[b].push_back(static_cast<std::uint32_t>(copy));
    of[m].push_back(t);
    of[m].push_back(static_cast<std::uint32_t>(copy));
  };
  for (const auto& [a, b] : edges) {
    if (a == b || a >= tets_of.size() || b >= tets_of.size()) continue;  // no edge
    std::vector<std::uint32_t> tets, tris;
    for (std::uint32_t t : tets_of[a])
      if (holds(&r.tets[4 * std::size_t(t)], 4, b)) tets.push_back(t);
    for (std::uint32_t t : tris_of[a])
      if (holds(&r.triangles[3 * std::size_t(t)], 3, b)) tris.push_back(t);
    if (tris.empty()) continue;  // not a boundary edge (any more)
    const auto m = static_cast<std::uint32_t>(r.vertex_count());
    for (int k = 0; k < 3; ++k)
      r.vertices.push_back(
          0.5 * (r.vertices[3 * std::size_t(a) + k] + r.vertices[3 * std::size_t(b) + k]));
    tets_of.emplace_back();
    tris_of.emplace_back();
    for (mesh::Field& f : r.fields) {
      const auto c = static_cast<std::size_t>(f.components);
      if (f.location == 0) {
        for (std::size_t k = 0; k < c; ++k)
          f.values.push_back(0.5 * (f.values[c * a + k] + f.values[c * b + k]));
      } else {
        for (std::uint32_t t : tets)
          for (std::size_t k = 0; k < c; ++k) f.values.push_back(f.values[c * t + k]);
      }
    }
    for (std::uint32_t t : tets) split(r.tets, tets_of, 4, t, a, b, m);
    for (std::uint32_t t : tris) {
      split(r.triangles, tris_of, 3, t, a, b, m);
      r.triangle_tags.push_back(r.triangle_tags[t]);
    }
  }
  return r;
}

namespace {

// mapped_departure with the source's surface index given (built once per source).
double departure(const mesh::Sample& source, const mesh::SurfaceIndex& on_source,
                 const mesh::Sample& canonical, const std::vector<double>& mapped_vertices,
                 double tolerance, std::vector<std::size_t>* marked) {
  const double diag = source.bbox_diagonal();
  if (!(diag > 0)) return 0;
  const mesh::SurfaceIndex on_mapped(mapped_vertices, canonical.triangles);
  double worst = 0;
  std::set<std::size_t> mark;
  // Source vertices far from the mapped surface: a canonical triangle spans a bend of the
  // source (the vertex-sampled Hausdorff distance's source side, mapping_quality.h).
  std::vector<char> seen(source.vertex_count(), 0);
  for (std::uint32_t v : source.triangles) {
    if (seen[v]) continue;
    seen[v] = 1;
    std::size_t t = 0;
    const double d = on_mapped.distance(&source.vertices[3 * std::size_t(v)], &t) / diag;
    worst = std::max(worst, d);
    if (d > tolerance) mark.insert(t);
  }
  // Mapped triangles whose centroid is off the source: their corners lie on it (step 3), so
  // this is where the chord cuts through a bend the source's vertices do not show.
  for (std::size_t t = 0; t < canonical.triangle_count(); ++t) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 3; ++i)
        c[i] += mapped_vertices[3 * std::size_t(canonical.triangles[3 * t + k]) + i] / 3.0;
    const double d = on_source.distance(c) / diag;
    worst = std::max(worst, d);
    if (d > tolerance) mark.insert(t);
  }
  if (marked) marked->insert(marked->end(), mark.begin(), mark.end());
  return worst;
}

// The edges of the marked triangles of `c` (as mapped: V) to bisect for one source: per
// triangle, each edge whose mapped midpoint lies off the triangle's face on the source (its tag;
// the whole surface for a tag the source lacks, after a topology change) by at least half the
// most of its edges does.
std::vector<std::array<std::uint32_t, 2>> sagging_edges(
    const mesh::Sample& c, const std::vector<double>& V, const std::vector<std::size_t>& marked,
    const std::map<std::int32_t, mesh::SurfaceIndex>& on_face, const mesh::SurfaceIndex& whole) {
  std::vector<std::array<std::uint32_t, 2>> edges;
  for (std::size_t t : marked) {
    const std::uint32_t* f = &c.triangles[3 * t];
    const auto face = on_face.find(c.triangle_tags[t]);
    const mesh::SurfaceIndex& under = face != on_face.end() ? face->second : whole;
    double off[3], most = 0;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = f[k], b = f[(k + 1) % 3];
      double mid[3];
      for (int j = 0; j < 3; ++j)
        mid[j] = 0.5 * (V[3 * std::size_t(a) + j] + V[3 * std::size_t(b) + j]);
      off[k] = under.distance(mid);
      most = std::max(most, off[k]);
    }
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = f[k], b = f[(k + 1) % 3];
      if (off[k] >= 0.5 * most && squared_length(V, a, b) > 0)
        edges.push_back({std::min(a, b), std::max(a, b)});
    }
  }
  return edges;
}

// The point of `idx`'s surface closest to p, as the triangle under it and its weights. Weights
// below 1e-9 are made 0: a point on a triangle's edge is then one to the smooth surface, which
// places edge points on the edge's own curve (smooth_surface.h).
SurfacePoint closest_on(const mesh::SurfaceIndex& idx, const double* p) {
  std::size_t t = 0;
  idx.distance(p, &t);
  const std::uint32_t* f = idx.triangle(t);
  SurfacePoint sp;
  for (int k = 0; k < 3; ++k) sp.v[k] = f[k];
  mesh::closest_point_weights(p, idx.vertex(f[0]), idx.vertex(f[1]), idx.vertex(f[2]), sp.w);
  double sum = 0;
  for (double& w : sp.w) {
    if (w < 1e-9) w = 0;
    sum += w;
  }
  for (double& w : sp.w) w /= sum;
  return sp;
}

// A source's own surface as carry_map needs it: whole, per face tag, and smooth.
struct SourceSurface {
  const mesh::SurfaceIndex* whole = nullptr;
  const std::map<std::int32_t, mesh::SurfaceIndex>* faces = nullptr;
  const SmoothSurface* smooth = nullptr;
};

// Per source, its surface as measuring and carrying need it, each part built once: the whole
// surface's index; per face tag that face's triangles alone (an edge's offset is measured from
// its own face, since a chord along a sharp CAD edge lies on the plane next to it, a bend's arc
// beside a flat side face, and measured from the whole surface would show no sag); its smooth
// reconstruction. A source of the canonical's own combinatorics needs none: bisected, its mapped
// surface is its own surface, which departs by nothing. The face indices and the smooth surface
// are built the first time a source marks a triangle or has a map carried (most elements never
// do), on the thread that handles the source: source i must be asked from one thread at a time.
class SourceSurfaces {
 public:
  SourceSurfaces(const std::vector<const mesh::Sample*>& sources, const std::vector<char>& own,
                 int threads)
      : sources_(sources), whole_(sources.size()), faces_(sources.size()), smooth_(sources.size()) {
    parallel_for(sources.size(), threads, [&](std::size_t i) {
      if (!own[i])
        whole_[i] =
            std::make_unique<mesh::SurfaceIndex>(sources[i]->vertices, sources[i]->triangles);
    });
  }
  const mesh::SurfaceIndex& whole(std::size_t i) const { return *whole_[i]; }
  const std::map<std::int32_t, mesh::SurfaceIndex>& faces(std::size_t i) {
    if (!faces_[i].empty()) return faces_[i];  // built (a boundary has at least one face)
    const mesh::Sample& s = *sources_[i];
    std::map<std::int32_t, std::vector<std::uint32_t>> by_tag;
    for (std::size_t t = 0; t < s.triangle_count(); ++t)
      by_tag[s.triangle_tags[t]].insert(by_tag[s.triangle_tags[t]].end(), &s.triangles[3 * t],
                                        &s.triangles[3 * t + 3]);
    for (const auto& [tag, F] : by_tag) faces_[i].emplace(tag, mesh::SurfaceIndex(s.vertices, F));
    return faces_[i];
  }
  SourceSurface for_carrying(std::size_t i) {
    if (!smooth_[i]) smooth_[i] = std::make_unique<SmoothSurface>(*sources_[i]);
    return {whole_[i].get(), &faces(i), smooth_[i].get()};
  }

 private:
  const std::vector<const mesh::Sample*>& sources_;
  std::vector<std::unique_ptr<mesh::SurfaceIndex>> whole_;
  std::vector<std::map<std::int32_t, mesh::SurfaceIndex>> faces_;
  std::vector<std::unique_ptr<SmoothSurface>> smooth_;
};

// `m`, `source` mapped onto `prev`, carried onto bisect_edges(prev, edges) without mapping the
// source again. Bisection keeps every vertex and adds only boundary vertices at edge midpoints,
// so the old vertices keep their mapped positions and each new one is its mapped edge's
// midpoint moved onto the source's boundary, where the mapper puts boundary vertices (§6.2,
// surface mapping): onto the face of the canonical triangles around it (by tag), or, on an edge
// between two faces, onto both alternately, which ends on their common CAD edge where they meet
// at an angle; then lifted onto the smooth reconstruction as the mapper lifts (smooth_surface.h),
// or left on the flat triangles where the lift inverts a tet. Per-vertex fields are
// interpolated there with the same weights; per-tet fields are copied to both halves of a split
// tet, as bisect_edges does. False where a tet would be inverted or flat either way
// (mesh::validate's rule): the caller maps the source again.
bool carry_map(const mesh::Sample& source, const SourceSurface& surface, const mesh::Sample& prev,
               const mesh::MappedSample& m, const std::vector<std::array<std::uint32_t, 2>>& edges,
               mesh::MappedSample& out) {
  if (m.fields.size() != source.fields.size()) return false;
  mesh::Sample t;
  t.vertices = m.vertices;
  t.tets = prev.tets;
  t.triangles = prev.triangles;
  t.triangle_tags = prev.triangle_tags;
  for (std::size_t k = 0; k < source.fields.size(); ++k) {
    mesh::Field f;
    f.name = source.fields[k].name;
    f.location = source.fields[k].location;
    f.components = source.fields[k].components;
    f.values = m.fields[k];
    t.fields.push_back(std::move(f));
  }
  mesh::Sample b = bisect_edges(t, edges);
  const std::size_t n0 = t.vertex_count();
  std::vector<std::vector<std::int32_t>> tags(b.vertex_count() - n0);
  for (std::size_t f = 0; f < b.triangle_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = b.triangles[3 * f + std::size_t(k)];
      if (v < n0) continue;
      auto& l = tags[v - n0];
      if (std::find(l.begin(), l.end(), b.triangle_tags[f]) == l.end())
        l.push_back(b.triangle_tags[f]);
    }
  auto face = [&](std::size_t j, std::size_t i) -> const mesh::SurfaceIndex* {
    if (tags[j].size() <= i) return nullptr;
    const auto it = surface.faces->find(tags[j][i]);
    return it == surface.faces->end() ? nullptr : &it->second;
  };
  std::vector<SurfacePoint> at(tags.size());
  for (std::size_t j = 0; j < tags.size(); ++j) {
    double p[3];
    for (int a = 0; a < 3; ++a) p[a] = b.vertices[3 * (n0 + j) + std::size_t(a)];
    const mesh::SurfaceIndex *A = face(j, 0), *B = face(j, 1);
    if (tags[j].size() == 1 && A) {
      at[j] = closest_on(*A, p);
    } else if (tags[j].size() == 2 && A && B) {
      for (int round = 0; round < 8; ++round) {
        at[j] = closest_on(round % 2 ? *B : *A, p);
        position_of(source, at[j], p);
      }
    } else {
      at[j] = closest_on(*surface.whole, p);
    }
  }
  auto place = [&](bool smooth) {
    for (std::size_t j = 0; j < at.size(); ++j) {
      double* x = &b.vertices[3 * (n0 + j)];
      if (smooth)
        surface.smooth->position(at[j], x);
      else
        position_of(source, at[j], x);
      for (std::size_t k = 0; k < source.fields.size(); ++k) {
        const mesh::Field& f = source.fields[k];
        if (f.location != 0) continue;
        const auto c = static_cast<std::size_t>(f.components);
        for (std::size_t q = 0; q < c; ++q) {
          double v = 0;
          for (int i = 0; i < 3; ++i) v += at[j].w[i] * f.values[c * at[j].v[i] + q];
          b.fields[k].values[c * (n0 + j) + q] = v;
        }
      }
    }
    return mesh::validate(b).empty();
  };
  if (!place(true) && !place(false)) return false;
  out.vertices = std::move(b.vertices);
  out.fields.clear();
  for (mesh::Field& f : b.fields) out.fields.push_back(std::move(f.values));
  return true;
}

}  // namespace

double mapped_departure(const mesh::Sample& source, const mesh::Sample& canonical,
                        const std::vector<double>& mapped_vertices, double tolerance,
                        std::vector<std::size_t>* marked) {
  const mesh::SurfaceIndex on_source(source.vertices, source.triangles);
  return departure(source, on_source, canonical, mapped_vertices, tolerance, marked);
}

bool refine_canonical(const std::vector<const mesh::Sample*>& sources,
                      const mesh::Sample& canonical, const mesh::Mapper& mapper,
                      mesh::Sample& refined, std::vector<mesh::MappedSample>& mapped,
                      std::string& why, RefineStats* stats, const RefineOptions& options) {
  RefineStats st;
  // The edge lists bisected so far, round by round (`c` below is the canonical bisected so).
  std::vector<std::vector<std::array<std::uint32_t, 2>>> history;
  // Per source: of the canonical's own combinatorics (decided once, not per round).
  std::vector<char> own(sources.size());
  for (std::size_t i = 0; i < sources.size(); ++i)
    own[i] = mesh::same_combinatorics(*sources[i], canonical) ? 1 : 0;
  SourceSurfaces surfaces(sources, own, options.threads);
  // Every source onto `c`; false (with why) at the first that fails. A source of the
  // canonical's own combinatorics (the canonical sample itself, or one the builder blends with
  // it vertex by vertex) is bisected as the canonical was instead: its vertex i is the
  // canonical's, so that is its exact map, new vertices on its own surface, and no mapping.
  // Sources are mapped on up to options.threads threads (the mapper is const and thread-safe);
  // the first failure in source order is reported, whichever thread met it.
  // With `from_current` (`c` is `current` bisected by history.back()) the other sources' maps
  // onto `current` are carried over (carry_map) where options.carry_maps allows it and no tet
  // inverts; mapped again otherwise.
  mesh::Sample current = canonical;
  std::vector<mesh::MappedSample> current_mapped;
  auto map_all = [&](const mesh::Sample& c, bool from_current, std::vector<mesh::MappedSample>& out,
                     std::string& w) {
    out.assign(sources.size(), mesh::MappedSample());
    std::vector<std::string> whys(sources.size());
    std::vector<char> ok(sources.size(), 1), carried(sources.size(), 0);
    parallel_for(sources.size(), options.threads, [&](std::size_t i) {
      if (options.cancelled && options.cancelled()) {
        ok[i] = 0;
        whys[i] = "cancelled";
        return;
      }
      if (own[i]) {
        mesh::Sample b = *sources[i];
        for (const auto& edges : history) b = bisect_edges(b, edges);
        out[i].vertices = std::move(b.vertices);
        for (mesh::Field& f : b.fields) out[i].fields.push_back(std::move(f.values));
        return;
      }
      if (from_current && options.carry_maps &&
          carry_map(*sources[i], surfaces.for_carrying(i), current, current_mapped[i],
                    history.back(), out[i])) {
        carried[i] = 1;
        return;
      }
      ok[i] = mapper.map(*sources[i], c, out[i], whys[i]) ? 1 : 0;
    });
    for (std::size_t i = 0; i < sources.size(); ++i)
      if (!ok[i]) {
        w = whys[i];
        return false;
      }
    if (from_current)
      for (std::size_t i = 0; i < sources.size(); ++i)
        if (!own[i]) ++(carried[i] ? st.carried : st.remapped);
    return true;
  };
  // The departure of every source on `c`, and the edges to bisect, over all sources: per
  // marked triangle, every edge whose mapped midpoint lies off the source's face by at least
  // half the most any of its edges does. On a cylinder a triangle's edge across the bend and
  // its diagonal have the same sag (kappa L^2 / 8 along the curvature kappa in the edge's
  // direction), and splitting only one leaves the other's; the axial edge has none. Sources are
  // measured on their threads (source i on one thread per call, so its surfaces are built
  // on one); the maximum and the union of edge sets do not depend on order.
  auto measure = [&](const mesh::Sample& c, const std::vector<mesh::MappedSample>& m,
                     std::set<std::array<std::uint32_t, 2>>& edges) {
    std::vector<double> worst(sources.size(), 0.0);
    std::vector<std::vector<std::array<std::uint32_t, 2>>> split(sources.size());
    parallel_for(sources.size(), options.threads, [&](std::size_t i) {
      if (own[i]) return;
      std::vector<std::size_t> marked;
      worst[i] =
          departure(*sources[i], surfaces.whole(i), c, m[i].vertices, options.tolerance, &marked);
      if (marked.empty()) return;
      split[i] = sagging_edges(c, m[i].vertices, marked, surfaces.faces(i), surfaces.whole(i));
    });
    for (const auto& e : split) edges.insert(e.begin(), e.end());
    return worst.empty() ? 0.0 : *std::max_element(worst.begin(), worst.end());
  };
  refined = canonical;
  if (mapped.size() != sources.size() && !map_all(refined, false, mapped, why)) return false;
  std::set<std::array<std::uint32_t, 2>> edges;
  st.before = st.after = measure(refined, mapped, edges);
  // Rounds go on from the last refined mesh even where one did not lower the departure (the
  // bend's diagonals are split the round after its edges across it); the best is kept.
  current_mapped = mapped;
  const double limit = (1.0 + options.max_growth) * static_cast<double>(canonical.vertex_count());
  for (int round = 0; round < options.rounds && !edges.empty(); ++round) {
    if (static_cast<double>(current.vertex_count() + edges.size()) > limit) {
      st.stopped = "the growth limit (" + std::to_string(edges.size()) + " more vertices)";
      break;
    }
    // Sorted edges: the refined mesh is a function of the inputs alone.
    history.emplace_back(edges.begin(), edges.end());
    mesh::Sample next = bisect_edges(current, history.back());
    std::vector<mesh::MappedSample> next_mapped;
    std::string w;
    if (!map_all(next, true, next_mapped, w)) {
      st.stopped = "round " + std::to_string(round + 1) + " could not be mapped: " + w;
      break;
    }
    edges.clear();
    const double d = measure(next, next_mapped, edges);
    current = std::move(next);
    current_mapped = std::move(next_mapped);
    if (d < st.after) {
      st.after = d;
      st.rounds = round + 1;
      st.added_vertices = current.vertex_count() - canonical.vertex_count();
      refined = current;
      mapped = current_mapped;
    }
  }
  if (st.stopped.empty() && !edges.empty() && options.rounds > 0) st.stopped = "the round limit";
  if (stats) *stats = st;
  return true;
}

}  // namespace cadinterp::mapping
