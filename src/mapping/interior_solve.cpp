#include "mapping/interior_solve.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>

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

}  // namespace cadinterp::mapping
