/* cadinterp optimize: shape optimization on the interpolant of an opened asset (paper §7.2), with
 * Ipopt (interior point, limited-memory Hessian) and the runtime's exact gradients.
 *
 * EXPERIMENTAL ABI (CADINTERP_OPTIMIZE_ABI_VERSION, 0), as cadinterp_builder.h's: this header may
 * change incompatibly in a release, each change listed in CHANGELOG.md with a new SONAME
 * libcadinterp_optimize.so.N. Link libcadinterp_optimize.
 *
 * C99, in the conventions of cadinterp.h: every fallible function returns a
 * cadinterp_status (CADINTERP_OK is 0) and leaves its outputs untouched on failure; each call on
 * a problem keeps a message (cadinterp_optimize_error: "" after a success); a NULL problem or a
 * NULL pointer where a value is read or written gives CADINTERP_E_INVALID_ARGUMENT (without a
 * message when the problem itself is NULL); no C++ exception crosses this interface.
 * Structs that may grow carry their size in their first member (struct_size): set it with the
 * matching *_init function; members added later are appended.
 *
 * Thread-safety: a problem is used by one thread at a time (it holds a workspace of the asset);
 * distinct problems, also of one asset, may be used by different threads at once.
 *
 * A problem minimizes an objective subject to constraints lower <= g_j(x) <= upper over the
 * asset's parameter box. The objective and each constraint are weighted sums of terms
 * (cadinterp_optimize_term), each a quantity of the interpolated mesh at x with its exact
 * gradient: the mass properties of cadinterp_eval_properties, the field integrals of
 * cadinterp_eval_integral, and smooth maxima of a field (through cadinterp_eval and
 * cadinterp_vjp).
 *
 * Walls: where the runtime cannot evaluate x (CADINTERP_E_INFEASIBLE: an element that depends on
 * a sample the host could not build; CADINTERP_E_OUTSIDE_DOMAIN), the problem reports an
 * evaluation error to Ipopt, which then cuts its step back (its line search's backtracking on
 * evaluation errors). Every point Ipopt accepts was evaluated, so iterates stay where the runtime
 * answers, and the box is a pair of bounds Ipopt never relaxes (bound_relax_factor 0). The
 * result's x is always a point the runtime evaluates.
 */
#ifndef CADINTERP_OPTIMIZE_H
#define CADINTERP_OPTIMIZE_H

#include <stddef.h>

#include "cadinterp/cadinterp.h"

#if defined(_WIN32)
#if defined(CADINTERP_BUILDING_OPTIMIZE)
#define CADINTERP_OPTIMIZE_API __declspec(dllexport)
#else
#define CADINTERP_OPTIMIZE_API __declspec(dllimport)
#endif
#else
#define CADINTERP_OPTIMIZE_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/** An optimization problem on an opened asset (opaque). */
typedef struct cadinterp_optimize_problem cadinterp_optimize_problem;

/** What a term measures. Values are stable; new quantities are appended. */
typedef enum cadinterp_optimize_quantity {
  CADINTERP_OPTIMIZE_VOLUME = 0,       /**< volume of the mesh */
  CADINTERP_OPTIMIZE_MASS = 1,         /**< parameter * volume (parameter: the density) */
  CADINTERP_OPTIMIZE_AREA = 2,         /**< boundary surface area */
  CADINTERP_OPTIMIZE_FRONTAL_AREA = 3, /**< area projected along `direction` */
  CADINTERP_OPTIMIZE_CENTROID = 4,     /**< centroid coordinate `component` (0..2) */
  /** inertia about the centroid, row-major entry `component` (0..8), density `parameter` */
  CADINTERP_OPTIMIZE_INERTIA = 5,
  /** integral of the field's `component` over the solid (region -1) or a boundary region, as
   *  cadinterp_eval_integral (field -1: of 1, the volume or the region's area) */
  CADINTERP_OPTIMIZE_INTEGRAL = 6,
  /** p-norm of the field's `component` over its rows (vertices or tets), p = `parameter` >= 1:
   *  (sum_i |f_i|^p)^(1/p). An upper bound of max_i |f_i|, at most N^(1/p) times it (N rows):
   *  a constraint on it is conservative, within a factor N^(1/p) (1.9 for N = 200, p = 8) */
  CADINTERP_OPTIMIZE_MAX_PNORM = 7,
  /** Kreisselmeier-Steinhauser aggregate, rho = `parameter` > 0 in 1/(field unit):
   *  max_i f_i + ln(sum_i exp(rho (f_i - max_i f_i))) / rho, between max_i f_i and
   *  max_i f_i + ln(N) / rho: an upper bound within ln(N) / rho, in the field's unit */
  CADINTERP_OPTIMIZE_MAX_KS = 8,
  /** the per-sample scalar output `field` (an output index: cadinterp_find_output), a quantity
   *  the host computed exactly on each sample, interpolated with the basis weights
   *  (cadinterp_eval_outputs): O(terms) per evaluation, no mesh blend, no mapping error */
  CADINTERP_OPTIMIZE_OUTPUT = 9
} cadinterp_optimize_quantity;

/** One term of a function: weight * quantity(x). */
typedef struct cadinterp_optimize_term {
  size_t struct_size; /**< sizeof(cadinterp_optimize_term) */
  cadinterp_optimize_quantity quantity;
  double weight; /**< finite; default 1 */
  int field;     /**< a field index (integrals and maxima; -1 allowed for integrals), or an output
                      index (CADINTERP_OPTIMIZE_OUTPUT) */
  int component; /**< of the field, centroid or inertia; default 0 */
  int region;    /**< integrals: a region index, or -1 (default) for the solid */
  double parameter;    /**< density (mass, inertia), p (p-norm), rho (KS); default 1 */
  double direction[3]; /**< frontal area's direction; default (0, 0, 1) */
} cadinterp_optimize_term;

/** Fills `term` with the defaults above (struct_size included) and `quantity`; field -1. NULL is
 *  a no-op. Thread-safe. */
CADINTERP_OPTIMIZE_API void cadinterp_optimize_term_init(cadinterp_optimize_term* term,
                                                         cadinterp_optimize_quantity quantity);

/**
 * Creates an empty problem on `asset` (objective 0, no constraints, every parameter free in the
 * asset's box). The asset must stay open until cadinterp_optimize_destroy.
 * @param[out] out  the problem, owned by the caller; untouched on failure
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument;
 *         CADINTERP_E_OUT_OF_MEMORY. Thread-safe (the asset may be in use by other threads).
 */
CADINTERP_OPTIMIZE_API cadinterp_status cadinterp_optimize_create(const cadinterp_asset* asset,
                                                                  cadinterp_optimize_problem** out);
/** Destroys a problem; NULL is a no-op. Every pointer it returned becomes invalid. */
CADINTERP_OPTIMIZE_API void cadinterp_optimize_destroy(cadinterp_optimize_problem* problem);
/** Message of the most recent call with `problem`: its failure's text, "" after a success; ""
 *  for NULL. Owned by the problem, valid until its next call. Never NULL. */
CADINTERP_OPTIMIZE_API const char* cadinterp_optimize_error(
    const cadinterp_optimize_problem* problem);

/**
 * Adds a constraint lower <= g(x) <= upper (g starts as 0; add its terms with
 * cadinterp_optimize_add_term or cadinterp_optimize_parse). -HUGE_VAL / HUGE_VAL: no bound.
 * @param[out] function  its function index (1, 2, ...; 0 is the objective)
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument, a NaN bound or
 *         lower > upper; CADINTERP_E_OUT_OF_MEMORY.
 */
CADINTERP_OPTIMIZE_API cadinterp_status cadinterp_optimize_add_constraint(
    cadinterp_optimize_problem* problem, double lower, double upper, int* function);

/**
 * Adds a term to function `function` (0: the objective; 1..: the constraints).
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument, a struct_size too
 *         small, an unknown function or quantity, a field, component or region index out of
 *         range for the asset, a non-finite weight, density or direction, p < 1 or rho <= 0
 *         (the message says which); CADINTERP_E_OUT_OF_MEMORY.
 */
CADINTERP_OPTIMIZE_API cadinterp_status cadinterp_optimize_add_term(
    cadinterp_optimize_problem* problem, int function, const cadinterp_optimize_term* term);

/**
 * Adds the terms of an expression to function `function`: a sum of terms, each an optional
 * number and '*' before a quantity, with '+' or '-' between them:
 *   volume | area | mass[(density)] | frontal_area[(dx, dy, dz)] | centroid_x|_y|_z |
 *   inertia_xx|_xy|...|_zz[(density)] | integral(FIELD[, component]) |
 *   region_integral(FIELD, REGION[, component]) | region_area(REGION) |
 *   max(FIELD[, p=P | ks=RHO][, component]) | output(OUTPUT) | OUTPUT
 * FIELD, REGION and OUTPUT are names of the asset (quoted with '...' when they hold other
 * characters than letters, digits and '_'); max defaults to p = 8. An output (a per-sample
 * scalar, CADINTERP_OPTIMIZE_OUTPUT) may be named bare when its name is none of the quantities
 * above (those win: `volume` is always the mesh's; `output(volume)` the output). Examples:
 * "integral(von_mises) + 0.1*mass(7.8e-9)", "output(brep_volume)", "brep_volume".
 * @return CADINTERP_OK (terms added); CADINTERP_E_INVALID_ARGUMENT for a NULL argument, an
 *         unknown function or a syntax error; CADINTERP_E_NOT_FOUND for an unknown field,
 *         region or output name. On failure no term is added and the message names the offending
 * token and its column (1-based), e.g. "column 12: unknown quantity 'mas'".
 */
CADINTERP_OPTIMIZE_API cadinterp_status
cadinterp_optimize_parse(cadinterp_optimize_problem* problem, int function, const char* expression);

/**
 * Adds a constraint written as "EXPR <= V", "EXPR >= V" or "EXPR == V" (V a number), as
 * cadinterp_optimize_add_constraint and cadinterp_optimize_parse would.
 * @param[out] function  its function index (may be NULL)
 * @return as cadinterp_optimize_parse; CADINTERP_E_INVALID_ARGUMENT also for a missing or
 *         misplaced comparison. Nothing is added on failure.
 */
CADINTERP_OPTIMIZE_API cadinterp_status cadinterp_optimize_parse_constraint(
    cadinterp_optimize_problem* problem, const char* constraint, int* function);

/**
 * Narrows parameter i's range to [lower, upper] (inside the asset's box); lower == upper fixes
 * it (Ipopt then optimizes the others only). Replaces an earlier range or fix.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL problem, i out of range, a NaN
 *         bound, lower > upper or a range outside the box.
 */
CADINTERP_OPTIMIZE_API cadinterp_status cadinterp_optimize_set_bounds(
    cadinterp_optimize_problem* problem, int i, double lower, double upper);

/** Number of constraints (0 for NULL). */
CADINTERP_OPTIMIZE_API int cadinterp_optimize_constraint_count(
    const cadinterp_optimize_problem* problem);

/**
 * The objective and the constraints at x, and optionally their gradients.
 * @param[in]  x          K parameter values (fixed parameters are not replaced: x is used as given)
 * @param[out] values     1 + constraint count values: objective, then constraints
 * @param[out] gradients  NULL, or (1 + constraint count) rows of K: d value / d x
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument; the runtime's status
 *         where it cannot evaluate x (CADINTERP_E_OUTSIDE_DOMAIN, CADINTERP_E_INFEASIBLE, a
 *         decode error), its message in cadinterp_optimize_error.
 */
CADINTERP_OPTIMIZE_API cadinterp_status cadinterp_optimize_evaluate(
    cadinterp_optimize_problem* problem, const double* x, double* values, double* gradients);

/** Called once per Ipopt iteration (after iteration 0: the start). Return nonzero to stop that
 *  start (Ipopt reports "stopped by the caller"). x holds K values (fixed ones included), valid
 *  during the call. */
typedef int (*cadinterp_optimize_progress_fn)(void* user, int start, int iteration, const double* x,
                                              double objective, double constraint_violation,
                                              double optimality);

/** Options of a solve. Fill with cadinterp_optimize_options_init, then change. */
typedef struct cadinterp_optimize_options {
  size_t struct_size;  /**< sizeof(cadinterp_optimize_options) */
  int max_iterations;  /**< per start (default 200) */
  double tolerance;    /**< Ipopt's tol: scaled KKT error to stop at (default 1e-6; a run
                          that stays within max(1e-4, tol) for 10 iterations stops as acceptable) */
  const double* start; /**< K values inside the free ranges, or NULL (default): the centre */
  /** Starts: 1 (default) runs from `start`; N > 1 adds N - 1 points of a Halton sequence over
   *  the free ranges (deterministic), skipping the ones the runtime cannot evaluate. The result
   *  is the best start's: feasible for the constraints first, then lowest objective. */
  int multistart;
  int print_level;                         /**< Ipopt's print_level (default 0: silent) */
  cadinterp_optimize_progress_fn progress; /**< may be NULL */
  void* progress_user;
} cadinterp_optimize_options;

/** Fills `options` with the defaults (struct_size included). NULL is a no-op. Thread-safe. */
CADINTERP_OPTIMIZE_API void cadinterp_optimize_options_init(cadinterp_optimize_options* options);

/** The outcome of a solve. Pointers are owned by the problem, valid until its next solve or its
 *  destruction. */
typedef struct cadinterp_optimize_result {
  size_t struct_size; /**< sizeof(cadinterp_optimize_result), set by the caller */
  int parameter_count;
  int constraint_count;
  const double* x;           /**< K values: the optimum (a point the runtime evaluates) */
  double objective;          /**< at x */
  const double* constraints; /**< constraint_count values at x */
  /** Largest distance of a constraint outside its bounds, in its units. The solve treats a
   * constraint as met within 1e-6 of its bound's magnitude (at least 1): Ipopt sees each constraint
   * divided by that magnitude, so feasibility does not depend on its units. */
  double constraint_violation;
  double gradient_norm;         /**< 2-norm of the objective's gradient over free parameters */
  double optimality;            /**< Ipopt's final scaled dual infeasibility (KKT error) */
  int converged;                /**< nonzero when Ipopt reports an optimum (to tol or acceptable) */
  int ipopt_status;             /**< Ipopt's ApplicationReturnStatus of the best start */
  const char* status;           /**< that status in words */
  int iterations;               /**< Ipopt iterations, summed over starts */
  int evaluations;              /**< distinct points evaluated, summed over starts */
  int starts;                   /**< starts run */
  int best_start;               /**< the start x comes from (0: `start` or the centre) */
  int path_length;              /**< iterates of the best start */
  const double* path;           /**< path_length rows of K */
  const double* path_objective; /**< path_length values */
  /** cadinterp_error_estimate at x: the builder's geometric error of its element, relative to
   *  the model's diagonal (negative: not measured) */
  double error_estimate;
  /** nonzero for a linear asset: the interpolant is only C0, its gradient jumps at kinks inside
   *  and between elements, and Ipopt may stop short of its tolerance there */
  int linear_asset;
  const char* note; /**< a sentence on the above for a linear asset, else "" */
  /** Of `evaluations`, the points the runtime refused (infeasible elements, or a value that is
   *  not finite): how often the iterates ran into a wall, summed over starts */
  int refused_evaluations;
} cadinterp_optimize_result;

/**
 * Minimizes the objective from each start (options->multistart) with Ipopt.
 * @param[in]  options  NULL: the defaults
 * @param[out] result   filled up to result->struct_size; untouched on failure
 * @return CADINTERP_OK when some start gave a point (also when Ipopt did not converge: see
 *         result->converged and result->status); CADINTERP_E_INVALID_ARGUMENT for a NULL problem
 *         or result, a struct_size too small, a start outside the free ranges or not finite,
 *         multistart < 1 or max_iterations < 0; CADINTERP_E_INFEASIBLE when the runtime cannot
 *         evaluate any start; CADINTERP_E_INTERNAL when Ipopt cannot be set up (message).
 */
CADINTERP_OPTIMIZE_API cadinterp_status cadinterp_optimize_solve(
    cadinterp_optimize_problem* problem, const cadinterp_optimize_options* options,
    cadinterp_optimize_result* result);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* CADINTERP_OPTIMIZE_H */
