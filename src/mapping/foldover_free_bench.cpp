// Cost of the foldover-free untangler (foldover_free.h, the mapping pipeline's stage 5), which
// dominates the mappings that need it (docs/mapping-decisions.md, "Interior and untangling"): the
// harmonic interior of a unit cube on an n^3 Kuhn grid whose boundary is twisted by two full
// turns (the unit test's case, finer), untangled within a fixed evaluation budget. Counters: tet
// evaluations per second (the number to compare across changes of the energy's code, since the
// path the minimiser takes may change with the last digits), evaluations, tets, inverted tets
// before and after.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "mapping/foldover_free.h"
#include "mapping/interior_solve.h"
#include "mapping/kuhn_cube.h"

namespace cadinterp::mapping {
namespace {

struct TwistedCube {
  KuhnCube cube;
  std::vector<double> start;  // the harmonic interior of the twisted boundary; empty on failure
};

// Built once per grid size: the benchmark function runs several times while the library sizes
// its iteration count.
const TwistedCube& twisted_cube(int n) {
  static std::map<int, TwistedCube> cache;
  auto it = cache.find(n);
  if (it != cache.end()) return it->second;
  // Two full turns: one leaves the harmonic interior of this grid valid.
  TwistedCube c{KuhnCube(n), {}};
  c.start = twisted_boundary(c.cube, 720);
  std::string why;
  if (!harmonic_interior(c.cube.x, c.cube.tets, c.cube.fixed, c.start, why)) c.start.clear();
  return cache.emplace(n, std::move(c)).first->second;
}

void BM_UntangleTwistedCube(benchmark::State& state) {
  const TwistedCube& c = twisted_cube(static_cast<int>(state.range(0)));
  if (c.start.empty()) {
    state.SkipWithError("harmonic interior failed");
    return;
  }
  FoldoverFreeOptions o;
  o.rings = -1;  // every free vertex: the cost per evaluation is the whole mesh's
  o.max_evaluations = static_cast<int>(state.range(1));
  FoldoverFreeResult r;
  long long evaluations = 0;
  for (auto _ : state) {
    std::vector<double> x = c.start;
    r = untangle_foldover_free(c.cube.x, c.cube.tets, c.cube.fixed, 0.0, x, o);
    evaluations += r.evaluations;
    benchmark::DoNotOptimize(x.data());
  }
  const double tets = double(c.cube.tets.size() / 4);
  // Tet evaluations per second of CPU time (one evaluation: energy and gradient of one tet).
  state.counters["tet_evals"] =
      benchmark::Counter(double(evaluations) * tets, benchmark::Counter::kIsRate);
  state.counters["evaluations"] = double(r.evaluations);
  state.counters["tets"] = tets;
  state.counters["inverted_before"] = double(r.inverted_before);
  state.counters["inverted_after"] = double(r.inverted_after);
}
BENCHMARK(BM_UntangleTwistedCube)->Args({12, 400})->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace cadinterp::mapping

BENCHMARK_MAIN();
