// Finite-element physics for the example hosts: linear elasticity, steady heat conduction and
// their one-way thermoelastic coupling on tetrahedral meshes. A host's simulate callback calls
// solve() on the mesh it regenerated; boundary conditions are attached to the mesh's face tags
// (the B-rep faces), so a fixture or a load stays on the same CAD face whatever the mesh.
//
// Units are the caller's, consistent (e.g. mm, N, MPa, K, W). Errors are thrown as
// physics::Error with a message naming the problem (no fixture, an unknown tag, a singular
// system); solve() never returns a partial solution.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace cadinterp::physics {

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A tet mesh as a host regenerates it (cadinterp_host_mesh): positive tets, outward boundary
/// triangles, one face tag per boundary triangle.
struct TetMesh {
  std::vector<double> vertices;             ///< #V by 3
  std::vector<std::uint32_t> tets;          ///< #T by 4
  std::vector<std::uint32_t> triangles;     ///< #F by 3
  std::vector<std::int32_t> triangle_tags;  ///< #F
};

struct Material {
  double youngs_modulus = 210e3;       ///< E (MPa with mm)
  double poisson_ratio = 0.3;          ///< nu, in [0, 0.5)
  double conductivity = 50.0;          ///< k (W/(mm K) or the caller's unit)
  double thermal_expansion = 12e-6;    ///< alpha (1/K)
  double reference_temperature = 0.0;  ///< temperature of zero thermal strain
};

/// Boundary conditions, each on the boundary triangles whose tag is in `tags`.
struct Fixed {  ///< displacement components fixed to zero
  std::vector<std::int32_t> tags;
  bool axes[3] = {true, true, true};  ///< which components (all: a clamp)
};
struct Force {  ///< a total force spread over the region's area as a uniform traction
  std::vector<std::int32_t> tags;
  double force[3] = {0, 0, 0};
};
struct Pressure {  ///< normal pressure, positive pushing into the solid
  std::vector<std::int32_t> tags;
  double pressure = 0.0;
};
struct Temperature {  ///< prescribed temperature (Dirichlet)
  std::vector<std::int32_t> tags;
  double temperature = 0.0;
};
struct HeatFlux {  ///< heat flux into the solid per unit area (Neumann)
  std::vector<std::int32_t> tags;
  double flux = 0.0;
};
struct Convection {  ///< Robin: q = h (T_ambient - T) into the solid
  std::vector<std::int32_t> tags;
  double coefficient = 0.0, ambient = 0.0;
};

/// The linear solver for the (symmetric positive definite) FE systems. `automatic` picks by the
/// measurement behind physics_linear_solver.cpp's default_solver (docs/physics-solvers.md): Eigen's
/// SimplicialLDLT below 1000 unknowns, conjugate_gradient_two_level above.
enum class LinearSolver {
  automatic,
  cholmod,             ///< SuiteSparse CHOLMOD supernodal Cholesky (direct)
  conjugate_gradient,  ///< Eigen ConjugateGradient, Jacobi-preconditioned
  /// CG preconditioned by Jacobi plus a coarse space of per-aggregate rigid-body modes
  /// (smoothed aggregation, two levels): far fewer iterations on large meshes.
  conjugate_gradient_two_level,
};

/// How the stresses reach the mesh vertices (README.md, "Stress recovery").
enum class StressRecovery {
  /// Consistent L2 projection of the element stresses onto the continuous piecewise-linear
  /// field on the vertices: solve M s = int phi sigma_h (M the P1 mass matrix, CG). Converges at
  /// the element's stress order in L2 (order 2 for quadratic tets), boundary vertices included.
  l2_projection,
  /// Volume-weighted average of each tet's stress at its corners: no global solve and no
  /// stability bound; on the measured cases the same order as the projection with larger errors
  /// (README.md, "Stress recovery").
  volume_average,
};

struct Problem {
  TetMesh mesh;
  Material material;
  bool elastic = true;   ///< solve linear elasticity (needs at least one Fixed)
  bool thermal = false;  ///< solve steady conduction (needs Temperature or Convection)
  /// When both are solved, the temperature field loads the elastic problem with the thermal
  /// strain alpha (T - T_ref) I.
  std::vector<Fixed> fixed;
  std::vector<Force> forces;
  std::vector<Pressure> pressures;
  std::vector<Temperature> temperatures;
  std::vector<HeatFlux> heat_fluxes;
  std::vector<Convection> convections;
  int order = 1;  ///< element order: 1 (linear tets) or 2 (quadratic, edge nodes added inside)
  // Appended after the first version of this header (existing fields keep their meaning).
  LinearSolver solver = LinearSolver::automatic;
  double cg_tolerance = 1e-10;  ///< relative residual |K u - f| / |f| for conjugate_gradient
  StressRecovery recovery = StressRecovery::l2_projection;  ///< stresses at the vertices
};

struct Solution {
  std::vector<double> displacement;  ///< #V by 3 (empty unless elastic)
  std::vector<double> von_mises;     ///< #V, from the recovered vertex stresses (Problem::recovery)
  std::vector<double> stress;        ///< #V by 6 (xx, yy, zz, yz, xz, xy) at the vertices
  std::vector<double> temperature;   ///< #V (empty unless thermal)
  // What it cost, for the host's per-stage report.
  std::size_t dofs = 0;
  double assemble_seconds = 0.0, solve_seconds = 0.0;
  std::string solver;  ///< the linear solver used (e.g. "cholmod", "eigen-cg")
  // Appended after the first version of this header.
  /// #fixed by 3: total support reaction force on each Fixed region (order of Problem::fixed),
  /// the force the support exerts on the solid; a fixed component shared by several regions is
  /// counted in the first. With the applied loads they sum to zero (equilibrium).
  std::vector<double> reactions;
  int iterations = 0;  ///< conjugate-gradient iterations of the last solve (0 for a direct one)
};

/// Solves the problem. Throws Error on invalid input or a singular system.
/// Thread-safety: reentrant (no shared state); concurrent calls on different problems are safe.
/// Timing: assemble_seconds covers everything but the linear solves (validation, assembly,
/// stress recovery), solve_seconds the linear solves (factorization or CG, with its setup).
Solution solve(const Problem& problem);

}  // namespace cadinterp::physics
