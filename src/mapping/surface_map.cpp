// The surface map (paper §6.2 (surface mapping)): every canonical boundary vertex gets a point of
// the source surface. Per patch, both sides onto one disk (mean_value_param.h), composed; the inner
// vertices then relaxed towards the canonical's own shape on the source, or a flat patch unfolded
// in its plane; each vertex's freedom recorded for the boundary untangling; the points placed in
// 3-D on the source's smooth reconstruction. Owns map_surface and the point helpers the later
// stages share (loop_point, disk_point, position_of, MappingState::place_point).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "mapping/foldover_free.h"
#include "mapping/mapping_state.h"
#include "mesh/surface_distance.h"

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

// In-patch relaxation (§6.2 (surface mapping)). Composing the two disk maps places a canonical
// vertex where the canonical's and the source's parametrizations agree, not where the canonical
// mesh's own spacing would put it on the source: on a curved face whose two samples are
// parametrized with different distortion, vertices slide within the face, triangles stretch along
// the curvature and their chords cut deeper into it (the bracket's Hausdorff at 1.01e-3 of its
// diagonal). Each sweep moves every inner vertex towards the mean-value-weighted average of its
// neighbours' mapped positions, with the weights of the canonical mesh (Floater 2003, the same
// weights as its disk map), so the fixed point is the canonical mesh's local shape laid onto the
// source. The 3-D step is taken in the source disk through the containing triangle's affine
// map (least squares), so every vertex stays exactly on the source surface; loop vertices stay
// fixed. Where both samples are flat and equal the canonical positions are already the fixed
// point (mean-value weights reproduce linear functions), so nothing moves. Jacobi sweeps in a
// fixed order: deterministic.
void relax_in_patch(const mesh::Sample& source, const mesh::Sample& canonical, const DiskMap& cd,
                    const DiskMap& sd, const DiskLocator& locator,
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

// Flat patches, and patches nearly so (§6.2 (surface mapping)). The composed disk maps are
// one-to-one in the disk, but a straight canonical triangle between three composed points is not
// the image of its disk triangle: where the source's disk map is far from linear across one
// canonical triangle (a wide face against a narrow strip of the same face: the OpenCASCADE press's
// plate beside fillets of 8.1 and 38.5 mm, 81 triangles folded, and every tet on them inverted
// whatever the interior does) those triangles fold. Where the source patch projects onto its mean
// plane without any triangle turning over, the projection is a chart in which the folds are removed
// directly: the patch's inner vertices move in the plane (untangle_foldover_free_planar, the
// canonical triangles' shapes as reference; loop vertices fixed) and are lifted back onto the
// source triangles through the chart. Writes each inner local vertex's surface point and
// source-disk coordinates; false where no such chart exists.
bool planar_placement(const mesh::Sample& source, const mesh::Sample& canonical, const DiskMap& cd,
                      const DiskMap& sd, const std::vector<std::size_t>& inner,
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

// The source positions of a patch's local vertices (cd's) at surface points `at`.
std::vector<double> positions(const mesh::Sample& source, const DiskMap& cd,
                              const std::vector<SurfacePoint>& at) {
  const std::size_t n = cd.vertices.size();
  std::vector<double> P(3 * n);
  for (std::size_t l = 0; l < n; ++l) position_of(source, at[l], &P[3 * l]);
  return P;
}

// The larger distance from a source patch vertex (sd's) to the mapped patch at `at`.
double gap(const mesh::Sample& source, const DiskMap& cd, const DiskMap& sd,
           const std::vector<SurfacePoint>& at) {
  const std::vector<double> P = positions(source, cd, at);
  const std::vector<std::uint32_t> F(cd.triangles.begin(), cd.triangles.end());
  const mesh::SurfaceIndex index(P, F);
  double d = 0;
  for (std::uint32_t v : sd.vertices)
    d = std::max(d, index.distance(source.vertices.data() + 3 * std::size_t(v)));
  return d;
}

// The patch's triangles whose mapped normal opposes the source's normal where they lie
// (the source triangle a vertex of theirs was placed in): folds of the surface map.
std::vector<std::size_t> folded(const mesh::Sample& source, const DiskMap& cd,
                                const std::vector<SurfacePoint>& at) {
  const std::vector<double> P = positions(source, cd, at);
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
    normal(&source.vertices[3 * std::size_t(in->v[0])], &source.vertices[3 * std::size_t(in->v[1])],
           &source.vertices[3 * std::size_t(in->v[2])], ns);
    if (nm[0] * ns[0] + nm[1] * ns[1] + nm[2] * ns[2] <= 0) folds.push_back(t);
  }
  return folds;
}

// Loop vertices of canonical patch pi: along the source loop at the same segment and fraction,
// each (but anchors) with its freedom along that loop.
void place_loop(MappingState& st, std::size_t pi, const LoopFrame& cf, const LoopFrame& sf) {
  const auto& cp = st.cp;
  const auto& sp = st.sp;
  const auto& source_of = st.source_of;
  const auto& can_anchor_of = st.can_anchor_of;
  auto& where = st.where;
  auto& assigned = st.assigned;
  auto& dofs = st.dofs;
  auto& dof_of = st.dof_of;
  const Patch& c = cp[pi];
  const Patch& s = sp[static_cast<std::size_t>(source_of[pi])];
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
    loop_dofs.push_back({i, dofs.size(), sf.origin + sf.rel[k], sf.origin + sf.rel[k] + sf.seg[k]});
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
}

// The in-patch relaxation (relax_in_patch) of a patch's inner local vertices, kept only where it
// folds no more triangles and brings the patch nearer to the source's (the larger distance from
// a source patch vertex to the mapped patch, the builder's vertex-sampled Hausdorff): it lowers
// the worst pairs but not every pair (cadinterp-mapping-report pairs --relax).
void relax_patch(MappingState& st, const DiskMap& cd, const DiskMap& sd, const DiskLocator& locator,
                 const std::vector<std::size_t>& inner, std::vector<double>& inner_uv) {
  const auto& source = st.source;
  const auto& canonical = st.canonical;
  const auto& options = st.options;
  auto& where = st.where;
  const std::size_t n = cd.vertices.size();
  std::vector<double> uv = cd.uv;
  relax_in_patch(source, canonical, cd, sd, locator, inner, where, options.relax_iterations, uv);
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
  const std::size_t folds_composed = folded(source, cd, composed).size();
  std::vector<std::size_t> f = folded(source, cd, relaxed);
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
    f = folded(source, cd, relaxed);
  }
  const std::size_t folds_relaxed = f.size();
  if (folds_relaxed < folds_composed ||
      (folds_relaxed == folds_composed &&
       gap(source, cd, sd, relaxed) < gap(source, cd, sd, composed))) {
    for (std::size_t l : inner) where[cd.vertices[l]] = relaxed[l];
    inner_uv = uv;
  }
}

// A patch still folded whose source projects onto a plane (planar_placement): unfolded there,
// kept when it folds fewer triangles.
void unfold_in_plane(MappingState& st, const DiskMap& cd, const DiskMap& sd,
                     const std::vector<std::size_t>& inner, std::vector<double>& inner_uv) {
  const auto& source = st.source;
  const auto& canonical = st.canonical;
  auto& where = st.where;
  auto& planar_patches = st.planar_patches;
  const std::size_t n = cd.vertices.size();
  std::vector<SurfacePoint> current(n), planar(n);
  for (std::size_t l = 0; l < n; ++l) current[l] = planar[l] = where[cd.vertices[l]];
  const std::size_t folds = folded(source, cd, current).size();
  std::vector<double> planar_uv = inner_uv;
  if (folds > 0 && planar_placement(source, canonical, cd, sd, inner, planar, planar_uv) &&
      folded(source, cd, planar).size() < folds) {
    for (std::size_t l : inner) where[cd.vertices[l]] = planar[l];
    inner_uv = std::move(planar_uv);
    ++planar_patches;
  }
}

// The inner vertices' freedom in their patch's source disk (those not already given one), with an
// initial step of half the size of the source disk triangle each lies in.
void inner_dofs(MappingState& st, std::size_t pi, const DiskMap& cd, const DiskMap& sd,
                const DiskLocator& locator, const std::vector<std::size_t>& inner,
                const std::vector<double>& inner_uv) {
  const auto& can_anchor_of = st.can_anchor_of;
  auto& dofs = st.dofs;
  auto& dof_of = st.dof_of;
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

// Canonical patch pi onto its source patch: its loop along the source loop, its inner vertices
// through the two disks.
bool map_patch(MappingState& st, std::size_t pi) {
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& cp = st.cp;
  const auto& sp = st.sp;
  const auto& source_of = st.source_of;
  const auto& options = st.options;
  auto& why = st.why;
  auto& assigned = st.assigned;
  auto& where = st.where;
  auto& source_disks = st.source_disks;
  auto& source_locators = st.source_locators;
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
  place_loop(st, pi, cf, sf);
  // Interior vertices of the patch (if any): through the disks.
  bool interior = false;
  for (int t : c.triangles)
    for (int k = 0; k < 3 && !interior; ++k) interior = !assigned[cs.from(3 * t + k)];
  if (!interior) return true;
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
  if (options.relax_iterations > 0 && !inner.empty())
    relax_patch(st, cd, sd, locator, inner, inner_uv);
  if (options.planar_patches && !inner.empty()) unfold_in_plane(st, cd, sd, inner, inner_uv);
  inner_dofs(st, pi, cd, sd, locator, inner, inner_uv);
  return true;
}

}  // namespace

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
                        int* triangle) {
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

void MappingState::place_point(const SurfacePoint& pt, double* x) const {
  if (smooth)
    smooth->position(pt, x);
  else
    position_of(source, pt, x);
}

// §6.2 (surface mapping): per patch, both sides onto one disk; every canonical surface vertex gets
// a point of the source surface, and its position in 3-D.
bool map_surface(MappingState& st) {
  const auto& source = st.source;
  const auto& canonical = st.canonical;
  const auto& options = st.options;
  const auto& cp = st.cp;
  auto& out = st.out;
  auto& why = st.why;
  auto& V = st.V;
  auto& on_surface = st.on_surface;
  auto& assigned = st.assigned;
  auto& where = st.where;
  auto& dof_of = st.dof_of;
  auto& source_disks = st.source_disks;
  auto& source_locators = st.source_locators;
  auto& smooth = st.smooth;
  V = canonical.vertex_count();
  on_surface.assign(V, 0);
  assigned.assign(V, 0);
  for (std::uint32_t v : canonical.triangles) on_surface[v] = 1;
  where.assign(V, SurfacePoint());
  dof_of.assign(V, -1);
  source_disks.resize(cp.size());
  source_locators.resize(cp.size());
  for (std::size_t pi = 0; pi < cp.size(); ++pi)
    if (!map_patch(st, pi)) return false;
  // The 3-D position of a surface point: on the source's smooth reconstruction per B-rep face
  // (smooth_surface.h; the mapped boundary then follows curved faces instead of the source's
  // chords: on 10 OpenCASCADE wrench pairs the Hausdorff max is 6.4e-4 on it, 1.04e-3 on the
  // flat triangles), or on its flat triangles. The weights `where` (the field transfer's) are
  // the same either way.
  if (options.smooth_alpha > 0)
    smooth = std::make_unique<SmoothSurface>(source, options.smooth_alpha);
  out.vertices = canonical.vertices;
  for (std::size_t v = 0; v < V; ++v) {
    if (!on_surface[v]) continue;
    if (!assigned[v]) {
      why = "mapping: canonical boundary vertex " + std::to_string(v) + " lies in no patch";
      return false;
    }
    st.place_point(where[v], &out.vertices[3 * v]);
  }
  return true;
}

}  // namespace cadinterp::mapping
