// Test and benchmark data for the codecs: a tet mesh of a box, bent, with a second "sample" of it
// (a small smooth deformation of the first, coded against it) and a smooth scalar field.
// Header-only; used by codec_test.cpp and codec_bench.cpp.
//
// Two layouts. Grid: vertices, tets and triangles in lexicographic grid order; its perfectly
// regular strides flatter delta + LZ coders (whole rows repeat). Irregular: what a mesher plus a
// locality renumbering gives: vertices jittered by up to 0.15 h, numbered along a Morton curve,
// tets in Morton order of their cell with the 6 tets of a cell shuffled and each tet's corners
// evenly permuted, triangles sorted by their smallest vertex and cyclically rotated.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

namespace cadinterp::format::testdata {

struct BoxMesh {
  std::vector<float> canonical;     // V  #V by 3 positions of the bent box (the reference)
  std::vector<float> sample;        // S  #V by 3 positions of a sample: V + a small smooth field
  std::vector<float> field;         // F  #V by 1 smooth scalar field (a temperature-like value)
  std::vector<std::uint32_t> tets;  // T  #T by 4, six Kuhn tets per hex, positive volume
  std::vector<std::uint32_t> tris;  // B  #B by 3 boundary triangles, outward-oriented
  std::size_t vertex_count() const { return canonical.size() / 3; }
  std::size_t tet_count() const { return tets.size() / 4; }
  std::size_t tri_count() const { return tris.size() / 3; }
};

// Axis-aligned bounding box diagonal of an #rows by 3 array.
inline double bbox_diagonal(const std::vector<float>& p) {
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < p.size(); ++i) {
    lo[i % 3] = std::min(lo[i % 3], static_cast<double>(p[i]));
    hi[i % 3] = std::max(hi[i % 3], static_cast<double>(p[i]));
  }
  double d2 = 0;
  for (int c = 0; c < 3; ++c) d2 += (hi[c] - lo[c]) * (hi[c] - lo[c]);
  return std::sqrt(d2);
}

enum class Layout { Grid, Irregular };

inline std::uint64_t morton3(std::uint32_t i, std::uint32_t j, std::uint32_t k) {
  std::uint64_t code = 0;
  for (int b = 0; b < 16; ++b) {
    code |= static_cast<std::uint64_t>((i >> b) & 1u) << (3 * b);
    code |= static_cast<std::uint64_t>((j >> b) & 1u) << (3 * b + 1);
    code |= static_cast<std::uint64_t>((k >> b) & 1u) << (3 * b + 2);
  }
  return code;
}

// Renumbers a Grid-layout mesh into the Irregular layout (see the top of the file).
inline void renumber_irregular(BoxMesh& m, int nx, int ny, std::mt19937_64& rng) {
  const std::size_t nv = m.vertex_count();
  const auto vx = static_cast<std::uint32_t>(nx + 1), vy = static_cast<std::uint32_t>(ny + 1);
  std::vector<std::uint32_t> order(nv);  // order[new] = old
  std::iota(order.begin(), order.end(), 0u);
  auto vcode = [&](std::uint32_t v) { return morton3(v % vx, v / vx % vy, v / (vx * vy)); };
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return vcode(a) < vcode(b); });
  std::vector<std::uint32_t> new_of_old(nv);
  for (std::uint32_t n = 0; n < nv; ++n) new_of_old[order[n]] = n;
  auto permute = [&](std::vector<float>& a, std::size_t comps) {
    std::vector<float> b(a.size());
    for (std::size_t n = 0; n < nv; ++n)
      for (std::size_t c = 0; c < comps; ++c) b[n * comps + c] = a[order[n] * comps + c];
    a.swap(b);
  };
  permute(m.canonical, 3);
  permute(m.sample, 3);
  permute(m.field, 1);

  // Tets: cells (6 consecutive tets each, cell index i + nx (j + ny k)) in Morton order, the 6
  // shuffled, each tet's corners permuted by a random even permutation (orientation kept).
  static const int even[12][4] = {{0, 1, 2, 3}, {0, 2, 3, 1}, {0, 3, 1, 2}, {1, 0, 3, 2},
                                  {1, 2, 0, 3}, {1, 3, 2, 0}, {2, 0, 1, 3}, {2, 1, 3, 0},
                                  {2, 3, 0, 1}, {3, 0, 2, 1}, {3, 1, 0, 2}, {3, 2, 1, 0}};
  const std::size_t ncell = m.tet_count() / 6;
  std::vector<std::uint32_t> cells(ncell);
  std::iota(cells.begin(), cells.end(), 0u);
  const auto cx = static_cast<std::uint32_t>(nx), cy = static_cast<std::uint32_t>(ny);
  auto ccode = [&](std::uint32_t c) { return morton3(c % cx, c / cx % cy, c / (cx * cy)); };
  std::sort(cells.begin(), cells.end(),
            [&](std::uint32_t a, std::uint32_t b) { return ccode(a) < ccode(b); });
  std::vector<std::uint32_t> tets;
  tets.reserve(m.tets.size());
  for (std::uint32_t c : cells) {
    int local[6] = {0, 1, 2, 3, 4, 5};
    std::shuffle(local, local + 6, rng);
    for (int t : local) {
      const std::uint32_t* src = &m.tets[(std::size_t{c} * 6 + t) * 4];
      const int* p = even[rng() % 12];
      for (int q = 0; q < 4; ++q) tets.push_back(new_of_old[src[p[q]]]);
    }
  }
  m.tets.swap(tets);

  // Triangles: renumbered, cyclically rotated at random, sorted by their smallest vertex.
  std::vector<std::array<std::uint32_t, 3>> tris(m.tri_count());
  for (std::size_t t = 0; t < tris.size(); ++t) {
    const std::size_t r = rng() % 3;
    for (std::size_t q = 0; q < 3; ++q) tris[t][q] = new_of_old[m.tris[3 * t + (q + r) % 3]];
  }
  std::stable_sort(tris.begin(), tris.end(), [](const auto& a, const auto& b) {
    return std::min({a[0], a[1], a[2]}) < std::min({b[0], b[1], b[2]});
  });
  for (std::size_t t = 0; t < tris.size(); ++t)
    for (std::size_t q = 0; q < 3; ++q) m.tris[3 * t + q] = tris[t][q];
}

// nx x ny x nz hexahedral cells of size h. Grid layout: vertex (i, j, k) at index
// i + (nx+1) (j + (ny+1) k).
inline BoxMesh make_box_mesh(int nx, int ny, int nz, double h = 0.05,
                             Layout layout = Layout::Grid) {
  BoxMesh m;
  const bool irregular = layout == Layout::Irregular;
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> jitter(-0.15, 0.15);
  const int vx = nx + 1, vy = ny + 1, vz = nz + 1;
  auto vid = [&](int i, int j, int k) { return static_cast<std::uint32_t>(i + vx * (j + vy * k)); };
  const double lx = nx * h, ly = ny * h, lz = nz * h;
  const double radius = 1.5 * lx;  // bend about the y axis through one full-ish arc
  for (int k = 0; k < vz; ++k) {
    for (int j = 0; j < vy; ++j) {
      for (int i = 0; i < vx; ++i) {
        // Jitter moves vertices within the box's faces, never off them.
        const double x = (i + (irregular && i > 0 && i < nx ? jitter(rng) : 0.0)) * h;
        const double y = (j + (irregular && j > 0 && j < ny ? jitter(rng) : 0.0)) * h;
        const double z = (k + (irregular && k > 0 && k < nz ? jitter(rng) : 0.0)) * h;
        // Canonical: bent around the y axis, with a slight twist about x.
        const double theta = x / radius;
        const double twist = 0.3 * x / lx * (y / ly - 0.5);
        const double zt = z + twist * lz;
        const double px = (radius + zt) * std::sin(theta);
        const double pz = (radius + zt) * std::cos(theta) - radius;
        const double py = y + 0.05 * lz * std::sin(3.0 * x / lx);
        m.canonical.push_back(static_cast<float>(px));
        m.canonical.push_back(static_cast<float>(py));
        m.canonical.push_back(static_cast<float>(pz));
        // Sample: a smooth displacement of ~1% of the size.
        const double a = 0.01 * lx;
        m.sample.push_back(static_cast<float>(px + a * std::sin(2.0 * y / ly + x / lx)));
        m.sample.push_back(static_cast<float>(py + a * std::cos(1.5 * x / lx) * z / lz));
        m.sample.push_back(static_cast<float>(pz + a * std::sin(3.0 * x / lx) * (1 + y / ly)));
        m.field.push_back(
            static_cast<float>(293.15 + 40.0 * std::sin(2.0 * x / lx) * std::cos(3.0 * y / ly) +
                               15.0 * (z / lz) * (z / lz)));
      }
    }
  }
  // Kuhn subdivision: the 6 paths 0 -> e_a -> e_a + e_b -> 7 along the cube's main diagonal.
  // Corner c (bits dx, dy, dz) = c & 1, c >> 1 & 1, c >> 2 & 1. Conforming across cells.
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  static const bool odd[6] = {false, true, true, false, false, true};
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        auto corner = [&](int c) { return vid(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)); };
        for (int p = 0; p < 6; ++p) {
          const int a = 1 << perms[p][0], b = a | (1 << perms[p][1]);
          std::uint32_t t[4] = {corner(0), corner(a), corner(b), corner(7)};
          if (odd[p]) std::swap(t[2], t[3]);  // det(e_a, e_b, e_c) = sign of the permutation
          m.tets.insert(m.tets.end(), t, t + 4);
        }
      }
    }
  }
  // Boundary: each face quad split along the Kuhn diagonal (low corner to high corner), the
  // orientation chosen so that the normal points out of the box.
  auto quad = [&](std::uint32_t v00, std::uint32_t v10, std::uint32_t v11, std::uint32_t v01,
                  bool flip) {
    if (!flip) {
      m.tris.insert(m.tris.end(), {v00, v10, v11, v00, v11, v01});
    } else {
      m.tris.insert(m.tris.end(), {v00, v11, v10, v00, v01, v11});
    }
  };
  // (u, v) axes of each face have u x v = +axis; flip on the low side.
  for (int side = 0; side < 2; ++side) {
    const bool flip = side == 0;
    const int ii = side ? nx : 0, jj = side ? ny : 0, kk = side ? nz : 0;
    for (int k = 0; k < nz; ++k)  // x faces: u = y, v = z
      for (int j = 0; j < ny; ++j)
        quad(vid(ii, j, k), vid(ii, j + 1, k), vid(ii, j + 1, k + 1), vid(ii, j, k + 1), flip);
    for (int i = 0; i < nx; ++i)  // y faces: u = z, v = x
      for (int k = 0; k < nz; ++k)
        quad(vid(i, jj, k), vid(i, jj, k + 1), vid(i + 1, jj, k + 1), vid(i + 1, jj, k), flip);
    for (int j = 0; j < ny; ++j)  // z faces: u = x, v = y
      for (int i = 0; i < nx; ++i)
        quad(vid(i, j, kk), vid(i + 1, j, kk), vid(i + 1, j + 1, kk), vid(i, j + 1, kk), flip);
  }
  if (irregular) renumber_irregular(m, nx, ny, rng);
  return m;
}

}  // namespace cadinterp::format::testdata
