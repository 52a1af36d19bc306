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
  /// With check_face_centres: test each element at the face centres the host has answered
  /// already (for a neighbour, for its parent's split direction, or as samples) and evaluate the
  /// others only for the elements that fail, whose split direction needs them. An element that
  /// passes then costs its centre alone, at the price of a test on fewer points.
  bool reuse_face_centres = false;
  /// With check_face_centres: the same test on fewer host calls, for budget-bound runs. An
  /// element is tested at its centre and at the face centres the host has answered already;
  /// only if it passes there are its other face centres evaluated (it is kept only if it passes
  /// at all of them, as without this option). An element that fails is split along the
  /// direction of largest midpoint error, taken from answered points on the line through its
  /// centre (its face centres; else the centres of same-size neighbours or their far faces,
  /// scaled by the distance squared), else from its parent's (the same width in every direction
  /// but the split one, whose error a split divides by 4 on a smooth function); a direction
  /// with neither is probed at its face centres. Probes stop at the element the remaining budget
  /// is expected to reach. Off by default: on tolerance-bound runs the estimated directions
  /// cost more samples and a larger max error (src/core/README.md).
  bool lazy_face_centres = false;
  /// With lazy_face_centres: how many splits an inherited direction error is trusted for; an
  /// older one is measured again at the element's face centres.
  int inherited_direction_splits = 2;
  /// Refine toward the feasibility boundary (the paper's locality: an element whose
  /// own terms are all feasible is usable whatever its neighbours are). An element that depends
  /// on an infeasible sample is split, up to max_level, along the direction that best separates
  /// its feasible from its infeasible corners (its terms when no corner fails; the widest on a
  /// tie), so that its children on the feasible side become usable; without corner_fallback a
  /// cubic element is split along its widest direction instead (its terms reach beyond its box
  /// in every direction, adaptive.cpp gives the measurement). An element lying wholly inside the
  /// infeasible region (its centre and every sample in its closed box infeasible) is not split:
  /// its children would keep an infeasible corner, so splitting buys nothing and every new point
  /// fails. Each wave decides these elements first, largest first, and their children that are
  /// still refused at once, before the elements above tolerance (the feasible space is kept
  /// first when the budget ends); max_infeasible_points bounds what that costs.
  bool refine_infeasible = true;
  /// Bounds the points that fail spent on that refinement: once this many evaluated points are
  /// infeasible (every failure counts, whatever element asked for it), no element is split for
  /// being infeasible any more; elements above tolerance still are. The points of splits already
  /// decided are still evaluated, so the count can exceed the bound by the points of the last
  /// wave's splits. Negative: no bound. Counted by point, not by host call, so that a resumed
  /// build (points read from a store) decides exactly as the first.
  int max_infeasible_points = -1;
  /// Cubic bases: an element whose terms reach an infeasible sample but whose 2^K corners and
  /// centre are feasible is usable through its corner fallback (Basis::corner_fallback_basis,
  /// multilinear on its corners), tested and refined like any other element; the asset must be
  /// compiled with the same choice (CompiledBasis::compile). Without it such an element is
  /// refused, and a failed sample makes every cubic element within two widths unusable.
  bool corner_fallback = true;
};

struct AdaptiveResult {
  explicit AdaptiveResult(Basis b) : basis(std::move(b)) {}
  Basis basis;
  int m = 0;
  std::vector<double> values;      ///< #samples by m (NaN rows for infeasible samples)
  std::vector<bool> infeasible;    ///< per sample
  std::vector<double> leaf_error;  ///< per tree node: last centre error of a leaf (NaN if unknown)
  int host_calls = 0;              ///< distinct points at which the host was called
  int infeasible_calls = 0;        ///< of which the host failed (or returned non-finite values)
  int splits = 0;
  bool budget_exhausted = false;  ///< stopped by max_samples with elements still above tolerance
};

/// Runs the driver over the box [lo, hi] (K values each). Exceptions thrown by `f` propagate.
AdaptiveResult adaptive_sample(int K, int m, const std::vector<double>& lo,
                               const std::vector<double>& hi, const HostFunction& f,
                               const AdaptiveOptions& options);

/// The driver over something more general than a value vector per point: the builder's meshes,
/// whose value at a sample depends on the element it is mapped into (paper §6), so the problem
/// computes the errors itself. Points are "rows": every distinct grid point the driver needs gets
/// the next row number, in a deterministic order, and is evaluated once.
class AdaptiveProblem {
 public:
  virtual ~AdaptiveProblem() = default;
  /// Evaluates rows[i] at x[i * K .. i * K + K) (real coordinates) for all i, in any order and
  /// possibly in parallel; sets feasible[i]. The driver asks for a whole refinement wave at once.
  virtual void evaluate(const std::vector<int>& rows, const std::vector<double>& x,
                        std::vector<char>& feasible) = 0;
  /// Error of the interpolant sum_t psi[t] * value(terms[t]) (n terms, all feasible) against
  /// value(at) (feasible), for the element whose centre is row `centre`; larger is worse, and
  /// the driver compares it with AdaptiveOptions::tolerance.
  virtual double interpolation_error(int at, int centre, const int* terms, const double* psi,
                                     int n) = 0;
  /// The per-direction error: (value(a) + value(b)) / 2 against value(c), all feasible.
  virtual double midpoint_error(int a, int b, int c) = 0;
  /// Told the number of elements (leaves) at the start of every wave (for progress reports).
  virtual void on_wave(int elements) { (void)elements; }

  /// One interpolation_error (midpoint = false) or midpoint_error (midpoint = true: terms holds
  /// a and b, at is c) call.
  struct ErrorQuery {
    bool midpoint = false;
    int at = -1, centre = -1;
    std::vector<int> terms;
    std::vector<double> psi;
    bool operator<(const ErrorQuery& o) const;
  };
  /// out[i] = the error of queries[i]. The driver asks for a wave's errors at once before it
  /// decides the wave's splits in order; the default answers them in turn, a problem may answer
  /// them in parallel (its error functions must then be thread-safe). Errors are pure functions
  /// of their arguments, so the order never changes a result.
  virtual void errors(const std::vector<ErrorQuery>& queries, std::vector<double>& out);
  /// One query's error (interpolation_error or midpoint_error): what errors() computes per query.
  double error(const ErrorQuery& q);
};

struct AdaptiveRun {
  explicit AdaptiveRun(Basis b) : basis(std::move(b)) {}
  Basis basis;
  std::vector<int> sample_row;     ///< per basis sample: its row
  std::vector<int> centre_row;     ///< per tree node: the row of its centre (-1 if never asked)
  std::vector<char> row_feasible;  ///< per row
  int infeasible_rows = 0;         ///< rows whose point is infeasible
  /// Splits of elements that depend on an infeasible sample (refine_infeasible), and of those,
  /// the infeasible elements left unsplit because they lie wholly inside the infeasible region
  /// or because max_infeasible_points was reached.
  int infeasible_splits = 0, interior_unsplit = 0, bound_unsplit = 0;
  /// Per tree node: the last error measured on a leaf (centre and face centres), or for leaves
  /// the budget stopped before they were checked, the error at the centre alone; NaN where
  /// unknown (infeasible leaves).
  std::vector<double> leaf_error;
  int splits = 0;
  int waves = 0;
  bool budget_exhausted = false;
};

/// Runs the driver (the algorithm of adaptive_sample) over `problem`. Each pass takes every
/// queued element, evaluates all their new centre and face-centre points in one
/// problem.evaluate() call, then decides the splits in a fixed order; so the result depends only
/// on the values, never on how evaluate() schedules them. Exceptions from `problem` propagate.
AdaptiveRun adaptive_run(int K, const std::vector<double>& lo, const std::vector<double>& hi,
                         AdaptiveProblem& problem, const AdaptiveOptions& options);

}  // namespace cadinterp::core
