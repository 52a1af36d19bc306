// Times the linear solvers of cadinterp_physics on box meshes of growing size (the measurement
// behind default_solver() in physics_linear_solver.cpp; its tables are in docs/physics-solvers.md).
// Usage: physics_solver_bench [max_vertices (default 60000)] [repeats (default 1)] [only (elastic|
// thermal)] [skip solvers slower than this many seconds at the previous size (default 5)]
// [min_vertices (default 0)] [solver name, e.g. cg-two-level (default: all)]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>

#include "physics_internal.h"
#include "physics_test_meshes.h"

using namespace cadinterp::physics;
using namespace cadinterp::physics::testing;

namespace {

struct Case {
  const char* physics;
  int order;
};

}  // namespace

int main(int argc, char** argv) {
  const double max_vertices = argc > 1 ? std::atof(argv[1]) : 60000;
  const int repeats = argc > 2 ? std::atoi(argv[2]) : 1;
  const std::string only = argc > 3 ? argv[3] : "";
  const double give_up = argc > 4 ? std::atof(argv[4]) : 5.0;
  const double min_vertices = argc > 5 ? std::atof(argv[5]) : 0.0;
  const std::string only_solver = argc > 6 ? argv[6] : "";
  const detail::SolverKind kinds[] = {detail::SolverKind::cholmod_supernodal,
                                      detail::SolverKind::cholmod_simplicial,
                                      detail::SolverKind::eigen_simplicial_ldlt,
                                      detail::SolverKind::cg_incomplete_cholesky,
                                      detail::SolverKind::cg_jacobi,
                                      detail::SolverKind::cg_two_level};
  const Case cases[] = {{"elastic", 1}, {"elastic", 2}, {"thermal", 1}, {"thermal", 2}};
  std::printf("%-8s %5s %8s %9s %-20s %9s %9s %9s %6s %12s\n", "physics", "order", "vertices",
              "dofs", "solver", "assemble", "solve", "cpu", "iters", "max|u|");
  for (const Case& c : cases) {
    if (!only.empty() && only != c.physics) continue;
    double previous[6] = {0, 0, 0, 0, 0, 0};
    for (int n : {4, 6, 8, 11, 14, 18, 21, 23, 26}) {
      const double vertices = (2.0 * n + 1) * (n + 1) * (n + 1);
      if (vertices > max_vertices) break;
      if (vertices < min_vertices) continue;
      // Order 2 has ~8x the nodes: stop it at a quarter of the vertex budget.
      if (c.order == 2 && vertices > max_vertices / 4) break;
      const Problem p = bar_problem(n, std::string(c.physics) == "elastic", c.order);
      for (int ki = 0; ki < 6; ++ki) {
        const detail::SolverKind kind = kinds[ki];
        if (previous[ki] > give_up) continue;  // a size up would take minutes
        if (!only_solver.empty() && only_solver != detail::solver_name(kind)) continue;
        double assemble = 1e300, solve = 1e300, cpu = 1e300;
        Solution s;
        for (int r = 0; r < repeats; ++r) {
          // Process CPU time as well as wall time: on a shared machine the wall time includes
          // waiting for a core, the CPU time does not (solve() is single-threaded, CHOLMOD's
          // OpenMP team aside).
          const std::clock_t c0 = std::clock();
          s = detail::solve_with(p, &kind);
          cpu = std::min(cpu, static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
          assemble = std::min(assemble, s.assemble_seconds);
          solve = std::min(solve, s.solve_seconds);
        }
        previous[ki] = solve;
        double umax = 0;
        for (double v : c.physics[0] == 'e' ? s.displacement : s.temperature) {
          umax = std::max(umax, std::abs(v));
        }
        std::printf("%-8s %5d %8.0f %9zu %-20s %9.4f %9.4f %9.4f %6d %12.6e\n", c.physics, c.order,
                    vertices, s.dofs, s.solver.c_str(), assemble, solve, cpu, s.iterations, umax);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
