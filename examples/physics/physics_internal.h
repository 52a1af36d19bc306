// Internals of cadinterp_physics shared by its sources, the benchmark and the convergence report:
// the discretization (order-1/2 nodes), the sparse system layout and the linear solvers.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "physics.h"

namespace cadinterp::physics::detail {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

/// The FE nodes of a validated mesh. Order 1: the mesh vertices. Order 2: the vertices followed by
/// one node per tet edge (at its midpoint: straight-sided, affine tets).
struct Discretization {
  int order = 1;
  std::size_t vertex_count = 0;
  std::size_t node_count = 0;
  std::vector<double> nodes;  ///< #N by 3 node positions (the first #V are the vertices)
  int nodes_per_element = 4;  ///< 4 or 10
  /// #T by nodes_per_element: corners 0-3, then edges (01, 12, 20, 03, 13, 23)
  std::vector<std::uint32_t> elements;
  int nodes_per_face = 3;  ///< 3 or 6
  /// #F by nodes_per_face: corners 0-2, then edges (01, 12, 20)
  std::vector<std::uint32_t> faces;
  std::vector<std::int32_t> face_tags;  ///< #F
  std::size_t element_count() const { return elements.size() / nodes_per_element; }
  std::size_t face_count() const { return face_tags.size(); }
};

/// Validates the mesh (sizes, indices, finiteness, tet volumes, boundary triangles being
/// outward tet faces) and builds the nodes of `order`. Throws Error naming the problem.
Discretization discretize(const TetMesh& mesh, int order);

/// The triangles (face indices) carrying any of `tags`; throws Error naming `what` and the first
/// tag that no triangle carries.
std::vector<std::uint32_t> faces_with_tags(const Discretization& d,
                                           const std::vector<std::int32_t>& tags, const char* what);

/// Node adjacency (each node's sorted neighbours including itself), CSR.
struct NodeGraph {
  std::vector<std::size_t> start;        ///< #N+1
  std::vector<std::uint32_t> neighbors;  ///< start[#N]
};
NodeGraph node_graph(const Discretization& d);

/// A symmetric system with `components` unknowns per node (3 elastic, 1 thermal), dof =
/// node * components + component, stored as a full (both triangles) CSC matrix whose pattern is
/// the node graph expanded by components. Element matrices are scattered straight into the
/// values (no triplet list: a 20k-vertex P1 elastic problem would need 14M triplets, ~230 MB,
/// and setFromTriplets' sort; the closed-form column offsets make the scatter a binary search).
class System {
 public:
  System(const NodeGraph& graph, int components);
  /// Position in values of entry (row dof of node a comp i, column dof of node b comp j).
  std::size_t position(std::uint32_t a, int i, std::uint32_t b, int j) const;
  /// Adds an element matrix Ke (n*c by n*c, row-major, local dof = local node * c + comp).
  void add_element(const std::uint32_t* element_nodes, int n, const double* Ke);
  /// Prescribes dof values (Dirichlet): the rows/columns are replaced by diag(K_ii) u_i =
  /// K_ii g_i with the right-hand side corrected, so the matrix stays SPD and well scaled.
  /// Keeps the original rows to compute reactions afterwards.
  void constrain(const std::vector<std::uint8_t>& is_fixed, const Eigen::VectorXd& values);
  /// K_original u - f_original at each constrained dof (in the order of constrained_dofs()).
  Eigen::VectorXd constrained_residual(const Eigen::VectorXd& u) const;
  const std::vector<std::size_t>& constrained_dofs() const { return fixed_dofs_; }

  SparseMatrix K;
  Eigen::VectorXd f;  ///< right-hand side

 private:
  const NodeGraph& graph_;
  int c_;
  std::vector<std::size_t> fixed_dofs_;
  std::vector<std::vector<std::pair<int, double>>> fixed_rows_;  // original row of each
  std::vector<double> fixed_rhs_;
};

/// Which linear solver (more than LinearSolver offers, for the benchmark).
enum class SolverKind {
  cholmod_supernodal,
  cholmod_simplicial,
  eigen_simplicial_ldlt,
  cg_incomplete_cholesky,
  cg_jacobi,
  cg_two_level,  ///< CG with Jacobi + an aggregation coarse space of rigid-body modes
};
const char* solver_name(SolverKind kind);
/// The default for a system of `dofs` unknowns (measured; see physics_linear_solver.cpp).
SolverKind default_solver(std::size_t dofs);
struct LinearSolveResult {
  Eigen::VectorXd x;
  int iterations = 0;
  double seconds = 0.0;
};
/// What the two-level preconditioner needs besides the matrix: the node graph and positions.
struct NodeSpace {
  const NodeGraph* graph = nullptr;
  const std::vector<double>* nodes = nullptr;  ///< #N by 3
  int components = 1;
};
/// Solves K x = f (K SPD, both triangles stored). Throws Error when K is not positive definite
/// or CG does not converge.
LinearSolveResult solve_linear(const SparseMatrix& K, const Eigen::VectorXd& f, SolverKind kind,
                               double cg_tolerance, const NodeSpace& space);
/// The cg_two_level solver (physics_two_level.cpp).
LinearSolveResult solve_two_level(const SparseMatrix& K, const Eigen::VectorXd& f,
                                  const NodeGraph& graph, const std::vector<double>& nodes,
                                  int components, double tolerance);

/// solve() with the linear solver forced to `*forced` (nullptr: as solve() picks), for the
/// benchmark.
/// The stresses at the vertices (#V by 6) from each tet's stress at its four corners
/// (`corner`: #T by 4 by 6, the element's field is linear between them) and the tet volumes, by
/// `recovery` (physics_recovery.cpp). Throws Error if the projection's CG does not converge.
std::vector<double> recover_vertex_stress(const Discretization& d,
                                          const std::vector<double>& corner,
                                          const std::vector<double>& volume,
                                          StressRecovery recovery);

Solution solve_with(const Problem& problem, const SolverKind* forced);

}  // namespace cadinterp::physics::detail
