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
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_optimize.h"
#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"
#include "json_writer.h"
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
  if (r.constraint_count)
    std::printf("violation:   %.3g%s\n", r.constraint_violation,
                r.constraint_violation > 1e-6 ? "  (constraints NOT met)" : "");
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

#ifdef CADINTERP_CLI_HAVE_VERIFY
// The host named by --host, checked against the asset before any work: a library that cannot be
// loaded or refuses the model is a runtime failure (exit 1), other parameters a usage error.
const cadinterp_host* load_verify_host(const Args& a, const cadinterp_asset* asset,
                                       tools::HostLibrary& library) {
  if (a.host.empty()) throw UsageError("--verify needs --host LIB.so (and usually --model)");
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

// Whether `value` meets the constraint "EXPR <= V" (>=, ==: within 1e-6 relative); -1 when the
// text has no comparison with a number (the parser accepted it, so this does not happen).
int meets(const std::string& constraint, double value) {
  for (const char* op : {"<=", ">=", "=="}) {
    const std::size_t at = constraint.rfind(op);
    double v = 0;
    if (at == std::string::npos) continue;
    std::string rhs = constraint.substr(at + 2);
    rhs.erase(0, rhs.find_first_not_of(" \t"));
    rhs.erase(rhs.find_last_not_of(" \t") + 1);
    if (!parse_double(rhs, &v)) continue;
    const double slack = 1e-6 * std::max(1.0, std::fabs(v));
    if (op[0] == '<') return value <= v + slack;
    if (op[0] == '>') return value >= v - slack;
    return std::fabs(value - v) <= slack;
  }
  return -1;
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
    if (t.defined && f > 0 && meets(name, t.value) == 0)
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
      if (f > 0 && meets(a.spec.subject_to[f - 1], v.values[f].value) >= 0)
        w.field("true_meets_constraint", meets(a.spec.subject_to[f - 1], v.values[f].value) == 1);
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
  p.option("host", 0, "LIB.so", "--verify: the host library the asset was built with", &a.host);
  p.option("model", 'm', "NAME", "--verify: the host's model", &a.model);
  p.option("host-options", 0, "K=V,...", "--verify: the host's settings", &a.host_options);
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
  if (!a.verify && (!a.host.empty() || !a.model.empty() || !a.host_options.empty()))
    throw UsageError("--host, --model and --host-options are for --verify");
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
  const cadinterp_host* host = a.verify ? load_verify_host(a, asset.get(), library) : nullptr;
#else
  if (a.verify)
    throw RuntimeFailure(
        "--verify needs the builder's host adapter, which this build of cadinterp does not have");
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
#ifdef CADINTERP_CLI_HAVE_VERIFY
  Verification v;
  if (host) {
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
    if (host) write_verification(w, a, r, v);
#endif
    w.end_object();
    std::printf("%s\n", out.c_str());
  } else {
    print_text(a, r, names);
#ifdef CADINTERP_CLI_HAVE_VERIFY
    if (host) print_verification(a, r, v);
#endif
  }
  return kExitOk;
}

}  // namespace cadinterp::cli
