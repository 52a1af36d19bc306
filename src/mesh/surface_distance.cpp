#include "mesh/surface_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

namespace cadinterp::mesh {

// The closest point lies in one of the seven Voronoi regions of the triangle (3 vertices,
// 3 edges, the face), told apart by barycentric signs (Ericson, Real-Time Collision Detection,
// 5.1.5).
void closest_point_weights(const double* p, const double* a, const double* b, const double* c,
                           double w[3]) {
  double ab[3], ac[3], ap[3];
  for (int i = 0; i < 3; ++i) {
    ab[i] = b[i] - a[i];
    ac[i] = c[i] - a[i];
    ap[i] = p[i] - a[i];
  }
  auto dot = [](const double* u, const double* v) {
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  };
  auto at = [&](double s, double t) {  // a + s ab + t ac
    w[0] = 1 - s - t;
    w[1] = s;
    w[2] = t;
  };
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return at(0, 0);
  double bp[3], cp[3];
  for (int i = 0; i < 3; ++i) {
    bp[i] = p[i] - b[i];
    cp[i] = p[i] - c[i];
  }
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return at(1, 0);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return at(d1 / (d1 - d3), 0);
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return at(0, 1);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return at(0, d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return at(1 - t, t);
  }
  const double denom = va + vb + vc;
  if (!(denom > 0)) {  // degenerate triangle: the nearest of its corners
    double best = std::numeric_limits<double>::infinity();
    const double* corner[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      double d = 0;
      for (int i = 0; i < 3; ++i) d += (corner[k][i] - p[i]) * (corner[k][i] - p[i]);
      if (d < best) {
        best = d;
        w[0] = w[1] = w[2] = 0;
        w[k] = 1;
      }
    }
    return;
  }
  at(vb / denom, vc / denom);
}

namespace {

// Squared distance from p to triangle abc, at its closest point (closest_point_weights).
double point_triangle_sq(const double* p, const double* a, const double* b, const double* c) {
  double w[3], d = 0;
  closest_point_weights(p, a, b, c, w);
  for (int i = 0; i < 3; ++i) {
    const double q = w[0] * a[i] + w[1] * b[i] + w[2] * c[i] - p[i];
    d += q * q;
  }
  return d;
}

}  // namespace

SurfaceIndex::SurfaceIndex(const std::vector<double>& V, const std::vector<std::uint32_t>& F)
    : V_(V), F_(F) {
  const std::size_t nf = F_.size() / 3;
  if (nf == 0) return;
  double hi[3];
  for (int c = 0; c < 3; ++c) lo_[c] = hi[c] = V_[3 * F_[0] + static_cast<std::size_t>(c)];
  double edge_sum = 0;
  for (std::size_t t = 0; t < nf; ++t)
    for (int k = 0; k < 3; ++k) {
      const double* p = &V_[3 * F_[3 * t + static_cast<std::size_t>(k)]];
      const double* q = &V_[3 * F_[3 * t + static_cast<std::size_t>((k + 1) % 3)]];
      for (int c = 0; c < 3; ++c) {
        lo_[c] = std::min(lo_[c], p[c]);
        hi[c] = std::max(hi[c], p[c]);
      }
      edge_sum += std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                            (p[2] - q[2]) * (p[2] - q[2]));
    }
  // Cells about twice the mean edge: a few triangles per cell, and capped at 2^21 cells.
  const double extent = std::max({hi[0] - lo_[0], hi[1] - lo_[1], hi[2] - lo_[2], 1e-300});
  cell_ = std::max(2.0 * edge_sum / static_cast<double>(3 * nf), extent / 128.0);
  for (int c = 0; c < 3; ++c)
    n_[c] = std::max(1, static_cast<int>(std::ceil((hi[c] - lo_[c]) / cell_)) + 1);
  const std::size_t cells = static_cast<std::size_t>(n_[0]) * n_[1] * n_[2];
  std::vector<std::uint32_t> count(cells + 1, 0);
  auto for_cells = [&](std::size_t t, auto&& f) {
    int a[3], b[3];
    for (int c = 0; c < 3; ++c) {
      double mn = std::numeric_limits<double>::infinity(), mx = -mn;
      for (int k = 0; k < 3; ++k) {
        const double v =
            V_[3 * F_[3 * t + static_cast<std::size_t>(k)] + static_cast<std::size_t>(c)];
        mn = std::min(mn, v);
        mx = std::max(mx, v);
      }
      a[c] = cell_of(mn, c);
      b[c] = cell_of(mx, c);
    }
    for (int i = a[0]; i <= b[0]; ++i)
      for (int j = a[1]; j <= b[1]; ++j)
        for (int k = a[2]; k <= b[2]; ++k)
          f((static_cast<std::size_t>(i) * n_[1] + static_cast<std::size_t>(j)) * n_[2] +
            static_cast<std::size_t>(k));
  };
  for (std::size_t t = 0; t < nf; ++t) for_cells(t, [&](std::size_t cell) { ++count[cell + 1]; });
  for (std::size_t i = 0; i < cells; ++i) count[i + 1] += count[i];
  start_ = count;
  items_.resize(count[cells]);
  for (std::size_t t = 0; t < nf; ++t)
    for_cells(t, [&](std::size_t cell) { items_[count[cell]++] = static_cast<std::uint32_t>(t); });
}

int SurfaceIndex::cell_of(double v, int axis) const {
  const double c = std::floor((v - lo_[axis]) / cell_);
  return static_cast<int>(std::min(std::max(c, 0.0), static_cast<double>(n_[axis] - 1)));
}

double SurfaceIndex::distance(const double* p, std::size_t* triangle) const {
  if (F_.empty()) return std::numeric_limits<double>::infinity();
  int home[3];
  for (int c = 0; c < 3; ++c) home[c] = cell_of(p[c], c);
  // Distance from p to the grid's box, so that shells are counted from where p enters it.
  double outside = 0;
  for (int c = 0; c < 3; ++c) {
    const double top = lo_[c] + cell_ * n_[c];
    const double d = std::max({lo_[c] - p[c], p[c] - top, 0.0});
    outside += d * d;
  }
  outside = std::sqrt(outside);
  double best = std::numeric_limits<double>::infinity();
  const int max_ring = std::max({n_[0], n_[1], n_[2]});
  for (int r = 0; r <= max_ring; ++r) {
    // A triangle not yet seen meets no cell of rings < r, so it lies outside their box: never
    // closer than p's distance to that box's faces (for p inside it; at least r - 1 cells), nor
    // than the grid's box. Points near the surface, which most queries are, stop after ring 0.
    double unseen = std::max(outside, (r - 1) * cell_);
    if (r > 0 && outside == 0) {
      double inner = std::numeric_limits<double>::infinity();
      for (int c = 0; c < 3; ++c) {
        const double below = p[c] - (lo_[c] + (home[c] - r + 1) * cell_);
        const double above = lo_[c] + (home[c] + r) * cell_ - p[c];
        inner = std::min({inner, below, above});
      }
      // Less a hair: the cells were assigned by floor((v - lo) / cell), which may round the
      // other way than these sums.
      unseen = std::max(unseen, inner - 1e-9 * cell_);
    }
    if (best <= unseen) break;
    for (int i = home[0] - r; i <= home[0] + r; ++i) {
      if (i < 0 || i >= n_[0]) continue;
      for (int j = home[1] - r; j <= home[1] + r; ++j) {
        if (j < 0 || j >= n_[1]) continue;
        for (int k = home[2] - r; k <= home[2] + r; ++k) {
          if (k < 0 || k >= n_[2]) continue;
          if (std::max({std::abs(i - home[0]), std::abs(j - home[1]), std::abs(k - home[2])}) != r)
            continue;  // the shell only
          const std::size_t cell =
              (static_cast<std::size_t>(i) * n_[1] + static_cast<std::size_t>(j)) * n_[2] +
              static_cast<std::size_t>(k);
          for (std::uint32_t q = start_[cell]; q < start_[cell + 1]; ++q) {
            const std::size_t t = items_[q];
            const double d = point_triangle_sq(p, &V_[3 * F_[3 * t]], &V_[3 * F_[3 * t + 1]],
                                               &V_[3 * F_[3 * t + 2]]);
            if (std::sqrt(d) < best) {
              best = std::sqrt(d);
              if (triangle) *triangle = t;
            }
          }
        }
      }
    }
  }
  return best;
}

std::vector<double> vertex_distances(const std::vector<double>& VA,
                                     const std::vector<std::uint32_t>& FA, const SurfaceIndex& B) {
  std::vector<char> used(VA.size() / 3, 0);
  for (std::uint32_t i : FA) used[i] = 1;
  std::vector<double> d;
  for (std::size_t v = 0; v < used.size(); ++v)
    if (used[v]) d.push_back(B.distance(&VA[3 * v]));
  return d;
}

double symmetric_hausdorff(const std::vector<double>& VA, const std::vector<std::uint32_t>& FA,
                           const std::vector<double>& VB, const std::vector<std::uint32_t>& FB,
                           int threads) {
  auto one_way = [](const std::vector<double>& V1, const std::vector<std::uint32_t>& F1,
                    const std::vector<double>& V2, const std::vector<std::uint32_t>& F2) {
    double h = 0;
    for (double d : vertex_distances(V1, F1, SurfaceIndex(V2, F2))) h = std::max(h, d);
    return h;
  };
  // The two directions are independent: on large surfaces the second runs on another thread
  // (this is the builder's refinement test, on its critical path between host waves).
  if (threads < 2 || FA.size() + FB.size() < 6000)
    return std::max(one_way(VA, FA, VB, FB), one_way(VB, FB, VA, FA));
  double h2 = 0;
  std::thread other([&] { h2 = one_way(VB, FB, VA, FA); });
  const double h1 = one_way(VA, FA, VB, FB);
  other.join();
  return std::max(h1, h2);
}

}  // namespace cadinterp::mesh
