#include "mapping/boundary_untangle.h"

#include <algorithm>
#include <cmath>

#include "mapping/interior_solve.h"

namespace cadinterp::mapping {

namespace {

// The objective around one vertex: (inverted count, min scaled Jacobian), lexicographic.
struct Score {
  std::size_t bad = 0;
  double min_sj = 1;
  bool better_than(const Score& o) const {
    if (bad != o.bad) return bad < o.bad;
    // A relative margin, so that rounding noise cannot make the search cycle.
    return min_sj > o.min_sj + 1e-12;
  }
};

}  // namespace

double scaled_jacobian(const std::vector<double>& x, const std::uint32_t* t) {
  const double det = six_volume(x, t);
  double sj = 1.0;
  for (int i = 0; i < 4; ++i) {
    const double* pi = &x[3 * std::size_t(t[i])];
    double prod = 1;
    for (int j = 0; j < 4; ++j) {
      if (j == i) continue;
      const double* pj = &x[3 * std::size_t(t[j])];
      prod *= std::sqrt((pj[0] - pi[0]) * (pj[0] - pi[0]) + (pj[1] - pi[1]) * (pj[1] - pi[1]) +
                        (pj[2] - pi[2]) * (pj[2] - pi[2]));
    }
    sj = std::min(sj, prod > 0 ? std::sqrt(2.0) * det / prod : -1.0);
  }
  return sj;
}

BoundaryUntangleResult untangle_boundary(const std::vector<std::uint32_t>& tets,
                                         const std::vector<int>& dof_of,
                                         std::vector<BoundaryDof>& dofs, const PlaceFn& place,
                                         double min_six_volume, std::vector<double>& x,
                                         const std::vector<char>* free_vertex, int rounds) {
  BoundaryUntangleResult r;
  const std::size_t T = tets.size() / 4, V = x.size() / 3;
  auto bad = [&](std::size_t t) { return !(six_volume(x, &tets[4 * t]) > min_six_volume); };
  auto count_inverted = [&] {
    std::size_t n = 0;
    for (std::size_t t = 0; t < T; ++t) n += bad(t) ? 1 : 0;
    return n;
  };
  r.inverted_before = r.inverted_after = count_inverted();
  if (r.inverted_before == 0) return r;
  std::vector<std::vector<std::uint32_t>> tets_of(V);
  for (std::size_t t = 0; t < T; ++t)
    for (int i = 0; i < 4; ++i) tets_of[tets[4 * t + std::size_t(i)]].push_back(std::uint32_t(t));
  auto score = [&](std::uint32_t v) {
    Score s;
    for (std::uint32_t t : tets_of[v]) {
      if (bad(t)) ++s.bad;
      s.min_sj = std::min(s.min_sj, scaled_jacobian(x, &tets[4 * std::size_t(t)]));
    }
    return s;
  };
  std::vector<char> moved(dofs.size(), 0);
  bool widen = false;
  for (int round = 0; round < rounds && r.inverted_after > 0; ++round) {
    // The dofs to optimize this pass: vertices of inverted tets (and, widened, of their
    // vertex neighbours' tets).
    std::vector<std::uint32_t> verts;
    for (std::size_t t = 0; t < T; ++t) {
      if (!bad(t)) continue;
      for (int i = 0; i < 4; ++i) {
        const std::uint32_t v = tets[4 * t + std::size_t(i)];
        verts.push_back(v);
        if (!widen) continue;
        for (std::uint32_t u : tets_of[v])
          for (int k = 0; k < 4; ++k) verts.push_back(tets[4 * std::size_t(u) + std::size_t(k)]);
      }
    }
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    for (std::uint32_t v : verts) {
      const int d = dof_of[v];
      BoundaryDof interior;  // a free vertex: its parameters are its position
      if (d < 0) {
        if (!free_vertex || !(*free_vertex)[v]) continue;
        interior.vertex = v;
        interior.dims = 3;
        for (int a = 0; a < 3; ++a) interior.p[a] = x[3 * std::size_t(v) + std::size_t(a)];
        // A quarter of its shortest tet edge.
        double shortest = 1e300;
        for (std::uint32_t t : tets_of[v])
          for (int k = 0; k < 4; ++k) {
            const std::uint32_t w = tets[4 * std::size_t(t) + std::size_t(k)];
            if (w == v) continue;
            shortest = std::min(shortest, std::hypot(x[3 * std::size_t(w)] - interior.p[0],
                                                     x[3 * std::size_t(w) + 1] - interior.p[1],
                                                     x[3 * std::size_t(w) + 2] - interior.p[2]));
          }
        interior.step = 0.25 * shortest;
      }
      BoundaryDof& dof = d < 0 ? interior : dofs[std::size_t(d)];
      if (dof.dims <= 0 || !(dof.step > 0)) continue;
      Score cur = score(v);
      if (cur.bad == 0 && widen && cur.min_sj > 0.2) continue;  // a healthy neighbour stays
      double* xv = &x[3 * std::size_t(v)];
      const double old_x[3] = {xv[0], xv[1], xv[2]};
      // Starting at twice the dof's step: a sliver across a sharp edge may need its vertex to
      // pass the next source vertex.
      double step = 2 * dof.step;
      const double min_step = dof.step * std::ldexp(1.0, -12);
      // Compass search: the best of the axis and diagonal directions at the current step,
      // halving the step when none improves.
      constexpr double h = 0.7071067811865476, c = 0.5773502691896258;
      static const double kDirs2[8][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0},  {0, -1, 0},
                                          {h, h, 0}, {-h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
      static const double kDirs3[14][3] = {
          {1, 0, 0},  {-1, 0, 0}, {0, 1, 0},  {0, -1, 0},  {0, 0, 1},   {0, 0, -1},  {c, c, c},
          {-c, c, c}, {c, -c, c}, {c, c, -c}, {-c, -c, c}, {-c, c, -c}, {c, -c, -c}, {-c, -c, -c}};
      const double(*kDirs)[3] = dof.dims == 3 ? kDirs3 : kDirs2;
      const int ndirs = dof.dims == 1 ? 2 : dof.dims == 2 ? 8 : 14;
      for (int it = 0; it < 200 && step >= min_step; ++it) {
        double best_p[3] = {dof.p[0], dof.p[1], dof.p[2]}, best_x[3] = {xv[0], xv[1], xv[2]};
        Score best = cur;
        bool found = false;
        for (int k = 0; k < ndirs; ++k) {
          double p[3] = {dof.p[0] + step * kDirs[k][0], dof.p[1] + step * kDirs[k][1],
                         dof.p[2] + step * kDirs[k][2]};
          if (dof.dims == 1) {
            // Strictly between the neighbours along the path (their current parameters).
            const double margin = 1e-3 * dof.step;
            const double lo = dof.prev >= 0
                                  ? std::max(dof.lo, dofs[std::size_t(dof.prev)].p[0] + margin)
                                  : dof.lo;
            const double hi = dof.next >= 0
                                  ? std::min(dof.hi, dofs[std::size_t(dof.next)].p[0] - margin)
                                  : dof.hi;
            if (!(lo < hi)) continue;
            p[0] = std::clamp(p[0], lo, hi);
            p[1] = dof.p[1];
            if (p[0] == dof.p[0]) continue;
          }
          double y[3] = {p[0], p[1], p[2]};
          if (dof.dims < 3 && !place(dof, p, y)) continue;
          const double keep[3] = {xv[0], xv[1], xv[2]};
          for (int a = 0; a < 3; ++a) xv[a] = y[a];
          const Score s = score(v);
          for (int a = 0; a < 3; ++a) xv[a] = keep[a];
          if (s.better_than(best)) {
            best = s;
            found = true;
            for (int a = 0; a < 3; ++a) best_p[a] = p[a];
            for (int a = 0; a < 3; ++a) best_x[a] = y[a];
          }
        }
        if (!found) {
          step *= 0.5;
          continue;
        }
        for (int a = 0; a < 3; ++a) dof.p[a] = best_p[a];
        for (int a = 0; a < 3; ++a) xv[a] = best_x[a];
        cur = best;
        // Untangled and no longer near flat: stop early (the interior solve follows).
        if (cur.bad == 0 && cur.min_sj > 0.2) break;
      }
      if (d >= 0 && (xv[0] != old_x[0] || xv[1] != old_x[1] || xv[2] != old_x[2]))
        moved[std::size_t(d)] = 1;
    }
    const std::size_t now = count_inverted();
    widen = !(now < r.inverted_after);
    r.inverted_after = now;
  }
  for (char m : moved) r.moved += m ? 1 : 0;
  return r;
}

}  // namespace cadinterp::mapping
