// Two-level preconditioned conjugate gradient: Jacobi plus a coarse correction on aggregates of
// nodes, whose coarse space holds each aggregate's rigid-body modes (elasticity: 3 translations,
// 3 rotations) or its constant (heat), smoothed once by damped Jacobi (smoothed aggregation,
// Vanek-Mandel-Brezina 1996). Additive: M^-1 r = D^-1 r + P (P^T K P)^-1 P^T r, SPD for any P.
// The coarse space carries the low-energy modes (bending of the whole part) that make
// Jacobi-CG's iteration count grow like 1/h: ~80 iterations instead of ~700 at 40k unknowns.
// (A symmetric multiplicative cycle took fewer iterations, ~45, but two extra products with K
// per iteration made it slower; see README.md.)
#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "physics_internal.h"

namespace cadinterp::physics::detail {
namespace {

// Nodes per aggregate: measured on the cantilever box (physics_solver_bench): 50 gives a
// coarse matrix too large to factor cheaply, 300 too few modes (iterations double).
constexpr std::size_t kNodesPerAggregate = 100;

}  // namespace

LinearSolveResult solve_two_level(const SparseMatrix& K, const Eigen::VectorXd& f,
                                  const NodeGraph& graph, const std::vector<double>& nodes,
                                  int components, double tolerance) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = graph.start.size() - 1;
  const auto c = static_cast<std::size_t>(components);
  // Aggregates: the nodes in each cell of a regular grid sized for ~kNodesPerAggregate nodes
  // per non-empty cell (a few bisection steps on the cell size): a coarse space small enough for
  // a cheap sparse Cholesky, rich enough (6 modes each) to carry the global bending.
  const std::size_t wanted = std::max<std::size_t>(1, n / kNodesPerAggregate);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (std::size_t i = 0; i < n; ++i) {
    lo = lo.cwiseMin(Eigen::Map<const Eigen::Vector3d>(&nodes[3 * i]));
    hi = hi.cwiseMax(Eigen::Map<const Eigen::Vector3d>(&nodes[3 * i]));
  }
  std::vector<std::int32_t> label(n);
  std::int32_t count2 = 0;
  {
    std::vector<std::uint64_t> keys(n), sorted;
    double cell = (hi - lo).maxCoeff() + 1e-300;
    double lo_cell = 0, hi_cell = cell;  // cells too small (many) .. too big (few)
    for (int step = 0; step < 9; ++step) {
      for (std::size_t i = 0; i < n; ++i) {
        std::uint64_t key = 0;
        for (int k = 0; k < 3; ++k) {
          key = key * 2097152u +
                static_cast<std::uint64_t>((nodes[3 * i + k] - lo[k]) / cell) % 2097152u;
        }
        keys[i] = key;
      }
      sorted = keys;
      std::sort(sorted.begin(), sorted.end());
      sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
      if (step == 8) break;
      if (sorted.size() > wanted) {
        lo_cell = cell;
      } else {
        hi_cell = cell;
      }
      cell = lo_cell > 0 ? 0.5 * (lo_cell + hi_cell) : 0.5 * hi_cell;
    }
    for (std::size_t i = 0; i < n; ++i) {
      label[i] = static_cast<std::int32_t>(std::lower_bound(sorted.begin(), sorted.end(), keys[i]) -
                                           sorted.begin());
    }
    count2 = static_cast<std::int32_t>(sorted.size());
  }
  // Members and centroid of each aggregate.
  std::vector<std::vector<std::uint32_t>> members(static_cast<std::size_t>(count2));
  for (std::size_t i = 0; i < n; ++i) members[label[i]].push_back(static_cast<std::uint32_t>(i));
  const int modes = components == 3 ? 6 : 1;
  // Tentative prolongator: each aggregate's modes, orthonormalized (QR) and with dependent
  // ones (an aggregate on a line has no rotation about it) dropped.
  std::vector<Eigen::Triplet<double, int>> triplets;
  int columns = 0;
  for (const auto& group : members) {
    const auto rows = static_cast<Eigen::Index>(group.size() * c);
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(rows, modes);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (std::uint32_t i : group) centre += Eigen::Map<const Eigen::Vector3d>(&nodes[3 * i]);
    centre /= static_cast<double>(group.size());
    double radius = 0.0;
    for (std::uint32_t i : group) {
      radius = std::max(radius, (Eigen::Map<const Eigen::Vector3d>(&nodes[3 * i]) - centre).norm());
    }
    if (!(radius > 0)) radius = 1.0;  // a single node: only its translations survive the QR
    for (std::size_t m = 0; m < group.size(); ++m) {
      const auto r0 = static_cast<Eigen::Index>(m * c);
      if (components == 1) {
        B(r0, 0) = 1.0;
        continue;
      }
      // Offsets in units of the aggregate's radius: the QR rank test is then unit-free.
      const Eigen::Vector3d d =
          (Eigen::Map<const Eigen::Vector3d>(&nodes[3 * group[m]]) - centre) / radius;
      for (int k = 0; k < 3; ++k) {
        B(r0 + k, k) = 1.0;
        const Eigen::Vector3d rot = Eigen::Vector3d::Unit(k).cross(d);
        for (int i = 0; i < 3; ++i) B(r0 + i, 3 + k) = rot[i];
      }
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(B);
    qr.setThreshold(1e-8);
    const auto rank = qr.rank();
    const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(rows, rank);
    for (std::size_t m = 0; m < group.size(); ++m) {
      for (std::size_t i = 0; i < c; ++i) {
        const auto row = static_cast<Eigen::Index>(m * c + i);
        for (Eigen::Index j = 0; j < rank; ++j) {
          triplets.emplace_back(static_cast<int>(group[m] * c + i), columns + static_cast<int>(j),
                                Q(row, j));
        }
      }
    }
    columns += static_cast<int>(rank);
  }
  SparseMatrix P(K.rows(), columns);
  P.setFromTriplets(triplets.begin(), triplets.end());
  // Smoothed aggregation: P = (I - omega D^-1 K) P_tent lowers the energy of the coarse
  // functions (Vanek, Mandel, Brezina 1996), omega = 4 / (3 rho(D^-1 K)) with rho estimated
  // by 6 power iterations (enough: any P gives an SPD preconditioner).
  const Eigen::VectorXd inv_diag = K.diagonal().cwiseInverse();
  double rho = 0.0;
  {
    Eigen::VectorXd v = Eigen::VectorXd::Ones(K.rows());
    for (int i = 0; i < 6; ++i) {
      const Eigen::VectorXd w = inv_diag.cwiseProduct(K * v);
      rho = w.norm() / v.norm();
      v = w / w.norm();
    }
  }
  const double omega = 4.0 / (3.0 * rho);
  const SparseMatrix KPt = K * P;
  const SparseMatrix DKP = inv_diag.asDiagonal() * KPt;
  P = P - omega * DKP;
  P.prune(0.0);
  const SparseMatrix Pt = P.transpose();
  const SparseMatrix Kc = Pt * (K * P);
  Eigen::SimplicialLLT<SparseMatrix> coarse(Kc);
  if (coarse.info() != Eigen::Success) {
    throw Error("physics: singular system: the coarse matrix is not positive definite");
  }
  // Every vector is allocated once: a 60k-unknown vector is 0.5 MB, which glibc maps and
  // unmaps (page faults included) on each temporary.
  Eigen::VectorXd coarse_r(Pt.rows()), coarse_x(Pt.rows());
  auto precondition = [&](const Eigen::VectorXd& res, Eigen::VectorXd& out) {
    out = inv_diag.cwiseProduct(res);
    coarse_r.noalias() = Pt * res;
    coarse_x = coarse.solve(coarse_r);
    out.noalias() += P * coarse_x;
  };
  // Preconditioned CG (the textbook loop; Eigen's needs a preconditioner class).
  LinearSolveResult result;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(f.size());
  Eigen::VectorXd r = f;
  Eigen::VectorXd z(f.size()), q(f.size());
  const double target = tolerance * f.norm();
  precondition(r, z);
  Eigen::VectorXd p = z;
  double rz = r.dot(z);
  const int max_iterations = static_cast<int>(std::max<Eigen::Index>(1000, f.size()));
  int it = 0;
  for (; it < max_iterations && r.norm() > target; ++it) {
    q.noalias() = K * p;
    const double pq = p.dot(q);
    if (!(pq > 0)) {
      throw Error("physics: singular system: conjugate gradient met a non-positive curvature");
    }
    const double alpha = rz / pq;
    x += alpha * p;
    r -= alpha * q;
    precondition(r, z);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  if (!(r.norm() <= target) || !x.allFinite()) {
    throw Error("physics: two-level conjugate gradient did not converge in " + std::to_string(it) +
                " iterations (singular system?)");
  }
  result.x = std::move(x);
  result.iterations = it;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace cadinterp::physics::detail
