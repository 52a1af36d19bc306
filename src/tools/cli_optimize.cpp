// `cadinterp optimize`: shape optimization on an asset's interpolant with Ipopt, through the
// public C ABI of libcadinterp_optimize (cadinterp_optimize.h): objective and constraints in its
// expression language, fixed parameters, start point, multi-start; a progress line per
// iteration, then a summary (or JSON).
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

namespace cadinterp::cli {
namespace {

struct ProblemDestroyer {
  void operator()(cadinterp_optimize_problem* p) const { cadinterp_optimize_destroy(p); }
};
using ProblemPtr = std::unique_ptr<cadinterp_optimize_problem, ProblemDestroyer>;

struct Args {
  std::string asset, minimize, fix, start;
  std::vector<std::string> subject_to;
  int multistart = 1, max_iterations = 200;
  double tolerance = 1e-6;
  bool json = false, quiet = false;
};

std::vector<std::string> parameter_names(const cadinterp_asset* a) {
  std::vector<std::string> out;
  for (int i = 0; i < cadinterp_parameter_count(a); ++i) {
    cadinterp_parameter_info p{};
    cadinterp_parameter(a, i, &p);
    out.push_back(p.name);
  }
  return out;
}

// An expression error as a usage error: the option, the message, the text and a caret under
// the offending column ("column C: ...").
[[noreturn]] void expression_error(const std::string& option, const std::string& text,
                                   const std::string& message) {
  std::string out = option + ": " + message + "\n  " + text;
  int column = 0;
  if (std::sscanf(message.c_str(), "column %d", &column) == 1 && column >= 1)
    out += "\n  " + std::string(static_cast<std::size_t>(column - 1), ' ') + "^";
  throw UsageError(out);
}

// --fix name=value,...: each parameter's range becomes that value.
void apply_fixes(cadinterp_optimize_problem* p, const std::string& spec,
                 const std::vector<std::string>& names) {
  for (const std::string& item : split_list(spec)) {
    const std::size_t eq = item.find('=');
    double v = 0;
    if (eq == std::string::npos || !parse_double(item.substr(eq + 1), &v))
      throw UsageError("--fix: expected name=value, got '" + item + "'");
    const std::string name = item.substr(0, eq);
    int i = 0;
    while (i < static_cast<int>(names.size()) && names[static_cast<std::size_t>(i)] != name) ++i;
    if (i == static_cast<int>(names.size())) {
      std::string all;
      for (const std::string& n : names) all += (all.empty() ? "" : ", ") + n;
      throw UsageError("--fix: the asset has no parameter '" + name + "' (it has " + all + ")");
    }
    if (cadinterp_optimize_set_bounds(p, i, v, v) != CADINTERP_OK)
      throw UsageError("--fix: " + std::string(cadinterp_optimize_error(p)));
  }
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
  std::printf("objective:   %.9g   (minimize %s)\n", r.objective, a.minimize.c_str());
  for (int j = 0; j < r.constraint_count; ++j)
    std::printf("constraint:  %.9g   (%s)\n", r.constraints[j],
                a.subject_to[static_cast<std::size_t>(j)].c_str());
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

void print_json(const Args& a, const cadinterp_optimize_result& r,
                const std::vector<std::string>& names) {
  std::string out;
  JsonWriter w(out);
  w.begin_object();
  w.field("status", r.status).field("ipopt_status", r.ipopt_status);
  w.field("converged", r.converged != 0);
  w.field("objective_expression", a.minimize).field("objective", r.objective);
  w.key("constraints").begin_array();
  for (int j = 0; j < r.constraint_count; ++j) {
    w.begin_object();
    w.field("expression", a.subject_to[static_cast<std::size_t>(j)])
        .field("value", r.constraints[j]);
    w.end_object();
  }
  w.end_array();
  w.field("constraint_violation", r.constraint_violation);
  w.key("x").begin_object();
  for (int i = 0; i < r.parameter_count; ++i) w.field(names[static_cast<std::size_t>(i)], r.x[i]);
  w.end_object();
  w.field("gradient_norm", r.gradient_norm).field("optimality", r.optimality);
  w.field("iterations", r.iterations).field("evaluations", r.evaluations);
  w.field("refused_evaluations", r.refused_evaluations);
  w.field("starts", r.starts).field("best_start", r.best_start);
  w.field("error_estimate", r.error_estimate);
  w.field("linear_asset", r.linear_asset != 0).field("note", r.note);
  w.key("path").begin_array();
  for (int k = 0; k < r.path_length; ++k) {
    w.begin_object();
    w.field("objective", r.path_objective[k]);
    w.key("x").begin_array();
    for (int i = 0; i < r.parameter_count; ++i)
      w.value(r.path[static_cast<std::size_t>(k * r.parameter_count + i)]);
    w.end_array();
    w.end_object();
  }
  w.end_array();
  w.end_object();
  std::printf("%s\n", out.c_str());
}

}  // namespace

int cmd_optimize(const std::vector<std::string>& args) {
  Args a;
  ArgParser p("cadinterp optimize",
              "ASSET --minimize EXPR [--subject-to 'EXPR <= V' ...] [options]",
              "Minimizes a quantity of the interpolated shape over the asset's parameter box with\n"
              "Ipopt, using the runtime's exact gradients. Points the runtime cannot evaluate\n"
              "(infeasible elements) and the box edge are walls.");
  p.positional("ASSET", "the asset file (.cadi)", &a.asset);
  p.option("minimize", 0, "EXPR", "the objective, e.g. 'integral(von_mises) + 0.1*mass'",
           &a.minimize)
      .required();
  p.repeated("subject-to", 0, "'EXPR <= V'", "a constraint: EXPR <= V, EXPR >= V or EXPR == V",
             &a.subject_to);
  p.option("fix", 0, "NAME=V,...", "fix parameters at values", &a.fix);
  p.option("start", 0, "V1,V2,...", "start point, K values (default: the box centre)", &a.start);
  p.option("multistart", 0, "N", "N deterministic starts (Halton points), keep the best",
           &a.multistart, 1, 1000);
  p.option("max-iterations", 0, "N", "Ipopt iterations per start", &a.max_iterations, 0, 100000);
  p.option("tolerance", 0, "T", "Ipopt's tol", &a.tolerance, 1e-12, 1.0);
  p.flag("json", 0, "print JSON (with the path of iterates) instead of text", &a.json);
  p.flag("quiet", 'q', "no progress line per iteration", &a.quiet);
  p.epilog(
      "expressions: sums of [WEIGHT*]QUANTITY with + and -. Quantities: volume, area,\n"
      "  mass[(density)], frontal_area[(dx,dy,dz)], centroid_x|y|z, inertia_xx..zz[(density)],\n"
      "  integral(FIELD[,component]), region_integral(FIELD,REGION[,component]),\n"
      "  region_area(REGION), max(FIELD[,p=P|ks=RHO][,component]) (a smooth upper bound of the\n"
      "  field's maximum: p-norm, default p=8, or Kreisselmeier-Steinhauser).\n"
      "example:\n"
      "  cadinterp optimize press.cadi --minimize 'integral(von_mises)' \\\n"
      "      --subject-to 'mass(7.85e-9) <= 12' --fix height=200,width=120\n"
      "The interpolated optimum is not re-simulated with the host: check it with the host\n"
      "(`cadinterp eval` shows the interpolant at x*).");
  if (!p.parse(args)) return kExitOk;

  const AssetPtr asset = open_asset(a.asset);
  const std::vector<std::string> names = parameter_names(asset.get());
  cadinterp_optimize_problem* raw = nullptr;
  if (cadinterp_optimize_create(asset.get(), &raw) != CADINTERP_OK)
    throw RuntimeFailure("cannot create the problem (out of memory)");
  const ProblemPtr problem(raw);
  cadinterp_optimize_problem* pr = problem.get();
  if (cadinterp_optimize_parse(pr, 0, a.minimize.c_str()) != CADINTERP_OK)
    expression_error("--minimize", a.minimize, cadinterp_optimize_error(pr));
  for (const std::string& c : a.subject_to)
    if (cadinterp_optimize_parse_constraint(pr, c.c_str(), nullptr) != CADINTERP_OK)
      expression_error("--subject-to", c, cadinterp_optimize_error(pr));
  if (!a.fix.empty()) apply_fixes(pr, a.fix, names);
  std::vector<double> start;
  if (!a.start.empty()) {
    for (const std::string& v : split_list(a.start)) {
      double d = 0;
      if (!parse_double(v, &d)) throw UsageError("--start: '" + v + "' is not a number");
      start.push_back(d);
    }
    if (start.size() != names.size())
      throw UsageError(
          fmt("--start: the asset has %zu parameters, got %zu values", names.size(), start.size()));
  }
  Progress progress{a.quiet || a.json, names};
  cadinterp_optimize_options o;
  cadinterp_optimize_options_init(&o);
  o.start = start.empty() ? nullptr : start.data();
  o.multistart = a.multistart;
  o.max_iterations = a.max_iterations;
  o.tolerance = a.tolerance;
  o.progress = &print_progress;
  o.progress_user = &progress;
  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  const cadinterp_status s = cadinterp_optimize_solve(pr, &o, &r);
  if (s == CADINTERP_E_INVALID_ARGUMENT) throw UsageError(cadinterp_optimize_error(pr));
  if (s != CADINTERP_OK) throw RuntimeFailure(describe(s, cadinterp_optimize_error(pr)));
  if (a.json)
    print_json(a, r, names);
  else
    print_text(a, r, names);
  return kExitOk;
}

}  // namespace cadinterp::cli
