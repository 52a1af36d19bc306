#include "mapping/interior_solve.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>

#include "mapping/foldover_free.h"
#include "mapping/mapping_state.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

namespace {

// Above this many interior vertices the solve is iterative (see harmonic_interior).
constexpr int kDirectUnknowns = 3000;

// Gradients of the four P1 hat functions of tet (p0..p3) times 6V, and 6V (signed).
double hat_gradients(const double* p[4], double g[4][3]) {
  double e[3][3];
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a) e[i][a] = p[i + 1][a] - p[0][a];
  auto cross = [](const double* u, const double* v, double* out) {
    out[0] = u[1] * v[2] - u[2] * v[1];
    out[1] = u[2] * v[0] - u[0] * v[2];
    out[2] = u[0] * v[1] - u[1] * v[0];
  };
  cross(e[1], e[2], g[1]);
  cross(e[2], e[0], g[2]);
  cross(e[0], e[1], g[3]);
  const double det = e[0][0] * g[1][0] + e[0][1] * g[1][1] + e[0][2] * g[1][2];
  for (int a = 0; a < 3; ++a) g[0][a] = -(g[1][a] + g[2][a] + g[3][a]);
  return det;
}

}  // namespace

bool harmonic_interior(const std::vector<double>& vertices, const std::vector<std::uint32_t>& tets,
                       const std::vector<char>& fixed, std::vector<double>& mapped,
                       std::string& why, double stiffening) {
  const std::size_t V = vertices.size() / 3, T = tets.size() / 4;
  std::vector<int> unknown(V, -1);
  int m = 0;
  for (std::size_t v = 0; v < V; ++v)
    if (!fixed[v]) unknown[v] = m++;
  if (m == 0) return true;
  double mean_volume = 0;
  if (stiffening > 0) {
    for (std::size_t t = 0; t < T; ++t) {
      const double* p[4];
      for (int i = 0; i < 4; ++i) p[i] = &vertices[3 * std::size_t(tets[4 * t + std::size_t(i)])];
      double g[4][3];
      mean_volume += std::fabs(hat_gradients(p, g));
    }
    mean_volume /= double(T);
  }
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(16 * T);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(m, 3);
  for (std::size_t t = 0; t < T; ++t) {
    const std::uint32_t* q = &tets[4 * t];
    const double* p[4];
    for (int i = 0; i < 4; ++i) p[i] = &vertices[3 * std::size_t(q[i])];
    double g[4][3];
    const double det = hat_gradients(p, g);
    if (det == 0) continue;
    // Stiffness K_ij = V grad(phi_i).grad(phi_j) = (g_i.g_j) / (36 V) with g = 6V grad phi.
    double scale = 1.0 / (6.0 * std::fabs(det));
    if (stiffening > 0) scale *= std::pow(mean_volume / std::fabs(det), stiffening);
    for (int i = 0; i < 4; ++i) {
      const int ui = unknown[q[i]];
      if (ui < 0) continue;
      for (int j = 0; j < 4; ++j) {
        const double k = scale * (g[i][0] * g[j][0] + g[i][1] * g[j][1] + g[i][2] * g[j][2]);
        const int uj = unknown[q[j]];
        if (uj >= 0) {
          trip.emplace_back(ui, uj, k);
        } else {
          for (int a = 0; a < 3; ++a)
            rhs(ui, a) -= k * (mapped[3 * std::size_t(q[j]) + std::size_t(a)] -
                               vertices[3 * std::size_t(q[j]) + std::size_t(a)]);
        }
      }
    }
  }
  Eigen::SparseMatrix<double> K(m, m);
  K.setFromTriplets(trip.begin(), trip.end());
  Eigen::MatrixXd d;
  bool solved = false;
  if (m > kDirectUnknowns) {
    // Large meshes: the direct factor's fill grows like m^(4/3) in 3D, so conjugate gradients
    // (sequential, hence deterministic) with an incomplete Cholesky preconditioner; the direct
    // solve remains the fallback.
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper,
                             Eigen::IncompleteCholesky<double>>
        cg;
    cg.setTolerance(1e-12);
    cg.setMaxIterations(4 * m);
    cg.compute(K);
    if (cg.info() == Eigen::Success) {
      d = cg.solve(rhs);
      solved = cg.info() == Eigen::Success;
    }
  }
  if (!solved) {
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
    ldlt.compute(K);
    if (ldlt.info() != Eigen::Success) {
      why = "interior solve: factorization of the P1 Laplacian failed";
      return false;
    }
    d = ldlt.solve(rhs);
  }
  for (std::size_t v = 0; v < V; ++v) {
    const int u = unknown[v];
    if (u < 0) continue;
    for (int a = 0; a < 3; ++a) {
      const double x = vertices[3 * v + std::size_t(a)] + d(u, a);
      if (!std::isfinite(x)) {
        why = "interior solve: non-finite solution";
        return false;
      }
      mapped[3 * v + std::size_t(a)] = x;
    }
  }
  return true;
}

bool incremental_interior(const std::vector<double>& vertices,
                          const std::vector<std::uint32_t>& tets, const std::vector<char>& fixed,
                          std::vector<double>& mapped, std::string& why, int steps,
                          double stiffening) {
  if (steps <= 1) return harmonic_interior(vertices, tets, fixed, mapped, why, stiffening);
  const std::size_t V = vertices.size() / 3;
  std::vector<double> current = vertices, next = vertices;
  for (int s = 1; s <= steps; ++s) {
    const double f = double(s) / double(steps);
    for (std::size_t v = 0; v < V; ++v)
      if (fixed[v])
        for (std::size_t a = 0; a < 3; ++a)
          next[3 * v + a] =
              s == steps ? mapped[3 * v + a]  // exactly the boundary data
                         : vertices[3 * v + a] + f * (mapped[3 * v + a] - vertices[3 * v + a]);
    if (!harmonic_interior(current, tets, fixed, next, why, stiffening)) return false;
    current = next;
  }
  mapped = std::move(current);
  return true;
}

double six_volume(const std::vector<double>& x, const std::uint32_t* t) {
  const double* p[4];
  for (int i = 0; i < 4; ++i) p[i] = &x[3 * std::size_t(t[i])];
  double a[3], b[3], c[3];
  for (int k = 0; k < 3; ++k) {
    a[k] = p[1][k] - p[0][k];
    b[k] = p[2][k] - p[0][k];
    c[k] = p[3][k] - p[0][k];
  }
  return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
         a[2] * (b[0] * c[1] - b[1] * c[0]);
}

double min_six_volume(const std::vector<double>& vertices) {
  const double diag = mesh::bbox_diagonal(vertices);
  return 1e-12 * diag * diag * diag;
}

TetQuality tet_quality(const std::vector<double>& vertices,
                       const std::vector<std::uint32_t>& tets) {
  TetQuality q;
  const std::size_t T = tets.size() / 4;
  // The rule of mesh::validate: 6 V above 1e-12 diag^3.
  const double min_six = min_six_volume(vertices);
  for (std::size_t t = 0; t < T; ++t) {
    const double* p[4];
    for (int i = 0; i < 4; ++i) p[i] = &vertices[3 * std::size_t(tets[4 * t + std::size_t(i)])];
    double g[4][3];
    const double det = hat_gradients(p, g);
    if (!(det > min_six)) ++q.inverted;
    for (int i = 0; i < 4; ++i) {
      double prod = 1;
      for (int j = 0; j < 4; ++j) {
        if (j == i) continue;
        double l2 = 0;
        for (int a = 0; a < 3; ++a) l2 += (p[j][a] - p[i][a]) * (p[j][a] - p[i][a]);
        prod *= std::sqrt(l2);
      }
      const double sj = prod > 0 ? std::sqrt(2.0) * det / prod : -1.0;
      q.min_scaled_jacobian = std::min(q.min_scaled_jacobian, sj);
    }
  }
  return q;
}

namespace {

// Local untangling after the harmonic interior (§6.2 (interior mapping)): a large shape change can
// leave a few slivers of a host's mesh inverted (measured on the OpenCASCADE wrench: 1 or 2 of
// ~13000 tets over random pairs across the whole box). Each interior vertex of an inverted tet is
// moved to the mean of its tet neighbours' positions, in a fixed order, and the move is kept only
// when it leaves fewer inverted tets around that vertex and inverts none that was valid. Boundary
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

// One interior solve for the surface map in st.surface_map: `steps` boundary increments with
// this stiffening, then the local untangling where tets are inverted.
bool solve_once(MappingState& st, int steps, double stiffening, TetQuality& q) {
  const auto& canonical = st.canonical;
  const auto& on_surface = st.on_surface;
  const auto& surface_map = st.surface_map;
  auto& out = st.out;
  auto& why = st.why;
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
}

}  // namespace

// Regions folded over as a whole (foldover_free.h): the interior vertices near the tets still
// inverted move together; kept when fewer stay inverted. All calls of one mapping share
// MapOptions::foldover_free_evaluations.
void untangle_whole(MappingState& st, TetQuality& q) {
  const auto& canonical = st.canonical;
  const auto& on_surface = st.on_surface;
  auto& out = st.out;
  auto& foldover_budget = st.foldover_budget;
  if (foldover_budget <= 0) return;
  FoldoverFreeOptions fo;
  fo.max_evaluations = foldover_budget;
  const FoldoverFreeResult r =
      untangle_foldover_free(canonical.vertices, canonical.tets, on_surface,
                             min_six_volume(out.vertices), out.vertices, fo);
  foldover_budget -= r.evaluations;
  if (r.inverted_after < r.inverted_before) q = tet_quality(out.vertices, canonical.tets);
}

// §6.2 (interior mapping): the interior follows: the P1-harmonic solve (exact on affine maps),
// untangled; where tets stay inverted, once more in MapOptions::fallback_steps boundary increments
// with volume-stiffened tets (measured on the OpenCASCADE wrench, 10 random pairs: one harmonic
// solve 5 mapped, 4 increments alone 5, stiffening alone 5 (exponent 1) or 4 (2), both 8).
bool solve_interior(MappingState& st, TetQuality& q) {
  const auto& options = st.options;
  auto& out = st.out;
  if (!solve_once(st, options.interior_steps, options.stiffening, q)) return false;
  if (q.inverted > 0 && options.fallback_steps > 0) {
    const std::vector<double> first = out.vertices;
    TetQuality q2;
    if (!solve_once(st, options.fallback_steps, options.fallback_stiffening, q2)) return false;
    if (q2.inverted < q.inverted) {
      q = q2;
    } else {
      out.vertices = first;
    }
  }
  if (q.inverted > 0 && options.foldover_free && options.foldover_free_early) untangle_whole(st, q);
  return true;
}

}  // namespace cadinterp::mapping
