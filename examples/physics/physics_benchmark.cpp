// Google Benchmark of physics::solve() on the cantilever box of physics_solver_bench (2:1:1,
// clamped at x = 0, end load; or held at 0 K at one end with a flux at the other): the home of
// README.md's results table ("Results"). physics_solver_bench prints the comparison tables
// (every solver at every size, docs/physics-solvers.md); this one times chosen cases repeatedly.
//
//   physics_benchmark --benchmark_filter='two-level'
//
// Each benchmark is named solver/physics/order/vertices; counters: dofs, CG iterations, and the
// wall seconds solve() reports for its assembly and its linear solve (setup included).
#include <benchmark/benchmark.h>

#include <string>

#include "physics_internal.h"
#include "physics_test_meshes.h"

namespace {

using namespace cadinterp::physics;
using namespace cadinterp::physics::testing;

void solve_case(benchmark::State& state, detail::SolverKind kind, bool elastic, int order, int n) {
  const Problem p = bar_problem(n, elastic, order);
  double assemble = 0, solve = 0;
  Solution s;
  for (auto _ : state) {
    s = detail::solve_with(p, &kind);
    benchmark::DoNotOptimize(s.displacement.data());
    assemble += s.assemble_seconds;
    solve += s.solve_seconds;
  }
  const auto runs = static_cast<double>(state.iterations());
  state.counters["dofs"] = static_cast<double>(s.dofs);
  state.counters["cg_iterations"] = s.iterations;
  state.counters["assemble_s"] = assemble / runs;
  state.counters["solve_s"] = solve / runs;
}

void add(detail::SolverKind kind, bool elastic, int order, int n) {
  const int vertices = (2 * n + 1) * (n + 1) * (n + 1);
  const std::string name = std::string(detail::solver_name(kind)) + "/" +
                           (elastic ? "elastic" : "thermal") + "/order" + std::to_string(order) +
                           "/" + std::to_string(vertices);
  benchmark::RegisterBenchmark(
      name.c_str(), [=](benchmark::State& st) { solve_case(st, kind, elastic, order, n); })
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
}

}  // namespace

int main(int argc, char** argv) {
  using K = detail::SolverKind;
  // The host-sized case (n = 21: 20,812 vertices, 62,436 unknowns) and smaller boxes (n = 8:
  // 1,377 vertices; 11: 3,312; 14: 6,525).
  for (int n : {8, 14, 21}) add(K::cg_two_level, true, 1, n);
  add(K::cg_jacobi, true, 1, 21);
  add(K::cg_incomplete_cholesky, true, 1, 14);
  add(K::cholmod_supernodal, true, 1, 11);  // 9,936 unknowns; 20k+ takes seconds
  add(K::cg_two_level, true, 2, 11);        // 71,415 unknowns
  add(K::cg_two_level, false, 1, 21);
  add(K::cg_two_level, false, 2, 11);  // 23,805 unknowns
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
