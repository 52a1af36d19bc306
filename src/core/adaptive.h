// Adaptive sampling of a host function f: R^K -> R^m on the K-d tree (paper §4.2).
//
// Refine once in every direction; then pop elements from a priority queue, largest first.
// For each, the error is metric(P(c), f(c)) at its centre c (the paper's test) and, by default,
// also at the centres of its 2K faces: the centre alone is fooled whenever the interpolant
// happens to be exact there (a Gaussian bump at tolerance 2e-3 kept an element whose max error
// was 25 times the tolerance, with a centre error of 1.2e-4). Face centres are the points the
// split-direction test evaluates anyway, they are shared with the neighbours, and they become
// samples as the tree refines. Above the tolerance the element is split along the direction of
// largest per-direction error, and its children and the leaves whose interpolant the split
// changed are queued again.
//
// Per-direction error (the paper's "distance in each direction"): the error that linear
// interpolation along d alone makes at the centre, metric((f(c - w_d/2 e_d) + f(c + w_d/2 e_d))/2,
// f(c)), i.e. the curvature of f along d at the element's scale. It costs 2K host calls per
// split decision; every call is cached by grid point, and the face centres become samples as the
// tree refines, so they are rarely wasted.
#pragma once

#include <functional>
#include <vector>

#include "core/basis.h"

namespace cadinterp::core {

/// The host: writes m values for the point x (K values, real coordinates) and returns true, or
/// returns false when x is infeasible (the values are then ignored). Non-finite values also
/// make x infeasible.
using HostFunction = std::function<bool(const double* x, double* values)>;

/// Error between an interpolated and a true value vector (m values each); larger is worse.
using ErrorMetric = std::function<double(const double* approx, const double* truth, int m)>;

/// max_i |approx_i - truth_i|
double max_norm_error(const double* approx, const double* truth, int m);

struct AdaptiveOptions {
  Degree degree = Degree::Linear;
  double tolerance = 1e-3;  ///< split while the centre error exceeds this
  int max_samples = 4096;   ///< no split is started once the basis has this many samples
  int max_level = 12;       ///< per-direction depth limit, 1..kMaxLevel-1
  ErrorMetric metric;       ///< empty: max_norm_error
  /// Measure the error at the 2K face centres too (see above); false: the centre only (§4.2).
  bool check_face_centres = true;
  /// Split elements that depend on an infeasible sample (widest direction first), up to
  /// max_level, so that the infeasible region is confined to small elements.
  bool refine_infeasible = true;
};

struct AdaptiveResult {
  explicit AdaptiveResult(Basis b) : basis(std::move(b)) {}
  Basis basis;
  int m = 0;
  std::vector<double> values;      ///< #samples by m (NaN rows for infeasible samples)
  std::vector<bool> infeasible;    ///< per sample
  std::vector<double> leaf_error;  ///< per tree node: last centre error of a leaf (NaN if unknown)
  int host_calls = 0;              ///< distinct points at which the host was called
  int splits = 0;
  bool budget_exhausted = false;  ///< stopped by max_samples with elements still above tolerance
};

/// Runs the driver over the box [lo, hi] (K values each). Exceptions thrown by `f` propagate.
AdaptiveResult adaptive_sample(int K, int m, const std::vector<double>& lo,
                               const std::vector<double>& hi, const HostFunction& f,
                               const AdaptiveOptions& options);

}  // namespace cadinterp::core
