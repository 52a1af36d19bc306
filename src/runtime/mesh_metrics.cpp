// Mass properties from the exact polynomial integrals over each tet, surface and frontal area
// from the triangle area vectors, and their hand-derived adjoints. Derivations are inline.
#include "runtime/mesh_metrics.h"

#include <cmath>
#include <limits>

namespace cadinterp::runtime {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Vec3 {
  double x, y, z;
};
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// Symmetric 3x3 matrix by its six distinct entries.
struct Sym3 {
  double xx, yy, zz, xy, yz, zx;
};
inline void add_outer(Sym3& m, double w, Vec3 a) {
  m.xx += w * a.x * a.x;
  m.yy += w * a.y * a.y;
  m.zz += w * a.z * a.z;
  m.xy += w * a.x * a.y;
  m.yz += w * a.y * a.z;
  m.zx += w * a.z * a.x;
}
inline void add_scaled(Sym3& m, double w, const Sym3& b) {  // m += w b
  m.xx += w * b.xx;
  m.yy += w * b.yy;
  m.zz += w * b.zz;
  m.xy += w * b.xy;
  m.yz += w * b.yz;
  m.zx += w * b.zx;
}
inline Vec3 mul(const Sym3& m, Vec3 a) {
  return {m.xx * a.x + m.xy * a.y + m.zx * a.z, m.xy * a.x + m.yy * a.y + m.yz * a.z,
          m.zx * a.x + m.yz * a.y + m.zz * a.z};
}

inline Vec3 load(const float* V, std::uint32_t i) {
  const float* p = V + 3 * static_cast<std::size_t>(i);
  return {static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2])};
}
inline void accumulate(double* dV, std::uint32_t i, Vec3 g) {
  double* p = dV + 3 * static_cast<std::size_t>(i);
  p[0] += g.x;
  p[1] += g.y;
  p[2] += g.z;
}

inline double finite_or_nan(double v) { return std::isfinite(v) ? v : kNaN; }

// sign(v) with sign(0) = 0 (the subgradient choice at a silhouette face) and sign(NaN) = NaN.
inline double sign_or_nan(double v) {
  if (v > 0.0) return 1.0;
  if (v < 0.0) return -1.0;
  return v == 0.0 ? 0.0 : kNaN;
}

// Moments are taken about p0, the first vertex of the first tet, not about the origin. In exact
// arithmetic nothing depends on the choice (p0 is a constant of the computation, also for the
// adjoint); in floating point a point of the mesh keeps the central second moment
// M2 - M1 M1^T / M0 free of the cancellation that moments about the origin suffer when the
// mesh sits far from it (|p0 - centroid|^2 / radius_of_gyration^2 digits are lost, not
// |centroid|^2 / radius_of_gyration^2).
inline Vec3 reference_point(const TetMeshView& mesh) { return load(mesh.V, mesh.T[0]); }

bool any_nonzero(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (v[i] != 0.0) return true;
  return false;
}

// Adjoint of the tet pass. For one tet with vertices q_i = x_i - p0, v6 = det[q1-q0, q2-q0,
// q3-q0] and s = q0+q1+q2+q3 its exact moments are (the last one is the standard closed form of
// integral x x^T over a tet, e.g. Tonon 2004):
//   m0 = v6/6,   m1 = v6 s/24,   m2 = v6 (sum_i q_i q_i^T + s s^T)/120.
// With adjoints (w0, w1, G) of the summed moments (G symmetric), the tet contributes
//   L = v6 * f,  f = w0/6 + w1.s/24 + (sum_i q_i^T G q_i + s^T G s)/120,
//   dL/dq_i = f dv6/dq_i + v6 (w1/24 + G (q_i + s)/60),
// with dv6/dq1 = e2 x e3, dv6/dq2 = e3 x e1, dv6/dq3 = e1 x e2, dv6/dq0 = -(their sum),
// e_k = q_k - q0.
template <bool kSecondMoment>
void tet_pass_vjp(const TetMeshView& mesh, Vec3 p0, double w0, Vec3 w1, const Sym3& G, double* dV) {
  const float* V = mesh.V;
  for (std::size_t t = 0; t < mesh.num_tets; ++t) {
    const std::uint32_t* tet = mesh.T + 4 * t;
    const Vec3 q0 = load(V, tet[0]) - p0, q1 = load(V, tet[1]) - p0;
    const Vec3 q2 = load(V, tet[2]) - p0, q3 = load(V, tet[3]) - p0;
    const Vec3 e1 = q1 - q0, e2 = q2 - q0, e3 = q3 - q0;
    const Vec3 c1 = cross(e2, e3), c2 = cross(e3, e1), c3 = cross(e1, e2);
    const double v6 = dot(e1, c1);
    const Vec3 s = q0 + q1 + q2 + q3;
    double f = w0 / 6.0 + dot(w1, s) / 24.0;
    Vec3 common = (v6 / 24.0) * w1;
    Vec3 g0{0, 0, 0}, g1{0, 0, 0}, g2{0, 0, 0}, g3{0, 0, 0};
    if constexpr (kSecondMoment) {
      const Vec3 gs = mul(G, s);
      g0 = mul(G, q0);
      g1 = mul(G, q1);
      g2 = mul(G, q2);
      g3 = mul(G, q3);
      f += (dot(q0, g0) + dot(q1, g1) + dot(q2, g2) + dot(q3, g3) + dot(s, gs)) / 120.0;
      const double k = v6 / 60.0;
      common = common + k * gs;
      g0 = k * g0;
      g1 = k * g1;
      g2 = k * g2;
      g3 = k * g3;
    }
    accumulate(dV, tet[0], common + g0 - f * (c1 + c2 + c3));
    accumulate(dV, tet[1], common + g1 + f * c1);
    accumulate(dV, tet[2], common + g2 + f * c2);
    accumulate(dV, tet[3], common + g3 + f * c3);
  }
}

}  // namespace

MassProperties mass_properties(const TetMeshView& mesh, const MassPropertiesOptions& opt) {
  MassProperties out;
  const double rho = opt.density;

  if (mesh.num_tets > 0) {
    const Vec3 p0 = reference_point(mesh);
    // Accumulators in units that keep the loop free of constant factors:
    // a0 = 6 M0, a1 = 24 M1, a2 = 120 M2 (moments about p0, see tet_pass_vjp).
    double a0 = 0.0;
    Vec3 a1{0, 0, 0};
    Sym3 a2{0, 0, 0, 0, 0, 0};
    for (std::size_t t = 0; t < mesh.num_tets; ++t) {
      const std::uint32_t* tet = mesh.T + 4 * t;
      const Vec3 q0 = load(mesh.V, tet[0]) - p0, q1 = load(mesh.V, tet[1]) - p0;
      const Vec3 q2 = load(mesh.V, tet[2]) - p0, q3 = load(mesh.V, tet[3]) - p0;
      const double v6 = dot(q1 - q0, cross(q2 - q0, q3 - q0));
      const Vec3 s = q0 + q1 + q2 + q3;
      // The tet's own sum first, then one add per accumulator: the loop-carried dependency is
      // one addition per tet, not five.
      Sym3 m2{0, 0, 0, 0, 0, 0};
      add_outer(m2, 1.0, q0);
      add_outer(m2, 1.0, q1);
      add_outer(m2, 1.0, q2);
      add_outer(m2, 1.0, q3);
      add_outer(m2, 1.0, s);
      a0 += v6;
      a1 = a1 + v6 * s;
      add_scaled(a2, v6, m2);
    }
    const double vol = a0 / 6.0;
    out.volume = vol;
    out.mass = rho * vol;
    if (vol != 0.0) {
      // c = M1 / M0 relative to p0; central second moment C = M2 - M0 c c^T.
      const Vec3 c = (1.0 / (24.0 * vol)) * a1;
      Sym3 C{a2.xx / 120.0, a2.yy / 120.0, a2.zz / 120.0,
             a2.xy / 120.0, a2.yz / 120.0, a2.zx / 120.0};
      add_outer(C, -vol, c);
      // inertia = rho (tr(C) Id - C), the diagonal summed directly rather than as tr - C_ii.
      double* I = out.inertia;
      I[0] = rho * (C.yy + C.zz);
      I[4] = rho * (C.zz + C.xx);
      I[8] = rho * (C.xx + C.yy);
      I[1] = I[3] = -rho * C.xy;
      I[5] = I[7] = -rho * C.yz;
      I[2] = I[6] = -rho * C.zx;
      out.centroid[0] = p0.x + c.x;
      out.centroid[1] = p0.y + c.y;
      out.centroid[2] = p0.z + c.z;
    } else {
      for (double& v : out.centroid) v = kNaN;
      for (double& v : out.inertia) v = kNaN;
    }
  }

  if (mesh.num_faces > 0) {
    const Vec3 d{opt.direction[0], opt.direction[1], opt.direction[2]};
    double area = 0.0, frontal = 0.0;
    for (std::size_t f = 0; f < mesh.num_faces; ++f) {
      const std::uint32_t* tri = mesh.F + 3 * f;
      const Vec3 x0 = load(mesh.V, tri[0]);
      // Area vector a = n A = (x1 - x0) x (x2 - x0) / 2.
      const Vec3 a = 0.5 * cross(load(mesh.V, tri[1]) - x0, load(mesh.V, tri[2]) - x0);
      area += std::sqrt(dot(a, a));
      frontal += std::fabs(dot(a, d));
    }
    out.area = area;
    out.frontal_area = 0.5 * frontal;
  }

  out.volume = finite_or_nan(out.volume);
  out.mass = finite_or_nan(out.mass);
  out.area = finite_or_nan(out.area);
  out.frontal_area = finite_or_nan(out.frontal_area);
  for (double& v : out.centroid) v = finite_or_nan(v);
  for (double& v : out.inertia) v = finite_or_nan(v);
  return out;
}

void mass_properties_vjp(const TetMeshView& mesh, const MassPropertiesOptions& opt,
                         const MassProperties& props, const MassPropertiesBar& bar, double* dV) {
  const double rho = opt.density;
  const bool want_centroid = any_nonzero(bar.centroid, 3);
  const bool want_inertia = any_nonzero(bar.inertia, 9);

  if (mesh.num_tets > 0 &&
      (bar.volume != 0.0 || bar.mass != 0.0 || want_centroid || want_inertia)) {
    const Vec3 p0 = reference_point(mesh);
    const double vol = props.volume;
    // Adjoints of the summed moments M0, M1, M2 (about p0). Terms are added only for outputs
    // with a nonzero bar, so a NaN that only an unrequested output carries (e.g. the centroid of
    // a zero-volume mesh) does not leak into the gradient of the requested ones.
    double w0 = bar.volume + (bar.mass != 0.0 ? rho * bar.mass : 0.0);
    Vec3 w1{0, 0, 0};
    Sym3 G{0, 0, 0, 0, 0, 0};
    const Vec3 c = Vec3{props.centroid[0], props.centroid[1], props.centroid[2]} - p0;
    const double inv_vol = vol != 0.0 ? 1.0 / vol : kNaN;
    if (want_centroid) {
      // centroid = p0 + M1 / M0.
      const Vec3 cb{bar.centroid[0], bar.centroid[1], bar.centroid[2]};
      w1 = w1 + inv_vol * cb;
      w0 -= dot(cb, c) * inv_vol;
    }
    if (want_inertia) {
      // inertia = rho (tr(C) Id - C): d/dC = rho (tr(Ib) Id - Ib), symmetrized because C is.
      const double* Ib = bar.inertia;
      const double tr = Ib[0] + Ib[4] + Ib[8];
      G = Sym3{rho * (tr - Ib[0]),           rho * (tr - Ib[4]),
               rho * (tr - Ib[8]),           -0.5 * rho * (Ib[1] + Ib[3]),
               -0.5 * rho * (Ib[5] + Ib[7]), -0.5 * rho * (Ib[2] + Ib[6])};
      // C = M2 - M1 M1^T / M0: dC/dM2 = Id, dM1 = -2 G c, dM0 = c^T G c.
      w1 = w1 - 2.0 * mul(G, c);
      w0 += dot(c, mul(G, c));
      tet_pass_vjp<true>(mesh, p0, w0, w1, G, dV);
    } else {
      tet_pass_vjp<false>(mesh, p0, w0, w1, G, dV);
    }
  }

  if (mesh.num_faces > 0 && (bar.area != 0.0 || bar.frontal_area != 0.0)) {
    const Vec3 d{opt.direction[0], opt.direction[1], opt.direction[2]};
    for (std::size_t f = 0; f < mesh.num_faces; ++f) {
      const std::uint32_t* tri = mesh.F + 3 * f;
      const Vec3 x0 = load(mesh.V, tri[0]), x1 = load(mesh.V, tri[1]), x2 = load(mesh.V, tri[2]);
      const Vec3 a = 0.5 * cross(x1 - x0, x2 - x0);
      // g = dL/da: area = |a|, frontal = 0.5 |a . d|.
      Vec3 g{0, 0, 0};
      if (bar.area != 0.0) {
        const double len = std::sqrt(dot(a, a));
        if (len != 0.0) g = (bar.area / len) * a;  // NaN len falls through to NaN
      }
      if (bar.frontal_area != 0.0) g = g + (0.5 * bar.frontal_area * sign_or_nan(dot(a, d))) * d;
      // a = (x0 x x1 + x1 x x2 + x2 x x0) / 2, so d(g.a)/dx0 = (x1 - x2) x g / 2, cyclically.
      accumulate(dV, tri[0], 0.5 * cross(x1 - x2, g));
      accumulate(dV, tri[1], 0.5 * cross(x2 - x0, g));
      accumulate(dV, tri[2], 0.5 * cross(x0 - x1, g));
    }
  }
}

}  // namespace cadinterp::runtime
