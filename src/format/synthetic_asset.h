// Assets without a CAD host: the adaptive driver (paper §4.2) over an analytic deformation of a
// fixed box tet mesh, with analytic fields. The mesh never changes combinatorics, so every
// sample maps to every element's canonical mesh by identity. Used by the format tests, the
// conformance generator and the benchmarks until the builder exists.
#pragma once

#include <memory>
#include <vector>

#include "core/adaptive.h"
#include "format/asset_writer.h"

namespace cadinterp::format {

struct SyntheticSpec {
  int K = 3;  ///< 1..4 parameters (bend, twist, taper, stretch)
  core::Degree degree = core::Degree::Linear;
  int cells[3] = {4, 3, 2};  ///< box cells along x, y, z (6 tets per cell)
  double tolerance = 2e-3;   ///< adaptive driver tolerance (absolute, on positions)
  int max_samples = 400;
  bool fields = true;              ///< "temperature" per vertex, "stress" per tet
  bool infeasible_corner = false;  ///< host fails where all parameters exceed 0.8
  bool check_face_centres = true;  ///< AdaptiveOptions::check_face_centres
  bool field_units = false;        ///< give the fields units ("K", "MPa"): a format 1.1 asset
  /// Store the scalar output "energy" per sample (synthetic_output): a format 1.3 asset.
  bool outputs = false;
};

/// The synthetic host's scalar output at x (K values): 1 + sum_d (d + 1) x_d^2 + sin(3 x_0) / 2,
/// smooth and non-polynomial so that cubic interpolation of it is not exact.
double synthetic_output(const SyntheticSpec& spec, const double* x);

/// The fixed topology of the box mesh.
struct BoxMesh {
  std::uint32_t vertex_count = 0;
  std::vector<float> rest;  ///< #V by 3
  std::vector<std::uint32_t> tets, triangles;
  std::vector<std::int32_t> tags;  ///< face of the box (0..5: -x, +x, -y, +y, -z, +z)
};
BoxMesh synthetic_box(const SyntheticSpec& spec);

/// The analytic host: positions (#V by 3) and, if spec.fields, field values (per vertex, then
/// per tet) at parameters x, on `box` = synthetic_box(spec). Returns false where the spec makes
/// x infeasible.
bool synthetic_host(const SyntheticSpec& spec, const BoxMesh& box, const double* x,
                    std::vector<float>& positions, std::vector<float>& fields);
/// As above, building the box first (convenient for one-off calls).
bool synthetic_host(const SyntheticSpec& spec, const double* x, std::vector<float>& positions,
                    std::vector<float>& fields);

/// A complete asset content; `basis` owns the compiled basis content.basis points to.
struct SyntheticAsset {
  std::unique_ptr<core::CompiledBasis> basis;
  AssetContent content;
  int samples = 0;
};
SyntheticAsset make_synthetic_asset(const SyntheticSpec& spec);

/// The runtime benchmarks' fixture (runtime_bench, the WebAssembly-vs-native comparison): K = 3,
/// 80 x 40 x 30 cells (about 103k vertices), fields, 27 samples (one level per direction).
SyntheticSpec benchmark_fixture_spec();

}  // namespace cadinterp::format
