// The solids the mapper's tests mesh themselves (mapping_test_util.h): their construction is
// the truth the tests compare the mapped meshes with.
#include "mapping/mapping_test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <utility>

#include "mapping/boundary_untangle.h"

namespace cadinterp::mapping_test {

namespace tube {

mesh::Sample make(const Shape& t) {
  mesh::Sample s;
  s.feasible = true;
  const int R = 3;  // radial nodes: one interior layer
  auto index = [&](int i, int j, int k) {
    return static_cast<std::uint32_t>((k * t.n + (j % t.n)) * R + i);
  };
  for (int k = 0; k <= t.k; ++k)
    for (int j = 0; j < t.n; ++j)
      for (int i = 0; i < R; ++i) {
        const double r = t.r_in + (t.r_out - t.r_in) * i / (R - 1), a = 2 * kPi * j / t.n;
        s.vertices.insert(s.vertices.end(), {r * std::cos(a), r * std::sin(a), t.height * k / t.k});
      }
  auto six_vol = [&](const std::uint32_t* q) {
    const double* p[4];
    for (int c = 0; c < 4; ++c) p[c] = &s.vertices[3 * std::size_t(q[c])];
    double e[3][3];
    for (int c = 0; c < 3; ++c)
      for (int d = 0; d < 3; ++d) e[c][d] = p[c + 1][d] - p[0][d];
    return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
           e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
           e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
  };
  // Kuhn's six tets per hex cell (the same diagonal everywhere: conforming).
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < t.k; ++k)
    for (int j = 0; j < t.n; ++j)
      for (int i = 0; i + 1 < R; ++i)
        for (const auto& p : perms) {
          int c[3] = {0, 0, 0};
          std::uint32_t q[4];
          q[0] = index(i, j, k);
          for (int s3 = 0; s3 < 3; ++s3) {
            c[p[s3]] = 1;
            q[s3 + 1] = index(i + c[0], j + c[1], k + c[2]);
          }
          if (six_vol(q) < 0) std::swap(q[2], q[3]);
          s.tets.insert(s.tets.end(), q, q + 4);
        }
  // Boundary: faces used by one tet, outward (tet faces (a,c,b), (a,b,d), (a,d,c), (b,c,d)).
  std::map<std::vector<std::uint32_t>, std::pair<int, std::vector<std::uint32_t>>> faces;
  for (std::size_t q = 0; q < s.tets.size(); q += 4) {
    const std::uint32_t a = s.tets[q], b = s.tets[q + 1], c = s.tets[q + 2], d = s.tets[q + 3];
    for (const std::vector<std::uint32_t>& f :
         {std::vector<std::uint32_t>{a, c, b}, {a, b, d}, {a, d, c}, {b, c, d}}) {
      std::vector<std::uint32_t> key = f;
      std::sort(key.begin(), key.end());
      auto& e = faces[key];
      ++e.first;
      e.second = f;
    }
  }
  for (const auto& [key, e] : faces) {
    if (e.first != 1) continue;
    s.triangles.insert(s.triangles.end(), e.second.begin(), e.second.end());
    int tag;  // 1 outer wall, 2 inner wall, 3 top, 4 bottom
    auto radial = [&](std::uint32_t v) { return static_cast<int>(v % R); };
    auto axial = [&](std::uint32_t v) { return static_cast<int>(v / (R * t.n)); };
    if (radial(key[0]) == R - 1 && radial(key[1]) == R - 1 && radial(key[2]) == R - 1)
      tag = 1;
    else if (radial(key[0]) == 0 && radial(key[1]) == 0 && radial(key[2]) == 0)
      tag = 2;
    else
      tag = axial(key[0]) == t.k ? 3 : 4;
    s.triangle_tags.push_back(tag);
  }
  // References: vertices OB, OT, IB, IT at angle 0; circles and seams with levels = 1.
  struct Vx {
    std::int64_t id;
    int i, k;
  };
  const Vx vx[4] = {{10, R - 1, 0}, {11, R - 1, t.k}, {12, 0, 0}, {13, 0, t.k}};
  struct Ed {
    std::int64_t id;
    int v0, v1;  // indices into vx; a circle has v0 == v1
  };
  const Ed ed[6] = {{20, 0, 0}, {21, 1, 1}, {22, 2, 2}, {23, 3, 3}, {24, 0, 1}, {25, 2, 3}};
  std::vector<std::vector<std::int64_t>> vid(4);
  for (int v = 0; v < 4; ++v) {
    vid[std::size_t(v)].push_back(0);
    vid[std::size_t(v)].push_back(vx[v].id);
    for (const Ed& e : ed)
      if (e.v0 == v || e.v1 == v) vid[std::size_t(v)].push_back(e.id);
    // Copy-constructed IDs (GCC 12's -Wnonnull misfires on vector<long> assignment here).
    mesh::ControlPoint cp{vid[std::size_t(v)], {0, 0, 0}};
    const double* x = &s.vertices[3 * std::size_t(index(vx[v].i, 0, vx[v].k))];
    std::copy(x, x + 3, cp.position);
    s.points.push_back(cp);
  }
  for (const Ed& e : ed) {
    const bool circle = e.v0 == e.v1;
    const int steps = circle ? t.n : t.k;  // mesh edges along the CAD edge
    auto node = [&](int m) {               // m = 0..steps along the edge
      return circle ? index(vx[e.v0].i, m, vx[e.v0].k) : index(vx[e.v0].i, 0, m);
    };
    const std::vector<std::int64_t> base{1, e.id, std::min(vx[e.v0].id, vx[e.v1].id),
                                         std::max(vx[e.v0].id, vx[e.v1].id), -1};
    std::vector<std::vector<std::int64_t>> ids{vid[std::size_t(e.v0)], base, base, base,
                                               vid[std::size_t(e.v1)]};
    ids[1].push_back(0);  // u = 1/4
    ids[3].push_back(1);  // u = 3/4
    for (int q = 1; q <= 3; ++q) {
      mesh::ControlPoint cp{ids[std::size_t(q)], {0, 0, 0}};
      const double* x = &s.vertices[3 * std::size_t(node(q * steps / 4))];
      std::copy(x, x + 3, cp.position);
      s.points.push_back(cp);
    }
    for (int q = 0; q < 4; ++q) {
      mesh::Path p{ids[std::size_t(q)], ids[std::size_t(q + 1)], {}};
      for (int m = q * steps / 4; m <= (q + 1) * steps / 4; ++m) {
        const double* x = &s.vertices[3 * std::size_t(node(m))];
        p.polyline.insert(p.polyline.end(), x, x + 3);
      }
      s.paths.push_back(std::move(p));
    }
  }
  return s;
}

}  // namespace tube

namespace voxel {

mesh::Sample plate(double X, double Y, double Z, double h, const std::vector<Hole>& holes) {
  const int nx = int(std::lround(X / h)), ny = int(std::lround(Y / h)),
            nz = int(std::lround(Z / h));
  auto in_hole = [&](double x, double y) {
    for (const Hole& o : holes)
      if (x > o.x0 && x < o.x1 && y > o.y0 && y < o.y1) return true;
    return false;
  };
  auto grid = [&](int i, int j, int k) { return std::size_t((k * (ny + 1) + j) * (nx + 1) + i); };
  std::vector<double> all(3 * std::size_t((nx + 1) * (ny + 1) * (nz + 1)));
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        all[3 * grid(i, j, k)] = i * h;
        all[3 * grid(i, j, k) + 1] = j * h;
        all[3 * grid(i, j, k) + 2] = k * h;
      }
  std::vector<std::uint32_t> tets;
  // The 6 paths from corner 000 to 111 through the cube's edges: each a Kuhn tet.
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (in_hole((i + 0.5) * h, (j + 0.5) * h)) continue;
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          std::uint32_t t[4];
          t[0] = std::uint32_t(grid(c[0], c[1], c[2]));
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[s + 1] = std::uint32_t(grid(c[0], c[1], c[2]));
          }
          if (mapping::scaled_jacobian(all, t) < 0) std::swap(t[2], t[3]);
          tets.insert(tets.end(), t, t + 4);
        }
      }
  // Compact (vertices inside holes are in no tet).
  std::vector<std::int64_t> index(all.size() / 3, -1);
  mesh::Sample s;
  s.feasible = true;
  for (std::uint32_t& v : tets) {
    if (index[v] < 0) {
      index[v] = std::int64_t(s.vertices.size() / 3);
      s.vertices.insert(s.vertices.end(), &all[3 * v], &all[3 * v] + 3);
    }
    v = std::uint32_t(index[v]);
  }
  s.tets = tets;
  // Boundary faces: those of one tet, oriented away from its fourth vertex.
  std::map<std::array<std::uint32_t, 3>, std::pair<int, std::array<std::uint32_t, 4>>> faces;
  for (std::size_t t = 0; t < s.tet_count(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<std::uint32_t, 3> tri;
      for (int a = 0, n = 0; a < 4; ++a)
        if (a != f) tri[std::size_t(n++)] = s.tets[4 * t + std::size_t(a)];
      std::array<std::uint32_t, 3> key = tri;
      std::sort(key.begin(), key.end());
      auto& e = faces[key];
      ++e.first;
      e.second = {tri[0], tri[1], tri[2], s.tets[4 * t + std::size_t(f)]};
    }
  for (const auto& [key, e] : faces) {
    if (e.first != 1) continue;
    std::array<std::uint32_t, 4> q = e.second;
    const double* a = &s.vertices[3 * q[0]];
    const double* b = &s.vertices[3 * q[1]];
    const double* c = &s.vertices[3 * q[2]];
    const double* d = &s.vertices[3 * q[3]];
    double n[3] = {(b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1]),
                   (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2]),
                   (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])};
    if (n[0] * (d[0] - a[0]) + n[1] * (d[1] - a[1]) + n[2] * (d[2] - a[2]) > 0) {
      std::swap(q[1], q[2]);
      for (double& x : n) x = -x;
    }
    s.triangles.insert(s.triangles.end(), {q[0], q[1], q[2]});
    const double m[3] = {(a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3,
                         (a[2] + b[2] + c[2]) / 3};
    std::int32_t tag = 0;
    if (std::fabs(n[2]) > 0.5 * std::hypot(n[0], n[1], n[2])) {
      tag = n[2] > 0 ? 1 : 2;
    } else if (m[0] < 1e-9 || m[0] > X - 1e-9 || m[1] < 1e-9 || m[1] > Y - 1e-9) {
      tag = m[0] < 1e-9 ? 3 : m[0] > X - 1e-9 ? 4 : m[1] < 1e-9 ? 5 : 6;
    } else {
      for (std::size_t k = 0; k < holes.size(); ++k)
        if (m[0] > holes[k].x0 - 1e-9 && m[0] < holes[k].x1 + 1e-9 && m[1] > holes[k].y0 - 1e-9 &&
            m[1] < holes[k].y1 + 1e-9)
          tag = 10 + std::int32_t(k);
    }
    s.triangle_tags.push_back(tag);
  }
  auto point = [&](std::int64_t id, double x, double y, double z) {
    mesh::ControlPoint p;
    p.id = {0, id};
    p.position[0] = x;
    p.position[1] = y;
    p.position[2] = z;
    s.points.push_back(p);
  };
  for (int c = 0; c < 8; ++c) point(1 + c, (c & 1) * X, (c >> 1 & 1) * Y, (c >> 2) * Z);
  for (std::size_t k = 0; k < holes.size(); ++k) {
    point(100 + std::int64_t(k), holes[k].x0, holes[k].y0, Z);
    point(200 + std::int64_t(k), holes[k].x0, holes[k].y0, 0);
  }
  return s;
}

void expect_on_outer_planes(const mesh::Sample& canonical, const mesh::MappedSample& m, double X,
                            double Z) {
  for_each_tagged_corner(canonical, m, [X, Z](std::int32_t tag, const double* x) {
    if (tag == 1) {
      EXPECT_NEAR(x[2], Z, 1e-12);
    }
    if (tag == 2) {
      EXPECT_NEAR(x[2], 0.0, 1e-12);
    }
    if (tag == 3) {
      EXPECT_NEAR(x[0], 0.0, 1e-12);
    }
    if (tag == 4) {
      EXPECT_NEAR(x[0], X, 1e-12);
    }
  });
}

}  // namespace voxel

}  // namespace cadinterp::mapping_test
