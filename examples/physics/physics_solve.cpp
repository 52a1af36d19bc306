// solve(): steady heat conduction, linear elasticity and their one-way coupling on order-1 and
// order-2 tets (Galerkin FE, straight-sided elements), boundary conditions by face tag.
#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "physics_internal.h"

namespace cadinterp::physics {
namespace detail {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// ---- Element geometry and shape functions ---------------------------------------------------

/// Affine tet: gradients of the barycentric coordinates (rows of G) and the volume.
struct TetGeometry {
  double G[4][3];
  double volume;
};
TetGeometry tet_geometry(const std::vector<double>& x, const std::uint32_t* q) {
  Eigen::Matrix3d J;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) J(r, c) = x[3 * q[c + 1] + r] - x[3 * q[0] + r];
  }
  const Eigen::Matrix3d Jinv = J.inverse();
  TetGeometry g;
  g.volume = J.determinant() / 6.0;
  for (int c = 0; c < 3; ++c) {
    g.G[0][c] = -(Jinv(0, c) + Jinv(1, c) + Jinv(2, c));
    for (int k = 0; k < 3; ++k) g.G[k + 1][c] = Jinv(k, c);
  }
  return g;
}

constexpr int kEdges[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};

/// Shape functions N (n) and their gradients dN (n by 3) at barycentric point L, n = 4 or 10.
/// Order 2: corners L_i (2 L_i - 1), edges 4 L_i L_j.
void shape(int n, const double L[4], const TetGeometry& g, double* N, double (*dN)[3]) {
  if (n == 4) {
    for (int a = 0; a < 4; ++a) {
      N[a] = L[a];
      for (int c = 0; c < 3; ++c) dN[a][c] = g.G[a][c];
    }
    return;
  }
  for (int a = 0; a < 4; ++a) {
    N[a] = L[a] * (2 * L[a] - 1);
    for (int c = 0; c < 3; ++c) dN[a][c] = (4 * L[a] - 1) * g.G[a][c];
  }
  for (int e = 0; e < 6; ++e) {
    const int i = kEdges[e][0], j = kEdges[e][1];
    N[4 + e] = 4 * L[i] * L[j];
    for (int c = 0; c < 3; ++c) dN[4 + e][c] = 4 * (L[i] * g.G[j][c] + L[j] * g.G[i][c]);
  }
}

/// Tet quadrature in barycentric coordinates; weights sum to 1 (multiply by the volume).
struct Rule {
  int count;
  double L[5][4];
  double w[5];
};
// Centroid: exact for degree 1 (order-1 stiffness and thermal load).
constexpr Rule kRule1 = {1, {{0.25, 0.25, 0.25, 0.25}}, {1.0}};
// 4 points, degree 2: exact for the order-2 stiffness (products of linear gradients).
constexpr double kA = 0.5854101966249685, kB = 0.1381966011250105;
constexpr Rule kRule2 = {4,
                         {{kA, kB, kB, kB}, {kB, kA, kB, kB}, {kB, kB, kA, kB}, {kB, kB, kB, kA}},
                         {.25, .25, .25, .25}};
// Keast 5 points, degree 3: the order-2 thermal load (quadratic temperature x linear gradient).
constexpr double kH = 0.5, kS = 1.0 / 6.0;
constexpr Rule kRule3 = {
    5,
    {{.25, .25, .25, .25}, {kH, kS, kS, kS}, {kS, kH, kS, kS}, {kS, kS, kH, kS}, {kS, kS, kS, kH}},
    {-0.8, 0.45, 0.45, 0.45, 0.45}};

// ---- Boundary regions ------------------------------------------------------------------------

using Vec3 = Eigen::Vector3d;
Vec3 node(const Discretization& d, std::uint32_t i) {
  return {d.nodes[3 * i], d.nodes[3 * i + 1], d.nodes[3 * i + 2]};
}
/// Area vector (outward normal times area) of boundary face f.
Vec3 area_vector(const Discretization& d, std::uint32_t f) {
  const std::uint32_t* t = &d.faces[static_cast<std::size_t>(f) * d.nodes_per_face];
  return 0.5 * (node(d, t[1]) - node(d, t[0])).cross(node(d, t[2]) - node(d, t[0]));
}
/// Consistent nodal weights of a uniform load on a face: int N_a dA. Order 1: A/3 at the
/// corners; order 2: 0 at the corners and A/3 at the edge nodes.
template <typename Add>
void distribute(const Discretization& d, std::uint32_t f, double area, Add add) {
  const std::uint32_t* t = &d.faces[static_cast<std::size_t>(f) * d.nodes_per_face];
  const int first = d.order == 1 ? 0 : 3;
  for (int a = first; a < first + 3; ++a) add(t[a], area / 3.0);
}

void check_finite(double v, const std::string& what) {
  if (!std::isfinite(v)) throw Error("physics: " + what + " is not finite");
}

// ---- Heat conduction -------------------------------------------------------------------------

Eigen::VectorXd solve_thermal(const Problem& p, const Discretization& d, const NodeGraph& graph,
                              SolverKind kind, Solution& out) {
  const auto t0 = Clock::now();
  const int n = d.nodes_per_element;
  const double k = p.material.conductivity;
  System sys(graph, 1);
  double Ke[10 * 10];
  double N[10], dN[10][3];
  const Rule& rule = n == 4 ? kRule1 : kRule2;
  for (std::size_t e = 0; e < d.element_count(); ++e) {
    const std::uint32_t* el = &d.elements[e * n];
    const TetGeometry g = tet_geometry(d.nodes, el);
    std::fill(Ke, Ke + n * n, 0.0);
    for (int q = 0; q < rule.count; ++q) {
      shape(n, rule.L[q], g, N, dN);
      const double w = rule.w[q] * g.volume * k;
      for (int a = 0; a < n; ++a) {
        for (int b = 0; b < n; ++b) {
          Ke[a * n + b] += w * (dN[a][0] * dN[b][0] + dN[a][1] * dN[b][1] + dN[a][2] * dN[b][2]);
        }
      }
    }
    sys.add_element(el, n, Ke);
  }
  for (const HeatFlux& h : p.heat_fluxes) {
    check_finite(h.flux, "HeatFlux.flux");
    for (std::uint32_t f : faces_with_tags(d, h.tags, "HeatFlux")) {
      distribute(d, f, area_vector(d, f).norm(),
                 [&](std::uint32_t a, double w) { sys.f[a] += h.flux * w; });
    }
  }
  // Robin: q = h (T_inf - T) adds h int N_a N_b to K and h T_inf int N_a to f (Galerkin face
  // mass matrices: order 1 A/12 (1 + delta_ab); order 2 the 6-node matrix below, times A/180).
  static constexpr double kMass2[6][6] = {{6, -1, -1, 0, -4, 0},  {-1, 6, -1, 0, 0, -4},
                                          {-1, -1, 6, -4, 0, 0},  {0, 0, -4, 32, 16, 16},
                                          {-4, 0, 0, 16, 32, 16}, {0, -4, 0, 16, 16, 32}};
  bool has_robin = false;
  for (const Convection& c : p.convections) {
    check_finite(c.coefficient, "Convection.coefficient");
    check_finite(c.ambient, "Convection.ambient");
    if (c.coefficient < 0) throw Error("physics: Convection.coefficient is negative");
    has_robin = has_robin || c.coefficient > 0;
    for (std::uint32_t f : faces_with_tags(d, c.tags, "Convection")) {
      const double area = area_vector(d, f).norm();
      const int m = d.nodes_per_face;
      double Me[36];
      for (int a = 0; a < m; ++a) {
        for (int b = 0; b < m; ++b) {
          Me[a * m + b] = c.coefficient * (m == 3 ? area / 12.0 * (a == b ? 2.0 : 1.0)
                                                  : area / 180.0 * kMass2[a][b]);
        }
      }
      sys.add_element(&d.faces[static_cast<std::size_t>(f) * m], m, Me);
      distribute(d, f, area,
                 [&](std::uint32_t a, double w) { sys.f[a] += c.coefficient * c.ambient * w; });
    }
  }
  std::vector<std::uint8_t> fixed(d.node_count, 0);
  Eigen::VectorXd values = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(d.node_count));
  for (const Temperature& t : p.temperatures) {
    check_finite(t.temperature, "Temperature.temperature");
    for (std::uint32_t f : faces_with_tags(d, t.tags, "Temperature")) {
      for (int a = 0; a < d.nodes_per_face; ++a) {
        const std::uint32_t i = d.faces[static_cast<std::size_t>(f) * d.nodes_per_face + a];
        fixed[i] = 1;
        values[i] = t.temperature;
      }
    }
  }
  if (p.temperatures.empty() && !has_robin) {
    throw Error(
        "physics: thermal problem without a Temperature or Convection region: the temperature "
        "is undetermined (singular system)");
  }
  sys.constrain(fixed, values);
  out.assemble_seconds += seconds_since(t0);
  LinearSolveResult r = solve_linear(sys.K, sys.f, kind, p.cg_tolerance, {&graph, &d.nodes, 1});
  out.solve_seconds += r.seconds;
  out.iterations = r.iterations;
  return r.x;
}

// ---- Linear elasticity -----------------------------------------------------------------------

/// Throws unless the fixed components remove all six rigid-body motions: the matrix of the
/// modes' fixed components (translations e_k, rotations e_k x x) must have rank 6.
void check_rigid_body(const Discretization& d, const std::vector<std::uint8_t>& fixed) {
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (std::size_t i = 0; i < d.vertex_count; ++i) {
    lo = lo.cwiseMin(node(d, static_cast<std::uint32_t>(i)));
    hi = hi.cwiseMax(node(d, static_cast<std::uint32_t>(i)));
  }
  const Vec3 centre = 0.5 * (lo + hi);
  const double size = std::max((hi - lo).norm(), 1e-300);
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  for (std::size_t dof = 0; dof < fixed.size(); ++dof) {
    if (!fixed[dof]) continue;
    const int axis = static_cast<int>(dof % 3);
    const Vec3 x = (node(d, static_cast<std::uint32_t>(dof / 3)) - centre) / size;
    Eigen::Matrix<double, 6, 1> r = Eigen::Matrix<double, 6, 1>::Zero();
    r[axis] = 1.0;
    for (int k = 0; k < 3; ++k) r[3 + k] = Vec3::Unit(k).cross(x)[axis];
    A += r * r.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(A);
  const double largest = eig.eigenvalues()[5];
  if (!(eig.eigenvalues()[0] > 1e-10 * largest)) {
    const Eigen::Matrix<double, 6, 1> mode = eig.eigenvectors().col(0);
    throw Error(std::string("physics: the Fixed regions leave rigid-body motion free (") +
                (mode.head<3>().norm() >= mode.tail<3>().norm() ? "a translation" : "a rotation") +
                " is unconstrained); fix more components");
  }
}

// The material's Lame constants and thermal stress factor.
struct Elastic {
  double lambda, mu;
  // Thermal stress -beta alpha (T - T_ref) I with beta = 3 lambda + 2 mu = E / (1 - 2 nu).
  double beta_alpha;
  explicit Elastic(const Material& m) {
    const double E = m.youngs_modulus, nu = m.poisson_ratio;
    lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
    mu = E / (2 * (1 + nu));
    beta_alpha = E / (1 - 2 * nu) * m.thermal_expansion;
  }
};

// The element stiffness matrices into sys.K, and with a temperature field its thermal load into
// sys.f.
void assemble_elastic(const Discretization& d, const Elastic& lame,
                      const Eigen::VectorXd* temperature, double reference_temperature,
                      System& sys) {
  const double lambda = lame.lambda, mu = lame.mu, beta_alpha = lame.beta_alpha;
  const int n = d.nodes_per_element;
  double Ke[30 * 30];
  double N[10], dN[10][3];
  const Rule& rule = n == 4 ? kRule1 : kRule2;
  const Rule& thermal_rule = n == 4 ? kRule1 : kRule3;
  for (std::size_t e = 0; e < d.element_count(); ++e) {
    const std::uint32_t* el = &d.elements[e * n];
    const TetGeometry g = tet_geometry(d.nodes, el);
    const int s = 3 * n;
    std::fill(Ke, Ke + s * s, 0.0);
    for (int q = 0; q < rule.count; ++q) {
      shape(n, rule.L[q], g, N, dN);
      const double w = rule.w[q] * g.volume;
      // Isotropic block (a, b): lambda dN_a dN_b^T + mu dN_b dN_a^T + mu (dN_a . dN_b) I.
      for (int a = 0; a < n; ++a) {
        for (int b = 0; b < n; ++b) {
          const double dd = dN[a][0] * dN[b][0] + dN[a][1] * dN[b][1] + dN[a][2] * dN[b][2];
          for (int i = 0; i < 3; ++i) {
            double* row = Ke + (3 * a + i) * s + 3 * b;
            for (int j = 0; j < 3; ++j) {
              row[j] += w * (lambda * dN[a][i] * dN[b][j] + mu * dN[a][j] * dN[b][i] +
                             (i == j ? mu * dd : 0.0));
            }
          }
        }
      }
    }
    sys.add_element(el, n, Ke);
    if (temperature != nullptr && beta_alpha != 0.0) {
      // Thermal load int beta alpha (T - T_ref) dN_a dV (one-way coupling).
      for (int q = 0; q < thermal_rule.count; ++q) {
        shape(n, thermal_rule.L[q], g, N, dN);
        double dT = -reference_temperature;
        for (int a = 0; a < n; ++a) dT += N[a] * (*temperature)[el[a]];
        const double w = thermal_rule.w[q] * g.volume * beta_alpha * dT;
        for (int a = 0; a < n; ++a) {
          for (int i = 0; i < 3; ++i) sys.f[3 * el[a] + i] += w * dN[a][i];
        }
      }
    }
  }
}

// The Force regions (a total force spread over the region by area) and the Pressure regions
// into sys.f.
void add_surface_loads(const Problem& p, const Discretization& d, System& sys) {
  for (const Force& force : p.forces) {
    for (double v : force.force) check_finite(v, "Force.force");
    const auto faces = faces_with_tags(d, force.tags, "Force");
    double total_area = 0.0;
    for (std::uint32_t f : faces) total_area += area_vector(d, f).norm();
    if (!(total_area > 0)) throw Error("physics: Force region has zero area");
    for (std::uint32_t f : faces) {
      distribute(d, f, area_vector(d, f).norm(), [&](std::uint32_t a, double w) {
        for (int i = 0; i < 3; ++i) sys.f[3 * a + i] += force.force[i] / total_area * w;
      });
    }
  }
  for (const Pressure& pr : p.pressures) {
    check_finite(pr.pressure, "Pressure.pressure");
    for (std::uint32_t f : faces_with_tags(d, pr.tags, "Pressure")) {
      const Vec3 av = area_vector(d, f);
      const double area = av.norm();
      if (area == 0.0) continue;
      const Vec3 traction = -pr.pressure * av / area;  // positive pressure pushes inward
      distribute(d, f, area, [&](std::uint32_t a, double w) {
        for (int i = 0; i < 3; ++i) sys.f[3 * a + i] += traction[i] * w;
      });
    }
  }
}

// Fixed components; each remembers the first region fixing it in `owner`, for the reactions.
void fixed_components(const Problem& p, const Discretization& d, std::vector<std::uint8_t>& fixed,
                      std::vector<std::int32_t>& owner) {
  fixed.assign(3 * d.node_count, 0);
  owner.assign(3 * d.node_count, -1);
  for (std::size_t r = 0; r < p.fixed.size(); ++r) {
    const Fixed& fx = p.fixed[r];
    for (std::uint32_t f : faces_with_tags(d, fx.tags, "Fixed")) {
      for (int a = 0; a < d.nodes_per_face; ++a) {
        const std::uint32_t i = d.faces[static_cast<std::size_t>(f) * d.nodes_per_face + a];
        for (int c = 0; c < 3; ++c) {
          if (!fx.axes[c] || fixed[3 * i + c]) continue;
          fixed[3 * i + c] = 1;
          owner[3 * i + c] = static_cast<std::int32_t>(r);
        }
      }
    }
  }
}

// Stress at the vertices: each tet's mechanical stress at its corners (constant for order 1,
// linear for order 2) taken to the vertices by the problem's recovery (recover_vertex_stress);
// the thermal part -beta alpha dT I is added at the vertex from the vertex temperature, which is
// exact there. Sets out.stress and out.von_mises.
void vertex_stress(const Discretization& d, const Elastic& lame, const Eigen::VectorXd& u,
                   const Eigen::VectorXd* temperature, const Problem& p, Solution& out) {
  const double lambda = lame.lambda, mu = lame.mu, beta_alpha = lame.beta_alpha;
  const int n = d.nodes_per_element;
  double N[10], dN[10][3];
  const std::size_t nv = d.vertex_count, nt = d.element_count();
  std::vector<double> corner(24 * nt), volume(nt);
  static constexpr double kCorner[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
  for (std::size_t e = 0; e < nt; ++e) {
    const std::uint32_t* el = &d.elements[e * n];
    const TetGeometry g = tet_geometry(d.nodes, el);
    volume[e] = g.volume;
    for (int c = 0; c < 4; ++c) {
      if (n == 4 && c > 0) {
        // Order 1: the strain is constant, reuse corner 0's.
        std::copy_n(&corner[24 * e], 6, &corner[24 * e + 6 * c]);
        continue;
      }
      shape(n, kCorner[c], g, N, dN);
      Eigen::Matrix3d grad = Eigen::Matrix3d::Zero();  // du_i / dx_j
      for (int a = 0; a < n; ++a) {
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) grad(i, j) += u[3 * el[a] + i] * dN[a][j];
        }
      }
      const Eigen::Matrix3d eps = 0.5 * (grad + grad.transpose());
      const Eigen::Matrix3d sigma =
          lambda * eps.trace() * Eigen::Matrix3d::Identity() + 2 * mu * eps;
      const double comps[6] = {sigma(0, 0), sigma(1, 1), sigma(2, 2),
                               sigma(1, 2), sigma(0, 2), sigma(0, 1)};
      std::copy_n(comps, 6, &corner[24 * e + 6 * c]);
    }
  }
  out.stress = recover_vertex_stress(d, corner, volume, p.recovery);
  out.von_mises.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    double* s = &out.stress[6 * v];
    if (temperature != nullptr) {
      const double thermal = beta_alpha * ((*temperature)[static_cast<Eigen::Index>(v)] -
                                           p.material.reference_temperature);
      for (int k = 0; k < 3; ++k) s[k] -= thermal;
    }
    out.von_mises[v] =
        std::sqrt(0.5 * ((s[0] - s[1]) * (s[0] - s[1]) + (s[1] - s[2]) * (s[1] - s[2]) +
                         (s[2] - s[0]) * (s[2] - s[0])) +
                  3.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]));
  }
}

Eigen::VectorXd solve_elastic(const Problem& p, const Discretization& d, const NodeGraph& graph,
                              const Eigen::VectorXd* temperature, SolverKind kind, Solution& out) {
  auto t0 = Clock::now();
  const Elastic lame(p.material);
  System sys(graph, 3);
  assemble_elastic(d, lame, temperature, p.material.reference_temperature, sys);
  add_surface_loads(p, d, sys);
  if (p.fixed.empty()) {
    throw Error("physics: elastic problem without a Fixed region: rigid-body motion is free");
  }
  std::vector<std::uint8_t> fixed;
  std::vector<std::int32_t> owner;
  fixed_components(p, d, fixed, owner);
  check_rigid_body(d, fixed);
  sys.constrain(fixed, Eigen::VectorXd::Zero(static_cast<Eigen::Index>(fixed.size())));
  out.assemble_seconds += seconds_since(t0);
  LinearSolveResult r = solve_linear(sys.K, sys.f, kind, p.cg_tolerance, {&graph, &d.nodes, 3});
  out.solve_seconds += r.seconds;
  out.iterations = r.iterations;
  const Eigen::VectorXd& u = r.x;

  t0 = Clock::now();
  // Reactions: K u - f on the fixed components (the support force on the solid).
  out.reactions.assign(3 * p.fixed.size(), 0.0);
  const Eigen::VectorXd residual = sys.constrained_residual(u);
  for (std::size_t k = 0; k < sys.constrained_dofs().size(); ++k) {
    const std::size_t dof = sys.constrained_dofs()[k];
    out.reactions[3 * static_cast<std::size_t>(owner[dof]) + dof % 3] +=
        residual[static_cast<Eigen::Index>(k)];
  }
  vertex_stress(d, lame, u, temperature, p, out);
  out.assemble_seconds += seconds_since(t0);
  return u;
}

SolverKind pick(const Problem& p, std::size_t dofs, const SolverKind* forced) {
  if (forced != nullptr) return *forced;
  switch (p.solver) {
    case LinearSolver::cholmod:
      return SolverKind::cholmod_supernodal;
    case LinearSolver::conjugate_gradient:
      return SolverKind::cg_jacobi;
    case LinearSolver::conjugate_gradient_two_level:
      return SolverKind::cg_two_level;
    case LinearSolver::automatic:
      break;
  }
  return default_solver(dofs);
}

void validate_material(const Problem& p) {
  const Material& m = p.material;
  if (p.elastic) {
    check_finite(m.youngs_modulus, "Material.youngs_modulus");
    check_finite(m.poisson_ratio, "Material.poisson_ratio");
    if (!(m.youngs_modulus > 0)) throw Error("physics: Material.youngs_modulus is not positive");
    if (!(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5)) {
      throw Error("physics: Material.poisson_ratio is outside (-1, 0.5)");
    }
  }
  if (p.thermal) {
    check_finite(m.conductivity, "Material.conductivity");
    if (!(m.conductivity > 0)) throw Error("physics: Material.conductivity is not positive");
  }
  if (p.thermal && p.elastic) {
    check_finite(m.thermal_expansion, "Material.thermal_expansion");
    check_finite(m.reference_temperature, "Material.reference_temperature");
  }
  if (!std::isfinite(p.cg_tolerance) || !(p.cg_tolerance > 0)) {
    throw Error("physics: cg_tolerance is not a positive number");
  }
}

}  // namespace

Solution solve_with(const Problem& problem, const SolverKind* forced) {
  const auto t0 = Clock::now();
  if (!problem.elastic && !problem.thermal) {
    throw Error("physics: nothing to solve (neither elastic nor thermal)");
  }
  validate_material(problem);
  const Discretization d = discretize(problem.mesh, problem.order);
  const NodeGraph graph = node_graph(d);
  Solution out;
  out.assemble_seconds = seconds_since(t0);
  const std::size_t nv = d.vertex_count;
  Eigen::VectorXd T;
  std::string thermal_solver;
  if (problem.thermal) {
    const SolverKind kind = pick(problem, d.node_count, forced);
    thermal_solver = solver_name(kind);
    T = solve_thermal(problem, d, graph, kind, out);
    out.temperature.assign(T.data(), T.data() + nv);
    out.dofs += d.node_count;
  }
  if (problem.elastic) {
    const SolverKind kind = pick(problem, 3 * d.node_count, forced);
    const Eigen::VectorXd u =
        solve_elastic(problem, d, graph, problem.thermal ? &T : nullptr, kind, out);
    out.displacement.assign(u.data(), u.data() + 3 * nv);
    out.dofs += 3 * d.node_count;
    out.solver = solver_name(kind);
    if (!thermal_solver.empty() && thermal_solver != out.solver) {
      out.solver = thermal_solver + " (thermal), " + out.solver + " (elastic)";
    }
  } else {
    out.solver = thermal_solver;
  }
  return out;
}

}  // namespace detail

Solution solve(const Problem& problem) { return detail::solve_with(problem, nullptr); }

}  // namespace cadinterp::physics
