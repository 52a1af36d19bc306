// Structured tet meshes with tagged, outward boundary triangles for the physics tests and the
// convergence report: boxes (each cube split into the 6 Kuhn tets around its main diagonal,
// which is conforming because every cube face is cut along its min-max diagonal) and quarter
// annuli (the box mapped from (r, theta, z)).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "physics.h"

namespace cadinterp::physics::testing {

/// Face tags of box_mesh: the face at the low / high end of each axis.
constexpr double kPi = 3.14159265358979323846;

enum BoxTag : std::int32_t { kXLow = 1, kXHigh = 2, kYLow = 3, kYHigh = 4, kZLow = 5, kZHigh = 6 };

inline double signed_volume6(const std::vector<double>& v, const std::uint32_t* t) {
  double e[3][3];
  for (int k = 0; k < 3; ++k) {
    for (int c = 0; c < 3; ++c) e[k][c] = v[3 * t[k + 1] + c] - v[3 * t[0] + c];
  }
  return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
         e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
         e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
}

/// [0,lx] x [0,ly] x [0,lz] with nx*ny*nz cubes, 6 tets each; boundary tags BoxTag.
inline TetMesh box_mesh(double lx, double ly, double lz, int nx, int ny, int nz) {
  TetMesh m;
  auto id = [&](int i, int j, int k) {
    return static_cast<std::uint32_t>((k * (ny + 1) + j) * (nx + 1) + i);
  };
  for (int k = 0; k <= nz; ++k) {
    for (int j = 0; j <= ny; ++j) {
      for (int i = 0; i <= nx; ++i) {
        m.vertices.insert(m.vertices.end(), {lx * i / nx, ly * j / ny, lz * k / nz});
      }
    }
  }
  static constexpr int kPerm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                      {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        for (const auto& perm : kPerm) {
          int c[3] = {i, j, k};
          std::uint32_t t[4];
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[perm[s]];
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          if (signed_volume6(m.vertices, t) < 0) std::swap(t[2], t[3]);
          m.tets.insert(m.tets.end(), t, t + 4);
        }
      }
    }
  }
  // Boundary squares, split along their min-max diagonal like the Kuhn tets, made outward.
  auto add_square = [&](std::uint32_t lo, std::uint32_t a, std::uint32_t b, std::uint32_t hi,
                        int axis, bool high_side, std::int32_t tag) {
    for (const auto& tri :
         {std::array<std::uint32_t, 3>{lo, a, hi}, std::array<std::uint32_t, 3>{lo, hi, b}}) {
      double e1[3], e2[3];
      for (int c = 0; c < 3; ++c) {
        e1[c] = m.vertices[3 * tri[1] + c] - m.vertices[3 * tri[0] + c];
        e2[c] = m.vertices[3 * tri[2] + c] - m.vertices[3 * tri[0] + c];
      }
      const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                           e1[0] * e2[1] - e1[1] * e2[0]};
      const bool outward = (n[axis] > 0) == high_side;
      m.triangles.insert(m.triangles.end(),
                         {tri[0], outward ? tri[1] : tri[2], outward ? tri[2] : tri[1]});
      m.triangle_tags.push_back(tag);
    }
  };
  for (int side = 0; side < 2; ++side) {
    const bool high = side == 1;
    for (int k = 0; k < nz; ++k) {
      for (int j = 0; j < ny; ++j) {
        const int i = high ? nx : 0;
        add_square(id(i, j, k), id(i, j + 1, k), id(i, j, k + 1), id(i, j + 1, k + 1), 0, high,
                   high ? kXHigh : kXLow);
      }
    }
    for (int k = 0; k < nz; ++k) {
      for (int i = 0; i < nx; ++i) {
        const int j = high ? ny : 0;
        add_square(id(i, j, k), id(i + 1, j, k), id(i, j, k + 1), id(i + 1, j, k + 1), 1, high,
                   high ? kYHigh : kYLow);
      }
    }
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const int k = high ? nz : 0;
        add_square(id(i, j, k), id(i + 1, j, k), id(i, j + 1, k), id(i + 1, j + 1, k), 2, high,
                   high ? kZHigh : kZLow);
      }
    }
  }
  return m;
}

/// Tags of quarter_annulus: inner and outer cylinder, the symmetry planes, the end faces.
enum AnnulusTag : std::int32_t {
  kInner = kXLow,
  kOuter = kXHigh,
  kPlaneY0 = kYLow,   ///< theta = 0: the plane y = 0
  kPlaneX0 = kYHigh,  ///< theta = pi/2: the plane x = 0
  kBottom = kZLow,
  kTop = kZHigh,
};

/// The quarter (x, y >= 0) of the tube a <= r <= b, 0 <= z <= height: the box (r, theta, z) mapped
/// by (r cos theta, r sin theta, z), which keeps orientation (Jacobian r > 0).
inline TetMesh quarter_annulus(double a, double b, double height, int nr, int ntheta, int nz) {
  TetMesh m = box_mesh(b - a, kPi / 2, height, nr, ntheta, nz);
  for (std::size_t v = 0; v < m.vertices.size() / 3; ++v) {
    const double r = a + m.vertices[3 * v], theta = m.vertices[3 * v + 1];
    m.vertices[3 * v] = r * std::cos(theta);
    m.vertices[3 * v + 1] = r * std::sin(theta);
  }
  // Exact symmetry planes (cos(pi/2) is 6e-17, not 0).
  for (std::size_t v = 0; v < m.vertices.size() / 3; ++v) {
    if (std::abs(m.vertices[3 * v]) < 1e-12 * b) m.vertices[3 * v] = 0.0;
  }
  return m;
}

/// Moves every vertex not on the box boundary by up to `fraction` of the cell size h per axis
/// (a distorted mesh for patch tests).
inline void jitter_interior(TetMesh& m, double lx, double ly, double lz, double h, double fraction,
                            unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-fraction * h, fraction * h);
  const double size[3] = {lx, ly, lz};
  for (std::size_t v = 0; v < m.vertices.size() / 3; ++v) {
    bool boundary = false;
    for (int c = 0; c < 3; ++c) {
      const double x = m.vertices[3 * v + c];
      boundary = boundary || std::abs(x) < 1e-12 || std::abs(x - size[c]) < 1e-12 * size[c];
    }
    if (boundary) continue;
    for (int c = 0; c < 3; ++c) m.vertices[3 * v + c] += u(rng);
  }
}

/// The solver benchmarks' case: a 2 x 1 x 1 bar of (2n+1)(n+1)^2 vertices, fixed (elastic) or
/// held at 0 (thermal) at x = 0, loaded by a unit downward force or heat flux at x = 2.
inline Problem bar_problem(int n, bool elastic, int order) {
  Problem p;
  p.mesh = box_mesh(2, 1, 1, 2 * n, n, n);
  p.order = order;
  if (elastic) {
    p.fixed.push_back({{kXLow}, {true, true, true}});
    p.forces.push_back({{kXHigh}, {0, 0, -1}});
  } else {
    p.elastic = false;
    p.thermal = true;
    p.temperatures.push_back({{kXLow}, 0.0});
    p.heat_fluxes.push_back({{kXHigh}, 1.0});
  }
  return p;
}

}  // namespace cadinterp::physics::testing
