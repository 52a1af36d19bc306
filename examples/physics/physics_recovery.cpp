// Stress recovery at the mesh vertices (Problem::recovery). The FE stress is discontinuous
// between tets (constant per tet for order 1, linear for order 2); the hosts report one value per
// vertex, so it has to be smoothed onto the vertices.
//
// Default: the consistent L2 projection onto the continuous piecewise-linear field s_h on the
// vertices, i.e. M s = b with M_ab = int phi_a phi_b and b_a = int phi_a sigma_h. Why this one:
// ||sigma - s_h|| <= ||sigma - sigma_h|| + ||sigma - P sigma|| (P is a projection, stable in L2),
// so the recovered field converges at the FE stress's own order, O(h^2) for quadratic tets, and
// the bound holds up to the boundary, where bending stresses peak. The volume-weighted average of
// the tets' corner values (kept as StressRecovery::volume_average) has no such bound; measured on
// the cantilever's surface it converges at the same order 2 for quadratic tets, with errors 25 %
// larger (physics_test). Superconvergent patch recovery would gain an order inside but needs a
// patch of enough tets around every vertex, which boundary vertices of thin parts lack.
// The projection costs one sparse solve with the P1 mass matrix, whose condition number (with
// Jacobi scaling) does not grow with refinement: a few tens of CG iterations per component.
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>

#include <string>
#include <vector>

#include "physics_internal.h"

namespace cadinterp::physics::detail {
namespace {

std::vector<double> volume_average(const Discretization& d, const std::vector<double>& corner,
                                   const std::vector<double>& volume) {
  const std::size_t nv = d.vertex_count;
  const int n = d.nodes_per_element;
  std::vector<double> sum(6 * nv, 0.0), weight(nv, 0.0);
  for (std::size_t e = 0; e < volume.size(); ++e) {
    for (int c = 0; c < 4; ++c) {
      const std::uint32_t v = d.elements[e * n + c];
      for (int k = 0; k < 6; ++k) sum[6 * v + k] += volume[e] * corner[24 * e + 6 * c + k];
      weight[v] += volume[e];
    }
  }
  for (std::size_t v = 0; v < nv; ++v) {
    for (int k = 0; k < 6; ++k) sum[6 * v + k] /= weight[v];
  }
  return sum;
}

std::vector<double> l2_projection(const Discretization& d, const std::vector<double>& corner,
                                  const std::vector<double>& volume) {
  const Eigen::Index nv = static_cast<Eigen::Index>(d.vertex_count);
  const int n = d.nodes_per_element;
  // Element mass matrix of linear tets: int L_a L_b = V (1 + delta_ab) / 20. The stress is
  // linear in the tet (its corner values), so b_a = sum_c Me_ac sigma_c is exact.
  std::vector<Eigen::Triplet<double, int>> triplets;
  triplets.reserve(16 * volume.size());
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(nv, 6);
  for (std::size_t e = 0; e < volume.size(); ++e) {
    const std::uint32_t* el = &d.elements[e * n];
    for (int a = 0; a < 4; ++a) {
      for (int c = 0; c < 4; ++c) {
        const double m = volume[e] * (a == c ? 2.0 : 1.0) / 20.0;
        triplets.emplace_back(static_cast<int>(el[a]), static_cast<int>(el[c]), m);
        for (int k = 0; k < 6; ++k) b(el[a], k) += m * corner[24 * e + 6 * c + k];
      }
    }
  }
  SparseMatrix M(nv, nv);
  M.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower | Eigen::Upper> cg;
  cg.setTolerance(1e-12);
  cg.compute(M);
  std::vector<double> out(6 * static_cast<std::size_t>(nv));
  for (int k = 0; k < 6; ++k) {
    const Eigen::VectorXd s = cg.solve(b.col(k));
    if (cg.info() != Eigen::Success && !(b.col(k).norm() == 0.0)) {
      throw Error("physics: the stress projection's CG did not converge (" +
                  std::to_string(cg.iterations()) + " iterations)");
    }
    for (Eigen::Index v = 0; v < nv; ++v) out[6 * static_cast<std::size_t>(v) + k] = s[v];
  }
  return out;
}

}  // namespace

std::vector<double> recover_vertex_stress(const Discretization& d,
                                          const std::vector<double>& corner,
                                          const std::vector<double>& volume,
                                          StressRecovery recovery) {
  switch (recovery) {
    case StressRecovery::volume_average:
      return volume_average(d, corner, volume);
    case StressRecovery::l2_projection:
      return l2_projection(d, corner, volume);
  }
  throw Error("physics: unknown Problem::recovery");
}

}  // namespace cadinterp::physics::detail
