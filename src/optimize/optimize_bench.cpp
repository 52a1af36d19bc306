// One optimization end to end on an analytic asset shaped like the press use case:
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
//
// With --press=ASSET (a cubic asset of the OpenCASCADE press, scripts/press-figure21.sh builds
// one) it measures the paper's use case itself instead (BM_Press*): height 240 and width 120
// fixed, minimize integral(von_mises) under volume <= its value at the start (mesh
// quantities), and output(max_von_mises) under output(brep_volume) <= its value at the start
// (per-sample outputs), from the centre of the structural box. --press-host=LIB adds one host
// evaluation (regenerate and simulate; options --press-host-options=OPTS, as the build had),
// the unit of the same optimization run on the host ((free parameters + 1) per gradient).
#include <benchmark/benchmark.h>
#include <dlfcn.h>
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

// What the timed optimizations solve: an asset, its use case (the fixed parameters and the
// start) and, per flavour (mesh quantities, per-sample outputs), an objective and a constraint.
struct UseCase {
  cadinterp_asset* asset = nullptr;
  std::vector<double> start;                  // K values, the fixed ones included
  std::vector<std::pair<int, double>> fixed;  // (parameter, value)
  std::vector<int> free;                      // the parameters Ipopt moves
  std::string objective[2], constraint[2];    // [0]: mesh quantities, [1]: sample outputs
  int field = 0;                              // the field BM_EvalGrad blends
  int outputs[2] = {0, 1};                    // the outputs BM_EvalOutputsGrad evaluates
};

UseCase analytic_case() {
  UseCase u;
  u.asset = fixture().asset;
  u.start.assign(kStart, kStart + kK);
  u.fixed = {{2, kFixed[0]}, {3, kFixed[1]}};
  u.free = {0, 1};
  const std::string limit = std::to_string(kVolumeLimit);
  u.objective[0] = "integral(q)";
  u.objective[1] = "exact_integral_q";
  u.constraint[0] = "volume >= " + limit;
  u.constraint[1] = "output(brep_volume) >= " + limit;
  return u;
}

// --press: the paper's tall use case on a press asset (see the top of the file).
std::string g_press, g_press_host, g_press_host_options;

int parameter_named(const cadinterp_asset* a, const char* name) {
  for (int i = 0; i < cadinterp_parameter_count(a); ++i) {
    cadinterp_parameter_info info;
    if (cadinterp_parameter(a, i, &info) == CADINTERP_OK && std::strcmp(info.name, name) == 0)
      return i;
  }
  std::fprintf(stderr, "optimize_bench: %s has no parameter '%s' (not a press asset)\n",
               g_press.c_str(), name);
  std::exit(1);
}

// The value of `expression` at x on the asset.
double value_at(cadinterp_asset* a, const char* expression, const double* x) {
  cadinterp_optimize_problem* p = nullptr;
  double v = 0;
  if (cadinterp_optimize_create(a, &p) != CADINTERP_OK ||
      cadinterp_optimize_parse(p, 0, expression) != CADINTERP_OK ||
      cadinterp_optimize_evaluate(p, x, &v, nullptr) != CADINTERP_OK) {
    std::fprintf(stderr, "optimize_bench: %s at the start: %s\n", expression,
                 p ? cadinterp_optimize_error(p) : "cannot create a problem");
    std::exit(1);
  }
  cadinterp_optimize_destroy(p);
  return v;
}

UseCase press_case() {
  UseCase u;
  if (cadinterp_open(g_press.c_str(), &u.asset) != CADINTERP_OK) {
    std::fprintf(stderr, "optimize_bench: %s: %s\n", g_press.c_str(), cadinterp_open_error());
    std::exit(1);
  }
  const int K = cadinterp_parameter_count(u.asset);
  u.start.resize(static_cast<std::size_t>(K));
  for (int i = 0; i < K; ++i) {
    cadinterp_parameter_info info;
    cadinterp_parameter(u.asset, i, &info);
    u.start[static_cast<std::size_t>(i)] = 0.5 * (info.lower + info.upper);
  }
  u.fixed = {{parameter_named(u.asset, "height"), 240.0},
             {parameter_named(u.asset, "width"), 120.0}};
  for (const auto& [i, v] : u.fixed) u.start[static_cast<std::size_t>(i)] = v;
  for (const char* name : {"throat_fillet", "spine_thickness", "ram_bore"})
    u.free.push_back(parameter_named(u.asset, name));
  char limit[64];
  std::snprintf(limit, sizeof limit, "%.9g", value_at(u.asset, "volume", u.start.data()));
  u.objective[0] = "integral(von_mises)";
  u.constraint[0] = std::string("volume <= ") + limit;
  std::snprintf(limit, sizeof limit, "%.9g",
                value_at(u.asset, "output(brep_volume)", u.start.data()));
  u.objective[1] = "output(max_von_mises)";
  u.constraint[1] = std::string("output(brep_volume) <= ") + limit;
  if (cadinterp_find_field(u.asset, "von_mises", &u.field) != CADINTERP_OK ||
      cadinterp_find_output(u.asset, "max_von_mises", &u.outputs[0]) != CADINTERP_OK ||
      cadinterp_find_output(u.asset, "brep_volume", &u.outputs[1]) != CADINTERP_OK) {
    std::fprintf(stderr, "optimize_bench: %s lacks von_mises, max_von_mises or brep_volume\n",
                 g_press.c_str());
    std::exit(1);
  }
  return u;
}

const UseCase& use_case() {
  static const UseCase u = g_press.empty() ? analytic_case() : press_case();
  return u;
}

cadinterp_optimize_problem* make_problem(bool outputs) {
  const UseCase& u = use_case();
  cadinterp_optimize_problem* p = nullptr;
  cadinterp_optimize_create(u.asset, &p);
  if (cadinterp_optimize_parse(p, 0, u.objective[outputs].c_str()) != CADINTERP_OK ||
      cadinterp_optimize_parse_constraint(p, u.constraint[outputs].c_str(), nullptr) !=
          CADINTERP_OK) {
    std::fprintf(stderr, "optimize_bench: %s\n", cadinterp_optimize_error(p));
    std::exit(1);
  }
  for (const auto& [i, v] : u.fixed) cadinterp_optimize_set_bounds(p, i, v, v);
  return p;
}

void solve(benchmark::State& state, bool outputs) {
  const UseCase& u = use_case();
  cadinterp_optimize_problem* p = make_problem(outputs);
  cadinterp_optimize_options o;
  cadinterp_optimize_options_init(&o);
  o.start = u.start.data();
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
  for (std::size_t i = 0; i < u.free.size(); ++i)
    state.counters["x" + std::to_string(u.free[i])] = r.x[u.free[i]];
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
  const UseCase& u = use_case();
  cadinterp_optimize_problem* p = make_problem(outputs);
  double v[2];
  std::vector<double> g(2 * u.start.size());
  for (auto _ : state) {
    if (cadinterp_optimize_evaluate(p, u.start.data(), v, g.data()) != CADINTERP_OK)
      state.SkipWithError(cadinterp_optimize_error(p));
    benchmark::DoNotOptimize(v);
  }
  cadinterp_optimize_destroy(p);
}
void BM_EvaluateMeshQuantities(benchmark::State& state) { evaluate(state, false); }
void BM_EvaluateSampleOutputs(benchmark::State& state) { evaluate(state, true); }

// One cadinterp_grad of positions and the use case's field at the start point: the blend behind
// each evaluation of the mesh problem (the integral and the volume share the element).
void BM_EvalGrad(benchmark::State& state) {
  const UseCase& u = use_case();
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(u.asset, &ws);
  cadinterp_mesh_grad g;
  for (auto _ : state) {
    if (cadinterp_grad(ws, u.start.data(), &u.field, 1, &g) != CADINTERP_OK)
      state.SkipWithError(cadinterp_workspace_error(ws));
    benchmark::DoNotOptimize(g.dpositions);
  }
  state.counters["vertices"] = g.vertex_count;
  cadinterp_workspace_destroy(ws);
}

// The bytes that blend reads at x: terms x (#V x 3 positions + #V values of one scalar field),
// float32, with the element's own term count. A memcpy of that many bytes, measured in the same
// run, is its bandwidth bound.
void BM_MemcpyOfTheBlendBytes(benchmark::State& state) {
  const UseCase& u = use_case();
  int element = -1, terms = 0;
  std::uint32_t vertices = 0;
  cadinterp_locate(u.asset, u.start.data(), &element, nullptr);
  cadinterp_element_term_count(u.asset, element, &terms);
  cadinterp_element_mesh_size(u.asset, element, &vertices, nullptr, nullptr);
  const std::size_t bytes = static_cast<std::size_t>(terms) * vertices * 4 * sizeof(float);
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
  const UseCase& u = use_case();
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(u.asset, &ws);
  double v[2];
  std::vector<double> g(2 * u.start.size());
  for (auto _ : state) {
    if (cadinterp_eval_outputs(ws, u.start.data(), u.outputs, 2, v, g.data()) != CADINTERP_OK)
      state.SkipWithError(cadinterp_workspace_error(ws));
    benchmark::DoNotOptimize(v);
  }
  cadinterp_workspace_destroy(ws);
}

// One host evaluation (regenerate, references, simulate; serialized as a worker would): the
// unit of the same optimization run on the host, (free parameters + 1) of them per iteration
// with forward differences.
void host_evaluation(benchmark::State& state, const cadinterp_host* host, const double* x) {
  for (auto _ : state) {
    void* bytes = nullptr;
    std::size_t size = 0;
    if (cadinterp_host_evaluate_serialized(host, x, &bytes, &size) != CADINTERP_OK)
      state.SkipWithError("host");
    cadinterp_bytes_free(bytes);
  }
}
void BM_HostEvaluation(benchmark::State& state) {
  host_evaluation(state, &fixture().host->host, kStart);
}

// The press host (--press-host): loaded once, kept until the process ends.
void BM_PressHostEvaluation(benchmark::State& state) {
  static const cadinterp_host* host = [] {
    void* lib = dlopen(g_press_host.c_str(), RTLD_NOW | RTLD_LOCAL);
    auto entry =
        lib ? reinterpret_cast<cadinterp_host_entry_fn>(dlsym(lib, CADINTERP_HOST_ENTRY_NAME))
            : nullptr;
    const char* error = nullptr;
    const cadinterp_host* h =
        entry ? entry("press", g_press_host_options.c_str(), &error) : nullptr;
    if (!h)
      std::fprintf(stderr, "optimize_bench: %s: %s\n", g_press_host.c_str(),
                   lib ? (error ? error : "no host entry") : dlerror());
    return h;
  }();
  if (!host) {
    state.SkipWithError("the press host could not be loaded");
    return;
  }
  host_evaluation(state, host, use_case().start.data());
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

void register_benchmarks() {
  const std::string prefix = g_press.empty() ? "" : "Press";
  auto add = [&](const char* name, void (*fn)(benchmark::State&), benchmark::TimeUnit unit) {
    benchmark::RegisterBenchmark(("BM_" + prefix + name).c_str(), fn)->Unit(unit);
  };
  add("OptimizeMeshQuantities", BM_OptimizeMeshQuantities, benchmark::kMillisecond);
  add("OptimizeSampleOutputs", BM_OptimizeSampleOutputs, benchmark::kMillisecond);
  add("EvaluateMeshQuantities", BM_EvaluateMeshQuantities, benchmark::kMicrosecond);
  add("EvaluateSampleOutputs", BM_EvaluateSampleOutputs, benchmark::kMicrosecond);
  add("EvalGrad", BM_EvalGrad, benchmark::kMicrosecond);
  add("MemcpyOfTheBlendBytes", BM_MemcpyOfTheBlendBytes, benchmark::kMicrosecond);
  add("EvalOutputsGrad", BM_EvalOutputsGrad, benchmark::kMicrosecond);
  if (g_press.empty()) {
    add("HostEvaluation", BM_HostEvaluation, benchmark::kMicrosecond);
    add("OptimizeOnTheHostWithDifferences", BM_OptimizeOnTheHostWithDifferences,
        benchmark::kMillisecond);
  } else if (!g_press_host.empty()) {
    // A regeneration and simulation takes seconds: once is the measurement.
    benchmark::RegisterBenchmark("BM_PressHostEvaluation", BM_PressHostEvaluation)
        ->Unit(benchmark::kSecond)
        ->Iterations(1);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--cubes=", 0) == 0)
      g_cubes = std::atoi(argv[i] + 8);
    else if (a.rfind("--press=", 0) == 0)
      g_press = a.substr(8);
    else if (a.rfind("--press-host=", 0) == 0)
      g_press_host = a.substr(13);
    else if (a.rfind("--press-host-options=", 0) == 0)
      g_press_host_options = a.substr(21);
    else
      rest.push_back(argv[i]);
  }
  if (g_cubes < 1) {
    std::fprintf(stderr, "optimize_bench: --cubes must be >= 1\n");
    return 2;
  }
  int n = static_cast<int>(rest.size());
  benchmark::Initialize(&n, rest.data());
  register_benchmarks();
  const UseCase& u = use_case();  // built (or opened) before any timing
  if (g_press.empty()) {
    std::fprintf(stderr, "asset: %d cubes per axis, %d samples, %d elements, max error %.3g\n",
                 g_cubes, fixture().report.samples, fixture().report.elements,
                 fixture().report.max_error);
  } else {
    std::fprintf(stderr, "asset: %s, %d elements; %s s.t. %s; %s s.t. %s\n", g_press.c_str(),
                 cadinterp_element_count(u.asset), u.objective[0].c_str(), u.constraint[0].c_str(),
                 u.objective[1].c_str(), u.constraint[1].c_str());
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (!g_press.empty()) cadinterp_close(u.asset);
  return 0;
}
