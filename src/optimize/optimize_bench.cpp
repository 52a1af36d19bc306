// One optimization end to end on an analytic asset shaped like the press use case (issue 28):
// K = 4 parameters, cubic, two of them fixed ("height and width given"), the objective an
// integral of a field under a volume limit. Once with quantities of the interpolated mesh
// (integral(q), volume: a blend of the element's meshes per evaluation), once with the same
// quantities as per-sample outputs (exact_integral_q, output(brep_volume): O(terms) each).
// Beside them: one cadinterp_grad (the per-iteration blend), a memcpy of the bytes that blend
// reads (terms x the element's positions and field; the bandwidth bound), one output evaluation,
// the host itself (one regenerate + simulate), and the same optimization run on the host with
// forward-difference gradients ((free parameters + 1) host evaluations per gradient).
//
// Usage: optimize_bench [--cubes=N] [benchmark flags]. N cubes per axis of the box mesh (default
// 16: 4,913 vertices, 24,576 tets); the CI smoke run passes --cubes=2.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_builder.h"
#include "cadinterp/cadinterp_optimize.h"
#include "optimize/host_fd_nlp.h"
#include "optimize/test_host.h"

namespace {

using cadinterp::optimize::test::BoxHost;

constexpr int kK = 4;
// Parameters 2 and 3 fixed (the use case's given sizes); 0 and 1 free.
constexpr double kFixed[2] = {0.3, 0.8};
// h >= 1.2: x0 >= 0.4, active (with these fixed values the free optimum is x0 ~ 0).
constexpr double kVolumeLimit = 1.2;
const double kStart[kK] = {0.2, 0.2, kFixed[0], kFixed[1]};

struct Fixture {
  std::unique_ptr<BoxHost> host;
  std::string path;
  cadinterp_asset* asset = nullptr;
  cadinterp_build_report report{};
  ~Fixture() {
    cadinterp_close(asset);
    std::filesystem::remove(path);
  }
};

int g_cubes = 16;

Fixture& fixture() {
  static const std::unique_ptr<Fixture> f = [] {
    auto x = std::make_unique<Fixture>();
    x->host = std::make_unique<BoxHost>(kK, std::array<double, 5>{0.6, 0.6, 0.4, 0.7, 0.5}, false,
                                        g_cubes);
    x->path = (std::filesystem::temp_directory_path() /
               ("cadinterp_optimize_bench_" + std::to_string(::getpid()) + ".cadi"))
                  .string();
    const std::string error = x->host->build(x->path, 3, 400, &x->report);
    if (!error.empty() || cadinterp_open(x->path.c_str(), &x->asset) != CADINTERP_OK) {
      std::fprintf(stderr, "optimize_bench: cannot build the asset: %s\n", error.c_str());
      std::exit(1);
    }
    return x;
  }();
  return *f;
}

cadinterp_optimize_problem* make_problem(bool outputs) {
  cadinterp_optimize_problem* p = nullptr;
  cadinterp_optimize_create(fixture().asset, &p);
  const cadinterp_status a =
      cadinterp_optimize_parse(p, 0, outputs ? "exact_integral_q" : "integral(q)");
  const std::string limit = std::to_string(kVolumeLimit);
  const cadinterp_status b = cadinterp_optimize_parse_constraint(
      p, ((outputs ? "output(brep_volume) >= " : "volume >= ") + limit).c_str(), nullptr);
  if (a != CADINTERP_OK || b != CADINTERP_OK) {
    std::fprintf(stderr, "optimize_bench: %s\n", cadinterp_optimize_error(p));
    std::exit(1);
  }
  cadinterp_optimize_set_bounds(p, 2, kFixed[0], kFixed[0]);
  cadinterp_optimize_set_bounds(p, 3, kFixed[1], kFixed[1]);
  return p;
}

void solve(benchmark::State& state, bool outputs) {
  cadinterp_optimize_problem* p = make_problem(outputs);
  cadinterp_optimize_options o;
  cadinterp_optimize_options_init(&o);
  o.start = kStart;
  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  // One untimed solve first: the elements it touches are then decoded and cached, as in an
  // interactive session that optimizes an asset already open (the cold solve is reported too).
  const auto c0 = std::chrono::steady_clock::now();
  cadinterp_optimize_solve(p, &o, &r);
  state.counters["cold_ms"] =
      1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
  double seconds = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    if (cadinterp_optimize_solve(p, &o, &r) != CADINTERP_OK) {
      state.SkipWithError(cadinterp_optimize_error(p));
      break;
    }
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  state.counters["iterations"] = r.iterations;
  state.counters["evaluations"] = r.evaluations;
  state.counters["x0"] = r.x[0];
  state.counters["x1"] = r.x[1];
  state.counters["objective"] = r.objective;
  // Wall time per evaluation (values and gradients of objective and constraint at one x).
  state.counters["us_per_evaluation"] =
      1e6 * seconds / static_cast<double>(state.iterations()) / std::max(1, r.evaluations);
  cadinterp_optimize_destroy(p);
}

void BM_OptimizeMeshQuantities(benchmark::State& state) { solve(state, false); }
void BM_OptimizeSampleOutputs(benchmark::State& state) { solve(state, true); }

// One evaluation of objective and constraint with their gradients at the start point
// (cadinterp_optimize_evaluate): what each Ipopt evaluation costs.
void evaluate(benchmark::State& state, bool outputs) {
  cadinterp_optimize_problem* p = make_problem(outputs);
  double v[2], g[2 * kK];
  for (auto _ : state) {
    if (cadinterp_optimize_evaluate(p, kStart, v, g) != CADINTERP_OK)
      state.SkipWithError(cadinterp_optimize_error(p));
    benchmark::DoNotOptimize(v);
  }
  cadinterp_optimize_destroy(p);
}
void BM_EvaluateMeshQuantities(benchmark::State& state) { evaluate(state, false); }
void BM_EvaluateSampleOutputs(benchmark::State& state) { evaluate(state, true); }

// One cadinterp_grad of positions and the field q at the start point: the blend behind each
// evaluation of the mesh problem (integral(q) and volume share the element).
void BM_EvalGrad(benchmark::State& state) {
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(fixture().asset, &ws);
  const int q = 0;
  cadinterp_mesh_grad g;
  for (auto _ : state) {
    if (cadinterp_grad(ws, kStart, &q, 1, &g) != CADINTERP_OK) state.SkipWithError("grad");
    benchmark::DoNotOptimize(g.dpositions);
  }
  state.counters["vertices"] = g.vertex_count;
  cadinterp_workspace_destroy(ws);
}

// The bytes that blend reads: terms x (#V x 3 positions + #V values of q), float32, with terms
// the mean over the asset's elements (the build report's stored meshes per element: the C ABI
// this module is written against does not expose one element's terms). A memcpy of that many
// bytes, measured in the same run, is its bandwidth bound.
std::size_t blend_bytes(int* terms_out) {
  const cadinterp_build_report& r = fixture().report;
  const int elements = r.elements - r.infeasible_elements;
  const int terms = elements > 0 ? (r.stored_meshes + elements - 1) / elements : 0;
  int element = -1, feasible = 0;
  cadinterp_locate(fixture().asset, kStart, &element, &feasible);
  std::uint32_t vertices = 0;
  cadinterp_element_mesh_size(fixture().asset, element, &vertices, nullptr, nullptr);
  *terms_out = terms;
  return static_cast<std::size_t>(terms) * vertices * 4 * sizeof(float);
}

void BM_MemcpyOfTheBlendBytes(benchmark::State& state) {
  int terms = 0;
  const std::size_t bytes = blend_bytes(&terms);
  std::vector<char> src(bytes, 1), dst(bytes);
  for (auto _ : state) {
    std::memcpy(dst.data(), src.data(), bytes);
    benchmark::ClobberMemory();
  }
  state.counters["terms"] = terms;
  state.counters["MB"] = static_cast<double>(bytes) / 1e6;
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
}

void BM_EvalOutputsGrad(benchmark::State& state) {
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(fixture().asset, &ws);
  const int which[2] = {0, 1};
  double v[2], g[2 * kK];
  for (auto _ : state) {
    if (cadinterp_eval_outputs(ws, kStart, which, 2, v, g) != CADINTERP_OK)
      state.SkipWithError("outputs");
    benchmark::DoNotOptimize(v);
  }
  cadinterp_workspace_destroy(ws);
}

// One host evaluation (regenerate, references, simulate; serialized as a worker would): the
// unit of the same optimization run on the host, (free parameters + 1) of them per iteration
// with forward differences.
void BM_HostEvaluation(benchmark::State& state) {
  const cadinterp_host* host = &fixture().host->host;
  for (auto _ : state) {
    void* bytes = nullptr;
    std::size_t size = 0;
    if (cadinterp_host_evaluate_serialized(host, kStart, &bytes, &size) != CADINTERP_OK)
      state.SkipWithError("host");
    cadinterp_bytes_free(bytes);
  }
}

// The same optimization on the host itself, forward-difference gradients (host_fd_nlp.h):
// objective exact_integral_q and constraint brep_volume >= limit, both the host's exact values.
void BM_OptimizeOnTheHostWithDifferences(benchmark::State& state) {
  using cadinterp::optimize::bench::HostFdNlp;
  int evaluations = 0;
  std::vector<double> x;
  for (auto _ : state) {
    Ipopt::SmartPtr<HostFdNlp> nlp = new HostFdNlp(
        &fixture().host->host, std::vector<double>(kStart, kStart + kK), {0, 1},
        [h = fixture().host.get()](const double* at, double* f, double* g) {
          *f = h->integral_q(at);  // the outputs exact_integral_q, brep_volume
          *g = BoxHost::height(at);
        },
        kVolumeLimit);
    const Ipopt::ApplicationReturnStatus s = cadinterp::optimize::bench::solve_on_host(nlp);
    if (s != Ipopt::Solve_Succeeded && s != Ipopt::Solved_To_Acceptable_Level)
      state.SkipWithError("Ipopt did not converge on the host");
    evaluations = nlp->host_evaluations;
    x = nlp->x_final;
  }
  state.counters["host_evaluations"] = evaluations;
  if (x.size() >= 2) state.counters["x0"] = x[0], state.counters["x1"] = x[1];
}

BENCHMARK(BM_OptimizeMeshQuantities)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_OptimizeSampleOutputs)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EvaluateMeshQuantities)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EvaluateSampleOutputs)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EvalGrad)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_MemcpyOfTheBlendBytes)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EvalOutputsGrad)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_HostEvaluation)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_OptimizeOnTheHostWithDifferences)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strncmp(argv[i], "--cubes=", 8) == 0)
      g_cubes = std::atoi(argv[i] + 8);
    else
      rest.push_back(argv[i]);
  }
  if (g_cubes < 1) {
    std::fprintf(stderr, "optimize_bench: --cubes must be >= 1\n");
    return 2;
  }
  int n = static_cast<int>(rest.size());
  benchmark::Initialize(&n, rest.data());
  fixture();  // built before any timing
  std::fprintf(stderr, "asset: %d cubes per axis, %d samples, %d elements, max error %.3g\n",
               g_cubes, fixture().report.samples, fixture().report.elements,
               fixture().report.max_error);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
