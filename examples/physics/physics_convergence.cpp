// Convergence tables of cadinterp_physics against analytic solutions, at sizes beyond the unit
// tests: the cantilever (Timoshenko tip deflection), the thick-walled cylinder under internal
// pressure (Lame, plane strain) and conduction (slab with convection; tube with a logarithmic
// profile). Its output: docs/physics-solvers.md, "Convergence against analytic solutions".
// Usage: physics_convergence [max_level (default 3)]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "physics.h"
#include "physics_test_meshes.h"

namespace {

using namespace cadinterp::physics;
using namespace cadinterp::physics::testing;

struct Row {
  double h;
  std::size_t dofs;
  double value, exact;
  std::string solver;
  double seconds;
  double error() const { return std::abs(value - exact) / std::abs(exact); }
};

void print_table(const char* title, const std::vector<Row>& rows) {
  std::printf("\n%s\n", title);
  std::printf("%9s %9s %14s %14s %10s %6s %-16s %8s\n", "h", "dofs", "computed", "exact",
              "rel.error", "order", "solver", "seconds");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    char order[16] = "";
    if (i > 0) {
      std::snprintf(order, sizeof order, "%.2f",
                    std::log(rows[i - 1].error() / r.error()) / std::log(rows[i - 1].h / r.h));
    }
    std::printf("%9.4f %9zu %14.7e %14.7e %10.3e %6s %-16s %8.3f\n", r.h, r.dofs, r.value, r.exact,
                r.error(), order, r.solver.c_str(), r.seconds);
  }
}

Solution timed_solve(const Problem& p, double& seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  Solution s = solve(p);
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

// Cantilever 10 x 1 x 1 clamped at x = 0, total load P in -z on x = 10: Timoshenko tip deflection
// P L^3 / (3 E I) + P L / (kappa G A), kappa = 10 (1 + nu) / (12 + 11 nu) (rectangle).
Row cantilever(int level, int order) {
  const double L = 10, E = 1000, nu = 0.3, P = 1;
  const int k = 1 << level;
  Problem p;
  p.mesh = box_mesh(L, 1, 1, 10 * k, k, k);
  p.material.youngs_modulus = E;
  p.material.poisson_ratio = nu;
  p.order = order;
  p.fixed.push_back({{kXLow}, {true, true, true}});
  p.forces.push_back({{kXHigh}, {0, 0, -P}});
  Row r;
  const Solution s = timed_solve(p, r.seconds);
  double sum = 0;
  int count = 0;
  for (std::size_t v = 0; v < p.mesh.vertices.size() / 3; ++v) {
    if (std::abs(p.mesh.vertices[3 * v] - L) < 1e-9) {
      sum += s.displacement[3 * v + 2];
      ++count;
    }
  }
  const double I = 1.0 / 12, G = E / (2 * (1 + nu)), kappa = 10 * (1 + nu) / (12 + 11 * nu);
  r.h = 1.0 / k;
  r.dofs = s.dofs;
  r.value = -sum / count;
  r.exact = P * L * L * L / (3 * E * I) + P * L / (kappa * G * 1.0);
  r.solver = s.solver;
  return r;
}

// Quarter tube a = 1, b = 2, height 0.25 (k layers, so the tets stay shaped) with u_z = 0 on both
// ends (plane strain), internal pressure p = 1. Lame: sigma_theta = A + B / r^2, u = (1 + nu) / E
// ((1 - 2 nu) A r + B / r), A = p a^2 / (b^2 - a^2), B = p a^2 b^2 / (b^2 - a^2). Reports the worst
// relative error of u_r (which = 0) or sigma_theta (which = 1) over the inner-surface vertices.
Row lame(int level, int order, int which) {
  const double a = 1, b = 2, E = 1000, nu = 0.3, pr = 1;
  const int k = 1 << level;
  Problem p;
  p.mesh = quarter_annulus(a, b, 0.25, 2 * k, 4 * k, k);  // layers ~ h: no needle tets
  p.material.youngs_modulus = E;
  p.material.poisson_ratio = nu;
  p.order = order;
  p.fixed.push_back({{kPlaneY0}, {false, true, false}});
  p.fixed.push_back({{kPlaneX0}, {true, false, false}});
  p.fixed.push_back({{kBottom, kTop}, {false, false, true}});
  p.pressures.push_back({{kInner}, pr});
  Row r;
  const Solution s = timed_solve(p, r.seconds);
  const double A = pr * a * a / (b * b - a * a), B = pr * a * a * b * b / (b * b - a * a);
  double worst = 0, worst_value = 0, worst_exact = 1;
  for (std::size_t v = 0; v < p.mesh.vertices.size() / 3; ++v) {
    const double x = p.mesh.vertices[3 * v], y = p.mesh.vertices[3 * v + 1];
    const double radius = std::hypot(x, y);
    if (std::abs(radius - a) > 1e-9) continue;
    const double c = x / radius, sn = y / radius;
    double value, exact;
    if (which == 0) {
      value = c * s.displacement[3 * v] + sn * s.displacement[3 * v + 1];
      exact = (1 + nu) / E * ((1 - 2 * nu) * A * radius + B / radius);
    } else {
      const double* st = &s.stress[6 * v];  // xx yy zz yz xz xy
      value = sn * sn * st[0] + c * c * st[1] - 2 * sn * c * st[5];
      exact = A + B / (radius * radius);
    }
    const double e = std::abs(value - exact) / std::abs(exact);
    if (e >= worst) {
      worst = e;
      worst_value = value;
      worst_exact = exact;
    }
  }
  r.h = (b - a) / (2 * k);
  r.dofs = s.dofs;
  r.value = worst_value;
  r.exact = worst_exact;
  r.solver = s.solver;
  return r;
}

// Conduction in the tube a <= r <= b with T(a) = 1, T(b) = 0: T = ln(b / r) / ln(b / a); the
// worst nodal error over all vertices, relative to the range 1.
Row tube_conduction(int level, int order) {
  const double a = 1, b = 2;
  const int k = 1 << level;
  Problem p;
  p.mesh = quarter_annulus(a, b, 0.25, 2 * k, 4 * k, k);  // layers ~ h: no needle tets
  p.elastic = false;
  p.thermal = true;
  p.order = order;
  p.temperatures.push_back({{kInner}, 1.0});
  p.temperatures.push_back({{kOuter}, 0.0});
  Row r;
  const Solution s = timed_solve(p, r.seconds);
  double worst = 0;
  for (std::size_t v = 0; v < p.mesh.vertices.size() / 3; ++v) {
    const double radius = std::hypot(p.mesh.vertices[3 * v], p.mesh.vertices[3 * v + 1]);
    worst = std::max(worst, std::abs(s.temperature[v] - std::log(b / radius) / std::log(b / a)));
  }
  r.h = (b - a) / (2 * k);
  r.dofs = s.dofs;
  r.value = 1 + worst;  // reported as 1 + max |T - T_exact| against 1
  r.exact = 1;
  r.solver = s.solver;
  return r;
}

// Slab 0 <= x <= 1 with T(0) = 100 and convection h = 20, T_inf = 20 at x = 1, k = 5:
// T = 100 + s x, s = h (T_inf - 100) / (k + h). Linear, so exact for both orders.
Row slab_robin(int level, int order) {
  const int k = 1 << level;
  Problem p;
  p.mesh = box_mesh(1, 0.5, 0.5, 4 * k, 2 * k, 2 * k);
  p.elastic = false;
  p.thermal = true;
  p.order = order;
  p.material.conductivity = 5;
  p.temperatures.push_back({{kXLow}, 100.0});
  p.convections.push_back({{kXHigh}, 20.0, 20.0});
  p.solver = LinearSolver::cholmod;  // exact solve: the error left is the discretization's
  Row r;
  const Solution s = timed_solve(p, r.seconds);
  const double slope = 20.0 * (20.0 - 100.0) / (5.0 + 20.0);
  double worst = 0;
  for (std::size_t v = 0; v < p.mesh.vertices.size() / 3; ++v) {
    worst = std::max(worst, std::abs(s.temperature[v] - (100 + slope * p.mesh.vertices[3 * v])));
  }
  r.h = 0.25 / k;
  r.dofs = s.dofs;
  r.value = 100 + worst;  // reported as 100 + max |T - T_exact|
  r.exact = 100;
  r.solver = s.solver;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  const int max_level = argc > 1 ? std::atoi(argv[1]) : 3;
  for (int order = 1; order <= 2; ++order) {
    std::vector<Row> tip, ur, hoop, tube, slab;
    for (int level = 0; level <= max_level; ++level) {
      tip.push_back(cantilever(level, order));
      ur.push_back(lame(level, order, 0));
      hoop.push_back(lame(level, order, 1));
      tube.push_back(tube_conduction(level, order));
      slab.push_back(slab_robin(level, order));
    }
    std::printf("\n===== order %d =====\n", order);
    print_table("Cantilever 10x1x1, tip deflection vs Timoshenko", tip);
    for (std::size_t i = 2; i < tip.size(); ++i) {
      // Self-convergence: the order from successive differences, free of the model error.
      std::printf("order from successive differences, h = %.4f: %.2f\n", tip[i].h,
                  std::log(std::abs(tip[i - 1].value - tip[i - 2].value) /
                           std::abs(tip[i].value - tip[i - 1].value)) /
                      std::log(2.0));
    }
    if (order == 2 && tip.size() >= 3) {
      // Aitken extrapolation of the last three levels: the 3D limit, which differs from beam
      // theory by the clamp's restraint of warping and Poisson contraction.
      const double u1 = tip[tip.size() - 3].value, u2 = tip[tip.size() - 2].value,
                   u3 = tip.back().value;
      const double limit = u3 - (u3 - u2) * (u3 - u2) / ((u3 - u2) - (u2 - u1));
      std::printf("extrapolated 3D limit %.6f (Timoshenko %.6f, %+.2f%%)\n", limit,
                  tip.back().exact, 100 * (limit / tip.back().exact - 1));
    }
    print_table("Lame cylinder a=1 b=2 p=1, plane strain: u_r at r=a (worst vertex)", ur);
    print_table("Lame cylinder: hoop stress at r=a (worst vertex, volume-averaged recovery)", hoop);
    print_table("Conduction in the tube, T = ln(b/r)/ln(b/a): 1 + max nodal error", tube);
    print_table("Slab with convection (linear profile): 100 + max nodal error", slab);
  }
  return 0;
}
