// The per-element error model (format 1.3, ElementMeshes.error_model; SPEC.md "Error model"):
// what the builder measured on an element, per quantity, and the shape the runtime gives it
// inside the element. Shared by the builder (which stores the element's largest geometry
// estimate in ElementMeshes.error_estimate) and the runtime (cadinterp_error_estimates).
#pragma once

namespace cadinterp::format {

/// The factors the runtime multiplies the shaped estimate by, per basis degree, chosen so that
/// the estimate bounds the true error at >= 90 % of random points: 1 / the smallest 10th
/// percentile of estimate / true error over every quantity of the calibration set, rounded up.
/// That set is the analytic models on one set of points (seed 7) and, for linear, the
/// OpenCASCADE wrench (its load angle alone and all four parameters); the check is another set
/// of points (seed 11), the error_estimate_tests' points and the other OpenCASCADE models
/// (docs/error-estimates.md). Linear: 1 / 0.74 (the four-parameter wrench's traction, p10 1.04 at
/// factor 1.4; the analytic models' smallest unscaled is 0.80). Cubic: the constant, the largest
/// error measured at 2K + 1 points, misses the element's worst points: 1 / 0.89.
inline constexpr double kErrorModelSafetyLinear = 1.4;
inline constexpr double kErrorModelSafetyCubic = 1.15;

/// The geometry estimate's floor: float32 storage rounds every position by up to 2^-24 of its
/// magnitude, so no geometric error below about 2^-23 of the diagonal can be promised (for
/// models whose coordinates are no larger than their diagonal).
inline constexpr double kGeometryFloor = 0x1p-23;

/// The estimate of one quantity at unit position t (K values in [0, 1], the point's place in the
/// element's box) from its model row (K + 1 values: centre error E, then one per direction; see
/// cadinterp.fbs), unscaled. Linear bases: multilinear interpolation of a function with
/// curvature e_d along d errs by sum_d e_d s_d(t), s_d = 4 t_d (1 - t_d) (paper §4.2, "distance
/// in each direction"), with e_d the measured midpoint error (E where it was not measured). Each
/// e_d is the largest error over the mesh along d alone, and the directions' largest errors sit
/// at different vertices, so that sum overstates the error at the centre, where E was measured:
/// the sum is scaled to equal E there (E sum_d e_d s_d / sum_d e_d; E sum_d s_d / K if every e_d
/// is 0). It is never less than any one direction's e_d s_d, which a saddle (curvatures of
/// opposite signs, E near 0) still errs by along the edges. Zero at the element's corners, where
/// the interpolant takes the samples' values. Cubic bases: the largest error measured at the
/// centre and the face centres, constant over the element (a cubic B-spline interpolant is not
/// exact at an element's corners, and its error has no simple per-direction shape). `cubic`
/// is false for a cubic basis's element on its corner fallback
/// (core::CompiledBasis::element_cubic is false): its interpolant is multilinear and the
/// builder measures its row as a linear element's. Negative when the centre error is unknown.
double error_model_estimate(const double* row, int K, bool cubic, const double* t);

/// The largest value of error_model_estimate over the element: the largest of E and the e_d
/// (linear: at the centre, or at the middle of the edges along the largest e_d).
double error_model_max(const double* row, int K);

/// An estimate `est` of a quantity with the element's floor for it (`floor`, measured: the
/// geometry_floor, the geometry's error at the element's own samples, or the field's
/// field_floors entry; SPEC.md "Error model"). Linear: est + floor, because the linear shape is
/// 0 at the samples, where the floor is the whole error. Cubic (not on the corner fallback):
/// max(est, floor), because the cubic constant is the largest error measured at the centre and
/// the face centres, each against the host's own mesh there, so it already holds the difference
/// of two meshes that the floor measures; adding it would count that difference twice (the
/// OpenCASCADE cubic mount's geometry: median estimate / error 3.04 added, 1.85 as the larger;
/// docs/error-estimates.md).
double error_model_with_floor(double est, bool cubic, double floor);

/// What cadinterp_error_estimates reports for an unscaled estimate `est` of a quantity: -1 when
/// it is unknown (negative), else est times the degree's safety factor, with the element's floor
/// for the quantity (error_model_with_floor; the floor is measured, so not scaled), the
/// geometry's no less than kGeometryFloor.
double error_model_reported(double est, bool cubic, bool geometry, double floor);

}  // namespace cadinterp::format
