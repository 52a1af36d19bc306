// mass_properties(): exact values on a tet, a cube (5 and 6 tets), a transformed box; convergence
// on a tet-meshed ball; every gradient against central differences; invariances; NaN and empty
// inputs.
#include "runtime/mesh_metrics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

namespace cadinterp::runtime {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Mesh {
  std::vector<float> V;          // #V by 3
  std::vector<std::uint32_t> T;  // #T by 4
  std::vector<std::uint32_t> F;  // #F by 3
  TetMeshView view() const {
    return TetMeshView{V.data(), V.size() / 3, T.data(), T.size() / 4, F.data(), F.size() / 3};
  }
};

using D3 = std::array<double, 3>;

D3 vertex(const Mesh& m, std::uint32_t i) {
  const float* p = &m.V[3 * static_cast<std::size_t>(i)];
  return {p[0], p[1], p[2]};
}

double signed_volume6(const Mesh& m, const std::uint32_t* t) {
  const D3 a = vertex(m, t[0]), b = vertex(m, t[1]), c = vertex(m, t[2]), d = vertex(m, t[3]);
  const D3 e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const D3 e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const D3 e3{d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  return e1[0] * (e2[1] * e3[2] - e2[2] * e3[1]) - e1[1] * (e2[0] * e3[2] - e2[2] * e3[0]) +
         e1[2] * (e2[0] * e3[1] - e2[1] * e3[0]);
}

// Orients every tet positively and sets F to the faces used by exactly one tet, outward.
void orient_and_extract_boundary(Mesh& m) {
  std::map<std::array<std::uint32_t, 3>, std::pair<int, std::array<std::uint32_t, 3>>> faces;
  for (std::size_t t = 0; t < m.T.size() / 4; ++t) {
    std::uint32_t* tet = &m.T[4 * t];
    if (signed_volume6(m, tet) < 0) std::swap(tet[2], tet[3]);
    const std::uint32_t a = tet[0], b = tet[1], c = tet[2], d = tet[3];
    // Outward faces of a positive tet (a, b, c, d).
    for (const std::array<std::uint32_t, 3>& f :
         {std::array<std::uint32_t, 3>{b, c, d}, std::array<std::uint32_t, 3>{a, d, c},
          std::array<std::uint32_t, 3>{a, b, d}, std::array<std::uint32_t, 3>{a, c, b}}) {
      std::array<std::uint32_t, 3> key = f;
      std::sort(key.begin(), key.end());
      auto& entry = faces[key];
      ++entry.first;
      entry.second = f;
    }
  }
  m.F.clear();
  for (const auto& kv : faces)
    if (kv.second.first == 1)
      m.F.insert(m.F.end(), kv.second.second.begin(), kv.second.second.end());
}

// n^3 cubes over [0,1]^3, each split into the 6 tets of the Kuhn (Freudenthal) subdivision
// along its main diagonal, which is conforming across cubes.
Mesh kuhn_grid(int n) {
  Mesh m;
  const auto id = [n](int i, int j, int k) {
    return static_cast<std::uint32_t>((k * (n + 1) + j) * (n + 1) + i);
  };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        m.V.push_back(static_cast<float>(i) / static_cast<float>(n));
        m.V.push_back(static_cast<float>(j) / static_cast<float>(n));
        m.V.push_back(static_cast<float>(k) / static_cast<float>(n));
      }
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          m.T.push_back(id(c[0], c[1], c[2]));
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            m.T.push_back(id(c[0], c[1], c[2]));
          }
        }
  orient_and_extract_boundary(m);
  return m;
}

// The unit cube as 5 tets: one per even corner and the regular central tet.
Mesh cube5() {
  Mesh m;
  for (int v = 0; v < 8; ++v) {
    m.V.push_back(static_cast<float>(v & 1));
    m.V.push_back(static_cast<float>((v >> 1) & 1));
    m.V.push_back(static_cast<float>((v >> 2) & 1));
  }
  m.T = {0, 1, 2, 4, 3, 1, 2, 7, 5, 1, 4, 7, 6, 2, 4, 7, 1, 2, 4, 7};
  orient_and_extract_boundary(m);
  return m;
}

// Kuhn grid of [-1,1]^3 pushed radially onto the unit ball: x -> x |x|_inf / |x|_2. Boundary
// vertices land on the sphere; interior vertices stay interior.
Mesh ball(int n) {
  Mesh m = kuhn_grid(n);
  for (std::size_t i = 0; i < m.V.size(); i += 3) {
    double x[3];
    double inf = 0.0, two = 0.0;
    for (int d = 0; d < 3; ++d) {
      x[d] = 2.0 * m.V[i + d] - 1.0;
      inf = std::max(inf, std::fabs(x[d]));
      two += x[d] * x[d];
    }
    const double s = two > 0.0 ? inf / std::sqrt(two) : 0.0;
    for (int d = 0; d < 3; ++d) m.V[i + d] = static_cast<float>(x[d] * s);
  }
  return m;
}

void apply_affine(Mesh& m, const double A[9], const double t[3]) {
  for (std::size_t i = 0; i < m.V.size(); i += 3) {
    const double x[3] = {m.V[i], m.V[i + 1], m.V[i + 2]};
    for (int r = 0; r < 3; ++r)
      m.V[i + r] =
          static_cast<float>(A[3 * r] * x[0] + A[3 * r + 1] * x[1] + A[3 * r + 2] * x[2] + t[r]);
  }
}

// Rotation about a (normalized) axis by angle, row-major.
void rotation(const double axis[3], double angle, double R[9]) {
  const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  const double x = axis[0] / n, y = axis[1] / n, z = axis[2] / n;
  const double c = std::cos(angle), s = std::sin(angle), C = 1 - c;
  const double r[9] = {c + x * x * C,     x * y * C - z * s, x * z * C + y * s,
                       y * x * C + z * s, c + y * y * C,     y * z * C - x * s,
                       z * x * C - y * s, z * y * C + x * s, c + z * z * C};
  std::copy(r, r + 9, R);
}

bool all_positive(const Mesh& m) {
  for (std::size_t t = 0; t < m.T.size() / 4; ++t)
    if (!(signed_volume6(m, &m.T[4 * t]) > 0)) return false;
  return true;
}

MassPropertiesOptions options(double density, double dx, double dy, double dz) {
  MassPropertiesOptions o;
  o.density = density;
  const double n = std::sqrt(dx * dx + dy * dy + dz * dz);
  o.direction[0] = dx / n;
  o.direction[1] = dy / n;
  o.direction[2] = dz / n;
  return o;
}

double frontal(const Mesh& m, double dx, double dy, double dz) {
  return mass_properties(m.view(), options(1.0, dx, dy, dz)).frontal_area;
}

void expect_rel(double got, double want, double rel, const char* what) {
  EXPECT_LE(std::fabs(got - want), rel * std::max(1.0, std::fabs(want)))
      << what << ": got " << got << " want " << want;
}

// ---------------------------------------------------------------------------------------------

TEST(MassProperties, SingleTetExact) {
  // x, y, z >= 0, x + y + z <= 1. Monomial integrals over it: int x^a y^b z^c =
  // a! b! c! / (a + b + c + 3)!, so int x^2 = 1/60, int xy = 1/120, V = 1/6, centroid 1/4.
  // Central: C_xx = 1/60 - (1/6)(1/16) = 1/160, C_xy = 1/120 - 1/96 = -1/480.
  // I_xx = C_yy + C_zz = 1/80, I_xy = -C_xy = 1/480.
  Mesh m;
  m.V = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.T = {0, 1, 2, 3};
  orient_and_extract_boundary(m);
  ASSERT_EQ(m.F.size(), 12u);
  const double rho = 3.0;
  const MassProperties p = mass_properties(m.view(), options(rho, 1, 0, 0));
  EXPECT_NEAR(p.volume, 1.0 / 6.0, 1e-16);
  EXPECT_NEAR(p.mass, rho / 6.0, 1e-15);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(p.centroid[d], 0.25, 1e-16);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(p.inertia[3 * r + c], rho * (r == c ? 1.0 / 80.0 : 1.0 / 480.0), 1e-16) << r << c;
  EXPECT_NEAR(p.area, 1.5 + std::sqrt(3.0) / 2.0, 1e-15);
  // Along x: the x = 0 face (1/2) seen from behind, the slanted face (sqrt(3)/2, n_x = 1/sqrt 3).
  EXPECT_NEAR(p.frontal_area, 0.5, 1e-15);
  // Along (1,1,1): the silhouette is the slanted face itself.
  EXPECT_NEAR(frontal(m, 1, 1, 1), std::sqrt(3.0) / 2.0, 1e-15);
  EXPECT_NEAR(frontal(m, -1, -1, -1), std::sqrt(3.0) / 2.0, 1e-15);
}

void expect_unit_cube(const Mesh& m) {
  const double rho = 2.5;
  const MassProperties p = mass_properties(m.view(), options(rho, 0, 0, 1));
  EXPECT_NEAR(p.volume, 1.0, 1e-15);
  EXPECT_NEAR(p.mass, rho, 1e-15);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(p.centroid[d], 0.5, 1e-15);
  // Box a x b x c: I_xx = m (b^2 + c^2) / 12.
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(p.inertia[3 * r + c], r == c ? rho / 6.0 : 0.0, 1e-15) << r << c;
  EXPECT_NEAR(p.area, 6.0, 1e-14);
  EXPECT_NEAR(p.frontal_area, 1.0, 1e-15);
  EXPECT_NEAR(frontal(m, 1, 0, 0), 1.0, 1e-15);
  EXPECT_NEAR(frontal(m, 0, -1, 0), 1.0, 1e-15);
  EXPECT_NEAR(frontal(m, 1, 1, 1), std::sqrt(3.0), 1e-14);
  EXPECT_NEAR(frontal(m, 1, -1, 0), std::sqrt(2.0), 1e-14);
}

TEST(MassProperties, UnitCubeSixTets) {
  const Mesh m = kuhn_grid(1);
  ASSERT_EQ(m.T.size(), 24u);
  ASSERT_EQ(m.F.size(), 36u);
  expect_unit_cube(m);
}

TEST(MassProperties, UnitCubeFiveTets) {
  const Mesh m = cube5();
  ASSERT_EQ(m.T.size(), 20u);
  ASSERT_EQ(m.F.size(), 36u);
  expect_unit_cube(m);
}

TEST(MassProperties, TransformedBoxMatchesClosedForm) {
  // Box [0,a] x [0,b] x [0,c] (a scaled 2x2x2 Kuhn grid), rotated by R and translated by t.
  const double a = 2.0, b = 0.5, c = 1.25, rho = 7.8;
  const double axis[3] = {1.0, 2.0, -0.5};
  double R[9];
  rotation(axis, 0.7, R);
  const double t[3] = {3.0, -2.0, 1.5};
  Mesh m = kuhn_grid(2);
  const double S[9] = {a, 0, 0, 0, b, 0, 0, 0, c}, zero[3] = {0, 0, 0};
  apply_affine(m, S, zero);
  apply_affine(m, R, t);
  ASSERT_TRUE(all_positive(m));

  const double mass = rho * a * b * c;
  const double Ibody[3] = {mass * (b * b + c * c) / 12, mass * (a * a + c * c) / 12,
                           mass * (a * a + b * b) / 12};
  const double half[3] = {a / 2, b / 2, c / 2};
  const double face_area[3] = {b * c, a * c, a * b};  // faces normal to body x, y, z
  // Float positions up to ~4 carry up to 2.4e-7 absolute rounding, ~5e-7 relative to the
  // 0.5 side; a formula error would be O(1).
  const double tol = 2e-6;

  const double dirs[5][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {R[0], R[3], R[6]}};
  for (const auto& dv : dirs) {
    const MassPropertiesOptions o = options(rho, dv[0], dv[1], dv[2]);
    const MassProperties p = mass_properties(m.view(), o);
    expect_rel(p.volume, a * b * c, tol, "volume");
    expect_rel(p.mass, mass, tol, "mass");
    for (int r = 0; r < 3; ++r) {
      const double want =
          t[r] + R[3 * r] * half[0] + R[3 * r + 1] * half[1] + R[3 * r + 2] * half[2];
      expect_rel(p.centroid[r], want, tol, "centroid");
    }
    // I = R diag(Ibody) R^T.
    for (int r = 0; r < 3; ++r)
      for (int s = 0; s < 3; ++s) {
        double want = 0;
        for (int k = 0; k < 3; ++k) want += R[3 * r + k] * Ibody[k] * R[3 * s + k];
        EXPECT_NEAR(p.inertia[3 * r + s], want, tol * Ibody[1]) << r << s;
      }
    expect_rel(p.area, 2 * (a * b + b * c + c * a), tol, "area");
    // Silhouette of a box along d: sum over the 3 face pairs of A_k |(R e_k) . d|.
    double want_frontal = 0;
    for (int k = 0; k < 3; ++k)
      want_frontal += face_area[k] * std::fabs(R[k] * o.direction[0] + R[3 + k] * o.direction[1] +
                                               R[6 + k] * o.direction[2]);
    expect_rel(p.frontal_area, want_frontal, tol, "frontal");
  }
  // Along the body x axis the silhouette is the b x c face.
  EXPECT_NEAR(frontal(m, R[0], R[3], R[6]), b * c, tol * b * c);
}

// Signed convention: reversing every tet negates volume, mass and inertia, keeps the centroid.
TEST(MassProperties, InvertedOrientationIsSigned) {
  Mesh m = kuhn_grid(2);
  const MassProperties p = mass_properties(m.view(), options(1, 0, 0, 1));
  for (std::size_t t = 0; t < m.T.size(); t += 4) std::swap(m.T[t + 2], m.T[t + 3]);
  const MassProperties q = mass_properties(m.view(), options(1, 0, 0, 1));
  EXPECT_NEAR(q.volume, -p.volume, 1e-15);
  EXPECT_NEAR(q.mass, -p.mass, 1e-15);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(q.centroid[d], p.centroid[d], 1e-15);
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(q.inertia[k], -p.inertia[k], 1e-15);
}

// Second-order convergence on the ball: the mesh is the piecewise-linear interpolant of the
// ball with boundary vertices on the sphere, so every quantity errs by O(h^2).
TEST(MassProperties, BallConvergesAtSecondOrder) {
  const double rho = 1.0;
  const double V = 4.0 * kPi / 3.0, I = 0.4 * rho * V, A = 4.0 * kPi, Fr = kPi;
  const int levels[] = {4, 8, 16, 32};
  constexpr int kQ = 5;
  const char* names[kQ] = {"volume", "inertia_xx", "inertia_xy", "area", "frontal_z"};
  double err[4][kQ];
  for (int l = 0; l < 4; ++l) {
    const Mesh m = ball(levels[l]);
    ASSERT_TRUE(all_positive(m)) << levels[l];
    const MassProperties p = mass_properties(m.view(), options(rho, 0, 0, 1));
    // The Kuhn grid is symmetric under x -> -x (all axes at once) and under axis permutations,
    // so the centroid is 0 and the diagonal of the inertia is isotropic, up to rounding. It is
    // not symmetric under single-axis reflections: the products of inertia are discretization
    // error and converge like the rest.
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(p.centroid[d], 0.0, 1e-6);
    EXPECT_NEAR(p.inertia[4], p.inertia[0], 1e-6);
    EXPECT_NEAR(p.inertia[8], p.inertia[0], 1e-6);
    err[l][0] = std::fabs(p.volume - V) / V;
    err[l][1] = std::fabs(p.inertia[0] - I) / I;
    err[l][2] = std::fabs(p.inertia[1]) / I;
    err[l][3] = std::fabs(p.area - A) / A;
    err[l][4] = std::fabs(p.frontal_area - Fr) / Fr;
  }
  for (int q = 0; q < kQ; ++q) {
    std::string line = std::string(names[q]) + " rel.err:";
    for (int l = 0; l < 4; ++l) {
      char buf[64];
      std::snprintf(buf, sizeof buf, " n=%d %.3e", levels[l], err[l][q]);
      line += buf;
    }
    line += "  rates:";
    for (int l = 1; l < 4; ++l) {
      const double rate = std::log2(err[l - 1][q] / err[l][q]);
      char buf[32];
      std::snprintf(buf, sizeof buf, " %.3f", rate);
      line += buf;
      if (l >= 2) {
        EXPECT_GT(rate, 1.8) << names[q] << " at n=" << levels[l];
        EXPECT_LT(rate, 2.2) << names[q] << " at n=" << levels[l];
      }
    }
    std::printf("%s\n", line.c_str());
    RecordProperty(std::string("convergence_") + names[q], line);
  }
}

// ---------------------------------------------------------------------------------------------
// Gradients.

// A perturbed, scaled and translated n^3 Kuhn grid with positions on a 2^-16 grid below 2^3 in
// magnitude, so x +- 2^-12 is exactly representable in float and central differences are taken
// at exactly the intended points.
Mesh perturbed_grid(int n, std::uint64_t seed) {
  Mesh m = kuhn_grid(n);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-0.06, 0.06);
  const double scale[3] = {1.5, 1.0, 0.75}, shift[3] = {3.0, -2.0, 1.0};
  for (std::size_t i = 0; i < m.V.size(); ++i) {
    const double x = (m.V[i] + u(rng) / n) * scale[i % 3] + shift[i % 3];
    m.V[i] = static_cast<float>(std::ldexp(std::round(std::ldexp(x, 16)), -16));
  }
  return m;
}

double objective(const Mesh& m, const MassPropertiesOptions& o, const MassPropertiesBar& bar) {
  const MassProperties p = mass_properties(m.view(), o);
  double L = bar.volume * p.volume + bar.mass * p.mass + bar.area * p.area +
             bar.frontal_area * p.frontal_area;
  for (int d = 0; d < 3; ++d) L += bar.centroid[d] * p.centroid[d];
  for (int k = 0; k < 9; ++k) L += bar.inertia[k] * p.inertia[k];
  return L;
}

std::vector<double> vjp(const Mesh& m, const MassPropertiesOptions& o,
                        const MassPropertiesBar& bar) {
  std::vector<double> dV(m.V.size(), 0.0);
  mass_properties_vjp(m.view(), o, mass_properties(m.view(), o), bar, dV.data());
  return dV;
}

void expect_matches_central_differences(Mesh m, const MassPropertiesOptions& o,
                                        const MassPropertiesBar& bar, const std::string& what) {
  const std::vector<double> g = vjp(m, o, bar);
  // Truncation error of the central difference is h^2/6 |f'''|; for the area of the smallest
  // faces here that is ~1e-6 of the gradient at h = 2^-10, ~1e-7 at 2^-12. Rounding adds
  // ~1e-16 |L| / h, negligible.
  const double h = std::ldexp(1.0, -12);
  double scale = 0.0;
  for (double v : g) scale = std::max(scale, std::fabs(v));
  ASSERT_GT(scale, 0.0) << what;
  double worst = 0.0;
  for (std::size_t i = 0; i < m.V.size(); ++i) {
    const float x = m.V[i];
    m.V[i] = static_cast<float>(x + h);
    ASSERT_EQ(static_cast<double>(m.V[i]), static_cast<double>(x) + h);
    const double Lp = objective(m, o, bar);
    m.V[i] = static_cast<float>(x - h);
    const double Lm = objective(m, o, bar);
    m.V[i] = x;
    const double fd = (Lp - Lm) / (2 * h);
    worst = std::max(worst, std::fabs(fd - g[i]) / scale);
    EXPECT_NEAR(g[i], fd, 1e-6 * scale) << what << " coordinate " << i;
  }
  ::testing::Test::RecordProperty("fd_worst_rel_" + what, std::to_string(worst));
  std::printf("%-14s worst |fd - vjp| / max|vjp| = %.2e\n", what.c_str(), worst);
}

TEST(MassPropertiesGradient, EveryOutputMatchesCentralDifferences) {
  const Mesh m = perturbed_grid(2, 7);
  ASSERT_TRUE(all_positive(m));
  const MassPropertiesOptions o = options(2.7, 0.3, -0.5, 0.8);
  for (int k = 0; k < 16; ++k) {
    MassPropertiesBar bar;
    std::string what;
    if (k == 0) bar.volume = 1, what = "volume";
    if (k == 1) bar.mass = 1, what = "mass";
    if (k == 2) bar.area = 1, what = "area";
    if (k == 3) bar.frontal_area = 1, what = "frontal_area";
    if (k >= 4 && k < 7) bar.centroid[k - 4] = 1, what = "centroid" + std::to_string(k - 4);
    if (k >= 7) bar.inertia[k - 7] = 1, what = "inertia" + std::to_string(k - 7);
    expect_matches_central_differences(m, o, bar, what);
  }
}

TEST(MassPropertiesGradient, RandomAdjointMatchesCentralDifferences) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> nd;
  for (int trial = 0; trial < 3; ++trial) {
    const Mesh m = perturbed_grid(2 + trial, 100 + static_cast<std::uint64_t>(trial));
    ASSERT_TRUE(all_positive(m));
    // Direction components of magnitude >= 0.3 keep every face of the (nearly axis-aligned)
    // boundary away from the |n . d| kink, where central differences would not apply.
    std::uniform_real_distribution<double> mag(0.3, 1.0);
    std::bernoulli_distribution flip;
    double d[3];
    for (double& c : d) c = flip(rng) ? -mag(rng) : mag(rng);
    const MassPropertiesOptions o = options(0.5 + trial, d[0], d[1], d[2]);
    MassPropertiesBar bar;
    bar.volume = nd(rng);
    bar.mass = nd(rng);
    bar.area = nd(rng);
    bar.frontal_area = nd(rng);
    for (double& v : bar.centroid) v = nd(rng);
    for (double& v : bar.inertia) v = nd(rng);
    expect_matches_central_differences(m, o, bar, "random" + std::to_string(trial));
  }
}

// The solid does not change when an interior vertex moves (the signed volumes of the tets around
// it always tile the same star), so volume, centroid and inertia have zero gradient there.
TEST(MassPropertiesGradient, InteriorVerticesHaveZeroGradient) {
  const int n = 3;
  const Mesh m = perturbed_grid(n, 3);
  MassPropertiesBar bar;
  bar.volume = 1.0;
  bar.mass = -2.0;
  bar.centroid[0] = 0.5;
  bar.centroid[2] = -1.5;
  for (int k = 0; k < 9; ++k) bar.inertia[k] = 0.1 * (k + 1);
  bar.area = 0.3;
  bar.frontal_area = 0.7;
  const std::vector<double> g = vjp(m, options(1.3, 1, 2, 3), bar);
  double scale = 0.0;
  for (double v : g) scale = std::max(scale, std::fabs(v));
  int interior = 0;
  for (int k = 1; k < n; ++k)
    for (int j = 1; j < n; ++j)
      for (int i = 1; i < n; ++i) {
        const std::size_t v = static_cast<std::size_t>((k * (n + 1) + j) * (n + 1) + i);
        for (int d = 0; d < 3; ++d) EXPECT_NEAR(g[3 * v + d], 0.0, 1e-12 * scale) << v << d;
        ++interior;
      }
  EXPECT_EQ(interior, 8);
  EXPECT_GT(scale, 0.1);
}

TEST(MassPropertiesGradient, AccumulatesIntoOutput) {
  const Mesh m = perturbed_grid(2, 5);
  const MassPropertiesOptions o = options(1, 1, 0, 0);
  MassPropertiesBar bar;
  bar.volume = 1;
  bar.inertia[4] = 1;
  bar.area = 1;
  const MassProperties p = mass_properties(m.view(), o);
  std::vector<double> once(m.V.size(), 0.0), twice(m.V.size(), 0.0);
  mass_properties_vjp(m.view(), o, p, bar, once.data());
  mass_properties_vjp(m.view(), o, p, bar, twice.data());
  mass_properties_vjp(m.view(), o, p, bar, twice.data());
  double scale = 0.0;
  for (double v : once) scale = std::max(scale, std::fabs(v));
  for (std::size_t i = 0; i < once.size(); ++i) EXPECT_NEAR(twice[i], 2 * once[i], 1e-14 * scale);
  // A zero bar touches nothing.
  std::vector<double> none(m.V.size(), 0.0);
  mass_properties_vjp(m.view(), o, p, MassPropertiesBar{}, none.data());
  for (double v : none) EXPECT_EQ(v, 0.0);
}

// ---------------------------------------------------------------------------------------------
// Invariances.

TEST(MassPropertiesInvariance, TranslationLeavesInertiaUnchanged) {
  // Positions on a 2^-16 grid below 2^3, shifted by integers to below 2^7: the float translation
  // is exact, so any difference is the algorithm's. Moments about the origin would lose about
  // log10(150^2 / 0.3) = 5 digits here (|centroid|^2 over the squared radius of gyration) and
  // fail the 1e-12 below; moments about a mesh vertex keep nearly all of them.
  const Mesh m = perturbed_grid(3, 21);
  Mesh moved = m;
  const double I3[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3] = {100.0, -75.0, 120.0};
  apply_affine(moved, I3, t);
  for (std::size_t i = 0; i < m.V.size(); ++i)
    ASSERT_EQ(static_cast<double>(moved.V[i]), static_cast<double>(m.V[i]) + t[i % 3]);
  const MassPropertiesOptions o = options(4.0, 1, -1, 2);
  const MassProperties p = mass_properties(m.view(), o);
  const MassProperties q = mass_properties(moved.view(), o);
  EXPECT_NEAR(q.volume, p.volume, 1e-13 * p.volume);
  EXPECT_NEAR(q.area, p.area, 1e-13 * p.area);
  EXPECT_NEAR(q.frontal_area, p.frontal_area, 1e-13 * p.frontal_area);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(q.centroid[d], p.centroid[d] + t[d], 1e-12);
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(q.inertia[k], p.inertia[k], 1e-12 * p.inertia[0]) << k;

  // Gradients of translation-invariant outputs are translation invariant too.
  MassPropertiesBar bar;
  for (int k = 0; k < 9; ++k) bar.inertia[k] = 1.0 + k;
  bar.volume = 1;
  const std::vector<double> gp = vjp(m, o, bar), gq = vjp(moved, o, bar);
  double scale = 0;
  for (double v : gp) scale = std::max(scale, std::fabs(v));
  for (std::size_t i = 0; i < gp.size(); ++i) EXPECT_NEAR(gq[i], gp[i], 1e-11 * scale) << i;
  // ... and sum to zero per axis (moving every vertex by the same vector changes nothing).
  for (int d = 0; d < 3; ++d) {
    double sum = 0;
    for (std::size_t i = static_cast<std::size_t>(d); i < gp.size(); i += 3) sum += gp[i];
    EXPECT_NEAR(sum, 0.0, 1e-12 * scale);
  }
}

TEST(MassPropertiesInvariance, RotationAndScaling) {
  const Mesh m = perturbed_grid(2, 33);
  const MassPropertiesOptions o = options(1.7, 0.2, 0.9, -0.4);
  const MassProperties p = mass_properties(m.view(), o);

  // Rotate the mesh by R and the direction with it: inertia becomes R I R^T, the rest follows.
  double R[9];
  const double axis[3] = {-0.3, 1.0, 0.4}, zero[3] = {0, 0, 0};
  rotation(axis, 1.1, R);
  Mesh rotated = m;
  apply_affine(rotated, R, zero);
  MassPropertiesOptions orot = o;
  for (int r = 0; r < 3; ++r)
    orot.direction[r] =
        R[3 * r] * o.direction[0] + R[3 * r + 1] * o.direction[1] + R[3 * r + 2] * o.direction[2];
  const MassProperties q = mass_properties(rotated.view(), orot);
  const double tol = 2e-6;  // float rounding of the rotated positions
  expect_rel(q.volume, p.volume, tol, "volume");
  expect_rel(q.area, p.area, tol, "area");
  expect_rel(q.frontal_area, p.frontal_area, tol, "frontal");
  for (int r = 0; r < 3; ++r) {
    double want = 0;
    for (int k = 0; k < 3; ++k) want += R[3 * r + k] * p.centroid[k];
    expect_rel(q.centroid[r], want, tol, "centroid");
    for (int s = 0; s < 3; ++s) {
      double wi = 0;
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) wi += R[3 * r + k] * p.inertia[3 * k + l] * R[3 * s + l];
      EXPECT_NEAR(q.inertia[3 * r + s], wi, tol * p.inertia[0]) << r << s;
    }
  }

  // Uniform scaling by 2 (exact in float): volume x8, area x4, inertia x32, centroid x2.
  Mesh scaled = m;
  const double S[9] = {2, 0, 0, 0, 2, 0, 0, 0, 2};
  apply_affine(scaled, S, zero);
  const MassProperties s = mass_properties(scaled.view(), o);
  EXPECT_NEAR(s.volume, 8 * p.volume, 1e-13 * s.volume);
  EXPECT_NEAR(s.mass, 8 * p.mass, 1e-13 * s.mass);
  EXPECT_NEAR(s.area, 4 * p.area, 1e-13 * s.area);
  EXPECT_NEAR(s.frontal_area, 4 * p.frontal_area, 1e-13 * s.area);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(s.centroid[d], 2 * p.centroid[d], 1e-13);
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(s.inertia[k], 32 * p.inertia[k], 1e-12 * s.inertia[0]);
  // Symmetric, with positive principal moments satisfying the triangle inequality.
  EXPECT_EQ(p.inertia[1], p.inertia[3]);
  EXPECT_EQ(p.inertia[2], p.inertia[6]);
  EXPECT_EQ(p.inertia[5], p.inertia[7]);
  EXPECT_LT(p.inertia[0], p.inertia[4] + p.inertia[8]);
}

// ---------------------------------------------------------------------------------------------
// Robustness.

TEST(MassPropertiesRobustness, EmptyMeshGivesZeros) {
  const TetMeshView empty{};
  const MassProperties p = mass_properties(empty, MassPropertiesOptions{});
  EXPECT_EQ(p.volume, 0.0);
  EXPECT_EQ(p.mass, 0.0);
  EXPECT_EQ(p.area, 0.0);
  EXPECT_EQ(p.frontal_area, 0.0);
  for (double v : p.centroid) EXPECT_EQ(v, 0.0);
  for (double v : p.inertia) EXPECT_EQ(v, 0.0);
  MassPropertiesBar bar;
  bar.volume = bar.area = bar.centroid[0] = bar.inertia[0] = 1.0;
  mass_properties_vjp(empty, MassPropertiesOptions{}, p, bar, nullptr);  // touches nothing
}

TEST(MassPropertiesRobustness, FlatMeshHasNoCentroid) {
  Mesh m;
  m.V = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};  // four coplanar points
  m.T = {0, 1, 2, 3};
  const MassProperties p = mass_properties(m.view(), MassPropertiesOptions{});
  EXPECT_EQ(p.volume, 0.0);
  EXPECT_TRUE(std::isnan(p.centroid[0]));
  EXPECT_TRUE(std::isnan(p.inertia[0]));
  // The volume gradient still exists (it is the only one asked for) and is finite.
  MassPropertiesBar bar;
  bar.volume = 1.0;
  std::vector<double> dV(12, 0.0);
  mass_properties_vjp(m.view(), MassPropertiesOptions{}, p, bar, dV.data());
  for (double v : dV) EXPECT_TRUE(std::isfinite(v));
  EXPECT_NE(dV[2], 0.0);  // lifting a vertex off the plane changes the volume
}

TEST(MassPropertiesRobustness, NonFinitePositionsGiveNaN) {
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity()};
  for (float value : bad) {
    for (std::uint32_t vtx : {0u, 13u, 26u}) {  // p0 itself, the centre, a corner
      Mesh m = perturbed_grid(2, 9);
      m.V[3 * vtx + 1] = value;
      const MassPropertiesOptions o = options(1, 1, 1, 1);
      const MassProperties p = mass_properties(m.view(), o);
      EXPECT_TRUE(std::isnan(p.volume)) << value << " at " << vtx;
      EXPECT_TRUE(std::isnan(p.mass));
      for (double v : p.centroid) EXPECT_TRUE(std::isnan(v));
      for (double v : p.inertia) EXPECT_TRUE(std::isnan(v));
      if (vtx != 13) {  // the centre is not on the boundary
        EXPECT_TRUE(std::isnan(p.area));
        EXPECT_TRUE(std::isnan(p.frontal_area));
      } else {
        EXPECT_TRUE(std::isfinite(p.area));
      }
      MassPropertiesBar bar;
      bar.volume = bar.mass = bar.area = bar.frontal_area = 1.0;
      for (double& v : bar.centroid) v = 1.0;
      for (double& v : bar.inertia) v = 1.0;
      std::vector<double> dV(m.V.size(), 0.0);
      mass_properties_vjp(m.view(), o, p, bar, dV.data());
      bool any_nonfinite = false;
      for (double v : dV) any_nonfinite = any_nonfinite || !std::isfinite(v);
      EXPECT_TRUE(any_nonfinite);
    }
  }
}

}  // namespace
}  // namespace cadinterp::runtime
