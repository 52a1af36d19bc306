#include "mapping/mesh_mapper.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iterator>
#include <limits>
#include <memory>
#include <set>
#include <tuple>

#include <Eigen/Dense>

#include "mesh/surface_distance.h"
#include "mapping/boundary_untangle.h"
#include "mapping/correspondence.h"
#include "mapping/field_transfer.h"
#include "mapping/foldover_free.h"
#include "mapping/geodesic.h"
#include "mapping/interior_solve.h"
#include "mapping/layout_paths.h"
#include "mapping/mean_value_param.h"
#include "mapping/patch_layout.h"
#include "mapping/path_release.h"
#include "mapping/smooth_surface.h"
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

// The source surface point at disk coordinates uv (sd's triangle containing it).
SurfacePoint disk_point(const DiskMap& sd, const DiskLocator& locator, const double* uv,
                        int* triangle = nullptr) {
  int tri;
  double w[3];
  locator.locate(uv[0], uv[1], tri, w);
  SurfacePoint p;
  for (int k = 0; k < 3; ++k) {
    p.v[k] =
        sd.vertices[static_cast<std::size_t>(sd.triangles[3 * std::size_t(tri) + std::size_t(k)])];
    p.w[k] = w[k];
  }
  if (triangle) *triangle = tri;
  return p;
}

void position_of(const mesh::Sample& s, const SurfacePoint& p, double* x) {
  for (int a = 0; a < 3; ++a) {
    x[a] = 0;
    for (int k = 0; k < 3; ++k)
      x[a] += p.w[k] * s.vertices[3 * std::size_t(p.v[k]) + std::size_t(a)];
  }
}

// In-patch relaxation (§6.3). Composing the two disk maps places a canonical vertex where the
// canonical's and the source's parametrizations agree, not where the canonical mesh's own
// spacing would put it on the source: on a curved face whose two samples are parametrized with
// different distortion, vertices slide within the face, triangles stretch along the curvature
// and their chords cut deeper into it (the bracket's Hausdorff at 1.01e-3 of its diagonal).
// Each sweep moves every inner vertex towards the mean-value-weighted average of its
// neighbours' mapped positions, with the weights of the canonical mesh (Floater 2003, the same
// weights as its disk map), so the fixed point is the canonical mesh's local shape laid onto the
// source. The 3-D step is taken in the source disk through the containing triangle's affine
// map (least squares), so every vertex stays exactly on the source surface; loop vertices stay
// fixed. Where both samples are flat and equal the canonical positions are already the fixed
// point (mean-value weights reproduce linear functions), so nothing moves. Jacobi sweeps in a
// fixed order: deterministic.
void relax_in_patch(const mesh::Sample& source, const mesh::Sample& canonical,
                    const DiskMap& cd, const DiskMap& sd, const DiskLocator& locator,
                    const std::vector<std::size_t>& inner, const std::vector<SurfacePoint>& where,
                    int iterations, std::vector<double>& uv) {
  if (iterations <= 0 || inner.empty()) return;
  const std::size_t n = cd.vertices.size();
  // Canonical mean-value weights of every inner vertex's neighbours (sorted by neighbour).
  std::vector<char> is_inner(n, 0);
  for (std::size_t l : inner) is_inner[l] = 1;
  std::vector<std::vector<std::pair<int, double>>> nbr(n);
  const std::size_t T = cd.triangles.size() / 3;
  for (std::size_t t = 0; t < T; ++t)
    for (std::size_t c = 0; c < 3; ++c) {
      const auto i = static_cast<std::size_t>(cd.triangles[3 * t + c]);
      if (!is_inner[i]) continue;
      const int j = cd.triangles[3 * t + (c + 1) % 3], k = cd.triangles[3 * t + (c + 2) % 3];
      const double* xi = &canonical.vertices[3 * std::size_t(cd.vertices[i])];
      const double* xj = &canonical.vertices[3 * std::size_t(cd.vertices[std::size_t(j)])];
      const double* xk = &canonical.vertices[3 * std::size_t(cd.vertices[std::size_t(k)])];
      double wj, wk;
      if (!mean_value_corner_weights(xi, xj, xk, wj, wk)) continue;
      nbr[i].emplace_back(j, wj);
      nbr[i].emplace_back(k, wk);
    }
  std::vector<double> X(3 * n, 0.0);
  std::vector<int> tri(n, -1);
  for (std::size_t l = 0; l < n; ++l)
    if (!is_inner[l]) position_of(source, where[cd.vertices[l]], &X[3 * l]);
  std::vector<double> next(uv);
  for (int it = 0; it < iterations; ++it) {
    for (std::size_t l : inner)
      position_of(source, disk_point(sd, locator, &uv[2 * l], &tri[l]), &X[3 * l]);
    for (std::size_t l : inner) {
      double target[3] = {0, 0, 0}, wsum = 0;
      for (const auto& [j, w] : nbr[l]) {
        for (int a = 0; a < 3; ++a) target[a] += w * X[3 * std::size_t(j) + std::size_t(a)];
        wsum += w;
      }
      if (!(wsum > 0)) continue;
      double d[3];
      for (int a = 0; a < 3; ++a) d[a] = target[a] / wsum - X[3 * l + std::size_t(a)];
      // The step in the containing source triangle's frame, carried to the disk.
      const int* q = &sd.triangles[3 * std::size_t(tri[l])];
      const double* pa = &source.vertices[3 * std::size_t(sd.vertices[std::size_t(q[0])])];
      const double* pb = &source.vertices[3 * std::size_t(sd.vertices[std::size_t(q[1])])];
      const double* pc = &source.vertices[3 * std::size_t(sd.vertices[std::size_t(q[2])])];
      double e1[3], e2[3];
      for (int a = 0; a < 3; ++a) {
        e1[a] = pb[a] - pa[a];
        e2[a] = pc[a] - pa[a];
      }
      const double a11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2];
      const double a12 = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2];
      const double a22 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2];
      const double b1 = e1[0] * d[0] + e1[1] * d[1] + e1[2] * d[2];
      const double b2 = e2[0] * d[0] + e2[1] * d[1] + e2[2] * d[2];
      const double det = a11 * a22 - a12 * a12;
      if (!(det > 1e-300)) continue;
      const double s = (b1 * a22 - b2 * a12) / det, t = (a11 * b2 - a12 * b1) / det;
      const double* ua = &sd.uv[2 * std::size_t(q[0])];
      const double* ub = &sd.uv[2 * std::size_t(q[1])];
      const double* uc = &sd.uv[2 * std::size_t(q[2])];
      constexpr double kDamping = 0.8;
      double u = uv[2 * l] + kDamping * (s * (ub[0] - ua[0]) + t * (uc[0] - ua[0]));
      double v = uv[2 * l + 1] + kDamping * (s * (ub[1] - ua[1]) + t * (uc[1] - ua[1]));
      // Inner vertices stay inside the disk (the loop is on its circle).
      const double r = std::hypot(u, v);
      if (r > 0.999) {
        u *= 0.999 / r;
        v *= 0.999 / r;
      }
      next[2 * l] = u;
      next[2 * l + 1] = v;
    }
    for (std::size_t l : inner) {
      uv[2 * l] = next[2 * l];
      uv[2 * l + 1] = next[2 * l + 1];
    }
  }
}

// Flat patches, and patches nearly so (§6.3). The composed disk maps are one-to-one in the disk,
// but a straight canonical triangle between three composed points is not the image of its disk
// triangle: where the source's disk map is far from linear across one canonical triangle (a wide
// face against a narrow strip of the same face: the OpenCASCADE press's plate beside fillets of 8.1
// and 38.5 mm, 81 triangles folded, and every tet on them inverted whatever the interior does)
// those triangles fold. Where the source patch projects onto its mean plane without any triangle
// turning over, the projection is a chart in which the folds are removed directly: the patch's
// inner vertices move in the plane (untangle_foldover_free_planar, the canonical triangles'
// shapes as reference; loop vertices fixed) and are lifted back onto the source triangles
// through the chart. Writes each inner local vertex's surface point and source-disk
// coordinates; false where no such chart exists.
bool planar_placement(const mesh::Sample& source, const mesh::Sample& canonical,
                      const DiskMap& cd, const DiskMap& sd, const std::vector<std::size_t>& inner,
                      std::vector<SurfacePoint>& at, std::vector<double>& uv) {
  const std::size_t ns = sd.vertices.size(), n = cd.vertices.size();
  if (ns < 3 || inner.empty()) return false;
  auto point = [&](std::size_t l) { return &source.vertices[3 * std::size_t(sd.vertices[l])]; };
  Eigen::Vector3d centre = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::Zero();
  for (std::size_t l = 0; l < ns; ++l) centre += Eigen::Vector3d(point(l));
  centre /= double(ns);
  for (std::size_t t = 0; 3 * t < sd.triangles.size(); ++t) {
    const Eigen::Vector3d a(point(std::size_t(sd.triangles[3 * t]))),
        b(point(std::size_t(sd.triangles[3 * t + 1]))),
        c(point(std::size_t(sd.triangles[3 * t + 2])));
    normal += (b - a).cross(c - a);
  }
  if (!(normal.norm() > 0)) return false;
  normal.normalize();
  double radius = 0;
  for (std::size_t l = 0; l < ns; ++l)
    radius = std::max(radius, (Eigen::Vector3d(point(l)) - centre).norm());
  if (!(radius > 0)) return false;
  // A frame of the plane with e1 x e2 = normal, so the source's outward triangles stay
  // counter-clockwise; coordinates scaled into the unit disk, the locator's domain.
  const Eigen::Vector3d e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
  auto to_plane = [&](const double* x, double* u) {
    const Eigen::Vector3d d = Eigen::Vector3d(x) - centre;
    u[0] = d.dot(e1) / radius;
    u[1] = d.dot(e2) / radius;
  };
  auto two_area = [](const double* a, const double* b, const double* c) {
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
  };
  DiskMap chart = sd;
  for (std::size_t l = 0; l < ns; ++l) to_plane(point(l), &chart.uv[2 * l]);
  for (std::size_t t = 0; 3 * t < chart.triangles.size(); ++t)
    if (!(two_area(&chart.uv[2 * std::size_t(chart.triangles[3 * t])],
                   &chart.uv[2 * std::size_t(chart.triangles[3 * t + 1])],
                   &chart.uv[2 * std::size_t(chart.triangles[3 * t + 2])]) > 0))
      return false;  // the projection turns a source triangle over: not a chart
  // The canonical patch in the chart, from where the composed maps put it.
  std::vector<double> x(2 * n), reference(3 * n);
  std::vector<char> fixed(n, 1);
  for (std::size_t l = 0; l < n; ++l) {
    double p[3];
    position_of(source, at[l], p);
    to_plane(p, &x[2 * l]);
    for (std::size_t a = 0; a < 3; ++a)
      reference[3 * l + a] = canonical.vertices[3 * std::size_t(cd.vertices[l]) + a];
  }
  for (std::size_t l : inner) fixed[l] = 0;
  std::vector<std::uint32_t> triangles(cd.triangles.begin(), cd.triangles.end());
  const FoldoverFreeResult r = untangle_foldover_free_planar(reference, triangles, fixed, 0.0, x);
  if (!(r.inverted_after < r.inverted_before)) return false;
  const DiskLocator locator(chart);
  for (std::size_t l : inner) {
    int tri;
    double w[3];
    locator.locate(x[2 * l], x[2 * l + 1], tri, w);
    SurfacePoint p;
    double d[2] = {0, 0};
    for (std::size_t k = 0; k < 3; ++k) {
      const auto q = std::size_t(sd.triangles[3 * std::size_t(tri) + k]);
      p.v[k] = sd.vertices[q];
      p.w[k] = w[k];
      d[0] += w[k] * sd.uv[2 * q];
      d[1] += w[k] * sd.uv[2 * q + 1];
    }
    at[l] = p;
    uv[2 * l] = d[0];
    uv[2 * l + 1] = d[1];
  }
  return true;
}

// Local untangling after the harmonic interior (§6.4): a large shape change can leave a few
// slivers of a host's mesh inverted (measured on the OpenCASCADE wrench: 1 or 2 of ~13000 tets
// over random pairs across the whole box). Each interior vertex of an inverted tet is moved to
// the mean of its tet neighbours' positions, in a fixed order, and the move is kept only when it
// leaves fewer inverted tets around that vertex and inverts none that was valid. Boundary
// vertices never move (the surface map is the mapping). Returns the tets still inverted.
std::size_t untangle(const std::vector<std::uint32_t>& tets, const std::vector<char>& fixed,
                     double min_six_volume, std::vector<double>& x) {
  const std::size_t T = tets.size() / 4, V = x.size() / 3;
  auto bad = [&](std::size_t t) { return !(six_volume(x, &tets[4 * t]) > min_six_volume); };
  std::vector<std::size_t> inverted;
  for (std::size_t t = 0; t < T; ++t)
    if (bad(t)) inverted.push_back(t);
  if (inverted.empty()) return 0;
  std::vector<std::vector<std::uint32_t>> tets_of(V);
  for (std::size_t t = 0; t < T; ++t)
    for (int i = 0; i < 4; ++i) tets_of[tets[4 * t + std::size_t(i)]].push_back(std::uint32_t(t));
  for (int round = 0; round < 20 && !inverted.empty(); ++round) {
    std::vector<std::uint32_t> movable;
    for (std::size_t t : inverted)
      for (int i = 0; i < 4; ++i)
        if (!fixed[tets[4 * t + std::size_t(i)]]) movable.push_back(tets[4 * t + std::size_t(i)]);
    std::sort(movable.begin(), movable.end());
    movable.erase(std::unique(movable.begin(), movable.end()), movable.end());
    if (movable.empty()) break;
    bool moved = false;
    for (std::uint32_t v : movable) {
      auto count_bad = [&] {
        std::size_t n = 0;
        for (std::uint32_t t : tets_of[v]) n += bad(t) ? 1 : 0;
        return n;
      };
      const std::size_t before = count_bad();
      if (before == 0) continue;
      double mean[3] = {0, 0, 0};
      std::size_t n = 0;
      for (std::uint32_t t : tets_of[v])
        for (int i = 0; i < 4; ++i) {
          const std::uint32_t w = tets[4 * std::size_t(t) + std::size_t(i)];
          if (w == v) continue;
          for (int a = 0; a < 3; ++a) mean[a] += x[3 * std::size_t(w) + std::size_t(a)];
          ++n;
        }
      if (n == 0) continue;
      double old[3];
      for (int a = 0; a < 3; ++a) {
        old[a] = x[3 * std::size_t(v) + std::size_t(a)];
        x[3 * std::size_t(v) + std::size_t(a)] = mean[a] / double(n);
      }
      if (count_bad() < before) {
        moved = true;
      } else {
        for (int a = 0; a < 3; ++a) x[3 * std::size_t(v) + std::size_t(a)] = old[a];
      }
    }
    inverted.clear();
    for (std::size_t t = 0; t < T; ++t)
      if (bad(t)) inverted.push_back(t);
    if (!moved) break;
  }
  return inverted.size();
}

bool same_field_layout(const mesh::Sample& a, const mesh::Sample& b) {
  if (a.fields.size() != b.fields.size()) return false;
  for (std::size_t i = 0; i < a.fields.size(); ++i)
    if (a.fields[i].name != b.fields[i].name || a.fields[i].location != b.fields[i].location ||
        a.fields[i].components != b.fields[i].components)
      return false;
  return true;
}

}  // namespace

bool map_sample(const mesh::Sample& source, const mesh::Sample& canonical,
                mesh::MappedSample& out, std::string& why, MapStats* stats,
                const MapOptions& options) {
  why.clear();
  if (!source.feasible || !canonical.feasible) {
    why = "mapping: both samples must be feasible";
    return false;
  }
  // Indices, sizes and orientation are relied on below: a malformed sample is refused by name.
  for (const auto& [s, name] :
       {std::make_pair(&source, "source"), std::make_pair(&canonical, "canonical")}) {
    const std::string problem = mesh::validate(*s);
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
  Correspondence corr = correspond(source, canonical);
  if (corr.matched_points == 0) {
    why = "mapping: the samples have no control point with the same ID";
    return false;
  }
  // Points and paths are placed on the mesh (cadinterp_builder.h); the tolerance only absorbs
  // rounding.
  const double src_tol = 1e-6 * source.bbox_diagonal();
  const double can_tol = 1e-6 * canonical.bbox_diagonal();
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
  const std::size_t dropped_anchors = before_drop - corr.anchors.size();
  if (corr.anchors.empty()) {
    why = "mapping: no matched control point is a mesh vertex in both samples";
    return false;
  }
  std::vector<const double*> src_anchor, can_anchor;
  for (const Anchor& a : corr.anchors) {
    src_anchor.push_back(a.source);
    can_anchor.push_back(a.canonical);
  }
  // §6.2: the common layout. CAD paths of both samples first; then each CAD edge of one side
  // only, shortest first, where the other side has a path between the same anchors.
  std::set<Id> src_keys = corr.common_edges, can_keys = corr.common_edges;
  std::vector<std::vector<std::uint32_t>> src_traced, can_traced;
  // Per side, the borders of faces separated again (below): cut whatever the edge keys say.
  std::vector<char> src_face_cuts(3 * std::size_t(ss.triangles()), 0),
      can_face_cuts(3 * std::size_t(cs.triangles()), 0);
  auto cuts_of = [&](const Surface& s, const std::set<Id>& keys,
                     const std::vector<std::vector<std::uint32_t>>& traced, double tol) {
    std::vector<char> cuts = layout_cuts(s, keys, tol);
    const std::vector<char>& faces = &s == &ss ? src_face_cuts : can_face_cuts;
    for (std::size_t h = 0; h < cuts.size(); ++h) cuts[h] |= faces[h];
    for (const auto& chain : traced) cut_along(s, chain, cuts);
    return cuts;
  };
  std::vector<int> src_anchor_of = anchor_vertices(ss, src_anchor, src_tol);
  std::vector<int> can_anchor_of = anchor_vertices(cs, can_anchor, can_tol);
  std::size_t rejected_paths = 0;
  std::vector<char> src_cuts = cuts_of(ss, src_keys, src_traced, src_tol);
  std::vector<char> can_cuts = cuts_of(cs, can_keys, can_traced, can_tol);
  // The layout's patches on either side, as the rounds below leave them.
  std::vector<Patch> sp, cp;
  // Loops without any anchor: only separate_faces makes them, and only new anchors (d)
  // remove them; a split or slit that encloses a piece without anchor makes one more.
  auto anchorless = [](const std::vector<Patch>& patches) {
    std::size_t n = 0;
    for (const Patch& q : patches) {
      n += q.anchors.empty() ? 1 : 0;
      for (const Loop& l : q.holes) n += l.anchors.empty() ? 1 : 0;
    }
    return n;
  };
  // Whether the layouts with these cuts (and the anchors as they are now) have the same patch
  // keys on both sides, and (unless `new_anchorless`) no more loops without anchor than now: what
  // every candidate split or slit below must keep.
  auto layouts_agree = [&](const std::vector<char>& try_src, const std::vector<char>& try_can,
                           bool new_anchorless = false) {
    std::vector<Patch> tsp, tcp;
    std::string ignored;
    if (!build_patches(ss, try_src, src_anchor, src_tol, true, tsp, ignored) ||
        !build_patches(cs, try_can, can_anchor, can_tol, true, tcp, ignored) ||
        tsp.size() != tcp.size() ||
        (!new_anchorless && (anchorless(tsp) > anchorless(sp) || anchorless(tcp) > anchorless(cp))))
      return false;
    std::vector<std::vector<int>> ks, kc;
    for (const Patch& q : tsp) ks.push_back(q.key());
    for (const Patch& q : tcp) kc.push_back(q.key());
    std::sort(ks.begin(), ks.end());
    std::sort(kc.begin(), kc.end());
    return ks == kc;
  };
  // Faces merged across CAD edges of one side only (layout_cuts: their edge keys differ, so
  // their borders are not cut) are separated again where both layouts allow it. Merging keeps the
  // layouts alike, but the disk map of a merged patch does not know the border between its
  // faces, which is often a sharp edge: canonical vertices on it land beside it on the source
  // and cut its corner, and tets at it flatten. Measured on the OpenCASCADE press across the
  // ram bore's cut into the throat fillet (the bore's wall, the throat's ceiling and the fillet
  // merge: the bore's rim, a 90-degree edge, is new on both sides): Hausdorff up to 9.7e-3 of the
  // diagonal, regions off by up to 16 %, 6 of 10 pairs with tets inverted at the rim. And on
  // the hub across its switch from round to obround bolt holes: the floor and the bottom joined
  // by five walls of faces of one side only, a patch with handles. Candidates, in turn: the
  // faces of one side only (one group per side: the hub's walls), then each face of both sides
  // that shares a patch with another face (by tag); each is cut off its patch on both sides
  // (separate_faces) and kept when the two layouts still have the same patch keys. The loops
  // such a cut makes carry no anchor when their CAD edges are new on both sides; the rounds
  // below add one to each (d).
  {
    auto tags_of = [](const mesh::Sample& x) {
      std::vector<std::int32_t> t(x.triangle_tags);
      std::sort(t.begin(), t.end());
      t.erase(std::unique(t.begin(), t.end()), t.end());
      return t;
    };
    const std::vector<std::int32_t> src_tags = tags_of(source), can_tags = tags_of(canonical);
    std::vector<std::int32_t> one_src, one_can, both;
    std::set_difference(src_tags.begin(), src_tags.end(), can_tags.begin(), can_tags.end(),
                        std::back_inserter(one_src));
    std::set_difference(can_tags.begin(), can_tags.end(), src_tags.begin(), src_tags.end(),
                        std::back_inserter(one_can));
    std::set_intersection(src_tags.begin(), src_tags.end(), can_tags.begin(), can_tags.end(),
                          std::back_inserter(both));
    std::vector<Patch> tsp, tcp;
    std::string ignored;
    bool current = false;  // tsp and tcp are the layouts of src_cuts and can_cuts
    // Tags of faces that share a patch with another face, on either side.
    auto merged_tags = [&]() {
      std::set<std::int32_t> merged;
      for (int side = 0; side < 2; ++side)
        for (const Patch& q : side == 0 ? tsp : tcp) {
          const std::vector<std::int32_t>& tags = (side == 0 ? source : canonical).triangle_tags;
          const std::int32_t first = tags[static_cast<std::size_t>(q.triangles[0])];
          bool several = false;
          for (int f : q.triangles) several = several || tags[static_cast<std::size_t>(f)] != first;
          if (several)
            for (int f : q.triangles) merged.insert(tags[static_cast<std::size_t>(f)]);
        }
      return merged;
    };
    std::set<std::int32_t> merged;
    for (std::size_t candidate = 0; candidate <= both.size(); ++candidate) {
      if (!current) {
        if (!build_patches(ss, src_cuts, src_anchor, src_tol, true, tsp, ignored) ||
            !build_patches(cs, can_cuts, can_anchor, can_tol, true, tcp, ignored))
          break;  // the rounds below report it
        merged = merged_tags();
        current = true;
      }
      std::vector<std::int32_t> group_s, group_c;
      if (candidate == 0) {
        group_s = one_src;
        group_c = one_can;
      } else if (merged.count(both[candidate - 1])) {
        group_s = group_c = {both[candidate - 1]};
      }
      if (group_s.empty() && group_c.empty()) continue;
      std::vector<char> try_src = src_cuts, try_can = can_cuts;
      const std::size_t ns = separate_faces(ss, tsp, group_s, try_src);
      const std::size_t nc = separate_faces(cs, tcp, group_c, try_can);
      if (ns + nc == 0 || !layouts_agree(try_src, try_can, true)) continue;
      for (std::size_t h = 0; h < try_src.size(); ++h)
        src_face_cuts[h] |= try_src[h] && !src_cuts[h];
      for (std::size_t h = 0; h < try_can.size(); ++h)
        can_face_cuts[h] |= try_can[h] && !can_cuts[h];
      src_cuts = std::move(try_src);
      can_cuts = std::move(try_can);
      current = false;
    }
  }
  // The keys of the patches beside the cuts that `after` adds to `before` (sorted); false where
  // the layout cannot be built.
  auto keys_beside = [](const Surface& s, const std::vector<char>& before,
                        const std::vector<char>& after, const std::vector<const double*>& anchors,
                        double tol, std::vector<std::vector<int>>& keys) {
    std::vector<Patch> patches;
    std::string ignored;
    if (!build_patches(s, after, anchors, tol, true, patches, ignored)) return false;
    const std::vector<int> of = patch_of_triangles(s, patches);
    std::set<int> beside;
    for (std::size_t h = 0; h < after.size(); ++h)
      if (after[h] && !before[h]) beside.insert(of[h / 3]);
    keys.clear();
    for (int q : beside)
      if (q >= 0) keys.push_back(patches[static_cast<std::size_t>(q)].key());
    std::sort(keys.begin(), keys.end());
    return true;
  };
  struct Proposal {
    std::set<Id> src_keys, can_keys;
    std::vector<std::vector<std::uint32_t>> src_traced, can_traced;
    std::vector<char> src_cuts, can_cuts;
  };
  for (const OneSidedEdge& e : one_sided_edges(source, canonical, corr, src_tol, can_tol)) {
    const Surface& other = e.in_source ? cs : ss;
    const double tol = e.in_source ? can_tol : src_tol;
    const Anchor& a0 = corr.anchors[static_cast<std::size_t>(e.anchor[0])];
    const Anchor& a1 = corr.anchors[static_cast<std::size_t>(e.anchor[1])];
    const int v0 = vertex_at(other, e.in_source ? a0.canonical : a0.source, tol);
    const int v1 = vertex_at(other, e.in_source ? a1.canonical : a1.source, tol);
    if (v0 < 0 || v1 < 0) continue;
    const std::vector<char>& other_cuts = e.in_source ? can_cuts : src_cuts;
    auto propose = [&](std::vector<std::uint32_t> chain) {
      Proposal n{src_keys, can_keys, src_traced, can_traced, {}, {}};
      if (e.in_source) {
        n.src_keys.insert(e.key);
        n.can_traced.push_back(std::move(chain));
      } else {
        n.can_keys.insert(e.key);
        n.src_traced.push_back(std::move(chain));
      }
      n.src_cuts = cuts_of(ss, n.src_keys, n.src_traced, src_tol);
      n.can_cuts = cuts_of(cs, n.can_keys, n.can_traced, can_tol);
      return n;
    };
    // Kraevoy–Sheffer's cyclic-order check at both ends before the path is accepted: a path that
    // leaves an anchor between other neighbours than its counterpart does would make patches
    // that cannot be paired (or pair them twisted); such a candidate is dropped and its faces
    // merge on both sides instead.
    auto cyclic_ok = [&](const Proposal& n) {
      for (int end = 0; end < 2; ++end) {
        const Anchor& a = corr.anchors[static_cast<std::size_t>(e.anchor[end])];
        const int vs = vertex_at(ss, a.source, src_tol), vc = vertex_at(cs, a.canonical, can_tol);
        if (vs < 0 || vc < 0) continue;
        if (!cyclic_order_agrees(
                {&ss, &src_cuts, &n.src_cuts, static_cast<std::uint32_t>(vs), &src_anchor_of},
                {&cs, &can_cuts, &n.can_cuts, static_cast<std::uint32_t>(vc), &can_anchor_of}))
          return false;
      }
      return true;
    };
    // Whether the patches beside the new cut have the same keys on both sides. The shortest
    // route can pass a hole of the face on the wrong side: on the OpenCASCADE press, a ram bore
    // whose rim cuts the throat fillet's edge with the ceiling on one side only splits that
    // edge in two; the other side's edge (whole, its bore in the ceiling) is traced round the
    // bore through the ceiling, leaving the bore in the fillet's patch, and the two layouts
    // cannot be paired (the builder refused 2 of its 32 elements for it). Returns 1 where they
    // agree; 0 where they differ only in which patch holds a loop without any anchor, which no
    // later path can change (the pairing of patches would fail); -1 otherwise (another
    // one-sided edge not yet traced may still differ), or where a layout cannot be built.
    auto beside = [&](const Proposal& n) {
      std::vector<std::vector<int>> ks, kc;
      if (!keys_beside(ss, src_cuts, n.src_cuts, src_anchor, src_tol, ks) ||
          !keys_beside(cs, can_cuts, n.can_cuts, can_anchor, can_tol, kc))
        return -1;
      if (ks == kc) return 1;
      // Patch::key marks each further loop by -1 before its anchors: an anchorless one is a -1
      // followed by another or by the end.
      auto anchored = [](std::vector<std::vector<int>> keys) {
        for (std::vector<int>& k : keys) {
          std::vector<int> kept;
          for (std::size_t i = 0; i < k.size(); ++i)
            if (k[i] != -1 || (i + 1 < k.size() && k[i + 1] != -1)) kept.push_back(k[i]);
          k = std::move(kept);
        }
        std::sort(keys.begin(), keys.end());
        return keys;
      };
      return anchored(ks) == anchored(kc) ? 0 : -1;
    };
    std::vector<std::uint32_t> chain = shortest_path(
        other, other_cuts, static_cast<std::uint32_t>(v0), static_cast<std::uint32_t>(v1));
    if (chain.size() < 2) continue;
    Proposal next = propose(std::move(chain));
    bool cyclic = cyclic_ok(next);
    int fit = cyclic ? beside(next) : -1;
    if (fit < 1) {
      // Then the shortest route within each face beside the edge (on its own side), so that a
      // hole the edge passes stays on the side it is on there: the first whose patches agree.
      const std::vector<char>& own_before = e.in_source ? src_cuts : can_cuts;
      const std::vector<char>& own_after = e.in_source ? next.src_cuts : next.can_cuts;
      const mesh::Sample& own = e.in_source ? source : canonical;
      std::set<std::int32_t> faces;
      for (std::size_t h = 0; h < own_after.size(); ++h)
        if (own_after[h] && !own_before[h]) faces.insert(own.triangle_tags[h / 3]);
      const std::vector<std::int32_t>& other_tags =
          (e.in_source ? canonical : source).triangle_tags;
      for (std::int32_t tag : faces) {
        std::vector<int> in_face(other_tags.size());
        for (std::size_t f = 0; f < other_tags.size(); ++f)
          in_face[f] = other_tags[f] == tag ? 0 : 1;
        std::vector<std::uint32_t> within =
            shortest_path(other, other_cuts, static_cast<std::uint32_t>(v0),
                          static_cast<std::uint32_t>(v1), &in_face, 0);
        if (within.size() < 2) continue;
        Proposal n = propose(std::move(within));
        if (cyclic_ok(n) && beside(n) == 1) {
          next = std::move(n);
          cyclic = true;
          fit = 1;
          break;
        }
      }
    }
    // No route keeps a hole without anchor on the same side of the path on both: the faces
    // merge on both sides instead, the hole inside (measured on the OpenCASCADE press, a ram
    // bore of 30 mm whose rim leaves no vertex of the fillet between it and the plate's edge).
    if (!cyclic || fit == 0) {
      ++rejected_paths;
      continue;
    }
    src_keys = std::move(next.src_keys);
    can_keys = std::move(next.can_keys);
    src_traced = std::move(next.src_traced);
    can_traced = std::move(next.can_traced);
    src_cuts = std::move(next.src_cuts);
    can_cuts = std::move(next.can_cuts);
  }
  // Patches with holes (a face with a hole, faces merged around one) are subdivided: two
  // shortest paths from the first loop to a hole, between the same anchors on both sides,
  // split such a patch into two disks; repeated until every patch is a disk.
  // Surface vertices of the anchors: what a hole-splitting path may never pass through.
  std::vector<int> src_anchor_of_all, can_anchor_of_all;
  for (const Anchor& a : corr.anchors) {
    src_anchor_of_all.push_back(vertex_at(ss, a.source, src_tol));
    can_anchor_of_all.push_back(vertex_at(cs, a.canonical, can_tol));
  }
  // A new anchor (a Steiner point of the layout, as Kraevoy and Sheffer add) at source vertex ps
  // and canonical vertex pc, entered in every table of anchors (positions are held by pointer);
  // pop_anchor takes the last one out again.
  auto refresh = [&] {
    src_anchor.clear();
    can_anchor.clear();
    for (const Anchor& a : corr.anchors) {
      src_anchor.push_back(a.source);
      can_anchor.push_back(a.canonical);
    }
  };
  auto push_anchor = [&](std::uint32_t ps, std::uint32_t pc) {
    Anchor na;
    na.id = {-1, static_cast<std::int64_t>(corr.anchors.size())};
    for (int a = 0; a < 3; ++a) {
      na.source[a] = source.vertices[3 * std::size_t(ps) + std::size_t(a)];
      na.canonical[a] = canonical.vertices[3 * std::size_t(pc) + std::size_t(a)];
    }
    corr.anchors.push_back(na);
    refresh();
    const int m = static_cast<int>(corr.anchors.size() - 1);
    src_anchor_of[ps] = m;
    can_anchor_of[pc] = m;
    src_anchor_of_all.push_back(static_cast<int>(ps));
    can_anchor_of_all.push_back(static_cast<int>(pc));
    return m;
  };
  auto pop_anchor = [&] {
    src_anchor_of[static_cast<std::size_t>(src_anchor_of_all.back())] = -1;
    can_anchor_of[static_cast<std::size_t>(can_anchor_of_all.back())] = -1;
    src_anchor_of_all.pop_back();
    can_anchor_of_all.pop_back();
    corr.anchors.pop_back();
    refresh();
  };
  // A new anchor at the ends of two slits traced alike, chain_s on the source and chain_c on the
  // canonical: kept, with the slits cut, when both layouts still have the same patch keys.
  auto add_new_anchor = [&](const std::vector<std::uint32_t>& chain_s,
                            const std::vector<std::uint32_t>& chain_c) {
    push_anchor(chain_s.back(), chain_c.back());
    std::vector<char> try_src = src_cuts, try_can = can_cuts;
    cut_along(ss, chain_s, try_src);
    cut_along(cs, chain_c, try_can);
    if (!layouts_agree(try_src, try_can)) {
      pop_anchor();
      return false;
    }
    src_cuts = std::move(try_src);
    can_cuts = std::move(try_can);
    src_traced.push_back(chain_s);
    can_traced.push_back(chain_c);
    return true;
  };
  auto occurs_once = [](const std::vector<std::uint32_t>& loop, std::uint32_t v) {
    return std::count(loop.begin(), loop.end(), v) == 1;
  };
  for (int round = 0;; ++round) {
    if (!build_patches(ss, src_cuts, src_anchor, src_tol, true, sp, why)) {
      why = "mapping: source layout: " + why;
      return false;
    }
    if (!build_patches(cs, can_cuts, can_anchor, can_tol, true, cp, why)) {
      why = "mapping: canonical layout: " + why;
      return false;
    }
    // The first patch with holes whose first loop has an anchor (one whose loops have none, a
    // face cut off by separate_faces, waits until a neighbour's slit anchors one of them).
    std::size_t holed = 0;
    while (holed < cp.size() && (cp[holed].holes.empty() || cp[holed].anchors.empty())) ++holed;
    if (holed == cp.size()) {
      // Every patch must now be a disk whose loop carries anchors.
      for (const auto* side : {&sp, &cp})
        for (const Patch& q : *side) {
          const Surface& surf = side == &sp ? ss : cs;
          const std::string what =
              std::string(side == &sp ? "source" : "canonical") + " patch of " +
              std::to_string(q.triangles.size()) + " triangles (face tag " +
              std::to_string(surf.sample->triangle_tags[static_cast<std::size_t>(q.triangles[0])]) +
              ")";
          if (q.genus > 0) {
            why = "mapping: " + what + " has " + std::to_string(q.genus) +
                  " handles that no cut along faces of one side only removes; patches with "
                  "handles are not supported";
            return false;
          }
          if (q.anchors.empty() || !q.holes.empty()) {
            why = "mapping: " + what + " has " + std::to_string(q.holes.size() + 1) +
                  " boundary loops without matched control point (no slit from a neighbour "
                  "reached them)";
            return false;
          }
        }
      break;
    }
    const Patch& c = cp[holed];
    std::size_t sidx = 0;
    const std::vector<int> key = c.key();
    while (sidx < sp.size() && sp[sidx].key() != key) ++sidx;
    if (sidx == sp.size() || round >= 64 || c.anchors.empty()) {
      why = "mapping: a patch with " + std::to_string(c.holes.size() + 1) +
            " boundary loops could not be subdivided into disks (" +
            (sidx == sp.size() ? "no source patch with the same anchors"
                               : "no anchor on its first loop") +
            ")";
      return false;
    }
    // The holes in turn (the first that can be joined or split off; the loop order is the
    // same on both sides, by smallest anchor): a hole that no path reaches now may be
    // reachable once another is joined.
    bool split = false;
    std::size_t tried = 0;
    //
    // A patch with several holes (the OpenCASCADE hub's flange: rim, bore and five bolt holes)
    // first gets a tree of short slits, as Prim's algorithm grows a spanning tree: the hole
    // nearest the first loop (canonical positions, from its anchors to the loop's vertices)
    // joins it by a slit not much longer than that distance (to an anchor, or to a new one), and
    // the next round measures from the grown loop. The two-path splits and the long slits of the
    // general order below run from the first loop's anchors, which on a face bounded by circles
    // are a seam's ends: paths across the whole face, round holes not yet joined, that trap
    // later holes or go round a hole one way on one side and the other way on the other (the
    // hub: 2 of 10 pairs folded over the flange). Only where no short slit exists does the
    // general order run.
    auto dist = [](const double* p, const double* q) {
      return std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]);
    };
    std::vector<std::pair<double, std::size_t>> hole_order;
    for (std::size_t h = 0; h < c.holes.size(); ++h) {
      double near = std::numeric_limits<double>::infinity();
      for (int b : c.holes[h].anchors)
        for (std::uint32_t v : c.loop)
          near = std::min(
              near, dist(corr.anchors[static_cast<std::size_t>(b)].canonical, cs.position(v)));
      if (c.holes[h].anchors.empty())  // (d) below: from the hole's vertices
        for (std::uint32_t u : c.holes[h].vertices)
          for (std::uint32_t v : c.loop)
            near = std::min(near, dist(cs.position(u), cs.position(v)));
      hole_order.emplace_back(near, h);
    }
    if (c.holes.size() > 1) std::stable_sort(hole_order.begin(), hole_order.end());
    // The anchors before and after loop vertex v of patch P's first loop.
    auto segment_of = [](const Patch& P, std::uint32_t v) {
      const double L = P.loop_s.back();
      const double s_p =
          P.loop_s[std::size_t(std::find(P.loop.begin(), P.loop.end(), v) - P.loop.begin())];
      // The last anchor at or before it along the loop (of several at one vertex, the last
      // in loop order), and the anchor after that one.
      const std::size_t Mp = P.anchors.size();
      std::size_t best = 0;
      double back = L + 1;
      for (std::size_t k = 0; k < Mp; ++k) {
        const double db = std::fmod(s_p - P.anchor_s[k] + 2 * L, L);
        if (db < back - 1e-12 * L ||
            (std::fabs(db - back) <= 1e-12 * L && P.anchor_s[(k + 1) % Mp] != P.anchor_s[k])) {
          back = db;
          best = k;
        }
      }
      return std::make_pair(P.anchors[best], P.anchors[(best + 1) % Mp]);
    };
    // P's first-loop vertices that are no anchor and occur once on it; with A >= 0 only
    // those strictly between anchors A and B, each with its fraction of the arc length
    // from A to B (`fraction`, may be null).
    auto loop_targets = [&](const Patch& P, const std::vector<int>& anchor_of, int A, int B,
                            std::vector<std::pair<std::uint32_t, double>>* fraction = nullptr) {
      std::vector<char> t(anchor_of.size(), 0);
      const double Ls = P.loop_s.back();
      const std::size_t Ms = P.anchors.size();
      for (std::size_t k = 0; k < Ms; ++k) {
        if (A >= 0 && (P.anchors[k] != A || P.anchors[(k + 1) % Ms] != B)) continue;
        const double s0 = P.anchor_s[k];
        double len = std::fmod(P.anchor_s[(k + 1) % Ms] - s0 + 2 * Ls, Ls);
        if (Ms == 1) len = Ls;
        for (std::size_t i = 0; i < P.loop.size(); ++i) {
          const double r = std::fmod(P.loop_s[i] - s0 + 2 * Ls, Ls);
          const std::uint32_t v = P.loop[i];
          if ((A < 0 || (r > 0 && r < len)) && anchor_of[v] < 0 && occurs_once(P.loop, v)) {
            t[v] = 1;
            if (fraction && A >= 0) fraction->emplace_back(v, r / len);
          }
        }
        if (A < 0) break;
      }
      return t;
    };
    // The vertex of (vertex, fraction) pairs whose fraction is nearest `want` (the first such in
    // their order); -1 where there is none.
    auto nearest_fraction = [](const std::vector<std::pair<std::uint32_t, double>>& at,
                               double want) -> std::int64_t {
      double best = std::numeric_limits<double>::infinity();
      std::int64_t pick = -1;
      for (const auto& [x, f] : at)
        if (std::fabs(f - want) < best) {
          best = std::fabs(f - want);
          pick = x;
        }
      return pick;
    };
    // The vertex of patch `to`'s first loop at the fraction of the CAD path between the same two
    // anchors that vertex v has on patch `from`'s (the nearest one, among those `allowed` marks
    // where given), so that a new anchor lies on the same CAD path on both sides; -1 where v is
    // not strictly between two anchors or `to` has no such vertex.
    auto at_same_fraction = [&](const Patch& from, const std::vector<int>& from_anchor_of,
                                std::uint32_t v, const Patch& to,
                                const std::vector<int>& to_anchor_of,
                                const std::vector<char>* allowed) -> std::int64_t {
      const auto [A, B] = segment_of(from, v);
      std::vector<std::pair<std::uint32_t, double>> at_from, at_to;
      loop_targets(from, from_anchor_of, A, B, &at_from);
      loop_targets(to, to_anchor_of, A, B, &at_to);
      double want = -1;
      for (const auto& [x, f] : at_from)
        if (x == v) want = f;
      if (want < 0) return -1;
      if (allowed)
        at_to.erase(std::remove_if(at_to.begin(), at_to.end(),
                                   [&](const auto& xf) { return !(*allowed)[xf.first]; }),
                    at_to.end());
      return nearest_fraction(at_to, want);
    };
    const int first_pass = c.holes.size() > 1 ? 0 : 1;
    for (int pass = first_pass; pass < 3 && !split; ++pass)
      for (const auto& [near, hole_index] : hole_order) {
        if (split) break;
        const Loop& hole = c.holes[hole_index];
        // Pass 2 (only where the passes before split nothing): new slit starts for a hole without
        // anchor (d, below); and for the one hole of an annulus, the general order again with
        // paths that run alike up to a quarter of the hole's diameter. Two paths between the same
        // anchors of an annulus differ in kind only by their winding round the hole, and one
        // that winds half a turn more runs about the hole's diameter away from the other; closer
        // than that they differ by the meshes (the OpenCASCADE hub's rim face at a chord angle of
        // 0.2: one row of triangles on the canonical, where the slit is one edge, and a vertex
        // inside the row on the source, where it bends by most of an edge: 2.65 mm off on a slit
        // of 8.6 mm, in an annulus whose hole is 110 mm across).
        const bool annulus = pass == 2 && !hole.anchors.empty();
        if (annulus && c.holes.size() != 1) continue;
        const double slack = annulus ? 0.25 * hole.s.back() / M_PI : 0;
        const bool short_only = pass == 0;
        const std::vector<int> src_of = patch_of_triangles(ss, sp);
        const std::vector<int> can_of = patch_of_triangles(cs, cp);
        // Per side, the vertices a path could leave the patch by (an uncut half-edge of it): an
        // anchor whose only triangle in the patch lies between two loop edges (a one-triangle
        // wedge, common at the hub's rim on both sides) has none, and candidates from it are
        // skipped before tracing.
        std::vector<char> leaves[2];
        for (int side = 0; side < 2; ++side) {
          const Surface& surf = side == 0 ? ss : cs;
          const std::vector<char>& cuts = side == 0 ? src_cuts : can_cuts;
          const std::vector<int>& of = side == 0 ? src_of : can_of;
          const int patch = static_cast<int>(side == 0 ? sidx : holed);
          leaves[side].assign(surf.sample->vertex_count(), 0);
          for (int h = 0; h < 3 * surf.triangles(); ++h)
            if (of[static_cast<std::size_t>(h / 3)] == patch && !cuts[static_cast<std::size_t>(h)])
              leaves[side][surf.from(h)] = 1;
        }
        auto usable = [&](int m) {
          const int vs = src_anchor_of_all[static_cast<std::size_t>(m)];
          const int vc = can_anchor_of_all[static_cast<std::size_t>(m)];
          return vs >= 0 && vc >= 0 && leaves[0][static_cast<std::size_t>(vs)] &&
                 leaves[1][static_cast<std::size_t>(vc)];
        };
        if (hole.anchors.empty()) {
          // (d) A hole loop without any anchor (separate_faces: the border of a face cut off
          // its merged patch, whose CAD edges are new on both sides: the hub's bolt-hole rim on
          // the floor or the bottom, or the wall's far rim once its near one is anchored; the
          // press's ram bore rim): a slit from a first-loop anchor to the hole loop's
          // vertex nearest along the surface on one side and to the vertex in the same direction
          // from the loop's centre on the other, whose end becomes a new anchor. No
          // ID names the source patch's loop that corresponds: it is the one whose centre lies
          // nearest the canonical loop's, when the canonical loop is also the nearest to it
          // (mutually nearest; the two samples are of one model, so such loops move with the
          // parameters, by less than their spacing). The two slits must run alike too. Tried
          // from the first-loop anchors nearest the hole (canonical, straight-line distance), up
          // to 12; in the first pass only those within 1.5x the hole's distance.
          auto centre = [](const Surface& surf, const Loop& l, double* x) {
            const std::size_t n = l.vertices.size();
            x[0] = x[1] = x[2] = 0;
            for (std::size_t i = 0; i < n; ++i) {
              // Each vertex weighted by half its two edges' lengths.
              const double w =
                  0.5 * (l.s[i + 1] - l.s[i] + (i > 0 ? l.s[i] - l.s[i - 1] : l.s[n] - l.s[n - 1]));
              for (int a = 0; a < 3; ++a) x[a] += w * surf.position(l.vertices[i])[a] / l.s[n];
            }
          };
          auto nearest_loop = [&](const Surface& surf, const Patch& P, const double* x) {
            const Loop* best = nullptr;
            double bd = std::numeric_limits<double>::infinity();
            for (const Loop& l : P.holes) {
              if (!l.anchors.empty()) continue;
              double y[3];
              centre(surf, l, y);
              if (dist(x, y) < bd) {
                bd = dist(x, y);
                best = &l;
              }
            }
            return best;
          };
          double hc[3], hs[3];
          centre(cs, hole, hc);
          const Loop* match = nearest_loop(ss, sp[sidx], hc);
          if (match) centre(ss, *match, hs);
          if (!match || nearest_loop(cs, c, hs) != &hole) continue;
          // Per side (0 source, 1 canonical): the loop, its centre, and the vertices a slit may
          // end at (those the loop passes once).
          const Surface* surf[2] = {&ss, &cs};
          const Loop* loop[2] = {match, &hole};
          const double* at[2] = {hs, hc};
          std::vector<char> targets[2];
          for (int side = 0; side < 2; ++side) {
            targets[side].assign(surf[side]->sample->vertex_count(), 0);
            for (std::uint32_t v : loop[side]->vertices)
              if (occurs_once(loop[side]->vertices, v)) targets[side][v] = 1;
          }
          auto direction = [&](int side, std::uint32_t v, double* u) {
            const double* p = surf[side]->position(v);
            const double n = dist(p, at[side]);
            for (int k = 0; k < 3; ++k) u[k] = n > 0 ? (p[k] - at[side][k]) / n : 0;
          };
          std::vector<std::pair<double, int>> from;
          std::vector<int> seen;
          for (int a : c.anchors) {
            const int va = can_anchor_of_all[static_cast<std::size_t>(a)];
            if (std::find(seen.begin(), seen.end(), va) != seen.end() || !usable(a)) continue;
            seen.push_back(va);
            double d = std::numeric_limits<double>::infinity();
            for (std::uint32_t v : hole.vertices)
              d = std::min(
                  d, dist(corr.anchors[static_cast<std::size_t>(a)].canonical, cs.position(v)));
            if (pass < 2 && (!short_only || d <= 1.5 * near)) from.emplace_back(d, a);
          }
          std::sort(from.begin(), from.end());
          if (from.size() > 12) from.resize(12);
          // The slit from first-loop anchor a, traced alike on both sides; true when its end is
          // a new anchor.
          auto slit_from = [&](int a) {
            const std::vector<char>* cuts[2] = {&src_cuts, &can_cuts};
            const std::vector<int>* of[2] = {&src_of, &can_of};
            const int patch[2] = {int(sidx), int(holed)};
            const int va[2] = {src_anchor_of_all[std::size_t(a)],
                               can_anchor_of_all[std::size_t(a)]};
            std::vector<std::uint32_t> chain[2];
            // Either side may lead (the canonical first): its slit ends at the loop's vertex
            // nearest along the surface; the follower's at its loop's vertex in the same
            // direction from the loop's centre. Each side's nearest vertex on its own may lie far
            // round the loop from the other's (the press's ram bore where its rim cuts the throat
            // fillet: about 45 degrees, on a corner whose rim nears the plate's face), and another
            // face round the loop, anchored elsewhere (the bore's wall, by its top rim), is then
            // twisted between the two.
            for (int lead : {1, 0}) {
              ++tried;
              const int follow = 1 - lead;
              chain[lead] = shortest_path_to_any(*surf[lead], *cuts[lead],
                                                 static_cast<std::uint32_t>(va[lead]),
                                                 targets[lead], *of[lead], patch[lead]);
              if (chain[lead].size() < 2) continue;
              double u[3], w[3], best = -2;
              direction(lead, chain[lead].back(), u);
              std::vector<char> target(surf[follow]->sample->vertex_count(), 0);
              std::uint32_t pick = 0;
              for (std::uint32_t v : loop[follow]->vertices) {
                if (!targets[follow][v]) continue;
                direction(follow, v, w);
                const double cosine = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
                if (cosine > best) {
                  best = cosine;
                  pick = v;
                }
              }
              if (best < -1) continue;  // no vertex the loop passes once
              target[pick] = 1;
              chain[follow] = shortest_path_to_any(*surf[follow], *cuts[follow],
                                                   static_cast<std::uint32_t>(va[follow]), target,
                                                   *of[follow], patch[follow]);
              if (chain[follow].size() >= 2 && paths_run_alike(ss, chain[0], cs, chain[1])) break;
              chain[follow].clear();
            }
            return chain[0].size() >= 2 && chain[1].size() >= 2 &&
                   add_new_anchor(chain[0], chain[1]);
          };
          for (const auto& [d0, a] : from) {
            (void)d0;
            if (slit_from(a)) {
              split = true;
              break;
            }
          }
          // Last (pass 2, only where the two passes before split nothing): a slit that starts at
          // a first-loop vertex that is no anchor, nearest the hole first (canonical,
          // straight-line), which becomes a new anchor too: on the source at the loop vertex
          // between the same two anchors at the same fraction of the arc length, as the
          // hole-anchor slits below place theirs, so that it lies on the same CAD path on both
          // sides. A first-loop anchor cannot start a slit when each of its wedges in the patch
          // is a single triangle between two loop edges, and on finer meshes that is every
          // anchor near the hole (the OpenCASCADE hub's flange at a chord angle of 0.2: the loop
          // passes its anchors once per wedge, up to three times; on one pair none at all, on
          // another only one far round the flange, whose slits found no path on the source or
          // left layouts that differ). Up to 6 tried.
          if (!split && pass == 2) {
            const std::vector<char> loop_free = loop_targets(c, can_anchor_of, -1, -1);
            std::vector<std::pair<double, std::uint32_t>> starts;
            for (std::uint32_t v : c.loop) {
              if (!loop_free[v] || !leaves[1][v]) continue;
              double d = std::numeric_limits<double>::infinity();
              for (std::uint32_t u : hole.vertices)
                d = std::min(d, dist(cs.position(v), cs.position(u)));
              starts.emplace_back(d, v);
            }
            std::sort(starts.begin(), starts.end());
            std::size_t started = 0;
            for (const auto& [d0, v] : starts) {
              (void)d0;
              if (started == 6) break;
              const std::int64_t pick =
                  at_same_fraction(c, can_anchor_of, v, sp[sidx], src_anchor_of, &leaves[0]);
              if (pick < 0) continue;
              ++started;
              const int a = push_anchor(static_cast<std::uint32_t>(pick), v);
              if (slit_from(a)) {
                split = true;
                break;
              }
              pop_anchor();
            }
          }
          continue;
        }
        // Two paths, first loop -> hole, between the same anchors on both sides. Candidates: each
        // anchor a1 of the first loop, nearest the hole first (canonical positions), with the
        // first-loop anchor half-way round from it (a2) and, on the hole, the anchor nearest a1
        // (b1) and the one half-way round from that (b2). A candidate is kept when both paths exist
        // on both sides and the two layouts still have the same patch keys (a path leaving an
        // anchor into a one-triangle wedge, measured on the OpenCASCADE hub, has none).
        auto canon_pos = [&](int m) { return corr.anchors[static_cast<std::size_t>(m)].canonical; };
        auto nearest_on_hole = [&](int a) {
          std::size_t nearest = 0;
          double best = std::numeric_limits<double>::infinity();
          for (std::size_t k = 0; k < hole.anchors.size(); ++k) {
            const double d = dist(canon_pos(hole.anchors[k]), canon_pos(a));
            if (d < best) {
              best = d;
              nearest = k;
            }
          }
          return std::make_pair(nearest, best);
        };
        const std::size_t M = c.anchors.size();
        std::vector<std::pair<double, std::size_t>> order;
        for (std::size_t i = 0; i < M; ++i)
          order.emplace_back(nearest_on_hole(c.anchors[i]).second, i);
        std::sort(order.begin(), order.end());
        // An anchor where earlier splits met occurs several times on the loop, and several
        // anchors may share one vertex (a closed edge's vertex): try each vertex once.
        std::vector<int> seen;
        order.erase(
            std::remove_if(order.begin(), order.end(),
                           [&](const std::pair<double, std::size_t>& o) {
                             const int a =
                                 can_anchor_of_all[static_cast<std::size_t>(c.anchors[o.second])];
                             if (std::find(seen.begin(), seen.end(), a) != seen.end()) return true;
                             seen.push_back(a);
                             return false;
                           }),
            order.end());
        const std::vector<std::pair<double, std::size_t>> all_first = order;
        if (order.size() > 12) order.resize(12);
        // Traces the paths (pairs of anchors) on both sides and keeps them when the two layouts
        // still have the same patch keys.
        auto try_split = [&](const std::vector<std::pair<int, int>>& paths) {
          std::vector<char> try_cuts[2] = {src_cuts, can_cuts};
          std::vector<std::vector<std::uint32_t>> try_traced[2];
          bool ok = true;
          for (int side = 0; side < 2 && ok; ++side) {
            const Surface& surf = side == 0 ? ss : cs;
            std::vector<char>& cuts = try_cuts[side];
            const std::vector<int>& of = side == 0 ? src_of : can_of;
            const int patch = static_cast<int>(side == 0 ? sidx : holed);
            const double tol = side == 0 ? src_tol : can_tol;
            for (const auto& [x, y] : paths) {
              const Anchor& ax = corr.anchors[static_cast<std::size_t>(x)];
              const Anchor& ay = corr.anchors[static_cast<std::size_t>(y)];
              const int vx = vertex_at(surf, side == 0 ? ax.source : ax.canonical, tol);
              const int vy = vertex_at(surf, side == 0 ? ay.source : ay.canonical, tol);
              std::vector<std::uint32_t> chain;
              if (vx >= 0 && vy >= 0) {
                chain = shortest_path(surf, cuts, static_cast<std::uint32_t>(vx),
                                      static_cast<std::uint32_t>(vy), &of, patch);
                // A coarse mesh may have no vertex off the loops between them (a small hole near
                // the rim: one triangle row): the path may then touch loops away from anchors, and
                // build_patches cuts the patch open there; the anchors' cyclic order is unchanged.
                if (chain.size() < 2) {
                  std::vector<char> never(surf.sample->vertex_count(), 0);
                  for (int v : side == 0 ? src_anchor_of_all : can_anchor_of_all)
                    if (v >= 0) never[static_cast<std::size_t>(v)] = 1;
                  // A slit may not touch the two loops it joins away from its ends either: the
                  // piece between it and the loop would be enclosed without an anchor.
                  if (paths.size() == 1) {
                    const Patch& pp = side == 0 ? sp[sidx] : c;
                    for (std::uint32_t v : pp.loop) never[v] = 1;
                    for (std::uint32_t v : pp.holes[hole_index].vertices) never[v] = 1;
                  }
                  // Nor the first path of this split: touching it would enclose anchorless bits.
                  for (const auto& ch : try_traced[side])
                    for (std::uint32_t v : ch) never[v] = 1;
                  chain = shortest_path(surf, cuts, static_cast<std::uint32_t>(vx),
                                        static_cast<std::uint32_t>(vy), &of, patch, &never);
                }
              }
              if (chain.size() < 2) {
                ok = false;
                break;
              }
              cut_along(surf, chain, cuts);
              try_traced[side].push_back(std::move(chain));
            }
          }
          for (std::size_t k = 0; ok && k < paths.size(); ++k)
            ok = paths_run_alike(ss, try_traced[0][k], cs, try_traced[1][k], slack);
          if (!ok || !layouts_agree(try_cuts[0], try_cuts[1])) return false;
          src_cuts = std::move(try_cuts[0]);
          can_cuts = std::move(try_cuts[1]);
          for (auto& ch : try_traced[0]) src_traced.push_back(std::move(ch));
          for (auto& ch : try_traced[1]) can_traced.push_back(std::move(ch));
          return true;
        };
        auto same_vertex = [&](int x, int y) {
          const int u = vertex_at(cs, canon_pos(x), can_tol);
          return u >= 0 && u == vertex_at(cs, canon_pos(y), can_tol);
        };
        // A new anchor on the hole loop, on the far side from anchor b (a quarter to three
        // quarters of the loop's arc length from it), at the canonical vertex nearest first-loop
        // anchor a and on the source at the same fraction of its loop from b, as (c) places its
        // new anchors; -1 where either side has no such vertex that a path can leave by.
        auto far_side_anchor = [&](int b, int a) -> int {
          const Loop* loops[2] = {&sp[sidx].holes[hole_index], &hole};
          double from[2];
          for (int side = 0; side < 2; ++side) {
            const Loop& l = *loops[side];
            const auto k = std::find(l.anchors.begin(), l.anchors.end(), b);
            if (k == l.anchors.end()) return -1;
            from[side] = l.anchor_s[static_cast<std::size_t>(k - l.anchors.begin())];
          }
          auto fraction = [&](int side, std::size_t i) {
            const double L = loops[side]->s.back();
            return std::fmod(loops[side]->s[i] - from[side] + 2 * L, L) / L;
          };
          auto candidate = [&](int side, std::size_t i) {
            const std::uint32_t v = loops[side]->vertices[i];
            return (side == 0 ? src_anchor_of : can_anchor_of)[v] < 0 && leaves[side][v] &&
                   occurs_once(loops[side]->vertices, v);
          };
          std::int64_t pick[2] = {-1, -1};
          double want = -1, best = std::numeric_limits<double>::infinity();
          for (std::size_t i = 0; i < hole.vertices.size(); ++i) {
            const double f = fraction(1, i);
            if (f < 0.25 || f > 0.75 || !candidate(1, i)) continue;
            const double d = dist(cs.position(hole.vertices[i]), canon_pos(a));
            if (d < best) {
              best = d;
              pick[1] = hole.vertices[i];
              want = f;
            }
          }
          if (pick[1] < 0) return -1;
          std::vector<std::pair<std::uint32_t, double>> at_source;
          for (std::size_t i = 0; i < loops[0]->vertices.size(); ++i)
            if (candidate(0, i)) at_source.emplace_back(loops[0]->vertices[i], fraction(0, i));
          pick[0] = nearest_fraction(at_source, want);
          if (pick[0] < 0) return -1;
          return push_anchor(static_cast<std::uint32_t>(pick[0]),
                             static_cast<std::uint32_t>(pick[1]));
        };
        if (!short_only && M >= 2 && hole.anchors.size() >= 2) {
          for (const auto& [d0, i] : order) {
            (void)d0;
            const int a1 = c.anchors[i], a2 = c.anchors[(i + M / 2) % M];
            const std::size_t nearest = nearest_on_hole(a1).first;
            const int b1 = hole.anchors[nearest];
            const int b2 = hole.anchors[(nearest + hole.anchors.size() / 2) % hole.anchors.size()];
            ++tried;
            // Where the hole's anchors are one vertex (a closed CAD edge's vertex, which is the
            // end of that edge twice), both paths would end there: the piece holding the hole
            // then wraps round it, a thin strip between a path and the rim on one side and a wide
            // one on the other, and the disk maps squeeze its rim's first row of triangles flat
            // (the OpenCASCADE mount's bolt holes at chord angle 0.2: the bottom face's row beside
            // the rim, 0.66 mm wide on the canonical, mapped to 0.01 mm; the tets on it inverted).
            // The second path ends instead at a new anchor on the far side of the hole.
            if (same_vertex(b1, b2)) {
              const int m = far_side_anchor(b1, a2);
              if (m >= 0) {
                if (try_split({{a1, b1}, {a2, m}})) {
                  split = true;
                  break;
                }
                pop_anchor();
              }
            }
            if (try_split({{a1, b1}, {a2, b2}})) {
              split = true;
              break;
            }
          }
        }
        // Otherwise one path, a slit from the first loop to the hole: the patch stays one piece,
        // cut open along the slit like a periodic face along its seam (patch_layout.h), which makes
        // it a disk whose loop runs round the first loop, along the slit, round the hole and back.
        // On a face with many holes (the OpenCASCADE hub's flange: rim, bore and five bolt holes)
        // the two-path split runs out of anchor pairs whose paths avoid each other and the other
        // holes on both sides; a slit needs one path and one anchor per loop, and the next round
        // connects the next hole to the loop this one joined (a spanning tree of slits).
        // Candidates: every (first-loop vertex, hole anchor) pair by increasing canonical distance,
        // up to 24.
        if (!split) {
          std::vector<std::tuple<double, int, int>> slits;
          for (const auto& o : all_first) {
            const int a = c.anchors[o.second];
            if (!usable(a)) continue;
            for (int b : hole.anchors)
              if (usable(b)) slits.emplace_back(dist(canon_pos(a), canon_pos(b)), a, b);
          }
          std::sort(slits.begin(), slits.end());
          slits.erase(std::unique(slits.begin(), slits.end()), slits.end());
          if (short_only)
            slits.erase(std::remove_if(slits.begin(), slits.end(),
                                       [&](const std::tuple<double, int, int>& t) {
                                         return std::get<0>(t) > 1.5 * near;
                                       }),
                        slits.end());
          if (slits.size() > 24) slits.resize(24);
          for (const auto& [d0, a, b] : slits) {
            (void)d0;
            ++tried;
            if (try_split({{a, b}})) {
              split = true;
              break;
            }
          }
        }
        // Last, a slit from a hole anchor to the nearest vertex of the first loop that is no
        // anchor, on each side, which becomes a new anchor (a Steiner point of the layout, as
        // Kraevoy and Sheffer add): on a coarse mesh the hole may be one triangle row from the
        // loop, so that no path between two anchors avoids touching a loop. The canonical side
        // picks the vertex; the source side the vertex between the same two anchors of the same
        // loop at the same fraction of the arc length (below), so the new anchor lies on the same
        // CAD path on both sides and the neighbouring patch gets it too.
        if (!split) {
          const Patch& s = sp[sidx];
          std::vector<int> hole_anchors(hole.anchors);
          std::sort(hole_anchors.begin(), hole_anchors.end());
          hole_anchors.erase(std::unique(hole_anchors.begin(), hole_anchors.end()),
                             hole_anchors.end());
          for (int b : hole_anchors) {
            const int vb[2] = {src_anchor_of_all[static_cast<std::size_t>(b)],
                               can_anchor_of_all[static_cast<std::size_t>(b)]};
            if (vb[0] < 0 || vb[1] < 0) continue;
            const Surface* surf[2] = {&ss, &cs};
            const std::vector<char>* cuts[2] = {&src_cuts, &can_cuts};
            const std::vector<int>* of[2] = {&src_of, &can_of};
            const Patch* P[2] = {&s, &c};
            const std::vector<int>* anchor_of[2] = {&src_anchor_of, &can_anchor_of};
            const int patch[2] = {int(sidx), int(holed)};
            std::vector<std::uint32_t> chain[2];
            // Either side may lead: the canonical first, then the source.
            for (int lead : {1, 0}) {
              ++tried;
              const int follow = 1 - lead;
              chain[lead] = shortest_path_to_any(
                  *surf[lead], *cuts[lead], static_cast<std::uint32_t>(vb[lead]),
                  loop_targets(*P[lead], *anchor_of[lead], -1, -1), *of[lead], patch[lead]);
              if (chain[lead].size() < 2) continue;
              const auto [A, B] = segment_of(*P[lead], chain[lead].back());
              // The follower's new anchor at the leader's fraction of the CAD path from A to B
              // (the loop vertex nearest it), not simply the vertex nearest its hole: new anchors
              // at different fractions shift the rim's vertices along it against the canonical's
              // (the hub's cavity rim: pairs' Hausdorff max 1.33e-3 with the nearest vertex,
              // 9.06e-4 so), and differently in each sample of an element, so interpolating
              // between them cuts the circle's corners (the hub's build, cadinterp-occt-results:
              // geometry max 0.0054 of the diagonal, 0.0020 so).
              // Where the leader's vertex is no loop vertex strictly between A and B, any of the
              // follower's between them.
              const std::vector<char> allowed = loop_targets(*P[follow], *anchor_of[follow], A, B);
              const std::int64_t pick =
                  at_same_fraction(*P[lead], *anchor_of[lead], chain[lead].back(), *P[follow],
                                   *anchor_of[follow], nullptr);
              std::vector<char> target(allowed.size(), 0);
              if (pick >= 0) target[static_cast<std::size_t>(pick)] = 1;
              chain[follow] = shortest_path_to_any(
                  *surf[follow], *cuts[follow], static_cast<std::uint32_t>(vb[follow]),
                  pick >= 0 ? target : allowed, *of[follow], patch[follow]);
              // The two slits must run alike.
              if (chain[follow].size() >= 2) {
                if (paths_run_alike(ss, chain[0], cs, chain[1])) break;
                chain[follow].clear();
              }
            }
            if (chain[0].size() < 2 || chain[1].size() < 2) continue;
            if (add_new_anchor(chain[0], chain[1])) {
              split = true;
              break;
            }
          }
        }
      }
    if (!split) {
      why =
          "mapping: no paths split a patch with a hole the same way on both sides (anchors "
          "not at mesh vertices, blocked, or the layouts differ after the split; " +
          std::to_string(tried) + " candidates tried)";
      return false;
    }
  }
  // §6.2, last: "more edges are added to further subdivide large patches for better
  // parametrization ... only if the shortest path length is significantly smaller than the path
  // that connects these two points on the patch layout" (Kraevoy and Sheffer's criterion: a
  // disk whose loop runs far round between two anchors that lie near each other across it is
  // folded, and its mean-value map squeezes the part beyond the narrows). Candidates: pairs of
  // anchors on one canonical patch's loop, not neighbours on it, whose shortest path inside the
  // patch is under MapOptions::subdivide_ratio of the shorter way round the loop between them;
  // the lowest ratio first. Each is traced on both sides in the patch that still holds both
  // anchors, and kept when the two paths run alike and the layouts still agree.
  std::size_t subdivided = 0;
  std::size_t planar_patches = 0;
  if (options.subdivide_ratio > 0) {
    struct Candidate {
      double ratio;
      int a, b;
    };
    std::vector<Candidate> candidates;
    {
      const std::vector<int> can_of = patch_of_triangles(cs, cp);
      for (std::size_t pi = 0; pi < cp.size(); ++pi) {
        const Patch& c = cp[pi];
        const double L = c.loop_s.back();
        // Anchor occurrences at vertices the loop passes once, in loop order.
        std::vector<std::pair<int, double>> at;
        for (std::size_t k = 0; k < c.anchors.size(); ++k) {
          const int v = can_anchor_of_all[static_cast<std::size_t>(c.anchors[k])];
          if (v >= 0 && occurs_once(c.loop, static_cast<std::uint32_t>(v)) &&
              (at.empty() || at.back().first != c.anchors[k]))
            at.emplace_back(c.anchors[k], c.anchor_s[k]);
        }
        if (at.size() < 4) continue;
        std::vector<char> targets(cs.sample->vertex_count(), 0);
        for (const auto& [m, arc] : at) {
          (void)arc;
          targets[static_cast<std::size_t>(can_anchor_of_all[static_cast<std::size_t>(m)])] = 1;
        }
        for (std::size_t i = 0; i < at.size(); ++i) {
          const std::vector<double> d = path_lengths_from(
              cs, can_cuts,
              static_cast<std::uint32_t>(can_anchor_of_all[static_cast<std::size_t>(at[i].first)]),
              targets, can_of, static_cast<int>(pi));
          for (std::size_t j = i + 2; j < at.size(); ++j) {
            if (i == 0 && j + 1 == at.size()) continue;  // neighbours round the loop's end
            const double gap = std::fabs(at[j].second - at[i].second);
            const double route = std::min(gap, L - gap);
            const double D = d[static_cast<std::size_t>(
                can_anchor_of_all[static_cast<std::size_t>(at[j].first)])];
            if (route > 0 && D < options.subdivide_ratio * route)
              candidates.push_back({D / route, at[i].first, at[j].first});
          }
        }
      }
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
      return std::tie(x.ratio, x.a, x.b) < std::tie(y.ratio, y.a, y.b);
    });
    // Each trial traces two paths and compares two layouts: the best 32 only.
    if (candidates.size() > 32) candidates.resize(32);
    std::vector<int> of[2] = {patch_of_triangles(ss, sp), patch_of_triangles(cs, cp)};
    // The patch of `patches` whose loop passes both anchor vertices once, or -1.
    auto holding = [&](const std::vector<Patch>& patches, int va, int vb) {
      for (std::size_t pi = 0; pi < patches.size(); ++pi) {
        const std::vector<std::uint32_t>& loop = patches[pi].loop;
        if (occurs_once(loop, static_cast<std::uint32_t>(va)) &&
            occurs_once(loop, static_cast<std::uint32_t>(vb)))
          return static_cast<int>(pi);
      }
      return -1;
    };
    for (const Candidate& k : candidates) {
      const int va[2] = {src_anchor_of_all[static_cast<std::size_t>(k.a)],
                         can_anchor_of_all[static_cast<std::size_t>(k.a)]};
      const int vb[2] = {src_anchor_of_all[static_cast<std::size_t>(k.b)],
                         can_anchor_of_all[static_cast<std::size_t>(k.b)]};
      const int pc = holding(cp, va[1], vb[1]);
      if (pc < 0 || va[0] < 0 || vb[0] < 0) continue;
      const int ps = holding(sp, va[0], vb[0]);
      if (ps < 0 ||
          sp[static_cast<std::size_t>(ps)].key() != cp[static_cast<std::size_t>(pc)].key())
        continue;
      std::vector<std::uint32_t> chain[2];
      std::vector<char> try_cuts[2] = {src_cuts, can_cuts};
      for (int side = 0; side < 2; ++side) {
        const Surface& surf = side == 0 ? ss : cs;
        chain[side] =
            shortest_path(surf, try_cuts[side], static_cast<std::uint32_t>(va[side]),
                          static_cast<std::uint32_t>(vb[side]), &of[side], side == 0 ? ps : pc);
        cut_along(surf, chain[side], try_cuts[side]);
      }
      if (chain[0].size() < 2 || chain[1].size() < 2 ||
          !paths_run_alike(ss, chain[0], cs, chain[1]) || !layouts_agree(try_cuts[0], try_cuts[1]))
        continue;
      src_cuts = std::move(try_cuts[0]);
      can_cuts = std::move(try_cuts[1]);
      src_traced.push_back(std::move(chain[0]));
      can_traced.push_back(std::move(chain[1]));
      if (!build_patches(ss, src_cuts, src_anchor, src_tol, true, sp, why) ||
          !build_patches(cs, can_cuts, can_anchor, can_tol, true, cp, why)) {
        why = "mapping: layout after subdividing a patch: " + why;
        return false;
      }
      of[0] = patch_of_triangles(ss, sp);
      of[1] = patch_of_triangles(cs, cp);
      ++subdivided;
    }
  }
  // §6.2: the traced paths refined to their geodesics once the layout is chosen: measured
  // along them (geodesic.h).
  if (options.geodesic_paths) {
    measure_traced_paths_along_geodesics(ss, src_traced, sp);
    measure_traced_paths_along_geodesics(cs, can_traced, cp);
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
  // Each boundary vertex's freedom on the source surface, for the boundary untangling after the
  // interior solve (boundary_untangle.h): anchors fixed, loop vertices along their source path
  // (arc length within their segment between two anchors, and between their loop neighbours so
  // the order along the path is kept), inner vertices in their patch's source disk.
  std::vector<BoundaryDof> dofs;
  std::vector<int> dof_of(V, -1);
  std::vector<std::unique_ptr<DiskMap>> source_disks(cp.size());
  std::vector<std::unique_ptr<DiskLocator>> source_locators(cp.size());
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
    const std::size_t n_loop = c.loop.size();
    struct LoopDof {
      std::size_t index, dof;
      double seg_lo, seg_hi;  // the segment's anchors' arc lengths
    };
    std::vector<LoopDof> loop_dofs;
    for (std::size_t i = 0; i < n_loop; ++i) {
      const std::uint32_t v = c.loop[i];
      if (assigned[v]) continue;
      std::size_t k;
      double f;
      cf.locate(c.loop_s[i], k, f);
      where[v] = loop_point(s, sf.arc(k, f));
      assigned[v] = 1;
      if (can_anchor_of[v] >= 0 || !(f > 0 && f < 1)) continue;  // an anchor: fixed
      // Neighbours along the loop, in source arc length relative to the first anchor; one in
      // another segment bounds at this segment's anchor.
      auto rel_of = [&](std::size_t j, bool previous) {
        std::size_t kj;
        double fj;
        cf.locate(c.loop_s[j], kj, fj);
        if (kj != k) return previous ? sf.rel[k] : sf.rel[k] + sf.seg[k];
        return sf.rel[k] + fj * sf.seg[k];
      };
      const double r = sf.rel[k] + f * sf.seg[k];
      const double r_prev = std::min(r, rel_of((i + n_loop - 1) % n_loop, true));
      const double r_next = std::max(r, rel_of((i + 1) % n_loop, false));
      BoundaryDof d;
      d.vertex = v;
      d.dims = 1;
      // Absolute arc length along the source loop (loop_point's argument). Bounds: the
      // segment's anchors, and half-way to a neighbour whose dof is not on this loop; the
      // neighbours on it bound dynamically (BoundaryDof::prev / next, linked below).
      d.p[0] = sf.origin + r;
      d.lo = sf.origin + 0.5 * (r_prev + r);
      d.hi = sf.origin + 0.5 * (r + r_next);
      d.step = 0.5 * (d.hi - d.lo);
      loop_dofs.push_back(
          {i, dofs.size(), sf.origin + sf.rel[k], sf.origin + sf.rel[k] + sf.seg[k]});
      d.patch = static_cast<int>(pi);
      dof_of[v] = static_cast<int>(dofs.size());
      dofs.push_back(d);
    }
    // Loop neighbours whose dofs lie on this loop (recorded just now, so on the same arc
    // length) bound each other; where both neighbours are on it, the bounds widen to the
    // segment, so that a vertex can pass a source vertex its neighbours' mid-points would block.
    for (std::size_t j = 0; j < loop_dofs.size(); ++j) {
      BoundaryDof& d = dofs[loop_dofs[j].dof];
      const std::size_t i = loop_dofs[j].index;
      const auto on_loop = [&](std::size_t other) -> int {
        for (const LoopDof& o : loop_dofs)
          if (o.index == other) return static_cast<int>(o.dof);
        return -1;
      };
      const int prev = on_loop((i + n_loop - 1) % n_loop), next = on_loop((i + 1) % n_loop);
      if (prev >= 0 && dofs[std::size_t(prev)].p[0] < d.p[0]) {
        d.prev = prev;
        d.lo = std::max(loop_dofs[j].seg_lo, d.p[0] - (loop_dofs[j].seg_hi - loop_dofs[j].seg_lo));
      }
      if (next >= 0 && dofs[std::size_t(next)].p[0] > d.p[0]) {
        d.next = next;
        d.hi = std::min(loop_dofs[j].seg_hi, d.p[0] + (loop_dofs[j].seg_hi - loop_dofs[j].seg_lo));
      }
    }
    // Interior vertices of the patch (if any): through the disks.
    bool interior = false;
    for (int t : c.triangles)
      for (int k = 0; k < 3 && !interior; ++k) interior = !assigned[cs.from(3 * t + k)];
    if (!interior) continue;
    DiskMap cd;
    source_disks[pi] = std::make_unique<DiskMap>();
    DiskMap& sd = *source_disks[pi];
    if (!mean_value_parametrize(cs, c, loop_uv(c, cf), cd, why) ||
        !mean_value_parametrize(ss, s, loop_uv(s, sf), sd, why)) {
      why = "mapping: " + why;
      return false;
    }
    source_locators[pi] = std::make_unique<DiskLocator>(sd);
    const DiskLocator& locator = *source_locators[pi];
    std::vector<std::size_t> inner;  // local vertices of cd placed through the disks
    for (std::size_t l = 0; l < cd.vertices.size(); ++l)
      if (!assigned[cd.vertices[l]]) inner.push_back(l);
    for (std::size_t l : inner) {
      where[cd.vertices[l]] = disk_point(sd, locator, &cd.uv[2 * l]);
      assigned[cd.vertices[l]] = 1;
    }
    std::vector<double> inner_uv(cd.uv);  // the disk coordinates finally used
    const std::size_t n = cd.vertices.size();
    auto positions = [&](const std::vector<SurfacePoint>& at) {
      std::vector<double> P(3 * n);
      for (std::size_t l = 0; l < n; ++l) position_of(source, at[l], &P[3 * l]);
      return P;
    };
    auto gap = [&](const std::vector<SurfacePoint>& at) {
      const std::vector<double> P = positions(at);
      const std::vector<std::uint32_t> F(cd.triangles.begin(), cd.triangles.end());
      const mesh::SurfaceIndex index(P, F);
      double d = 0;
      for (std::uint32_t v : sd.vertices)
        d = std::max(d, index.distance(source.vertices.data() + 3 * std::size_t(v)));
      return d;
    };
    // The patch's triangles whose mapped normal opposes the source's normal where they lie
    // (the source triangle a vertex of theirs was placed in): folds of the surface map.
    auto folded = [&](const std::vector<SurfacePoint>& at) {
      const std::vector<double> P = positions(at);
      auto normal = [](const double* a, const double* b, const double* e, double* nrm) {
        const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double w[3] = {e[0] - a[0], e[1] - a[1], e[2] - a[2]};
        nrm[0] = u[1] * w[2] - u[2] * w[1];
        nrm[1] = u[2] * w[0] - u[0] * w[2];
        nrm[2] = u[0] * w[1] - u[1] * w[0];
      };
      std::vector<std::size_t> folds;
      for (std::size_t t = 0; 3 * t < cd.triangles.size(); ++t) {
        const std::size_t q[3] = {std::size_t(cd.triangles[3 * t]),
                                  std::size_t(cd.triangles[3 * t + 1]),
                                  std::size_t(cd.triangles[3 * t + 2])};
        const SurfacePoint* in = nullptr;
        for (std::size_t k = 0; k < 3 && !in; ++k) {
          const SurfacePoint& pt = at[q[k]];
          if (pt.v[0] != pt.v[1] && pt.v[1] != pt.v[2] && pt.v[0] != pt.v[2]) in = &pt;
        }
        if (!in) continue;  // all three on the loop: placed along the source path
        double nm[3], ns[3];
        normal(&P[3 * q[0]], &P[3 * q[1]], &P[3 * q[2]], nm);
        normal(&source.vertices[3 * std::size_t(in->v[0])],
               &source.vertices[3 * std::size_t(in->v[1])],
               &source.vertices[3 * std::size_t(in->v[2])], ns);
        if (nm[0] * ns[0] + nm[1] * ns[1] + nm[2] * ns[2] <= 0) folds.push_back(t);
      }
      return folds;
    };
    if (options.relax_iterations > 0 && !inner.empty()) {
      // The relaxation is kept only where it folds no more triangles and brings this patch
      // nearer to the source's (the larger distance from a source patch vertex to the mapped
      // patch, the builder's vertex-sampled Hausdorff): measured on the bracket it lowers the
      // worst pairs but not every pair (cadinterp-mapping-report pairs --relax).
      std::vector<double> uv = cd.uv;
      relax_in_patch(source, canonical, cd, sd, locator, inner, where, options.relax_iterations,
                     uv);
      // Per local vertex: where the composed disk maps put it, and where the relaxation does.
      std::vector<SurfacePoint> composed(n), relaxed(n);
      std::vector<char> movable(n, 0);
      for (std::size_t l = 0; l < n; ++l) composed[l] = relaxed[l] = where[cd.vertices[l]];
      for (std::size_t l : inner) {
        relaxed[l] = disk_point(sd, locator, &uv[2 * l]);
        movable[l] = 1;
      }
      // The relaxation can fold triangles the composed map did not (measured on the OpenCASCADE
      // hub: a flange floor whose slit runs one triangle row from a bolt hole's loop, 0 triangles
      // folded composed, 98 relaxed and kept for its smaller gap, 85 tets inverted after). The
      // vertices of folded triangles go back to their composed place, repeatedly while that
      // leaves fewer folds; the result is kept when it folds less, or as little and lies nearer.
      const std::size_t folds_composed = folded(composed).size();
      std::vector<std::size_t> f = folded(relaxed);
      for (int round = 0; round < 20 && f.size() > folds_composed; ++round) {
        bool changed = false;
        for (std::size_t t : f)
          for (std::size_t k = 0; k < 3; ++k) {
            const auto l = static_cast<std::size_t>(cd.triangles[3 * t + k]);
            if (!movable[l]) continue;
            movable[l] = 0;
            relaxed[l] = composed[l];
            uv[2 * l] = cd.uv[2 * l];
            uv[2 * l + 1] = cd.uv[2 * l + 1];
            changed = true;
          }
        if (!changed) break;
        f = folded(relaxed);
      }
      const std::size_t folds_relaxed = f.size();
      if (folds_relaxed < folds_composed ||
          (folds_relaxed == folds_composed && gap(relaxed) < gap(composed))) {
        for (std::size_t l : inner) where[cd.vertices[l]] = relaxed[l];
        inner_uv = uv;
      }
    }
    if (options.planar_patches && !inner.empty()) {
      // A patch still folded whose source projects onto a plane (planar_placement): unfolded
      // there, kept when it folds fewer triangles.
      std::vector<SurfacePoint> current(n), planar(n);
      for (std::size_t l = 0; l < n; ++l) current[l] = planar[l] = where[cd.vertices[l]];
      const std::size_t folds = folded(current).size();
      std::vector<double> planar_uv = inner_uv;
      if (folds > 0 && planar_placement(source, canonical, cd, sd, inner, planar, planar_uv) &&
          folded(planar).size() < folds) {
        for (std::size_t l : inner) where[cd.vertices[l]] = planar[l];
        inner_uv = std::move(planar_uv);
        ++planar_patches;
      }
    }
    for (std::size_t l : inner) {
      const std::uint32_t v = cd.vertices[l];
      if (can_anchor_of[v] >= 0 || dof_of[v] >= 0) continue;
      BoundaryDof d;
      d.vertex = v;
      d.dims = 2;
      d.p[0] = inner_uv[2 * l];
      d.p[1] = inner_uv[2 * l + 1];
      // The initial step: half the size of the source disk triangle it lies in.
      int tri;
      double w[3];
      locator.locate(d.p[0], d.p[1], tri, w);
      const int* q = &sd.triangles[3 * std::size_t(tri)];
      const double* ua = &sd.uv[2 * std::size_t(q[0])];
      const double* ub = &sd.uv[2 * std::size_t(q[1])];
      const double* uc = &sd.uv[2 * std::size_t(q[2])];
      const double area =
          0.5 * std::fabs((ub[0] - ua[0]) * (uc[1] - ua[1]) - (ub[1] - ua[1]) * (uc[0] - ua[0]));
      d.step = 0.5 * std::sqrt(2 * area);
      d.patch = static_cast<int>(pi);
      dof_of[v] = static_cast<int>(dofs.size());
      dofs.push_back(d);
    }
  }
  // The 3-D position of a surface point: on the source's smooth reconstruction per B-rep face
  // (smooth_surface.h; the mapped boundary then follows curved faces instead of the source's
  // chords: Hausdorff max over 10 OpenCASCADE wrench pairs 1.04e-3 -> 6.4e-4), or on its flat
  // triangles. The weights `where` (the field transfer's) are the same either way.
  std::unique_ptr<SmoothSurface> smooth;
  if (options.smooth_alpha > 0)
    smooth = std::make_unique<SmoothSurface>(source, options.smooth_alpha);
  auto place_point = [&](const SurfacePoint& pt, double* x) {
    if (smooth)
      smooth->position(pt, x);
    else
      position_of(source, pt, x);
  };
  out.vertices = canonical.vertices;
  for (std::size_t v = 0; v < V; ++v) {
    if (!on_surface[v]) continue;
    if (!assigned[v]) {
      why = "mapping: canonical boundary vertex " + std::to_string(v) + " lies in no patch";
      return false;
    }
    place_point(where[v], &out.vertices[3 * v]);
  }
  // §6.4: the interior follows: the P1-harmonic solve (exact on affine maps), untangled; where
  // tets stay inverted, once more in MapOptions::fallback_steps boundary increments with
  // volume-stiffened tets (measured on the OpenCASCADE wrench, 10 random pairs: one harmonic
  // solve 5 mapped, 4 increments alone 5, stiffening alone 5 (exponent 1) or 4 (2), both 8).
  std::vector<double> surface_map = out.vertices;
  auto interior = [&](int steps, double stiffening, TetQuality& q) {
    out.vertices = surface_map;
    if (!incremental_interior(canonical.vertices, canonical.tets, on_surface, out.vertices, why,
                              steps, stiffening)) {
      why = "mapping: " + why;
      return false;
    }
    q = tet_quality(out.vertices, canonical.tets);
    if (q.inverted > 0) {
      // The same volume threshold as tet_quality (mesh::validate's rule), on the mapped mesh.
      untangle(canonical.tets, on_surface, min_six_volume(out.vertices), out.vertices);
      q = tet_quality(out.vertices, canonical.tets);
    }
    return true;
  };
  // Regions folded over as a whole (foldover_free.h): the interior vertices near the tets still
  // inverted move together; kept when fewer stay inverted. All calls of one mapping share
  // MapOptions::foldover_free_evaluations.
  int foldover_budget =
      options.foldover_free_evaluations > 0 ? options.foldover_free_evaluations : INT_MAX;
  auto untangle_whole = [&](TetQuality& q) {
    if (foldover_budget <= 0) return;
    FoldoverFreeOptions fo;
    fo.max_evaluations = foldover_budget;
    const FoldoverFreeResult r =
        untangle_foldover_free(canonical.vertices, canonical.tets, on_surface,
                               min_six_volume(out.vertices), out.vertices, fo);
    foldover_budget -= r.evaluations;
    if (r.inverted_after < r.inverted_before) q = tet_quality(out.vertices, canonical.tets);
  };
  auto solve = [&](TetQuality& q) {
    if (!interior(options.interior_steps, options.stiffening, q)) return false;
    if (q.inverted > 0 && options.fallback_steps > 0) {
      const std::vector<double> first = out.vertices;
      TetQuality q2;
      if (!interior(options.fallback_steps, options.fallback_stiffening, q2)) return false;
      if (q2.inverted < q.inverted) {
        q = q2;
      } else {
        out.vertices = first;
      }
    }
    if (q.inverted > 0 && options.foldover_free && options.foldover_free_early) untangle_whole(q);
    return true;
  };
  TetQuality q;
  if (!solve(q)) return false;
  const bool folded = static_cast<double>(q.inverted) >
                      options.untangle_max_fraction * static_cast<double>(canonical.tet_count());
  // Where tets stay inverted: the surface relaxed across the traced paths
  // (release_traced_paths), kept when the interior then has fewer inverted tets.
  struct Unreleased {
    std::vector<double> surface_map, vertices;
    std::vector<SurfacePoint> where;
    std::vector<BoundaryDof> dofs;
    TetQuality q;
  };
  std::unique_ptr<Unreleased> unreleased;
  if (q.inverted > 0 && !folded && options.release_sweeps > 0 && !can_traced.empty()) {
    const std::vector<char> cad_cuts = cuts_of(cs, can_keys, {}, can_tol);
    std::vector<char> on_cad(V, 0);
    for (int h = 0; h < 3 * cs.triangles(); ++h)
      if (cad_cuts[std::size_t(h)]) on_cad[cs.from(h)] = on_cad[cs.to(h)] = 1;
    // Within 3 surface rings of a traced path.
    std::vector<int> ring(V, -1);
    std::vector<std::uint32_t> front;
    for (const auto& chain : can_traced)
      for (std::uint32_t v : chain)
        if (ring[v] < 0) {
          ring[v] = 0;
          front.push_back(v);
        }
    std::vector<std::vector<std::uint32_t>> next_to(V);
    for (int h = 0; h < 3 * cs.triangles(); ++h) next_to[cs.from(h)].push_back(cs.to(h));
    for (int r = 1; r <= 3; ++r) {
      std::vector<std::uint32_t> grown;
      for (std::uint32_t v : front)
        for (std::uint32_t u : next_to[v])
          if (ring[u] < 0) {
            ring[u] = r;
            grown.push_back(u);
          }
      front.swap(grown);
    }
    std::vector<std::uint32_t> movable;
    for (std::uint32_t v = 0; v < V; ++v)
      if (ring[v] >= 0 && !on_cad[v] && can_anchor_of[v] < 0) movable.push_back(v);
    std::vector<SurfacePoint> released_where = where;
    std::vector<double> released = surface_map;
    release_traced_paths(source, ss, canonical, movable, options.release_sweeps, released_where,
                         place_point, released);
    const std::vector<double> kept_map = surface_map, kept_out = out.vertices;
    surface_map = released;
    TetQuality q2;
    if (!solve(q2)) return false;
    if (q2.inverted == 0) {
      q = q2;
      where = std::move(released_where);
    } else if (q2.inverted < q.inverted) {
      // Fewer, not none: the boundary untangling below runs from here, and once more from the
      // state before the release (kept in `unreleased`), the better result kept. The
      // untangling's parameters of the released vertices (disk coordinates) no longer say
      // where they are, so there it leaves them where the release put them.
      unreleased = std::make_unique<Unreleased>(Unreleased{kept_map, kept_out, where, dofs, q});
      q = q2;
      where = std::move(released_where);
      for (std::uint32_t v : movable)
        if (dof_of[v] >= 0) dofs[static_cast<std::size_t>(dof_of[v])].dims = 0;
    } else {
      surface_map = kept_map;
      out.vertices = kept_out;
    }
  }
  // Boundary untangling (boundary_untangle.h): tets that stay inverted after the interior solve,
  // most of them with all four vertices on the boundary (measured on the OpenCASCADE press and
  // mount), get their boundary vertices moved within the source surface, then the interior is
  // solved again for the moved boundary; repeated while it helps.
  std::size_t boundary_moved = 0;
  auto untangle_surface = [&]() {
    auto point_of = [&](const BoundaryDof& d, const double* p, SurfacePoint& pt) {
      const std::size_t pi = static_cast<std::size_t>(d.patch);
      if (d.dims == 1) {
        pt = loop_point(sp[static_cast<std::size_t>(source_of[pi])], p[0]);
        return true;
      }
      if (std::hypot(p[0], p[1]) > 0.999) return false;  // inner vertices stay off the circle
      pt = disk_point(*source_disks[pi], *source_locators[pi], p);
      return true;
    };
    const PlaceFn place = [&](const BoundaryDof& d, const double* p, double* x) {
      SurfacePoint pt;
      if (!point_of(d, p, pt)) return false;
      place_point(pt, x);
      return true;
    };
    std::vector<char> free_vertex(V);
    for (std::size_t v = 0; v < V; ++v) free_vertex[v] = on_surface[v] ? 0 : 1;
    const std::vector<BoundaryDof> initial = dofs;
    std::vector<double> best = out.vertices;
    std::vector<BoundaryDof> best_dofs = dofs;
    TetQuality best_q = q;
    for (int pass = 0; pass < options.boundary_untangle_passes && best_q.inverted > 0; ++pass) {
      const BoundaryUntangleResult r =
          untangle_boundary(canonical.tets, dof_of, dofs, place, min_six_volume(out.vertices),
                            out.vertices, &free_vertex);
      q = tet_quality(out.vertices, canonical.tets);
      if (q.inverted < best_q.inverted) {
        best = out.vertices;
        best_dofs = dofs;
        best_q = q;
      }
      if (best_q.inverted == 0 || r.moved == 0) break;
      // The interior once more for the moved boundary (the harmonic solve spreads the boundary
      // moves into the interior, which the local search alone cannot), then the next pass.
      for (std::size_t v = 0; v < V; ++v)
        if (on_surface[v])
          for (std::size_t a = 0; a < 3; ++a) surface_map[3 * v + a] = out.vertices[3 * v + a];
      if (!solve(q)) return false;
      if (q.inverted < best_q.inverted) {
        best = out.vertices;
        best_dofs = dofs;
        best_q = q;
      }
    }
    out.vertices = std::move(best);
    dofs = std::move(best_dofs);
    q = best_q;
    // The surface points of the moved boundary vertices (the field transfer's weights).
    for (std::size_t i = 0; i < dofs.size(); ++i) {
      if (dofs[i].p[0] == initial[i].p[0] && dofs[i].p[1] == initial[i].p[1]) continue;
      point_of(dofs[i], dofs[i].p, where[dofs[i].vertex]);
      ++boundary_moved;
    }
    return true;
  };
  if (q.inverted > 0 && !folded && options.boundary_untangle_passes > 0) {
    if (!untangle_surface()) return false;
    if (q.inverted > 0 && unreleased) {
      // Once more from the state before the release; the fewer inverted tets kept.
      const std::vector<double> r_vertices = out.vertices, r_map = surface_map;
      const std::vector<SurfacePoint> r_where = where;
      const std::size_t r_moved = boundary_moved;
      const TetQuality r_q = q;
      surface_map = unreleased->surface_map;
      out.vertices = unreleased->vertices;
      where = unreleased->where;
      dofs = unreleased->dofs;
      q = unreleased->q;
      boundary_moved = 0;
      if (!untangle_surface()) return false;
      if (r_q.inverted < q.inverted) {
        out.vertices = r_vertices;
        surface_map = r_map;
        where = r_where;
        boundary_moved = r_moved;
        q = r_q;
      }
    }
  }
  if (q.inverted > 0 && options.foldover_free && !options.foldover_free_early) {
    // Last resort (MapOptions::foldover_free): from the best state so far.
    untangle_whole(q);
    // And the boundary untangling once more, from the untangled interior: a tet left inverted
    // across a boundary triangle whose vertices the first passes could not move while the
    // interior around it was still folded (press pair 128 with the round-13 energy: 1 tet left,
    // none after this).
    if (q.inverted > 0 && !folded && options.boundary_untangle_passes > 0 && !untangle_surface())
      return false;
  }
  if (stats) {
    stats->matched_points = corr.anchors.size();
    stats->patches = cp.size();
    stats->rejected_paths = rejected_paths;
    stats->dropped_anchors = dropped_anchors;
    stats->subdivided = subdivided;
    stats->planar_patches = planar_patches;
    stats->min_scaled_jacobian = q.min_scaled_jacobian;
    stats->inverted = q.inverted;
    stats->boundary_moved = boundary_moved;
    stats->smoothed = smooth != nullptr;
  }
  // The whole mapping again with other options; its result replaces this one when it succeeds.
  auto retry = [&](const MapOptions& other) {
    mesh::MappedSample other_out;
    std::string other_why;
    MapStats other_stats;
    if (!map_sample(source, canonical, other_out, other_why, &other_stats, other)) return false;
    out = std::move(other_out);
    if (stats) *stats = other_stats;
    return true;
  };
  if (q.inverted > 0 && !folded && options.smooth_alpha > 0 && !options.foldover_free_early) {
    // The same mapping on the flat source triangles, kept when it succeeds: the reconstruction
    // lifts boundary vertices by up to the chordal sag, which can leave a thin tet near the
    // boundary inverted that the flat placement does not (measured on the OpenCASCADE press: 1
    // of 9 pairs; others the other way round), so the smooth placement never costs a pair.
    MapOptions flat = options;
    flat.smooth_alpha = 0;
    if (retry(flat)) return true;
  }
  if (q.inverted > 0 && options.foldover_free && !options.foldover_free_early) {
    // Once more with the untangling inside every interior solve, so that the release and the
    // boundary untangling start from an untangled interior: measured on the OpenCASCADE press
    // across its change, pairs 88 and 233 map only this way, pair 128 only the other way.
    MapOptions early = options;
    early.foldover_free_early = true;
    if (retry(early)) return true;
  }
  if (q.inverted > 0) {
    auto percent = [](double f) {
      char b[32];
      std::snprintf(b, sizeof b, "%g %%", 100 * f);
      return std::string(b);
    };
    // Tets with all four vertices on the boundary are fixed by the surface map alone: no
    // interior solve or untangling can repair them, so the message tells them apart.
    std::size_t surface_only = 0;
    for (std::size_t t = 0; t < canonical.tet_count(); ++t) {
      const std::uint32_t* c = &canonical.tets[4 * t];
      if (on_surface[c[0]] && on_surface[c[1]] && on_surface[c[2]] && on_surface[c[3]] &&
          tet_quality(out.vertices, std::vector<std::uint32_t>(c, c + 4)).inverted == 0)
        continue;
      if (on_surface[c[0]] && on_surface[c[1]] && on_surface[c[2]] && on_surface[c[3]])
        ++surface_only;
    }
    why = "mapping: the harmonic interior would invert or flatten " + std::to_string(q.inverted) +
          " of " + std::to_string(canonical.tet_count()) + " tets (" +
          std::to_string(surface_only) + " of them with all four vertices on the boundary" +
          (folded ? "; over " + percent(options.untangle_max_fraction) +
                        " of the tets: the surface map folds, no boundary untangling tried"
                  : std::string()) +
          ")";
    return false;
  }
  const TetLocator locator(source);
  out.fields = transfer_fields(source, canonical, out.vertices, on_surface, where, locator);
  return true;
}

}  // namespace cadinterp::mapping
