// `cadinterp optimize`: shape optimization on an asset's interpolant with Ipopt, through the
// public C ABI of libcadinterp_optimize (cadinterp_optimize.h): objective and constraints in its
// expression language, fixed parameters, start point, multi-start; a progress line per
// iteration, then a summary (or JSON). With --verify, the paper's second stage (§7.2): the host
// regenerates and simulates x*, and the interpolated and true values are printed side by side
// (optimize_verify.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_optimize.h"
#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"
#include "json_writer.h"
#include "optimize_grid.h"
#include "optimize_setup.h"
#ifdef CADINTERP_CLI_HAVE_VERIFY
#include "host_library.h"
#include "optimize_verify.h"
#endif

namespace cadinterp::cli {
namespace {

struct Args {
  OptimizeSpec spec;
  std::string asset, start;
  bool json = false, quiet = false;
  bool verify = false;
  std::string host, model, host_options;
  int grid = 0, host_grid = 0, threads = 0;
};

// A SpecError as a usage error: the option, the message, the text and a caret under the
// offending column.
[[noreturn]] void usage_error(const SpecError& e) {
  std::string out = e.input + ": " + e.what();
  if (!e.text.empty()) out += "\n  " + e.text;
  if (e.column >= 1 && !e.text.empty())
    out += "\n  " + std::string(static_cast<std::size_t>(e.column - 1), ' ') + "^";
  throw UsageError(out);
}

struct Progress {
  bool quiet;
  std::vector<std::string> names;
};

int print_progress(void* user, int start, int iteration, const double* x, double objective,
                   double violation, double optimality) {
  const auto* pr = static_cast<const Progress*>(user);
  if (pr->quiet) return 0;
  std::string xs;
  for (std::size_t i = 0; i < pr->names.size(); ++i)
    xs += fmt("%s%s=%.6g", i ? " " : "", pr->names[i].c_str(), x[i]);
  std::fprintf(stderr, "start %d iter %3d  objective %.9g  violation %.2e  kkt %.2e  %s\n", start,
               iteration, objective, violation, optimality, xs.c_str());
  return 0;
}

void print_text(const Args& a, const cadinterp_optimize_result& r,
                const std::vector<std::string>& names) {
  std::printf("status:      %s%s\n", r.status, r.converged ? "" : " (not converged)");
  std::printf("objective:   %.9g   (minimize %s)\n", r.objective, a.spec.minimize.c_str());
  for (int j = 0; j < r.constraint_count; ++j)
    std::printf("constraint:  %.9g   (%s)\n", r.constraints[j],
                a.spec.subject_to[static_cast<std::size_t>(j)].c_str());
  // Met as --verify and the grids judge it: within 1e-6 of the bound's size (constraint_met).
  bool met = true;
  for (int j = 0; j < r.constraint_count; ++j)
    met = met &&
          constraint_met(a.spec.subject_to[static_cast<std::size_t>(j)], r.constraints[j]) != 0;
  if (r.constraint_count)
    std::printf("violation:   %.3g%s\n", r.constraint_violation,
                met ? "" : "  (constraints NOT met)");
  std::printf("x*:\n");
  for (int i = 0; i < r.parameter_count; ++i)
    std::printf("  %-16s %.9g\n", names[static_cast<std::size_t>(i)].c_str(), r.x[i]);
  std::printf("gradient:    |grad f| = %.3g over free parameters; Ipopt KKT error %.3g\n",
              r.gradient_norm, r.optimality);
  std::printf(
      "work:        %d iterations, %d evaluations (%d refused by a wall), %d start%s "
      "(best: %d)\n",
      r.iterations, r.evaluations, r.refused_evaluations, r.starts, r.starts == 1 ? "" : "s",
      r.best_start);
  if (r.error_estimate >= 0)
    std::printf("accuracy:    the builder's error estimate at x* is %.3g of the model diagonal\n",
                r.error_estimate);
  else
    std::printf("accuracy:    the builder did not measure the error of x*'s element\n");
  if (r.linear_asset) std::printf("note:        %s\n", r.note);
}

std::string point_text(const std::vector<std::string>& names, const std::vector<double>& x) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i)
    out += fmt("%s%s=%.6g", i ? " " : "", names[i].c_str(), x[i]);
  return out;
}

// "1.2 % below the grid's best: x* beats every grid point" (objectives compared as minimized).
std::string compared_to_best(double objective, const GridSummary& g) {
  const double best = g.best_values[0];
  const double rel = best != 0 ? 100.0 * (objective - best) / std::fabs(best) : objective - best;
  return fmt("%.3g%s %s", std::fabs(rel), best != 0 ? " %" : " (abs)",
             rel <= 0 ? "below the grid's best: x* beats every grid point"
                      : "above the grid's best: a grid point beats x*");
}

// The grid's counts and best point, and x*'s objective (`xstar`: which value it is) against it.
void print_grid(const char* label, const char* what, const GridSummary& g, double objective,
                const char* xstar, const std::vector<std::string>& names) {
  std::printf(
      "%-12s %s, %d per free parameter: %zu points in %s; %zu not evaluated, %zu violate "
      "a constraint\n",
      label, what, g.per_axis, g.points, human_seconds(g.seconds).c_str(), g.failed, g.violating);
  if (g.failed) std::printf("  first not evaluated: %s\n", g.first_failure.c_str());
  if (!g.found) {
    std::printf("  no grid point meets the constraints\n");
    return;
  }
  std::printf("  best:      objective %.9g at %s\n", g.best_values[0],
              point_text(names, g.best_x).c_str());
  std::printf("  x*:        objective %.9g (%s), %s\n", objective, xstar,
              compared_to_best(objective, g).c_str());
}

void write_grid(JsonWriter& w, const char* key, const GridSummary& g,
                const std::vector<std::string>& names) {
  w.key(key).begin_object();
  w.field("per_axis", g.per_axis).field("points", static_cast<std::uint64_t>(g.points));
  w.field("not_evaluated", static_cast<std::uint64_t>(g.failed));
  w.field("violating", static_cast<std::uint64_t>(g.violating));
  w.field("seconds", g.seconds).field("found", g.found);
  if (g.failed) w.field("first_not_evaluated", g.first_failure);
  if (g.found) {
    w.key("best_x").begin_object();
    for (std::size_t i = 0; i < names.size(); ++i) w.field(names[i], g.best_x[i]);
    w.end_object();
    w.key("best_values").begin_array();
    for (double v : g.best_values) w.value(v);
    w.end_array();
  }
  w.end_object();
}

#ifdef CADINTERP_CLI_HAVE_VERIFY
// The host named by --host, checked against the asset before any work: a library that cannot be
// loaded or refuses the model is a runtime failure (exit 1), other parameters a usage error.
const cadinterp_host* load_verify_host(const Args& a, const cadinterp_asset* asset,
                                       tools::HostLibrary& library) {
  if (a.host.empty())
    throw UsageError("--verify and --host-grid need --host LIB.so (and usually --model)");
  const cadinterp_host* host = nullptr;
  try {
    host = library.load(a.host, a.model, a.host_options);
  } catch (const tools::HostLoadError& e) {
    throw RuntimeFailure(describe(e.status, e.what()));
  }
  const std::string mismatch = parameter_mismatch(*host, asset);
  if (!mismatch.empty())
    throw UsageError("--verify: the host does not match the asset: " + mismatch +
                     " (give the --model and --host-options the asset was built with)");
  // The asset records its host's name only (not its options): a different name is worth a
  // warning, not a refusal (a host may be renamed between releases).
  cadinterp_provenance prov{};
  if (cadinterp_asset_provenance(asset, &prov) == CADINTERP_OK && prov.host && host->name &&
      std::string(prov.host) != host->name)
    std::fprintf(stderr,
                 "cadinterp optimize: warning: the asset was built by host '%s', --host is '%s'\n",
                 prov.host, host->name);
  return host;
}

// Relative difference |true - interpolated| / |true| in percent, "n/a" without a true value.
std::string relative_difference(double interpolated, const TrueValue& t) {
  if (!t.defined) return "n/a";
  const double d = std::fabs(t.value - interpolated);
  return t.value != 0 ? fmt("%.3g %%", 100.0 * d / std::fabs(t.value)) : fmt("%.3g (abs)", d);
}

void print_verification(const Args& a, const cadinterp_optimize_result& r, const Verification& v) {
  std::printf("verify:      the host at x* (%s%s%s): ", a.host.c_str(),
              a.model.empty() ? "" : ", model ", a.model.c_str());
  if (!v.feasible) {
    std::printf("FAILED: %s\n", v.message.c_str());
    return;
  }
  std::printf("%zu vertices, %zu tets, %s\n", v.vertices, v.tets,
              human_seconds(v.host_seconds).c_str());
  std::printf("  %-40s %16s %16s %12s\n", "function", "interpolated", "true (host)", "difference");
  for (std::size_t f = 0; f < v.values.size(); ++f) {
    const std::string name = f == 0 ? "minimize " + a.spec.minimize : a.spec.subject_to[f - 1];
    const double interp = f == 0 ? r.objective : r.constraints[f - 1];
    const TrueValue& t = v.values[f];
    std::printf("  %-40s %16.9g %16s %12s\n", name.c_str(), interp,
                t.defined ? fmt("%.9g", t.value).c_str() : "n/a",
                relative_difference(interp, t).c_str());
    if (!t.defined) std::printf("    n/a: %s\n", t.reason.c_str());
    if (t.defined && f > 0 && constraint_met(name, t.value) == 0)
      std::printf("    the host's value does NOT meet this constraint\n");
  }
}

void write_verification(JsonWriter& w, const Args& a, const cadinterp_optimize_result& r,
                        const Verification& v) {
  w.key("verify").begin_object();
  w.field("host", a.host).field("model", a.model).field("feasible", v.feasible);
  if (!v.feasible) w.field("message", v.message);
  w.field("host_seconds", v.host_seconds);
  w.field("vertices", static_cast<std::uint64_t>(v.vertices));
  w.field("tets", static_cast<std::uint64_t>(v.tets));
  w.key("functions").begin_array();
  for (std::size_t f = 0; f < v.values.size(); ++f) {
    w.begin_object();
    w.field("expression", f == 0 ? a.spec.minimize : a.spec.subject_to[f - 1]);
    w.field("role", f == 0 ? "objective" : "constraint");
    w.field("interpolated", f == 0 ? r.objective : r.constraints[f - 1]);
    if (v.values[f].defined) {
      w.field("true", v.values[f].value);
      if (f > 0 && constraint_met(a.spec.subject_to[f - 1], v.values[f].value) >= 0)
        w.field("true_meets_constraint",
                constraint_met(a.spec.subject_to[f - 1], v.values[f].value) == 1);
    } else
      w.key("true").null().field("reason", v.values[f].reason);
    w.end_object();
  }
  w.end_array();
  w.end_object();
}
#endif

void parse_args(const std::vector<std::string>& args, Args& a, bool* go) {
  ArgParser p("cadinterp optimize",
              "ASSET --minimize EXPR [--subject-to 'EXPR <= V' ...] [options]",
              "Minimizes a quantity of the interpolated shape over the asset's parameter box with\n"
              "Ipopt, using the runtime's exact gradients. Points the runtime cannot evaluate\n"
              "(infeasible elements) and the box edge are walls.");
  p.positional("ASSET", "the asset file (.cadi)", &a.asset);
  p.option("minimize", 0, "EXPR", "the objective, e.g. 'integral(von_mises) + 0.1*mass'",
           &a.spec.minimize)
      .required();
  p.repeated("subject-to", 0, "'EXPR <= V'", "a constraint: EXPR <= V, EXPR >= V or EXPR == V",
             &a.spec.subject_to);
  p.option("fix", 0, "NAME=V,...", "fix parameters at values", &a.spec.fix);
  p.option("start", 0, "V1,V2,...", "start point, K values (default: the box centre)", &a.start);
  p.option("multistart", 0, "N", "N deterministic starts (Halton points), keep the best",
           &a.spec.multistart, 1, 1000);
  p.option("max-iterations", 0, "N", "Ipopt iterations per start", &a.spec.max_iterations, 0,
           100000);
  p.option("tolerance", 0, "T", "Ipopt's tol", &a.spec.tolerance, 1e-12, 1.0);
  p.flag("json", 0, "print JSON (with the path of iterates) instead of text", &a.json);
  p.flag("quiet", 'q', "no progress line per iteration", &a.quiet);
  p.flag("verify", 0,
         "regenerate and simulate x* with the host (--host) and print the\n"
         "interpolated and the true objective and constraints side by side",
         &a.verify);
  p.option("grid", 0, "N",
           "also evaluate the interpolant on a grid of N points per free\n"
           "parameter (ends included) and print its best point that meets the\n"
           "constraints: is x* the interpolant's global optimum?",
           &a.grid, 2, 1000);
  p.option("host-grid", 0, "N",
           "also evaluate the host (--host) on a grid of N points per free\n"
           "parameter and print its best point: is the optimum real?",
           &a.host_grid, 2, 100);
  p.option("threads", 'j', "N",
           "--host-grid: host evaluations in parallel (0: all cores;\n"
           "1 for a host that is not thread-safe)",
           &a.threads, 0, 1024);
  p.option("host", 0, "LIB.so", "--verify, --host-grid: the host library the asset was built with",
           &a.host);
  p.option("model", 'm', "NAME", "--verify, --host-grid: the host's model", &a.model);
  p.option("host-options", 0, "K=V,...", "--verify, --host-grid: the host's settings",
           &a.host_options);
  p.epilog(
      "expressions: sums of [WEIGHT*]QUANTITY with + and -. Quantities: volume, area,\n"
      "  mass[(density)], frontal_area[(dx,dy,dz)], centroid_x|y|z, inertia_xx..zz[(density)],\n"
      "  integral(FIELD[,component]), region_integral(FIELD,REGION[,component]),\n"
      "  region_area(REGION), max(FIELD[,p=P|ks=RHO][,component]) (a smooth upper bound of the\n"
      "  field's maximum: p-norm, default p=8, or Kreisselmeier-Steinhauser).\n"
      "example:\n"
      "  cadinterp optimize press.cadi --minimize 'integral(von_mises)' \\\n"
      "      --subject-to 'mass(7.85e-9) <= 12' --fix height=200,width=120 \\\n"
      "      --verify --host ./libpress_host.so --model press\n"
      "--verify measures the same expressions on the host's own mesh and fields at x*, with the\n"
      "runtime's definitions; a quantity the host does not return is reported as n/a.");
  *go = p.parse(args);
  if (!*go) return;
  for (const std::string& v : split_list(a.start)) {
    double d = 0;
    if (!parse_double(v, &d)) throw UsageError("--start: '" + v + "' is not a number");
    a.spec.start.push_back(d);
  }
  const bool uses_host = a.verify || a.host_grid > 0;
  if (!uses_host && (!a.host.empty() || !a.model.empty() || !a.host_options.empty()))
    throw UsageError("--host, --model and --host-options are for --verify and --host-grid");
}

}  // namespace

int cmd_optimize(const std::vector<std::string>& args) {
  Args a;
  bool go = false;
  parse_args(args, a, &go);
  if (!go) return kExitOk;

  const AssetPtr asset = open_asset(a.asset);
  const std::vector<std::string> names = parameter_names(asset.get());
#ifdef CADINTERP_CLI_HAVE_VERIFY
  tools::HostLibrary library;
  const cadinterp_host* host =
      a.verify || a.host_grid ? load_verify_host(a, asset.get(), library) : nullptr;
#else
  if (a.verify || a.host_grid)
    throw RuntimeFailure(
        "--verify and --host-grid need the builder's host adapter, which this build of cadinterp "
        "does not have");
#endif
  ProblemPtr problem;
  try {
    problem = make_problem(asset.get(), a.spec);
  } catch (const SpecError& e) {
    usage_error(e);
  }
  cadinterp_optimize_problem* pr = problem.get();
  Progress progress{a.quiet || a.json, names};
  cadinterp_optimize_options o = solve_options(a.spec);
  o.progress = &print_progress;
  o.progress_user = &progress;
  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  const cadinterp_status s = cadinterp_optimize_solve(pr, &o, &r);
  if (s == CADINTERP_E_INVALID_ARGUMENT) throw UsageError(cadinterp_optimize_error(pr));
  if (s != CADINTERP_OK) throw RuntimeFailure(describe(s, cadinterp_optimize_error(pr)));
  GridSummary grid, host_grid;
  const ParameterBox box = problem_box(asset.get(), a.spec);
  try {
    if (a.grid) grid = run_grid(box, a.grid, a.spec, interpolant_function(pr), 1);
#ifdef CADINTERP_CLI_HAVE_VERIFY
    if (a.host_grid) {
      const int threads = !host->thread_safe ? 1
                          : a.threads        ? a.threads
                                      : static_cast<int>(std::thread::hardware_concurrency());
      host_grid = run_grid(box, a.host_grid, a.spec, host_grid_function(*host, a.spec),
                           std::max(1, threads));
    }
#endif
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string(a.grid ? "--grid: " : "--host-grid: ") + e.what());
  }
#ifdef CADINTERP_CLI_HAVE_VERIFY
  Verification v;
  if (host && a.verify) {
    try {
      v = verify_with_host(*host, r.x, a.spec);
    } catch (const std::invalid_argument& e) {
      throw RuntimeFailure(
          describe(CADINTERP_E_INVALID_ARGUMENT, std::string("--verify: ") + e.what()));
    }
  }
#endif
  if (a.json) {
    std::string out;
    JsonWriter w(out);
    w.begin_object();
    write_result_members(w, a.spec, r, names);
#ifdef CADINTERP_CLI_HAVE_VERIFY
    if (host && a.verify) write_verification(w, a, r, v);
#endif
    if (a.grid) write_grid(w, "grid", grid, names);
    if (a.host_grid) write_grid(w, "host_grid", host_grid, names);
    w.end_object();
    std::printf("%s\n", out.c_str());
  } else {
    print_text(a, r, names);
#ifdef CADINTERP_CLI_HAVE_VERIFY
    if (host && a.verify) print_verification(a, r, v);
#endif
    if (a.grid) print_grid("grid:", "the interpolant", grid, r.objective, "interpolated", names);
    if (a.host_grid) {
      // Against the host's grid, x*'s true value when --verify measured it.
      double objective = r.objective;
      const char* which = "interpolated; add --verify for the host's value";
#ifdef CADINTERP_CLI_HAVE_VERIFY
      if (a.verify && v.feasible && v.values[0].defined) {
        objective = v.values[0].value;
        which = "the host's";
      }
#endif
      print_grid("host grid:", "the host", host_grid, objective, which, names);
    }
  }
  return kExitOk;
}

}  // namespace cadinterp::cli
