// The element stage (paper §4.2, §6; §5.3 for cubic elements): after the adaptive refinement,
// each element of the K-d tree gets its canonical mesh (the host's sample at its centre) and
// every term's sample in that mesh's combinatorics (mapped directly, or carried from a
// neighbour element through a shared sample), and becomes the asset's element record.
#pragma once

#include <cstdint>
#include <vector>

#include "builder/build.h"
#include "builder/calibration.h"
#include "builder/mesh_problem.h"
#include "core/adaptive.h"
#include "core/compiled_basis.h"

namespace cadinterp::builder {

/// Appends the record of every element (leaves[e], the leaves of run.basis' tree, element e of
/// `cb`) to out.content.elements, in that order, from the rows of `problem`. An element whose
/// centre or one of whose samples is infeasible, or with a term that can be neither mapped nor
/// carried from a neighbour, is refused: element_ok[e] = 0 (element_ok holds one entry per
/// leaf), counted in details.counts and details, the unmapped term named in out.infeasible.
/// A cubic element refused for a term that could not be mapped, whose samples are all feasible,
/// is built again on its corner fallback: `cb` is recompiled from run.basis with those elements
/// flagged (core::CompiledBasis::compile, `infeasible_sample` its flags per sample), counted in
/// details.unmapped_fallbacks. Fills out.neighbour. Returns the canonical sample of the first
/// element built (its fields and regions describe the asset), or nullptr when every element was
/// refused.
/// Elements (and, inside one, its canonical refinement) are built on exec.concurrency() threads;
/// each fills its own record and counts, merged in element order, so the content, the counts
/// and the reasons recorded do not depend on the thread count. Exceptions from a worker (e.g.
/// std::bad_alloc) are rethrown here once every worker has stopped. opt.progress is called on the
/// calling thread between terms (every sample done, none queued, the stage's ETA); when it
/// returns true, BuildCancelled is thrown once every worker has stopped at its next term.
/// `held_out` (may be null): each built element fills error[i] of the held-out points in it
/// (calibration.h, stored_errors) from the meshes it stores, before they are encoded.
const Sample* map_elements(const Host& host, const BuildOptions& opt, Executor& exec,
                           MeshProblem& problem, const core::AdaptiveRun& run,
                           core::CompiledBasis& cb, const std::vector<bool>& infeasible_sample,
                           const std::vector<int>& leaves, BuildReport& details, BuildResult& out,
                           std::vector<std::uint8_t>& element_ok, HeldOutPoints* held_out);

}  // namespace cadinterp::builder
