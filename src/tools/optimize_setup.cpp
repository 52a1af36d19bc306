// The shared set-up of an optimization (optimize_setup.h) over libcadinterp_optimize's C ABI.
#include "optimize_setup.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "cli_args.h"

namespace cadinterp::cli {
namespace {

// The column of "column C: ..." messages, 0 when there is none.
int message_column(const char* message) {
  int column = 0;
  return std::sscanf(message, "column %d", &column) == 1 && column >= 1 ? column : 0;
}

// "name=value,...": (parameter index, value) pairs, in the text's order.
std::vector<std::pair<int, double>> parse_fixes(const std::string& spec,
                                                const std::vector<std::string>& names) {
  std::vector<std::pair<int, double>> out;
  for (const std::string& item : split_list(spec)) {
    const std::size_t eq = item.find('=');
    double v = 0;
    if (eq == std::string::npos || !parse_double(item.substr(eq + 1), &v))
      throw SpecError("--fix", spec, "expected name=value, got '" + item + "'");
    const std::string name = item.substr(0, eq);
    int i = 0;
    while (i < static_cast<int>(names.size()) && names[static_cast<std::size_t>(i)] != name) ++i;
    if (i == static_cast<int>(names.size())) {
      std::string all;
      for (const std::string& n : names) all += (all.empty() ? "" : ", ") + n;
      throw SpecError("--fix", spec,
                      "the asset has no parameter '" + name + "' (it has " + all + ")");
    }
    out.emplace_back(i, v);
  }
  return out;
}

// Each fixed parameter's range becomes its value.
void apply_fixes(cadinterp_optimize_problem* p, const std::string& spec,
                 const std::vector<std::string>& names) {
  for (const auto& [i, v] : parse_fixes(spec, names))
    if (cadinterp_optimize_set_bounds(p, i, v, v) != CADINTERP_OK)
      throw SpecError("--fix", spec, cadinterp_optimize_error(p));
}

}  // namespace

std::vector<std::string> parameter_names(const cadinterp_asset* a) {
  std::vector<std::string> out;
  for (int i = 0; i < cadinterp_parameter_count(a); ++i) {
    cadinterp_parameter_info p{};
    cadinterp_parameter(a, i, &p);
    out.push_back(p.name);
  }
  return out;
}

ProblemPtr make_problem(const cadinterp_asset* asset, const OptimizeSpec& spec) {
  cadinterp_optimize_problem* raw = nullptr;
  if (cadinterp_optimize_create(asset, &raw) != CADINTERP_OK) throw std::bad_alloc();
  ProblemPtr problem(raw);
  if (cadinterp_optimize_parse(raw, 0, spec.minimize.c_str()) != CADINTERP_OK) {
    const char* m = cadinterp_optimize_error(raw);
    throw SpecError("--minimize", spec.minimize, m, message_column(m));
  }
  for (const std::string& c : spec.subject_to)
    if (cadinterp_optimize_parse_constraint(raw, c.c_str(), nullptr) != CADINTERP_OK) {
      const char* m = cadinterp_optimize_error(raw);
      throw SpecError("--subject-to", c, m, message_column(m));
    }
  const std::vector<std::string> names = parameter_names(asset);
  if (!spec.fix.empty()) apply_fixes(raw, spec.fix, names);
  if (!spec.start.empty() && spec.start.size() != names.size())
    throw SpecError("--start", "",
                    "the asset has " + std::to_string(names.size()) + " parameters, got " +
                        std::to_string(spec.start.size()) + " values");
  return problem;
}

ParameterBox problem_box(const cadinterp_asset* asset, const OptimizeSpec& spec) {
  ParameterBox box;
  for (int i = 0; i < cadinterp_parameter_count(asset); ++i) {
    cadinterp_parameter_info p{};
    cadinterp_parameter(asset, i, &p);
    box.lower.push_back(p.lower);
    box.upper.push_back(p.upper);
  }
  // make_problem has accepted the fixes (inside the box, known names): only narrow here.
  for (const auto& [i, v] : parse_fixes(spec.fix, parameter_names(asset)))
    box.lower[static_cast<std::size_t>(i)] = box.upper[static_cast<std::size_t>(i)] = v;
  return box;
}

int constraint_met(const std::string& constraint, double value) {
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

cadinterp_optimize_options solve_options(const OptimizeSpec& spec) {
  cadinterp_optimize_options o;
  cadinterp_optimize_options_init(&o);
  o.start = spec.start.empty() ? nullptr : spec.start.data();
  o.multistart = spec.multistart;
  o.max_iterations = spec.max_iterations;
  o.tolerance = spec.tolerance;
  return o;
}

void write_result_members(JsonWriter& w, const OptimizeSpec& spec,
                          const cadinterp_optimize_result& r,
                          const std::vector<std::string>& names) {
  w.field("status", r.status).field("ipopt_status", r.ipopt_status);
  w.field("converged", r.converged != 0);
  w.field("objective_expression", spec.minimize).field("objective", r.objective);
  w.key("constraints").begin_array();
  for (int j = 0; j < r.constraint_count; ++j) {
    w.begin_object();
    w.field("expression", spec.subject_to[static_cast<std::size_t>(j)])
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
}

}  // namespace cadinterp::cli
