// Brute-force grids for `cadinterp optimize --grid N` and `--host-grid N`: the objective and the
// constraints at every point of a regular grid over the free parameters, and the best point that
// meets the constraints. Paper §7.2 optimizes on the interpolant with Ipopt; a grid on the same
// interpolant tells whether Ipopt's x* is the global optimum of the interpolant, and a (coarse)
// grid on the host tells whether that optimum is real.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_optimize.h"
#include "optimize_setup.h"

namespace cadinterp::cli {

/// The objective and the constraints at one point, or why there are none.
struct GridValue {
  bool evaluated = false;
  std::string reason;          ///< when not evaluated
  std::vector<double> values;  ///< objective, then the constraints
};

/// Evaluates one point (K values). run_grid calls it from `threads` threads at once when asked.
using GridFunction = std::function<GridValue(const double* x)>;

struct GridSummary {
  int per_axis = 0;
  std::size_t points = 0;
  std::size_t failed = 0;     ///< not evaluated (infeasible element, host failure)
  std::size_t violating = 0;  ///< evaluated, but a constraint is not met
  std::string first_failure;  ///< the reason of the first failed point, in grid order
  bool found = false;         ///< some point was evaluated and met every constraint
  std::vector<double> best_x, best_values;
  double seconds = 0.0;
};

/// The largest grid run_grid accepts, in points.
constexpr std::size_t kMaxGridPoints = 1000000;

/// The grid's points, K values each, flattened: `per_axis` (>= 2) equally spaced values from
/// lower to upper, both included, on each free axis (lower < upper) and the one value of each
/// fixed axis; the first parameter varies slowest. Throws std::invalid_argument for per_axis < 2
/// or more than kMaxGridPoints points (the message says how many).
std::vector<double> grid_points(const ParameterBox& box, int per_axis);

/// Evaluates `f` at every grid point (threads >= 1 at once) and keeps the point with the lowest
/// objective among those meeting every constraint of `spec` (constraint_met), the first in grid
/// order on ties; so the result does not depend on `threads`. Throws as grid_points.
GridSummary run_grid(const ParameterBox& box, int per_axis, const OptimizeSpec& spec,
                     const GridFunction& f, int threads);

/// The problem's objective and constraints on the interpolant (cadinterp_optimize_evaluate);
/// a point the runtime refuses is "not evaluated" with the runtime's message. Not thread-safe:
/// run it with threads = 1. The problem must outlive the function.
GridFunction interpolant_function(cadinterp_optimize_problem* problem);

}  // namespace cadinterp::cli
