// Ipopt on a Problem (problem.h): one run per start, the walls of cadinterp_optimize.h, the
// result of the best start. Internal to libcadinterp_optimize.
#pragma once

#include <string>
#include <vector>

#include "cadinterp/cadinterp_optimize.h"
#include "optimize/problem.h"

namespace cadinterp::optimize {

struct Outcome {
  std::vector<double> x, constraints, path, path_objective;
  double objective = 0, violation = 0, gradient_norm = 0, optimality = 0, error_estimate = -1;
  int converged = 0, ipopt_status = 0, iterations = 0, evaluations = 0, starts = 0;
  int best_start = 0, linear = 0, refused = 0;
  std::string status, note;
};

// Runs the starts of `options` (already checked) and fills `out`. On failure returns the status
// and sets *error. May throw std::bad_alloc.
cadinterp_status solve(Problem& problem, const cadinterp_optimize_options& options, Outcome* out,
                       std::string* error);

}  // namespace cadinterp::optimize
