// End-to-end measurement shared by the builder's end-to-end test and the figures program:
// build a model through the C ABI, open the asset with the runtime, and compare it with the
// host's own answer at random parameter points (the paper's Table 2, ours).
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "builder/mesh_types.h"
#include "cadinterp/cadinterp_builder.h"

namespace cadinterp::builder {

struct AccuracyReport {
  int points = 0;      ///< random points evaluated
  int infeasible = 0;  ///< of which the runtime answered CADINTERP_E_INFEASIBLE
  int lost = 0;        ///< of those, points the host regenerates (count_lost only)
  double geometry_max = 0, geometry_p99 = 0;  ///< symmetric Hausdorff / bbox diagonal
  double field_max = 0, field_p99 = 0;        ///< per-vertex fields: max |error| / field range
  /// Feasible points whose fields were compared.
  int field_points = 0;
  std::vector<std::string> field_names;    ///< the per-vertex fields compared, asset order
  std::vector<double> field_max_by_field;  ///< max |error| / range of each of them
  std::vector<double> field_p99_by_field;  ///< and its 99th percentile over the points
  /// The 99th percentile over every compared vertex value of every point (pooled), the
  /// statistic of the paper's Table 2 (a max of 0.21 next to a 99% of 0.04 is per value).
  std::vector<double> field_vertex_p99_by_field;
  /// With `on_evaluated_mesh`: per field, the max and pooled 99th percentile against the host's
  /// own simulate at x on each evaluated mesh (its boundary-condition faces found through the
  /// asset's regions). The comparison above takes its truth from the host's own mesh of x, so
  /// it also holds the difference between two meshes' discretizations of one solid; this one
  /// leaves that out. Points where the host cannot simulate on the evaluated mesh (a tet the
  /// blend left flat, a region it cannot place) are counted, not compared.
  int evaluated_mesh_points = 0, evaluated_mesh_refused = 0;
  std::string evaluated_mesh_first_refusal;
  std::vector<double> evaluated_mesh_max_by_field, evaluated_mesh_vertex_p99_by_field;
  /// Calibration of cadinterp_error_estimates against the errors measured above, per quantity
  /// (geometry, then the compared fields in field_names order), over the compared points where
  /// the asset has an estimate: how many (estimate_points), the fraction where the estimate is
  /// at least the true error (estimate_coverage), and the median of estimate / true error over
  /// the points with a true error above 1e-12 (estimate_median_ratio). Empty for assets
  /// without the builder's error model.
  std::vector<int> estimate_points;
  std::vector<double> estimate_coverage, estimate_median_ratio;
  /// The 10th percentile of estimate / true error (same points as the median): the safety
  /// factor 1 / p10 makes the estimate bound the error at 90 % of these points.
  std::vector<double> estimate_p10_ratio;
  /// Every compared point with an estimate, in the order measured: x, then per quantity
  /// (geometry, then the compared fields in field_names order) the estimate and the true error,
  /// the pairs the calibration above is made of (estimate -1 where the asset has none).
  struct PointRecord {
    std::vector<double> x, estimate, error;
  };
  std::vector<PointRecord> per_point;
};

/// Outcome of one build through the C ABI (create, run, report, destroy).
struct BuildOutcome {
  cadinterp_status status = CADINTERP_E_INTERNAL;
  cadinterp_build_report report{};  ///< struct_size set; zeros when the builder was not created
  cadinterp_build_stages stages{};  ///< struct_size set; zeros when the builder was not created
                                    ///< (first_mapped_simulate_failure and calibration
                                    ///< NULL: copied below)
  std::string error;                ///< the builder's message (or cadinterp_builder_create_error's)
  std::string first_mapped_simulate_failure;
  std::vector<double> calibration;  ///< stages.calibration's values (empty without calibration)
  std::vector<double> calibration_floors;  ///< stages.calibration_floors' values
};
BuildOutcome build_asset(const cadinterp_host& host, const cadinterp_build_options& options,
                         const std::string& output_path);

/// One model at two mesh resolutions, split along a parameter: the `below` host where
/// x[parameter] <= split, the `above` host beyond. Their meshes differ in combinatorics while
/// their B-rep IDs agree (the same model), so every element across the split maps terms of one
/// resolution onto a canonical mesh of the other (the canonical refinement's tests).
struct SplitHost {
  const cadinterp_host* below = nullptr;
  const cadinterp_host* above = nullptr;
  int parameter = 0;
  double split = 0;
  std::string identity;
  /// The combined host (below's name, parameters and thread safety; `identity`); it points at
  /// this object, which must outlive it.
  cadinterp_host host() const;
};

/// Evaluates the asset at `points` uniformly random x (seeded) and compares with host.evaluate:
/// geometry by the symmetric Hausdorff distance of the boundary surfaces (meshes may differ in
/// combinatorics), per-vertex fields at each evaluated vertex: against the host's value at the
/// same vertex when the meshes are equal, else against the host's field interpolated in the
/// host's tet containing the evaluated vertex (mapping::TetLocator).
/// Throws std::runtime_error when the asset cannot be opened or a feasible eval fails.
/// When `truth` is given (field index in the asset, x, a point, out: its components; false if
/// unknown), per-vertex fields are compared with it at the evaluated vertex positions instead,
/// at every point whatever the mesh: a mapped mesh's vertices may slide within a face (§6), so
/// vertex i of the asset and of the host's mesh need not be the same point.
using FieldTruthAt = std::function<bool(int field, const double* x, const double* p, double* v)>;
/// With `count_lost`, the host is also asked at every point the runtime calls infeasible, to
/// count the feasible points the asset lost (`lost`).
/// With `on_evaluated_mesh` (needs a host with simulate), also the
/// evaluated_mesh_* statistics: one more simulate per feasible point.
/// `threads`: the host's regenerations, and its simulations on the evaluated meshes, run on that
/// many threads, a few points per thread at a time (one at a time for a host that is not
/// thread-safe); the comparisons run on the calling thread in the points' order, so the report
/// is the same for every thread count. `truth` is called on the calling thread only.
AccuracyReport measure_accuracy(const std::string& asset_path, const Host& host, int points,
                                unsigned seed, const FieldTruthAt& truth = nullptr,
                                bool count_lost = false, bool on_evaluated_mesh = false,
                                int threads = 1);

/// As measure_accuracy (no closed-form truth, no lost count, no evaluated-mesh simulation), at
/// the given points instead of random ones, in their order: the builder's measurements at its
/// own test points against the asset's true error there. With `located`, per-vertex fields are
/// compared with the host's located at the evaluated vertices even where the host's mesh has
/// the evaluated mesh's combinatorics: at a sample the builder mapped terms onto, the two share
/// combinatorics but a mapped vertex has slid within its face (located_errors.h). Throws
/// std::invalid_argument when a point has not host.dim() coordinates, else as measure_accuracy.
AccuracyReport measure_accuracy_at(const std::string& asset_path, const Host& host,
                                   const std::vector<std::vector<double>>& xs, bool located,
                                   int threads = 1);

/// The truth's own mesh dependence (Table 2's FEM columns take their truth from one mesh of x):
/// at the `points` random x that measure_accuracy visits with `seed`, each per-vertex field of
/// `reference` (another mesh of the same model: a finer one for the truth's discretization
/// error, one a few per cent apart for its meshing noise) at each of its vertices, against
/// `table`'s field at that position (barycentric in the table host's tet containing it), as
/// measure_accuracy compares an asset with `table`: |difference| / the table field's range.
/// It is the error Table 2 would report for an asset that reproduced `reference` exactly.
/// With `asset_path`, also that asset against `reference` at the same points, as
/// measure_accuracy measures it against its host (each reference evaluation serving both):
/// Table 2 against a finer truth. Throws as measure_accuracy for the asset.
/// Fields are matched by name, components and location. `threads` as for measure_accuracy
/// (both hosts' regenerations of a batch share them). Not thread-safe beyond the hosts' own
/// evaluate. Throws std::invalid_argument when the parameter boxes differ and
/// std::runtime_error when the matched fields change between points.
struct TruthDependenceReport {
  int points = 0;                           ///< random points drawn
  int infeasible = 0;                       ///< of which either host failed (not compared)
  int compared = 0;                         ///< points compared
  std::vector<std::string> field_names;     ///< the matched per-vertex fields, reference order
  std::vector<double> max_by_field;         ///< max over every vertex value of every point
  std::vector<double> vertex_p99_by_field;  ///< 99th percentile of those values, pooled
  /// Where each field's max is: the point x and the reference's vertex position there.
  std::vector<std::vector<double>> max_x;
  std::vector<std::array<double, 3>> max_at;
  bool has_asset = false;  ///< asset_path was given
  AccuracyReport asset;    ///< the asset against `reference` (has_asset)
};
TruthDependenceReport measure_truth_dependence(const Host& table, const Host& reference, int points,
                                               unsigned seed, const std::string& asset_path = {},
                                               int threads = 1);

}  // namespace cadinterp::builder
