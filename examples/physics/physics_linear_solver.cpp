// Linear solvers for the SPD FE systems: CHOLMOD (direct) and Eigen's conjugate gradient.
#ifdef CADINTERP_PHYSICS_HAVE_CHOLMOD
#include <Eigen/CholmodSupport>
#endif
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>

#include <chrono>
#include <string>
#include <type_traits>

#include "physics_internal.h"

namespace cadinterp::physics::detail {

const char* solver_name(SolverKind kind) {
#ifndef CADINTERP_PHYSICS_HAVE_CHOLMOD
  if (kind == SolverKind::cholmod_supernodal || kind == SolverKind::cholmod_simplicial) {
    return "eigen-ldlt";  // built without CHOLMOD: the fallback in solve_linear
  }
#endif
  switch (kind) {
    case SolverKind::cholmod_supernodal:
      return "cholmod";
    case SolverKind::cholmod_simplicial:
      return "cholmod-simplicial";
    case SolverKind::eigen_simplicial_ldlt:
      return "eigen-ldlt";
    case SolverKind::cg_incomplete_cholesky:
      return "eigen-cg-ichol";
    case SolverKind::cg_jacobi:
      return "eigen-cg-jacobi";
    case SolverKind::cg_two_level:
      return "cg-two-level";
  }
  return "unknown";
}

// The choice by size follows physics_solver_bench's table of every solver at every size
// (docs/physics-solvers.md, "Every solver by size": cantilever box 2:1:1 clamped at one end, CG
// to relative residual 1e-10, Debian's reference BLAS under CHOLMOD). 3D meshes give a direct
// factor O(n^2) flops (large separators) and the reference BLAS gives CHOLMOD's supernodal
// kernels little (even with OpenBLAS it stays 9-19x slower than the two-level CG at host sizes),
// so the iterative solvers win from ~1k unknowns on; of those the two-level one (iterations ~100
// instead of ~1/h) wins beyond a few thousand and is never far behind below. Under 1000 unknowns
// every solver takes milliseconds and a direct one is exact: Eigen's SimplicialLDLT, as fast
// there as CHOLMOD's simplicial (0.0027 s at 675 unknowns) and 10x faster than its supernodal
// one (whose OpenMP team, 4 threads in Debian's build, costs more than the factorization at that
// size, and would run inside the builder's own worker threads).
SolverKind default_solver(std::size_t dofs) {
  return dofs < 1000 ? SolverKind::eigen_simplicial_ldlt : SolverKind::cg_two_level;
}

namespace {

template <typename Direct>
Eigen::VectorXd solve_direct(const SparseMatrix& K, const Eigen::VectorXd& f, const char* name) {
  Direct solver;
#ifdef CADINTERP_PHYSICS_HAVE_CHOLMOD
  // CHOLMOD prints its own warning for a non-positive-definite matrix; we throw a named Error.
  if constexpr (std::is_base_of_v<Eigen::CholmodBase<SparseMatrix, Eigen::Lower, Direct>, Direct>) {
    solver.cholmod().print = 0;
  }
#endif
  solver.compute(K);
  if (solver.info() != Eigen::Success) {
    throw Error(std::string("physics: singular system: ") + name +
                " found the matrix not positive definite (missing fixtures or conditions?)");
  }
  Eigen::VectorXd x = solver.solve(f);
  if (solver.info() != Eigen::Success || !x.allFinite()) {
    throw Error(std::string("physics: singular system: ") + name + " solve failed");
  }
  return x;
}

template <typename Preconditioner>
Eigen::VectorXd solve_cg(const SparseMatrix& K, const Eigen::VectorXd& f, double tolerance,
                         int& iterations) {
  Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower | Eigen::Upper, Preconditioner> cg;
  cg.setTolerance(tolerance);
  cg.setMaxIterations(static_cast<Eigen::Index>(std::max<Eigen::Index>(1000, K.rows())));
  cg.compute(K);
  if (cg.info() != Eigen::Success) {
    throw Error("physics: conjugate gradient preconditioner failed (matrix not SPD?)");
  }
  Eigen::VectorXd x = cg.solve(f);
  iterations = static_cast<int>(cg.iterations());
  if (cg.info() != Eigen::Success || !x.allFinite()) {
    throw Error("physics: conjugate gradient did not converge in " +
                std::to_string(cg.iterations()) + " iterations (residual " +
                std::to_string(cg.error()) + "; singular system?)");
  }
  return x;
}

}  // namespace

LinearSolveResult solve_linear(const SparseMatrix& K, const Eigen::VectorXd& f, SolverKind kind,
                               double cg_tolerance, const NodeSpace& space) {
  const auto start = std::chrono::steady_clock::now();
  LinearSolveResult r;
  if (f.size() == 0 || f.isZero(0.0)) {
    r.x = Eigen::VectorXd::Zero(f.size());  // unloaded: skip the factorization
  } else {
    switch (kind) {
#ifdef CADINTERP_PHYSICS_HAVE_CHOLMOD
      case SolverKind::cholmod_supernodal:
        r.x =
            solve_direct<Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>>(K, f, "cholmod");
        break;
      case SolverKind::cholmod_simplicial:
        r.x = solve_direct<Eigen::CholmodSimplicialLLT<SparseMatrix, Eigen::Lower>>(
            K, f, "cholmod-simplicial");
        break;
#else
      case SolverKind::cholmod_supernodal:  // built without CHOLMOD: see CMakeLists.txt
      case SolverKind::cholmod_simplicial:
#endif
      case SolverKind::eigen_simplicial_ldlt:
        r.x = solve_direct<Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower>>(K, f, "eigen-ldlt");
        break;
      case SolverKind::cg_incomplete_cholesky:
        r.x = solve_cg<Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>>(
            K, f, cg_tolerance, r.iterations);
        break;
      case SolverKind::cg_jacobi:
        r.x = solve_cg<Eigen::DiagonalPreconditioner<double>>(K, f, cg_tolerance, r.iterations);
        break;
      case SolverKind::cg_two_level:
        return solve_two_level(K, f, *space.graph, *space.nodes, space.components, cg_tolerance);
    }
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace cadinterp::physics::detail
