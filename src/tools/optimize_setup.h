// What `cadinterp optimize` and the explorer's optimization endpoint (explore_server.h) share:
// a problem of libcadinterp_optimize set up from the expression language's texts (objective,
// constraints, fixed parameters, start), the options of a solve, and the result as JSON. One
// place, so that the command line and the page accept the same inputs with the same messages.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_optimize.h"
#include "json_writer.h"

namespace cadinterp::cli {

struct OptimizeSpec {
  std::string minimize;                 ///< the objective
  std::vector<std::string> subject_to;  ///< constraints "EXPR <= V", ">=", "=="
  std::string fix;                      ///< "name=value,..."
  std::vector<double> start;            ///< K values, or empty: the box centre
  int multistart = 1, max_iterations = 200;
  double tolerance = 1e-6;
};

/// A bad input: which one (`input`: "--minimize", "--subject-to", "--fix", "--start"), its text,
/// the message, and the 1-based column of the offending token in the text (0 when the message
/// names none). Messages of the expression language start "column C: ".
struct SpecError : std::runtime_error {
  SpecError(std::string input_, std::string text_, const std::string& message, int column_ = 0)
      : std::runtime_error(message),
        input(std::move(input_)),
        text(std::move(text_)),
        column(column_) {}
  std::string input, text;
  int column;
};

struct ProblemDestroyer {
  void operator()(cadinterp_optimize_problem* p) const { cadinterp_optimize_destroy(p); }
};
using ProblemPtr = std::unique_ptr<cadinterp_optimize_problem, ProblemDestroyer>;

std::vector<std::string> parameter_names(const cadinterp_asset* asset);

/// The problem of `spec` on `asset` (which must outlive it): objective, constraints in order,
/// fixed parameters. Throws SpecError for a bad expression, fix or start; std::bad_alloc.
ProblemPtr make_problem(const cadinterp_asset* asset, const OptimizeSpec& spec);

/// The box a solve of `spec` searches: the asset's parameter ranges, with each fixed parameter's
/// range narrowed to its value. Call after make_problem accepted `spec` (it does not re-check).
struct ParameterBox {
  std::vector<double> lower, upper;
};
ParameterBox problem_box(const cadinterp_asset* asset, const OptimizeSpec& spec);

/// Whether `value` meets the constraint text "EXPR <= V" (>=, ==: within 1e-6 relative to
/// max(1, |V|)): 1 or 0; -1 when the text has no comparison with a number.
int constraint_met(const std::string& constraint, double value);

/// The solve options of `spec`; `start` points into spec.start (keep spec alive).
cadinterp_optimize_options solve_options(const OptimizeSpec& spec);

/// Writes the result's members into the object `w` has open: status, objective and constraints
/// with their expressions, x by name, work counts, error estimate, note and the path of iterates.
void write_result_members(JsonWriter& w, const OptimizeSpec& spec,
                          const cadinterp_optimize_result& r,
                          const std::vector<std::string>& names);

}  // namespace cadinterp::cli
