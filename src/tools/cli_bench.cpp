// `cadinterp bench`: a quick timing of opening an asset and of each evaluation call (cold and
// warm eval, eval+grad, vjp, mass properties) at random feasible points. Element boxes come from
// the index with the format library; the timed calls use the C ABI only.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"
#include "format/asset_reader.h"

namespace cadinterp::cli {
namespace {

struct Timing {
  std::vector<double> s;
  double quantile(double q) const {
    if (s.empty()) return 0;
    std::vector<double> v = s;
    const std::size_t k =
        std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
  }
  double mean() const {
    return s.empty() ? 0 : std::accumulate(s.begin(), s.end(), 0.0) / static_cast<double>(s.size());
  }
};

}  // namespace

int cmd_bench(const std::vector<std::string>& args) {
  std::string path, fields_spec = "all";
  int iterations = 1000, seed = 1;
  ArgParser p("cadinterp bench", "ASSET [--iterations N]",
              "Times opening an asset and evaluating it at random feasible points: open, cold\n"
              "eval (the first eval in each element, which decodes it), warm eval, eval+grad,\n"
              "vector-Jacobian product and mass properties. A quick look, not the project's\n"
              "benchmark suite (see runtime_bench).");
  p.positional("ASSET", "the asset file (.cadi)", &path);
  p.option("iterations", 'n', "N", "calls per measurement", &iterations, 1, 100000000);
  p.option("fields", 0, "A,B", "fields evaluated with the mesh ('all', or '' for none)",
           &fields_spec);
  p.option("seed", 0, "S", "random seed of the points", &seed, 0, 2147483647);
  if (!p.parse(args)) return kExitOk;

  Timing open_t;
  const int opens = std::min(iterations, 20);
  for (int i = 0; i < opens; ++i) {
    const auto t0 = Clock::now();
    AssetPtr a = open_asset(path);
    open_t.s.push_back(seconds_since(t0));
  }

  // Element boxes come from the index (not part of the ABI); the timed calls use the ABI only.
  const std::unique_ptr<format::AssetReader> reader = open_index(path);
  const auto& basis = reader->basis();
  const int K = basis.dim();
  const auto uK = static_cast<std::size_t>(K);

  AssetPtr asset = open_asset(path);
  const std::vector<int> field_idx = select_fields(asset.get(), fields_spec);
  const int nf = static_cast<int>(field_idx.size());
  WorkspacePtr ws = make_workspace(asset.get());
  cadinterp_mesh mesh{};

  Timing cold;
  std::vector<double> lo(uK), hi(uK), x(uK);
  for (int e = 0; e < basis.element_count(); ++e) {
    if (!basis.element_feasible(e)) continue;
    basis.element_box(e, lo.data(), hi.data());
    for (std::size_t d = 0; d < uK; ++d) x[d] = 0.5 * (lo[d] + hi[d]);
    const auto t0 = Clock::now();
    check_ws(cadinterp_eval(ws.get(), x.data(), field_idx.data(), nf, &mesh), ws.get(), "eval");
    cold.s.push_back(seconds_since(t0));
  }
  if (cold.s.empty())
    throw RuntimeFailure(describe(CADINTERP_E_INFEASIBLE, "the asset has no feasible element"));

  std::mt19937_64 rng(static_cast<std::uint64_t>(seed));
  const std::vector<double>& plo = basis.lower();
  const std::vector<double>& phi = basis.upper();
  auto random_point = [&](std::vector<double>& out) {
    for (int attempt = 0; attempt < 10000; ++attempt) {
      for (std::size_t d = 0; d < uK; ++d)
        out[d] = std::uniform_real_distribution<double>(plo[d], phi[d])(rng);
      int el = -1, feasible = 0;
      if (cadinterp_locate(asset.get(), out.data(), &el, &feasible) == CADINTERP_OK && feasible)
        return;
    }
    throw RuntimeFailure("no feasible point found in 10000 random draws");
  };
  const auto n = static_cast<std::size_t>(iterations);
  std::vector<std::vector<double>> points(n, std::vector<double>(uK));
  for (auto& q : points) random_point(q);

  Timing warm, grad_t, vjp_t, prop_t, propg_t;
  for (const auto& q : points) {
    const auto t0 = Clock::now();
    check_ws(cadinterp_eval(ws.get(), q.data(), field_idx.data(), nf, &mesh), ws.get(), "eval");
    warm.s.push_back(seconds_since(t0));
  }
  cadinterp_mesh_grad g{};
  for (const auto& q : points) {
    const auto t0 = Clock::now();
    check_ws(cadinterp_grad(ws.get(), q.data(), field_idx.data(), nf, &g), ws.get(), "grad");
    grad_t.s.push_back(seconds_since(t0));
  }
  std::vector<float> adjoint;
  std::vector<double> dfdx(uK);
  std::normal_distribution<float> normal;
  for (const auto& q : points) {
    check_ws(cadinterp_eval(ws.get(), q.data(), nullptr, 0, &mesh), ws.get(), "eval");
    adjoint.resize(3 * static_cast<std::size_t>(mesh.vertex_count));
    for (float& v : adjoint) v = normal(rng);
    const auto t0 = Clock::now();
    check_ws(cadinterp_vjp(ws.get(), q.data(), adjoint.data(), nullptr, nullptr, 0, dfdx.data()),
             ws.get(), "vjp");
    vjp_t.s.push_back(seconds_since(t0));
  }
  const double dir[3] = {1, 0, 0};
  cadinterp_properties props{};
  std::vector<cadinterp_properties> dprops(uK);
  for (const auto& q : points) {
    auto t0 = Clock::now();
    check_ws(cadinterp_eval_properties(ws.get(), q.data(), 1.0, dir, &props, nullptr), ws.get(),
             "properties");
    prop_t.s.push_back(seconds_since(t0));
    t0 = Clock::now();
    check_ws(cadinterp_eval_properties(ws.get(), q.data(), 1.0, dir, &props, dprops.data()),
             ws.get(), "properties");
    propg_t.s.push_back(seconds_since(t0));
  }

  std::printf(
      "asset %s: K=%d, degree %d, %d elements, %d fields evaluated, %d points (seed %d)\n\n",
      path.c_str(), K, static_cast<int>(basis.degree()), basis.element_count(), nf, iterations,
      seed);
  std::printf("%-24s %8s %12s %12s %12s\n", "operation", "calls", "median", "mean", "p90");
  auto row = [](const char* name, const Timing& t) {
    std::printf("%-24s %8zu %12s %12s %12s\n", name, t.s.size(),
                human_seconds(t.quantile(0.5)).c_str(), human_seconds(t.mean()).c_str(),
                human_seconds(t.quantile(0.9)).c_str());
  };
  row("open", open_t);
  row("eval, cold (1/element)", cold);
  row("eval, warm", warm);
  row("eval+grad", grad_t);
  row("vjp (positions)", vjp_t);
  row("properties", prop_t);
  row("properties+grad", propg_t);
  return kExitOk;
}

}  // namespace cadinterp::cli
