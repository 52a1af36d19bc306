// The C ABI of include/cadinterp/cadinterp_optimize.h: argument checks, the exception barrier
// (nothing crosses the interface: bad_alloc is CADINTERP_E_OUT_OF_MEMORY, anything else
// CADINTERP_E_INTERNAL with its text), and the result's storage in the problem. The library
// sits on the runtime's public C ABI only (src/DEPENDENCIES.md).
#include "cadinterp/cadinterp_optimize.h"

#include <cmath>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <string>

#include "optimize/expression.h"
#include "optimize/problem.h"
#include "optimize/solver.h"

struct cadinterp_optimize_problem {
  std::unique_ptr<cadinterp::optimize::Problem> problem;
  std::string error;
  cadinterp::optimize::Outcome outcome;
};

namespace {

using cadinterp::optimize::Parsed;

cadinterp_status fail(cadinterp_optimize_problem* p, cadinterp_status s, const std::string& m) {
  p->error = m;
  return s;
}

template <class F>
cadinterp_status guarded(cadinterp_optimize_problem* p, F&& body) {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return fail(p, CADINTERP_E_OUT_OF_MEMORY, "out of memory");
  } catch (const std::exception& e) {
    return fail(p, CADINTERP_E_INTERNAL, e.what());
  } catch (...) {
    return fail(p, CADINTERP_E_INTERNAL, "unknown exception");
  }
}

cadinterp_status add_parsed(cadinterp_optimize_problem* p, int function, const Parsed& parsed) {
  if (parsed.status != CADINTERP_OK) return fail(p, parsed.status, parsed.error);
  auto& terms = p->problem->function(function).terms;
  terms.insert(terms.end(), parsed.terms.begin(), parsed.terms.end());
  p->error.clear();
  return CADINTERP_OK;
}

}  // namespace

extern "C" {

void cadinterp_optimize_term_init(cadinterp_optimize_term* t,
                                  cadinterp_optimize_quantity quantity) {
  if (!t) return;
  std::memset(t, 0, sizeof *t);
  t->struct_size = sizeof *t;
  t->quantity = quantity;
  t->weight = 1.0;
  t->field = -1;
  t->region = -1;
  t->parameter = 1.0;
  t->direction[2] = 1.0;
}

void cadinterp_optimize_options_init(cadinterp_optimize_options* o) {
  if (!o) return;
  std::memset(o, 0, sizeof *o);
  o->struct_size = sizeof *o;
  o->max_iterations = 200;
  o->tolerance = 1e-6;
  o->multistart = 1;
}

cadinterp_status cadinterp_optimize_create(const cadinterp_asset* asset,
                                           cadinterp_optimize_problem** out) {
  if (!asset || !out) return CADINTERP_E_INVALID_ARGUMENT;
  try {
    auto p = std::make_unique<cadinterp_optimize_problem>();
    p->problem = std::make_unique<cadinterp::optimize::Problem>(asset);
    *out = p.release();
    return CADINTERP_OK;
  } catch (const std::bad_alloc&) {
    return CADINTERP_E_OUT_OF_MEMORY;
  } catch (...) {
    return CADINTERP_E_OUT_OF_MEMORY;  // the workspace could not be created
  }
}

void cadinterp_optimize_destroy(cadinterp_optimize_problem* p) { delete p; }

const char* cadinterp_optimize_error(const cadinterp_optimize_problem* p) {
  return p ? p->error.c_str() : "";
}

int cadinterp_optimize_constraint_count(const cadinterp_optimize_problem* p) {
  return p ? p->problem->function_count() - 1 : 0;
}

cadinterp_status cadinterp_optimize_add_constraint(cadinterp_optimize_problem* p, double lower,
                                                   double upper, int* function) {
  if (!p) return CADINTERP_E_INVALID_ARGUMENT;
  if (!function) return fail(p, CADINTERP_E_INVALID_ARGUMENT, "function is NULL");
  if (std::isnan(lower) || std::isnan(upper) || lower > upper)
    return fail(p, CADINTERP_E_INVALID_ARGUMENT, "bounds are NaN or lower > upper");
  return guarded(p, [&] {
    *function = p->problem->add_constraint(lower, upper);
    p->error.clear();
    return CADINTERP_OK;
  });
}

cadinterp_status cadinterp_optimize_add_term(cadinterp_optimize_problem* p, int function,
                                             const cadinterp_optimize_term* term) {
  if (!p) return CADINTERP_E_INVALID_ARGUMENT;
  if (!term) return fail(p, CADINTERP_E_INVALID_ARGUMENT, "term is NULL");
  if (function < 0 || function >= p->problem->function_count())
    return fail(p, CADINTERP_E_INVALID_ARGUMENT, "no function " + std::to_string(function));
  const std::string why = p->problem->check(*term);
  if (!why.empty()) return fail(p, CADINTERP_E_INVALID_ARGUMENT, why);
  return guarded(p, [&] {
    cadinterp_optimize_term t;
    cadinterp_optimize_term_init(&t, term->quantity);
    std::memcpy(&t, term, sizeof t);
    p->problem->function(function).terms.push_back(t);
    p->error.clear();
    return CADINTERP_OK;
  });
}

cadinterp_status cadinterp_optimize_parse(cadinterp_optimize_problem* p, int function,
                                          const char* expression) {
  if (!p) return CADINTERP_E_INVALID_ARGUMENT;
  if (!expression) return fail(p, CADINTERP_E_INVALID_ARGUMENT, "expression is NULL");
  if (function < 0 || function >= p->problem->function_count())
    return fail(p, CADINTERP_E_INVALID_ARGUMENT, "no function " + std::to_string(function));
  return guarded(p, [&] {
    return add_parsed(p, function,
                      cadinterp::optimize::parse_expression(p->problem->asset(), expression));
  });
}

cadinterp_status cadinterp_optimize_parse_constraint(cadinterp_optimize_problem* p,
                                                     const char* constraint, int* function) {
  if (!p) return CADINTERP_E_INVALID_ARGUMENT;
  if (!constraint) return fail(p, CADINTERP_E_INVALID_ARGUMENT, "constraint is NULL");
  return guarded(p, [&] {
    const Parsed parsed = cadinterp::optimize::parse_constraint(p->problem->asset(), constraint);
    if (parsed.status != CADINTERP_OK) return fail(p, parsed.status, parsed.error);
    const int f = p->problem->add_constraint(parsed.lower, parsed.upper);
    if (function) *function = f;
    return add_parsed(p, f, parsed);
  });
}

cadinterp_status cadinterp_optimize_set_bounds(cadinterp_optimize_problem* p, int i, double lower,
                                               double upper) {
  if (!p) return CADINTERP_E_INVALID_ARGUMENT;
  cadinterp_parameter_info info;
  if (cadinterp_parameter(p->problem->asset(), i, &info) != CADINTERP_OK)
    return fail(p, CADINTERP_E_INVALID_ARGUMENT, "no parameter " + std::to_string(i));
  if (std::isnan(lower) || std::isnan(upper) || lower > upper || lower < info.lower ||
      upper > info.upper)
    return fail(p, CADINTERP_E_INVALID_ARGUMENT,
                std::string("range of ") + info.name + " is NaN, reversed or outside the box [" +
                    std::to_string(info.lower) + ", " + std::to_string(info.upper) + "]");
  p->problem->lower()[static_cast<std::size_t>(i)] = lower;
  p->problem->upper()[static_cast<std::size_t>(i)] = upper;
  p->error.clear();
  return CADINTERP_OK;
}

cadinterp_status cadinterp_optimize_evaluate(cadinterp_optimize_problem* p, const double* x,
                                             double* values, double* gradients) {
  if (!p) return CADINTERP_E_INVALID_ARGUMENT;
  if (!x || !values) return fail(p, CADINTERP_E_INVALID_ARGUMENT, "x or values is NULL");
  return guarded(p, [&] {
    std::string error;
    const cadinterp_status s = p->problem->evaluate(x, values, gradients, &error);
    p->error = s == CADINTERP_OK ? "" : error;
    return s;
  });
}

cadinterp_status cadinterp_optimize_solve(cadinterp_optimize_problem* p,
                                          const cadinterp_optimize_options* options,
                                          cadinterp_optimize_result* result) {
  if (!p) return CADINTERP_E_INVALID_ARGUMENT;
  if (!result || result->struct_size < sizeof(cadinterp_optimize_result))
    return fail(p, CADINTERP_E_INVALID_ARGUMENT, "result is NULL or its struct_size too small");
  cadinterp_optimize_options o;
  cadinterp_optimize_options_init(&o);
  if (options) {
    if (options->struct_size < sizeof o)
      return fail(p, CADINTERP_E_INVALID_ARGUMENT, "options struct_size too small");
    std::memcpy(&o, options, sizeof o);
  }
  if (o.multistart < 1 || o.max_iterations < 0 || !(o.tolerance > 0))
    return fail(p, CADINTERP_E_INVALID_ARGUMENT,
                "multistart < 1, max_iterations < 0 or tolerance <= 0");
  const cadinterp::optimize::Problem& pr = *p->problem;
  for (int i = 0; o.start && i < pr.parameter_count(); ++i) {
    const std::size_t s = static_cast<std::size_t>(i);
    if (pr.lower()[s] < pr.upper()[s] &&
        !(o.start[i] >= pr.lower()[s] && o.start[i] <= pr.upper()[s]))
      return fail(p, CADINTERP_E_INVALID_ARGUMENT,
                  "start value " + std::to_string(i) + " is outside its range or not finite");
  }
  return guarded(p, [&] {
    cadinterp::optimize::Outcome out;
    std::string error;
    const cadinterp_status s = cadinterp::optimize::solve(*p->problem, o, &out, &error);
    if (s != CADINTERP_OK) return fail(p, s, error);
    p->outcome = std::move(out);
    const cadinterp::optimize::Outcome& r = p->outcome;
    cadinterp_optimize_result v{};
    v.struct_size = sizeof v;
    v.parameter_count = pr.parameter_count();
    v.constraint_count = pr.function_count() - 1;
    v.x = r.x.data();
    v.objective = r.objective;
    v.constraints = r.constraints.data();
    v.constraint_violation = r.violation;
    v.gradient_norm = r.gradient_norm;
    v.optimality = r.optimality;
    v.converged = r.converged;
    v.ipopt_status = r.ipopt_status;
    v.status = r.status.c_str();
    v.iterations = r.iterations;
    v.evaluations = r.evaluations;
    v.starts = r.starts;
    v.best_start = r.best_start;
    v.path_length = static_cast<int>(r.path_objective.size());
    v.path = r.path.data();
    v.path_objective = r.path_objective.data();
    v.error_estimate = r.error_estimate;
    v.linear_asset = r.linear;
    v.note = r.note.c_str();
    v.refused_evaluations = r.refused;
    std::memcpy(result, &v, sizeof v);
    p->error.clear();
    return CADINTERP_OK;
  });
}

}  // extern "C"
