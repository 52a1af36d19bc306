// End-to-end measurement shared by the builder's end-to-end test and the figures program:
// build a model through the C ABI, open the asset with the runtime, and compare it with the
// host's own answer at random parameter points (the paper's Table 2, ours).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "builder/host_call.h"
#include "cadinterp/cadinterp_builder.h"

namespace cadinterp::builder {

struct AccuracyReport {
  int points = 0;      ///< random points evaluated
  int infeasible = 0;  ///< of which the runtime answered CADINTERP_E_INFEASIBLE
  double geometry_max = 0, geometry_p99 = 0;  ///< symmetric Hausdorff / bbox diagonal
  double field_max = 0, field_p99 = 0;        ///< per-vertex fields: max |error| / field range
};

/// Outcome of one build through the C ABI (create, run, report, destroy).
struct BuildOutcome {
  cadinterp_status status = CADINTERP_E_INTERNAL;
  cadinterp_build_report report{};
  std::string error;  ///< the builder's message (or cadinterp_builder_open_error's)
};
BuildOutcome build_asset(const cadinterp_host& host, const cadinterp_build_options& options,
                         const std::string& output_path);

/// Evaluates the asset at `points` uniformly random x (seeded) and compares with host.evaluate:
/// geometry by the symmetric Hausdorff distance of the boundary surfaces (meshes may differ in
/// combinatorics), per-vertex fields at the closest true vertex to each evaluated vertex.
/// Throws std::runtime_error when the asset cannot be opened or a feasible eval fails.
/// When `truth` is given (field index in the asset, x, a point, out: its components; false if
/// unknown), per-vertex fields are compared with it at the evaluated vertex positions instead,
/// at every point whatever the mesh: a mapped mesh's vertices may slide within a face (§6), so
/// vertex i of the asset and of the host's mesh need not be the same point.
using FieldTruthAt = std::function<bool(int field, const double* x, const double* p, double* v)>;
AccuracyReport measure_accuracy(const std::string& asset_path, const Host& host, int points,
                                unsigned seed, const FieldTruthAt& truth = nullptr);

}  // namespace cadinterp::builder
