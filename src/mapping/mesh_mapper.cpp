#include "mapping/mesh_mapper.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mapping/correspondence.h"
#include "mapping/field_transfer.h"
#include "mapping/interior_solve.h"
#include "mapping/layout_paths.h"
#include "mapping/mean_value_param.h"
#include "mapping/patch_layout.h"
#include "mapping/surface.h"

namespace cadinterp::mapping {

namespace {

constexpr double kTwoPi = 6.283185307179586476925286766559;

// Arc-length coordinates of a patch's anchors, relative to the first: rel[0] = 0 < rel[1] <
// ... < rel[M-1] < L, and segment k runs from anchor k to anchor k+1 (cyclically).
struct LoopFrame {
  double length = 0, origin = 0;
  std::vector<double> rel, seg;
  explicit LoopFrame(const Patch& p) {
    length = p.loop_s.back();
    origin = p.anchor_s[0];
    const std::size_t M = p.anchor_s.size();
    for (std::size_t k = 0; k < M; ++k)
      rel.push_back(std::fmod(p.anchor_s[k] - origin + length, length));
    for (std::size_t k = 0; k < M; ++k) seg.push_back((k + 1 < M ? rel[k + 1] : length) - rel[k]);
  }
  // Loop arc length s -> (segment k, fraction f).
  void locate(double s, std::size_t& k, double& f) const {
    const double r = std::fmod(s - origin + 2 * length, length);
    k = static_cast<std::size_t>(std::upper_bound(rel.begin(), rel.end(), r) - rel.begin());
    k = k == 0 ? 0 : k - 1;
    f = seg[k] > 0 ? std::clamp((r - rel[k]) / seg[k], 0.0, 1.0) : 0.0;
  }
  double arc(std::size_t k, double f) const { return origin + rel[k] + f * seg[k]; }
};

// The point at arc length s along a patch's loop, as a combination of two loop vertices.
SurfacePoint loop_point(const Patch& p, double s) {
  const double L = p.loop_s.back();
  s = std::fmod(std::fmod(s, L) + L, L);
  const std::size_t n = p.loop.size();
  std::size_t i = static_cast<std::size_t>(std::upper_bound(p.loop_s.begin(), p.loop_s.end(), s) -
                                           p.loop_s.begin());
  i = std::min(n - 1, i == 0 ? 0 : i - 1);
  const double len = p.loop_s[i + 1] - p.loop_s[i];
  const double t = len > 0 ? std::clamp((s - p.loop_s[i]) / len, 0.0, 1.0) : 0.0;
  SurfacePoint sp;
  sp.v[0] = p.loop[i];
  sp.v[1] = p.loop[(i + 1) % n];
  sp.v[2] = sp.v[0];
  sp.w[0] = 1 - t;
  sp.w[1] = t;
  sp.w[2] = 0;
  return sp;
}

bool same_field_layout(const builder::Sample& a, const builder::Sample& b) {
  if (a.fields.size() != b.fields.size()) return false;
  for (std::size_t i = 0; i < a.fields.size(); ++i)
    if (a.fields[i].name != b.fields[i].name || a.fields[i].location != b.fields[i].location ||
        a.fields[i].components != b.fields[i].components)
      return false;
  return true;
}

}  // namespace

bool map_sample(const builder::Sample& source, const builder::Sample& canonical,
                builder::MappedSample& out, std::string& why, MapStats* stats) {
  why.clear();
  if (!source.feasible || !canonical.feasible) {
    why = "mapping: both samples must be feasible";
    return false;
  }
  // Indices, sizes and orientation are relied on below: a malformed sample is refused by name.
  for (const auto& [s, name] :
       {std::make_pair(&source, "source"), std::make_pair(&canonical, "canonical")}) {
    const std::string problem = builder::validate(*s);
    if (!problem.empty()) {
      why = std::string("mapping: the ") + name + " sample is invalid: " + problem;
      return false;
    }
    if (s->triangle_count() == 0) {
      why = std::string("mapping: the ") + name + " sample has no boundary triangles";
      return false;
    }
  }
  if (!same_field_layout(source, canonical)) {
    why = "mapping: the samples' fields differ";
    return false;
  }
  Surface ss, cs;
  if (!build_surface(source, ss, why) || !build_surface(canonical, cs, why)) {
    why = "mapping: " + why;
    return false;
  }
  // §6.1: correspondence by equal IDs only.
  const Correspondence corr = correspond(source, canonical);
  if (corr.matched_points == 0) {
    why = "mapping: the samples have no control point with the same ID";
    return false;
  }
  std::vector<const double*> src_anchor, can_anchor;
  for (const Anchor& a : corr.anchors) {
    src_anchor.push_back(a.source);
    can_anchor.push_back(a.canonical);
  }
  // Points and paths are placed on the mesh (cadinterp_builder.h); the tolerance only absorbs
  // rounding.
  const double src_tol = 1e-6 * source.bbox_diagonal();
  const double can_tol = 1e-6 * canonical.bbox_diagonal();
  // §6.2: the common layout. CAD paths of both samples first; then each CAD edge of one side
  // only, shortest first, where the other side has a path between the same anchors.
  std::set<Id> src_keys = corr.common_edges, can_keys = corr.common_edges;
  std::vector<std::vector<std::uint32_t>> src_traced, can_traced;
  auto cuts_of = [](const Surface& s, const std::set<Id>& keys,
                    const std::vector<std::vector<std::uint32_t>>& traced, double tol) {
    std::vector<char> cuts = layout_cuts(s, keys, tol);
    for (const auto& chain : traced) cut_along(s, chain, cuts);
    return cuts;
  };
  std::vector<char> src_cuts = cuts_of(ss, src_keys, src_traced, src_tol);
  std::vector<char> can_cuts = cuts_of(cs, can_keys, can_traced, can_tol);
  for (const OneSidedEdge& e : one_sided_edges(source, canonical, corr, src_tol, can_tol)) {
    const Surface& other = e.in_source ? cs : ss;
    const double tol = e.in_source ? can_tol : src_tol;
    const Anchor& a0 = corr.anchors[static_cast<std::size_t>(e.anchor[0])];
    const Anchor& a1 = corr.anchors[static_cast<std::size_t>(e.anchor[1])];
    const int v0 = vertex_at(other, e.in_source ? a0.canonical : a0.source, tol);
    const int v1 = vertex_at(other, e.in_source ? a1.canonical : a1.source, tol);
    if (v0 < 0 || v1 < 0) continue;
    std::vector<std::uint32_t> chain =
        shortest_path(other, e.in_source ? can_cuts : src_cuts, static_cast<std::uint32_t>(v0),
                      static_cast<std::uint32_t>(v1));
    if (chain.size() < 2) continue;
    if (e.in_source) {
      src_keys.insert(e.key);
      can_traced.push_back(std::move(chain));
    } else {
      can_keys.insert(e.key);
      src_traced.push_back(std::move(chain));
    }
    src_cuts = cuts_of(ss, src_keys, src_traced, src_tol);
    can_cuts = cuts_of(cs, can_keys, can_traced, can_tol);
  }
  // Patches with holes (a face with a hole, faces merged around one) are subdivided: two
  // shortest paths from the first loop to a hole, between the same anchors on both sides,
  // split such a patch into two disks; repeated until every patch is a disk.
  std::vector<Patch> sp, cp;
  for (int round = 0;; ++round) {
    if (!build_patches(ss, src_cuts, src_anchor, src_tol, true, sp, why)) {
      why = "mapping: source layout: " + why;
      return false;
    }
    if (!build_patches(cs, can_cuts, can_anchor, can_tol, true, cp, why)) {
      why = "mapping: canonical layout: " + why;
      return false;
    }
    std::size_t holed = 0;
    while (holed < cp.size() && cp[holed].holes.empty()) ++holed;
    if (holed == cp.size()) break;
    const Patch& c = cp[holed];
    std::size_t sidx = 0;
    const std::vector<int> key = c.key();
    while (sidx < sp.size() && sp[sidx].key() != key) ++sidx;
    const Loop& hole = c.holes[0];
    if (sidx == sp.size() || round >= 64 || c.anchors.size() < 2 || hole.anchors.size() < 2) {
      why = "mapping: a patch with " + std::to_string(c.holes.size() + 1) +
            " boundary loops could not be subdivided into disks (" +
            (sidx == sp.size() ? "no source patch with the same anchors"
                               : "too few anchors on its loops") +
            ")";
      return false;
    }
    // Anchors: the first loop's first and middle ones; on the hole, the one nearest (on the
    // canonical side, then by index) to the first, and the one half-way round from it.
    const int a1 = c.anchors[0], a2 = c.anchors[c.anchors.size() / 2];
    std::size_t nearest = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < hole.anchors.size(); ++k) {
      const double* p = corr.anchors[static_cast<std::size_t>(hole.anchors[k])].canonical;
      const double* q = corr.anchors[static_cast<std::size_t>(a1)].canonical;
      const double d = std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]);
      if (d < best) {
        best = d;
        nearest = k;
      }
    }
    const int b1 = hole.anchors[nearest];
    const int b2 = hole.anchors[(nearest + hole.anchors.size() / 2) % hole.anchors.size()];
    for (int side = 0; side < 2; ++side) {
      const Surface& surf = side == 0 ? ss : cs;
      std::vector<char>& cuts = side == 0 ? src_cuts : can_cuts;
      const std::vector<int> of = patch_of_triangles(surf, side == 0 ? sp : cp);
      const int patch = static_cast<int>(side == 0 ? sidx : holed);
      const double tol = side == 0 ? src_tol : can_tol;
      for (const auto& [x, y] : {std::make_pair(a1, b1), std::make_pair(a2, b2)}) {
        const Anchor& ax = corr.anchors[static_cast<std::size_t>(x)];
        const Anchor& ay = corr.anchors[static_cast<std::size_t>(y)];
        const int vx = vertex_at(surf, side == 0 ? ax.source : ax.canonical, tol);
        const int vy = vertex_at(surf, side == 0 ? ay.source : ay.canonical, tol);
        std::vector<std::uint32_t> chain;
        if (vx >= 0 && vy >= 0)
          chain = shortest_path(surf, cuts, static_cast<std::uint32_t>(vx),
                                static_cast<std::uint32_t>(vy), &of, patch);
        if (chain.size() < 2) {
          why =
              "mapping: no path splits a patch with a hole (anchors not at mesh vertices, or "
              "blocked)";
          return false;
        }
        cut_along(surf, chain, cuts);
        (side == 0 ? src_traced : can_traced).push_back(std::move(chain));
      }
    }
  }
  std::vector<int> source_of;
  if (!pair_patches(sp, cp, source_of, why)) {
    why = "mapping: " + why;
    return false;
  }

  // §6.3: per patch, both sides onto one disk; every canonical surface vertex gets a point of
  // the source surface.
  const std::size_t V = canonical.vertex_count();
  std::vector<char> on_surface(V, 0), assigned(V, 0);
  for (std::uint32_t v : canonical.triangles) on_surface[v] = 1;
  std::vector<SurfacePoint> where(V);
  for (std::size_t pi = 0; pi < cp.size(); ++pi) {
    const Patch& c = cp[pi];
    const Patch& s = sp[static_cast<std::size_t>(source_of[pi])];
    const LoopFrame cf(c), sf(s);
    const std::size_t M = c.anchors.size();
    // Anchor angles: the mean of the two sides' relative segment lengths, so that neither disk
    // is much more distorted than the other.
    std::vector<double> theta(M + 1, 0.0);
    for (std::size_t k = 0; k < M; ++k)
      theta[k + 1] = theta[k] + 0.5 * (cf.seg[k] / cf.length + sf.seg[k] / sf.length) * kTwoPi;
    theta[M] = kTwoPi;
    auto loop_uv = [&](const Patch& p, const LoopFrame& fr) {
      std::vector<double> uv(2 * p.loop.size());
      for (std::size_t i = 0; i < p.loop.size(); ++i) {
        std::size_t k;
        double f;
        fr.locate(p.loop_s[i], k, f);
        const double a = theta[k] + f * (theta[k + 1] - theta[k]);
        uv[2 * i] = std::cos(a);
        uv[2 * i + 1] = std::sin(a);
      }
      return uv;
    };
    // Loop vertices: along the source loop at the same segment and fraction.
    for (std::size_t i = 0; i < c.loop.size(); ++i) {
      const std::uint32_t v = c.loop[i];
      if (assigned[v]) continue;
      std::size_t k;
      double f;
      cf.locate(c.loop_s[i], k, f);
      where[v] = loop_point(s, sf.arc(k, f));
      assigned[v] = 1;
    }
    // Interior vertices of the patch (if any): through the disks.
    bool interior = false;
    for (int t : c.triangles)
      for (int k = 0; k < 3 && !interior; ++k) interior = !assigned[cs.from(3 * t + k)];
    if (!interior) continue;
    DiskMap cd, sd;
    if (!mean_value_parametrize(cs, c, loop_uv(c, cf), cd, why) ||
        !mean_value_parametrize(ss, s, loop_uv(s, sf), sd, why)) {
      why = "mapping: " + why;
      return false;
    }
    const DiskLocator locator(sd);
    for (std::size_t l = 0; l < cd.vertices.size(); ++l) {
      const std::uint32_t v = cd.vertices[l];
      if (assigned[v]) continue;
      int tri;
      double w[3];
      locator.locate(cd.uv[2 * l], cd.uv[2 * l + 1], tri, w);
      SurfacePoint p;
      for (int k = 0; k < 3; ++k) {
        p.v[k] = sd.vertices[static_cast<std::size_t>(
            sd.triangles[3 * std::size_t(tri) + std::size_t(k)])];
        p.w[k] = w[k];
      }
      where[v] = p;
      assigned[v] = 1;
    }
  }
  out.vertices = canonical.vertices;
  for (std::size_t v = 0; v < V; ++v) {
    if (!on_surface[v]) continue;
    if (!assigned[v]) {
      why = "mapping: canonical boundary vertex " + std::to_string(v) + " lies in no patch";
      return false;
    }
    for (int a = 0; a < 3; ++a) {
      double x = 0;
      for (int k = 0; k < 3; ++k)
        x += where[v].w[k] * source.vertices[3 * std::size_t(where[v].v[k]) + std::size_t(a)];
      out.vertices[3 * v + std::size_t(a)] = x;
    }
  }
  // §6.4: the interior follows.
  if (!harmonic_interior(canonical.vertices, canonical.tets, on_surface, out.vertices, why)) {
    why = "mapping: " + why;
    return false;
  }
  const TetQuality q = tet_quality(out.vertices, canonical.tets);
  if (stats) {
    stats->matched_points = corr.anchors.size();
    stats->patches = cp.size();
    stats->min_scaled_jacobian = q.min_scaled_jacobian;
    stats->inverted = q.inverted;
  }
  if (q.inverted > 0) {
    why = "mapping: the harmonic interior would invert or flatten " + std::to_string(q.inverted) +
          " of " + std::to_string(canonical.tet_count()) + " tets";
    return false;
  }
  const TetLocator locator(source);
  out.fields = transfer_fields(source, canonical, out.vertices, on_surface, where, locator);
  return true;
}

}  // namespace cadinterp::mapping
