// The builder (paper §4.2 over meshes): adaptive sampling of a host's meshes and fields on the
// K-d tree, each element's canonical mesh at its centre, the neighbourhood samples mapped into
// its combinatorics (mesh/mapper.h), and the asset content for the writer.
//
// Refinement test, per element and at its centre and face centres (core/adaptive.h):
//   error = max( H(P(y), p(y)) / (diag(p(y)) * geometry_tolerance),
//                max_f |P_f(y) - p_f(y)| / (range(p_f(y)) * field_tolerance) )
// where P is the interpolant of the element's terms mapped into its canonical mesh, p(y) the
// host's sample at y, H the symmetric Hausdorff distance between boundary surfaces
// (surface_distance.h) and p_f(y) a field mapped the same way. An element is split while
// error > 1, along the direction whose midpoint interpolation error is largest.
#pragma once

#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "builder/executor.h"
#include "builder/mesh_types.h"
#include "cadinterp/cadinterp_builder.h"
#include "core/basis.h"
#include "core/compiled_basis.h"
#include "format/asset_writer.h"

namespace cadinterp::builder {

class SampleStore;

struct BuildCancelled : std::runtime_error {
  BuildCancelled() : std::runtime_error("build cancelled") {}
};

/// No element could be built: the host failed everywhere, or no element's samples could be mapped.
struct BuildInfeasible : std::runtime_error {
  explicit BuildInfeasible(const std::string& why) : std::runtime_error("build: " + why) {}
};

/// How a cubic element obtains the samples of its neighbours (paper §5.3, Fig. 15): mapped
/// directly into its canonical mesh, or carried from the neighbour's canonical mesh through a
/// sample on both elements (src/mapping/neighbour_transfer.h). element_stage.cpp says why the
/// direct mapping is the default.
enum class NeighbourTransfer {
  Fallback,  ///< direct; through a shared sample where the direct mapping fails (default)
  Always,    ///< through a shared sample wherever one exists, else direct
  Direct,    ///< direct only (a failure makes the element infeasible)
};

/// What the cubic neighbour transfer did in one build (BuildResult::neighbour).
struct NeighbourTransferStats {
  int neighbour_terms = 0;  ///< (element, term) pairs whose sample lies outside the element
  int direct_failed = 0;    ///< of which the direct mapping failed
  int bridged = 0;          ///< of which were emitted through a shared sample
  int bridge_failed = 0;    ///< bridge tried and impossible (no shared sample, mapping, inverted)
  /// Filled when BuildOptions::measure_neighbour_transfer: both routes computed for every
  /// neighbour term, each compared with the term's own sample (symmetric Hausdorff / its bbox
  /// diagonal) and by the min scaled Jacobian of the mapped tets.
  int compared = 0;         ///< terms where both routes succeeded
  int bridged_better = 0;   ///< of which the bridge's Hausdorff is smaller
  int bridge_inverted = 0;  ///< bridged results with inverted tets (never emitted)
  double direct_hausdorff_max = 0, bridged_hausdorff_max = 0;
  double direct_hausdorff_sum = 0, bridged_hausdorff_sum = 0;
  double direct_min_sj = 1, bridged_min_sj = 1;
};

struct BuildOptions {
  core::Degree degree = core::Degree::Linear;
  double geometry_tolerance = 1e-3;  ///< relative to the bbox diagonal
  double field_tolerance = 1e-2;     ///< relative to the field's range in the true sample
  int max_samples = 256;
  int max_depth = 8;
  int threads = 0;         ///< 0: hardware concurrency
  std::string store_path;  ///< empty: no store
  /// A store already opened for this host (store_fingerprint), used instead of opening
  /// store_path: a build session opens it when it is created, so that a bad store fails there.
  SampleStore* store = nullptr;
  double position_max_abs_error = 0.0;
  /// Each element's meshes encoded as soon as the element is built (format::encode_element_meshes
  /// with asset_write_options(*this)) and its arrays released, so that a build holds its
  /// elements compressed: the raw arrays of a cubic five-parameter CAD model are several times
  /// its asset's size. The asset written is the same, byte for byte. False keeps the arrays in
  /// BuildResult::content (for callers that read them).
  bool encode_elements = true;
  /// Called after every delivered sample; returns true to cancel.
  std::function<bool(const cadinterp_progress&)> progress;
  const Mapper* mapper = nullptr;  ///< nullptr: default_mapper()
  Executor* executor = nullptr;    ///< nullptr: a ThreadPoolExecutor with `threads`
  NeighbourTransfer neighbour_transfer = NeighbourTransfer::Fallback;  ///< cubic only
  bool measure_neighbour_transfer = false;  ///< fills the comparison in BuildResult::neighbour
  /// cadinterp_build_options::simulate_mapped: a mapped term's fields are the host's simulate on
  /// the mapped mesh (terms carried through a shared sample by the cubic neighbour transfer keep
  /// the carried fields).
  bool simulate_mapped = false;
  /// cadinterp_build_options::canonical_refinement: rounds of canonical refinement
  /// (mapping/canonical_refine.h) for an element whose mapped terms depart from their own
  /// boundary by more than 0.7 x geometry_tolerance (0: none).
  int canonical_refinement = 3;
  /// cadinterp_build_options::infeasible_call_fraction: failed points allowed for the refinement
  /// toward infeasible regions, as a fraction of max_samples (negative: no bound).
  double infeasible_call_fraction = 0.25;
  /// cadinterp_build_options::lazy_face_centres: the core's lazy face-centre test
  /// (core::AdaptiveOptions::lazy_face_centres), the direction inherited without a limit.
  bool lazy_face_centres = false;
  /// cadinterp_build_options::map_cache_bytes: memory for mapped samples kept between the
  /// refinement's tests and the element stage (0: default_map_cache_bytes()).
  std::size_t map_cache_bytes = 0;
  /// cadinterp_build_options::calibration_points: random points where the host is asked after
  /// the element stage to calibrate the error model (calibration.h; 0: none).
  int calibration_points = 0;
};

/// The map cache's budget when BuildOptions::map_cache_bytes is 0: a quarter of the machine's
/// physical memory, no less than 512 MiB (512 MiB where the platform does not say). A cubic
/// build of a five-parameter CAD model maps about 7,500 (element, term) pairs of about 350 kB
/// each; with less room the element stage maps again what the refinement's tests mapped.
/// Thread-safe; no failure.
std::size_t default_map_cache_bytes();

/// A point where the host failed, with its message.
struct InfeasiblePoint {
  std::vector<double> x;
  std::string message;
};

/// What a build did, filled on every exit path: on success (a copy is BuildResult::details) and
/// when build() throws (cancelled, every point infeasible, store unreadable or unwritable, out of
/// memory), so that a failed build still says how far it got and why. `counts` is the C report
/// (cadinterp_build_report); what it does not carry (requests, reasons, stage times) is here, and
/// cadinterp_build_stages hands the stage figures to C callers.
struct BuildReport {
  /// The C report. After a failure: host_evaluations, store_hits and infeasible_points count what
  /// was done before it; `samples` is the basis' sample count if the refinement finished, else the
  /// points requested so far (points_requested); `elements` the K-d tree's leaves so far.
  cadinterp_build_report counts{};
  int points_requested = 0;  ///< distinct sample points the refinement asked for (store or host)
  /// One distinct reason, with how often it occurred and the first point where it did.
  struct Reason {
    std::string message;
    int count = 0;
    std::vector<double> first_x;  ///< sample points only (empty for element reasons)
  };
  static constexpr std::size_t kMaxReasons = 8;
  /// Why points were infeasible: the host's distinct messages in the order first met (points are
  /// decided in row order, so deterministically), at most kMaxReasons; points whose message is
  /// not among them are counted in other_infeasible_points. Sum of counts + other =
  /// counts.infeasible_points.
  std::vector<Reason> infeasible_reasons;
  int other_infeasible_points = 0;
  /// Why elements were infeasible beyond their sample points (a term that could not be mapped
  /// into the element's canonical mesh): the mapper's distinct messages, same rules.
  std::vector<Reason> element_reasons;
  int other_infeasible_elements = 0;
  /// Elements refused although all their samples are feasible: a term could not be mapped into
  /// the canonical mesh (the rest of counts.infeasible_elements have an infeasible sample).
  int unmapped_elements = 0;
  /// Cubic elements built on their corner fallback because a term could not be mapped onto
  /// their canonical mesh (their samples all feasible); not refused, so not in the counts above.
  int unmapped_fallbacks = 0;
  /// simulate_mapped: mapped terms simulated on their mapped mesh, and the failures (carried
  /// fields kept; the first failure's message).
  int mapped_simulated = 0, mapped_simulate_failures = 0;
  std::string first_mapped_simulate_failure;
  /// canonical_refinement: elements whose canonical mesh was refined, and the vertices added
  /// to their canonical meshes in all.
  int refined_elements = 0, refined_vertices = 0;
  /// The refinement toward infeasible regions (core::AdaptiveRun): elements split for depending
  /// on a failed point, and infeasible elements left unsplit, inside the region or at the bound.
  int infeasible_splits = 0, interior_unsplit = 0, bound_unsplit = 0;
  /// Calls of the mapper through the map cache, and of those the pairs mapped again after the
  /// cache dropped them (cadinterp_build_stages.maps, maps_again).
  int maps = 0, maps_again = 0;
  /// Wall time per stage (seconds). store: opening the sample store; sampling: the refinement's
  /// waves of sample points (store reads, host evaluations, store writes); refinement: the rest
  /// of the adaptive run (error tests, including the mapping they need); elements: canonical
  /// meshes and their terms mapped into them, the asset content. counts.wall_seconds is the
  /// whole build() call; counts.host_seconds sums the host's own time over evaluations.
  double store_seconds = 0, sampling_seconds = 0, refinement_seconds = 0, elements_seconds = 0;
  /// calibration_points: the points where the host answered and the interpolant was measured,
  /// and per quantity (geometry, then each field) the factor the error model was multiplied by
  /// and the floor added to every element's floor (both empty without calibration;
  /// calibration.h).
  int calibrated_points = 0;
  std::vector<double> calibration, calibration_floors;
  /// "" after a successful build, else the message of the exception build() threw.
  std::string failure;
};

struct BuildResult {
  std::unique_ptr<core::CompiledBasis> basis;
  format::AssetContent content;  ///< content.basis points to *basis
  /// Host failures at their points; and per element refused because a term could not be mapped,
  /// the element's centre with "element E, term sample at (x...): " and the mapper's message.
  std::vector<InfeasiblePoint> infeasible;
  cadinterp_build_report report{};  ///< == details.counts
  BuildReport details;
  NeighbourTransferStats neighbour;  ///< cubic builds only
};

/// The options a build's asset is written with (format::write_asset): the default codecs and
/// the build's position_max_abs_error. Elements encoded as built (BuildOptions::encode_elements)
/// are encoded with these, and write_asset refuses them under any others.
format::WriteOptions asset_write_options(const BuildOptions& options);

/// The mapper a build uses unless BuildOptions::mapper says otherwise: the mesh mapper of paper
/// §6 (src/mapping). Samples of equal combinatorics are blended vertex by vertex without calling
/// it.
const Mapper& default_mapper();

/// Runs the build. Throws BuildCancelled, BuildInfeasible, StoreError (sample_store.h),
/// std::invalid_argument (options). When `report` is not null it receives the build's report
/// whatever happens, before build() returns or throws (std::invalid_argument on the options
/// included: then only `failure` is set). BuildInfeasible's message also names the first
/// reasons with their counts, so a caller that only shows what() still says why.
BuildResult build(const Host& host, const BuildOptions& options, BuildReport* report = nullptr);

/// What a sample store's samples are samples of: host name and identity, K, parameter names and
/// box (a store with another fingerprint is refused).
std::string store_fingerprint(const Host& host);

/// The options as the JSON text recorded in the asset's provenance (only what determines the
/// asset: thread count, store path and callbacks are left out, so that the bytes do not depend
/// on them).
std::string options_json(const BuildOptions& options, const char* mapper_name);

}  // namespace cadinterp::builder
