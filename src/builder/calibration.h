// The error model's calibration on held-out points (cadinterp_build_options::calibration_points;
// SPEC.md "Error model"). Before the element stage the builder asks its host at random points
// that no element is built from; each element measures the meshes it stores, blended at the
// points inside it, against the host's answer there, as the accuracy measurements compare an
// asset with its host; after the stage every element's model is multiplied, per quantity, by the
// factor those points call for.
#pragma once

#include <cstdint>
#include <vector>

#include "builder/build.h"
#include "builder/mesh_problem.h"
#include "cadinterp/cadinterp_builder.h"
#include "core/compiled_basis.h"
#include "format/asset_writer.h"

namespace cadinterp::builder {

/// The most points a build may ask for its calibration (cadinterp_build_options).
inline constexpr int kMaxCalibrationPoints = CADINTERP_MAX_CALIBRATION_POINTS;

/// The share of an asset's points whose error its calibrated estimate bounds (the 90 % the
/// estimates promise at random points), and the confidence with which the factor fitted on a
/// few dozen held-out points keeps that promise.
inline constexpr double kCalibrationCoverage = 0.9;
inline constexpr double kCalibrationConfidence = 0.95;

/// The held-out points of a build: where they are, the problem's row of the host's answer, the
/// element of the compiled basis each lies in, and (filled by the element stage) the error of
/// the element's stored meshes there, per quantity (empty where not measured: the host failed,
/// or the element was refused).
struct HeldOutPoints {
  std::vector<std::vector<double>> x;
  std::vector<int> row, element;
  std::vector<std::vector<double>> error;
  std::vector<std::vector<int>> in_element;  ///< per element of the basis: its points' indices
};

/// Draws opt.calibration_points random points (a fixed seed, so that the same build asks the
/// same points and a sample store answers them again) and asks `problem` for those in feasible
/// elements of `cb` (store, then host; counted in the report's host evaluations, store hits and
/// infeasible points, not in its samples or points requested). Empty when calibration_points is
/// 0. Throws BuildCancelled as MeshProblem::evaluate does.
HeldOutPoints ask_held_out_points(const BuildOptions& opt, MeshProblem& problem,
                                  const core::CompiledBasis& cb, BuildReport& details);

/// The errors of an element's stored meshes (`ed` before it is encoded: canonical topology,
/// per-term positions and concatenated fields, terms[t] the sample of term t) blended with the
/// basis weights `w` at a point, against `truth`, the host's answer there, per quantity:
/// out[0] the symmetric Hausdorff distance of the boundary surfaces / truth's bbox diagonal,
/// out[1 + f] field f's largest error / its range over truth (a per-vertex field located in
/// truth's tets where the meshes differ in combinatorics, value by value where they share it; a
/// per-tet field value by value where they share it, else -1: not measured), as
/// builder::measure_accuracy compares an asset with its host. Thread-safe; no failure.
void stored_errors(const format::ElementData& ed, const int* terms, int n,
                   const core::BasisWeights& w, const mesh::Sample& truth,
                   std::vector<double>& out);

/// The least unscaled estimate a factor may scale: float32 storage's resolution relative to a
/// quantity's scale (format::kGeometryFloor). Below it an element's model measured nothing (its
/// samples reproduce the quantity there), and the factor a point's error asks of it would be
/// that error over rounding noise.
inline constexpr double kCalibrationLeastEstimate = 0x1p-23;

/// One held-out point's need: the least factor c >= 0 by which an element's unscaled estimate
/// `est` (format::error_model_estimate) must be multiplied so that the estimate the runtime
/// reports from it (format::error_model_reported with `floor`) is at least `error`. 0 when the
/// floor alone bounds it; infinity when it does not and est is below kCalibrationLeastEstimate.
/// Thread-safe; no failure.
double calibration_need(double est, bool cubic, bool geometry, double floor, double error);

/// The ranks (1-based, in ascending order) of n needs (calibration_need) of points drawn
/// uniformly that bracket the kCalibrationCoverage quantile Q of the needs over the whole box,
/// each with kCalibrationConfidence: `upper`, the least k with P(Binomial(n, coverage) <= k - 1)
/// >= confidence (the k-th smallest is at least Q unless k or more draws fall below it), and
/// `lower`, the largest k with P(Binomial(n, coverage) >= k) >= confidence. 0 where no rank
/// does (upper: n < 29). Thread-safe; no failure.
void calibration_ranks(int n, int& lower, int& upper);

/// The factor of one quantity from its points' needs. The built-in safety factor is kept (1)
/// unless the needs reject it with kCalibrationConfidence: where the lower bracket of Q
/// (calibration_ranks) is above 1, the built-in factor bounds less than the coverage; where the
/// upper one is below 1, it overstates. Then the factor is the upper bracket (the factor that
/// bounds the coverage with that confidence), no less than `least`; 1 where that bracket is
/// infinite (points err where the shaped estimate is 0, which no factor changes) or does not
/// exist (too few points). Sorts `needs`. Thread-safe; no failure.
double calibration_factor(std::vector<double>& needs, double least);

/// One held-out point of one quantity: its element's unscaled estimate there
/// (format::error_model_estimate), the element's basis and floor for the quantity, and the
/// error measured there (stored_errors).
struct CalibrationPoint {
  double est = 0;
  bool cubic = false, geometry = false;
  double floor = 0, error = 0;
};

/// One point's floor need: the least F >= 0 such that, with F added to the element's floor,
/// the estimate the runtime reports (format::error_model_reported) is at least the error.
/// Thread-safe; no failure.
double calibration_floor_need(const CalibrationPoint& p);

/// What calibration does to one quantity: every element's model row multiplied by `factor`,
/// and `floor` added to every element's floor.
struct CalibrationChoice {
  double factor = 1, floor = 0;
};

/// One quantity's calibration from its measured points. The factor is calibration_factor of
/// the points' needs (calibration_need). Where the points reject the built-in factor as too
/// small, a floor may serve instead: F, the upper bracket (calibration_ranks) of the points'
/// floor needs, also bounds the coverage with kCalibrationConfidence. It serves where an error
/// does not follow the model's shape, which is zero at the samples while a field carried on
/// its sample's mesh differs from the host's mesh at x next to them as much as between them;
/// scaling the shape then takes a factor many times too large elsewhere. Of the two remedies
/// the one whose estimates are the smaller multiple of the errors at the points' median is
/// chosen (the floor alone where the factor's bracket is infinite). `least` as
/// calibration_factor. Thread-safe; no failure.
CalibrationChoice calibrate_quantity(const std::vector<CalibrationPoint>& points, double least);

/// Calibrates each quantity of every element of `elements` (one per element of `cb`) from the
/// measured held-out points (calibrate_quantity, with `least` = 1 / the degree's safety factor,
/// so that no estimate falls below the errors the builder measured): multiplies its model row
/// (the non-negative entries) by the factor, adds the floor to its floor (geometry_floor, or
/// field_floors, created at 0 where the element had none), and recomputes error_estimate.
/// Fills details.calibrated_points (the points measured), details.calibration and
/// details.calibration_floors (one per quantity). Does nothing without points. No failure.
void calibrate_error_models(const BuildOptions& opt, const core::CompiledBasis& cb,
                            const HeldOutPoints& held_out,
                            std::vector<format::ElementData>& elements, BuildReport& details);

}  // namespace cadinterp::builder
