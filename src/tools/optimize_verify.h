// The paper's "second stage" (§7.2) for `cadinterp optimize --verify`: regenerate and simulate
// the optimum x* with the host, and measure the objective and the constraints on the host's own
// mesh and fields with the runtime's definitions.
//
// How the true values reuse the runtime's kernels: the host's sample becomes a one-element
// asset in memory (one parameter, linear, both terms the sample's mesh and fields, stored
// losslessly), whose interpolant is that mesh at every x. The same expressions are then parsed
// and evaluated on it by libcadinterp_optimize, i.e. by the runtime's property, integral and
// smooth-maximum code, so "true" and "interpolated" differ only by the interpolation (and the
// float rounding of the host's double coordinates, ~1e-7 relative). A quantity the host's
// sample lacks (a field it did not return, a region it did not name) fails to parse there and
// is reported as n/a with the parser's message.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_builder.h"
#include "mesh/sample.h"
#include "optimize_grid.h"
#include "optimize_setup.h"

namespace cadinterp::cli {

/// One function's value on the host's sample, or why there is none.
struct TrueValue {
  bool defined = false;
  double value = 0.0;
  std::string reason;  ///< when not defined
};

/// The host's answer at x* and the functions (objective, then the constraints) on it.
struct Verification {
  bool feasible = false;
  std::string message;  ///< the host's failure when not feasible
  double host_seconds = 0.0;
  std::size_t vertices = 0, tets = 0;
  std::vector<TrueValue> values;  ///< 1 + constraint count
};

/// "" when the host and the asset have the same parameters (count and names, in order), else
/// what differs. Ranges may differ (x* must lie in the host's box: verify_with_host checks).
std::string parameter_mismatch(const cadinterp_host& host, const cadinterp_asset* asset);

/// The bytes of a one-parameter, one-element linear asset whose interpolant is `s`'s mesh, fields
/// and regions at every x in [0, 1]. Throws std::runtime_error for an infeasible sample.
std::vector<std::uint8_t> sample_asset_bytes(const mesh::Sample& s);

/// The objective and the constraints of `spec` on the sample (see the file comment).
std::vector<TrueValue> values_on_sample(const mesh::Sample& s, const OptimizeSpec& spec);

/// Runs the host at x (regenerate, references, simulate; guarded and validated as the builder
/// calls it) and measures `spec` on its sample. A failing host gives feasible = false and its
/// message. Throws std::invalid_argument for a host the builder would refuse, or x outside the
/// host's box.
Verification verify_with_host(const cadinterp_host& host, const double* x,
                              const OptimizeSpec& spec);

/// The host's true objective and constraints at a point (verify_with_host) as a grid function
/// (optimize_grid.h): a host failure or a quantity the sample lacks is "not evaluated" with its
/// reason. Thread-safe when the host is (cadinterp_host::thread_safe). `host` and `spec` must
/// outlive the function.
GridFunction host_grid_function(const cadinterp_host& host, const OptimizeSpec& spec);

}  // namespace cadinterp::cli
