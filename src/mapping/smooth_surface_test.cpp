// The smooth reconstruction the mapper places boundary vertices on (smooth_surface.h), on a
// constructed cylinder section with a flat floor: the truth is the cylinder x^2 + y^2 = R^2 and
// the plane z = 0 the facets approximate.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "mapping/smooth_surface.h"
#include "mesh/sample.h"

namespace {

using namespace cadinterp;

constexpr double kPi = 3.14159265358979323846;
constexpr double kR = 1.0;

// A cylinder section of `n` columns over 120 degrees and one row over z in [0, 1] (tag 1,
// outward = radial), and a flat floor at z = 0 between radii R/2 and R (tag 2, outward = -z).
// Vertex (i, j) of the wall is 2 i + j; floor vertex i at radius R/2 is 2 (n + 1) + i.
struct Section {
  int n;
  double step;  // column angle
  mesh::Sample s;
  explicit Section(int columns) : n(columns), step(2 * kPi / 3 / columns) {
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= 1; ++j)
        for (double c : {kR * std::cos(i * step), kR * std::sin(i * step), double(j)})
          s.vertices.push_back(c);
    for (int i = 0; i <= n; ++i)
      for (double c : {0.5 * kR * std::cos(i * step), 0.5 * kR * std::sin(i * step), 0.0})
        s.vertices.push_back(c);
    auto tri = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c, int tag) {
      s.triangles.insert(s.triangles.end(), {a, b, c});
      s.triangle_tags.push_back(tag);
    };
    for (std::uint32_t i = 0; i < std::uint32_t(n); ++i) {
      const std::uint32_t a = 2 * i, b = 2 * i + 2, c = 2 * i + 3, d = 2 * i + 1;
      tri(a, b, c, 1);  // lower: s >= t in the cell
      tri(a, c, d, 1);
      const std::uint32_t in = 2 * std::uint32_t(n + 1) + i;
      tri(a, in, b, 2);
      tri(in, in + 1, b, 2);
    }
  }
  // The wall point at angle theta and height z as the composed map gives it: the source cell's
  // triangle containing (theta, z) in parameter space, with its barycentric coordinates.
  mapping::SurfacePoint wall(double theta, double z) const {
    const int i = std::min(n - 1, static_cast<int>(theta / step));
    const double u = theta / step - i, t = z;
    const std::uint32_t a = 2 * std::uint32_t(i), b = a + 2, c = a + 3, d = a + 1;
    mapping::SurfacePoint p;
    if (u >= t) {
      p.v[0] = a, p.v[1] = b, p.v[2] = c;
      p.w[0] = 1 - u, p.w[1] = u - t, p.w[2] = t;
    } else {
      p.v[0] = a, p.v[1] = c, p.v[2] = d;
      p.w[0] = 1 - t, p.w[1] = u, p.w[2] = t - u;
    }
    return p;
  }
};

std::array<double, 3> flat(const mesh::Sample& s, const mapping::SurfacePoint& p) {
  std::array<double, 3> x{0, 0, 0};
  for (int k = 0; k < 3; ++k)
    for (std::size_t a = 0; a < 3; ++a) x[a] += p.w[k] * s.vertices[3 * p.v[k] + a];
  return x;
}

double six_volume(const std::array<std::array<double, 3>, 4>& x) {
  double e[3][3];
  for (int k = 0; k < 3; ++k)
    for (std::size_t a = 0; a < 3; ++a) e[k][a] = x[std::size_t(k) + 1][a] - x[0][a];
  return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
         e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
         e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
}

// A "cap" tet of a finer canonical mesh on the curved wall (four vertices on the cylinder, two
// of them a chord across the curvature, two on the ruling between: all inside one source
// triangle) is flat when placed on the chordal source and keeps its orientation and most of its
// volume on the reconstruction; the reconstruction lies on the cylinder far closer than the
// chords do. At two source resolutions (30 and 15 degrees per column).
TEST(SmoothSurface, CapTetsOnACurvedFaceKeepTheirOrientation) {
  for (int columns : {4, 8}) {
    const Section sec(columns);
    const mapping::SmoothSurface smooth(sec.s, 0.5);
    const double h = sec.step, tc = 1.75 * h, zc = 0.25, d = 0.15 * h, dz = 0.15;
    const double params[4][2] = {{tc - d, zc}, {tc, zc - dz}, {tc + d, zc}, {tc, zc + dz}};
    std::array<std::array<double, 3>, 4> truth, chord, smoothed;
    for (std::size_t k = 0; k < 4; ++k) {
      const double th = params[k][0], z = params[k][1];
      truth[k] = {kR * std::cos(th), kR * std::sin(th), z};
      const mapping::SurfacePoint p = sec.wall(th, z);
      // All four in the same source triangle: the chordal placement is coplanar.
      EXPECT_EQ(p.v[0], sec.wall(params[0][0], params[0][1]).v[0]);
      EXPECT_EQ(p.v[2], sec.wall(params[0][0], params[0][1]).v[2]);
      chord[k] = flat(sec.s, p);
      smooth.position(p, smoothed[k].data());
    }
    const double v_true = six_volume(truth);
    ASSERT_GT(std::fabs(v_true), 0.0);
    const double sign = v_true > 0 ? 1 : -1;
    // The mapper's flatness rule (mesh::validate): 6 V <= 1e-12 diag^3.
    EXPECT_LE(sign * six_volume(chord), 1e-12 * std::fabs(v_true)) << columns;
    const double v_smooth = sign * six_volume(smoothed);
    EXPECT_GT(v_smooth, 0.0) << columns;
    EXPECT_NEAR(v_smooth / std::fabs(v_true), 1.0, 0.2) << columns;

    // Distance to the cylinder over a grid of wall points away from the section's ends (whose
    // vertex normals see one side only): the chords sag by up to R (1 - cos(step / 2)).
    double err_chord = 0, err_smooth = 0;
    for (int a = 0; a <= 40; ++a)
      for (int b = 0; b <= 10; ++b) {
        const double th = h + (columns - 2) * h * a / 40.0, z = b / 10.0;
        const mapping::SurfacePoint p = sec.wall(th, z);
        const std::array<double, 3> c = flat(sec.s, p);
        double x[3];
        smooth.position(p, x);
        err_chord = std::max(err_chord, std::fabs(std::hypot(c[0], c[1]) - kR));
        err_smooth = std::max(err_smooth, std::fabs(std::hypot(x[0], x[1]) - kR));
        EXPECT_NEAR(x[2], z, 1e-12);  // a cylinder's rulings stay straight
      }
    EXPECT_NEAR(err_chord, kR * (1 - std::cos(h / 2)), 1e-3 * kR);
    EXPECT_LT(err_smooth, 0.1 * err_chord) << columns;
  }
}

// Never across a crease: the flat floor stays exactly flat up to the wall, and a point on the
// wall-floor crease follows the circle within the floor's plane (the tangent lines of the
// crease curve, n_wall x n_floor), not a blend of the two faces.
TEST(SmoothSurface, FlatFacesStayFlatAndCreasesFollowTheirCurve) {
  const Section sec(4);
  const mapping::SmoothSurface smooth(sec.s, 0.5);
  const std::size_t F = sec.s.triangle_count();
  double crease_chord = 0, crease_smooth = 0;
  for (std::size_t f = 0; f < F; ++f) {
    if (sec.s.triangle_tags[f] != 2) continue;
    const std::uint32_t* t = &sec.s.triangles[3 * f];
    for (double u : {0.1, 0.3, 0.6})
      for (double v : {0.1, 0.3}) {
        mapping::SurfacePoint p;
        p.v[0] = t[0], p.v[1] = t[1], p.v[2] = t[2];
        p.w[0] = 1 - u - v, p.w[1] = u, p.w[2] = v;
        double x[3];
        smooth.position(p, x);
        const std::array<double, 3> c = flat(sec.s, p);
        for (std::size_t a = 0; a < 3; ++a) EXPECT_NEAR(x[a], c[a], 1e-15);
      }
    // The triangle's edge on the wall (both ends at radius R): the crease.
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k], b = t[(k + 1) % 3];
      if (a >= 2 * std::uint32_t(sec.n + 1) || b >= 2 * std::uint32_t(sec.n + 1)) continue;
      // Not at the section's open ends, whose wall normals see one side only.
      if (std::min(a, b) < 2 || std::max(a, b) > 2 * std::uint32_t(sec.n) - 2) continue;
      for (double u : {0.25, 0.5, 0.75}) {
        mapping::SurfacePoint p;
        p.v[0] = a, p.v[1] = b, p.v[2] = a;
        p.w[0] = 1 - u, p.w[1] = u, p.w[2] = 0;
        double x[3];
        smooth.position(p, x);
        const std::array<double, 3> c = flat(sec.s, p);
        EXPECT_NEAR(x[2], 0.0, 1e-15);
        crease_chord = std::max(crease_chord, kR - std::hypot(c[0], c[1]));
        crease_smooth = std::max(crease_smooth, std::fabs(kR - std::hypot(x[0], x[1])));
      }
    }
  }
  EXPECT_GT(crease_chord, 0.02 * kR);  // the chords of 30 degrees sag by 3.4 %
  EXPECT_LT(crease_smooth, 0.1 * crease_chord);
  // A vertex is where it is; a point of no source triangle or edge stays at its flat position.
  mapping::SurfacePoint vtx;
  vtx.v[0] = 3;
  double x[3];
  smooth.position(vtx, x);
  for (std::size_t a = 0; a < 3; ++a) EXPECT_EQ(x[a], sec.s.vertices[9 + a]);
  mapping::SurfacePoint stray;
  stray.v[0] = 0, stray.v[1] = 4, stray.v[2] = 8;  // not a triangle
  stray.w[0] = stray.w[1] = stray.w[2] = 1.0 / 3;
  smooth.position(stray, x);
  const std::array<double, 3> c = flat(sec.s, stray);
  for (std::size_t a = 0; a < 3; ++a) EXPECT_EQ(x[a], c[a]);
}

}  // namespace
