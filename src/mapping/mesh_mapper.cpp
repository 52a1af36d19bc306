// map_sample: the mesh mapper's orchestrator (paper §6). Checks the inputs, then runs the stages
// of mapping_state.h in the order of §6 on one MappingState, retries with other options where
// tets stay inverted, and carries the fields over.
#include "mapping/mesh_mapper.h"

#include <climits>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "mapping/field_transfer.h"
#include "mapping/mapping_state.h"

namespace cadinterp::mapping {

namespace {

bool same_field_layout(const mesh::Sample& a, const mesh::Sample& b) {
  if (a.fields.size() != b.fields.size()) return false;
  for (std::size_t i = 0; i < a.fields.size(); ++i)
    if (a.fields[i].name != b.fields[i].name || a.fields[i].location != b.fields[i].location ||
        a.fields[i].components != b.fields[i].components)
      return false;
  return true;
}

// The samples' validity, or false with why.
bool check_inputs(const mesh::Sample& source, const mesh::Sample& canonical, std::string& why) {
  if (!source.feasible || !canonical.feasible) {
    why = "mapping: both samples must be feasible";
    return false;
  }
  // Indices, sizes and orientation are relied on below: a malformed sample is refused by name.
  for (const auto& [s, name] :
       {std::make_pair(&source, "source"), std::make_pair(&canonical, "canonical")}) {
    const std::string problem = mesh::validate(*s);
    if (!problem.empty()) {
      why = std::string("mapping: the ") + name + " sample is invalid: " + problem;
      return false;
    }
    if (s->triangle_count() == 0) {
      why = std::string("mapping: the ") + name + " sample has no boundary triangles";
      return false;
    }
  }
  if (!same_field_layout(source, canonical)) {
    why = "mapping: the samples' fields differ";
    return false;
  }
  return true;
}

// Why a mapping whose tets stay inverted is refused.
std::string inverted_message(const MappingState& st) {
  const mesh::Sample& canonical = st.canonical;
  const std::vector<char>& on_surface = st.on_surface;
  const TetQuality& q = st.q;
  auto percent = [](double f) {
    char b[32];
    std::snprintf(b, sizeof b, "%g %%", 100 * f);
    return std::string(b);
  };
  // Tets with all four vertices on the boundary are fixed by the surface map alone: no
  // interior solve or untangling can repair them, so the message tells them apart.
  std::size_t surface_only = 0;
  for (std::size_t t = 0; t < canonical.tet_count(); ++t) {
    const std::uint32_t* c = &canonical.tets[4 * t];
    if (on_surface[c[0]] && on_surface[c[1]] && on_surface[c[2]] && on_surface[c[3]] &&
        tet_quality(st.out.vertices, std::vector<std::uint32_t>(c, c + 4)).inverted == 0)
      continue;
    if (on_surface[c[0]] && on_surface[c[1]] && on_surface[c[2]] && on_surface[c[3]])
      ++surface_only;
  }
  return "mapping: the harmonic interior would invert or flatten " + std::to_string(q.inverted) +
         " of " + std::to_string(canonical.tet_count()) + " tets (" + std::to_string(surface_only) +
         " of them with all four vertices on the boundary" +
         (st.folded ? "; over " + percent(st.options.untangle_max_fraction) +
                          " of the tets: the surface map folds, no boundary untangling tried"
                    : std::string()) +
         ")";
}

// One run of §6's stages; where tets stay inverted and `retries` holds, the retries of
// MapOptions in turn, the first that maps kept.
bool map_runs(const mesh::Sample& source, const mesh::Sample& canonical, mesh::MappedSample& out,
              std::string& why, MapStats* stats, const MapOptions& options, bool retries) {
  why.clear();
  if (!check_inputs(source, canonical, why)) return false;
  MappingState st(source, canonical, options, out, why);
  if (!build_surface(source, st.ss, why) || !build_surface(canonical, st.cs, why)) {
    why = "mapping: " + why;
    return false;
  }
  // §6.2 (CAD referencing): control points matched by equal IDs only (requirement 1).
  if (!match_anchors(st)) return false;
  // §6.2: the common layout, patches bounded by common paths and paired by their anchors.
  if (!build_layout(st)) return false;
  // §6.2 (surface mapping): per patch, both sides onto one disk; every canonical boundary vertex
  // gets a point of the source surface.
  if (!map_surface(st)) return false;
  // §6.2 (interior mapping): the interior follows: the P1-harmonic solve (exact on affine maps),
  // untangled.
  st.surface_map = out.vertices;
  // Regions folded over as a whole (foldover_free.h): the interior vertices near the tets still
  // inverted move together; kept when fewer stay inverted. All calls of one mapping share
  // MapOptions::foldover_free_evaluations.
  st.foldover_budget =
      options.foldover_free_evaluations > 0 ? options.foldover_free_evaluations : INT_MAX;
  if (!solve_interior(st, st.q)) return false;
  const TetQuality& q = st.q;
  st.folded = static_cast<double>(q.inverted) >
              options.untangle_max_fraction * static_cast<double>(canonical.tet_count());
  const bool folded = st.folded;
  // §6.2 (interior mapping): where tets stay inverted, the surface map relaxed across traced
  // paths, the boundary moved within the source surface, the interior untangled as a whole.
  if (!untangle_mapping(st)) return false;
  if (stats) {
    stats->matched_points = st.corr.anchors.size();
    stats->patches = st.cp.size();
    stats->rejected_paths = st.rejected_paths;
    stats->dropped_anchors = st.dropped_anchors;
    stats->subdivided = st.subdivided;
    stats->planar_patches = st.planar_patches;
    stats->min_scaled_jacobian = q.min_scaled_jacobian;
    stats->inverted = q.inverted;
    stats->boundary_moved = st.boundary_moved;
    stats->smoothed = st.smooth != nullptr;
  }
  // The whole mapping again with other options (and, with `nested`, their own retries); its
  // result replaces this one when it succeeds.
  auto retry = [&](const MapOptions& other, bool nested) {
    mesh::MappedSample other_out;
    std::string other_why;
    MapStats other_stats;
    if (!map_runs(source, canonical, other_out, other_why, &other_stats, other, nested))
      return false;
    out = std::move(other_out);
    if (stats) *stats = other_stats;
    return true;
  };
  if (retries && q.inverted > 0 && !folded && options.smooth_alpha > 0 &&
      !options.foldover_free_early) {
    // The same mapping on the flat source triangles, kept when it succeeds: the reconstruction
    // lifts boundary vertices by up to the chordal sag, which can leave a thin tet near the
    // boundary inverted that the flat placement does not (measured on the OpenCASCADE press: 1
    // of 9 pairs; others the other way round), so the smooth placement never costs a pair.
    MapOptions flat = options;
    flat.smooth_alpha = 0;
    flat.subdivide_retry_ratio = 0;  // the subdivided retry below is made once, last
    if (retry(flat, true)) return true;
  }
  if (retries && q.inverted > 0 && options.foldover_free && !options.foldover_free_early) {
    // Once more with the untangling inside every interior solve, so that the release and the
    // boundary untangling start from an untangled interior. Neither order rescues every pair
    // (on the OpenCASCADE press across its topology change, some pairs map only one way, some
    // only the other), so the late untangling runs first and the early one only where it fails:
    // inside every solve it costs minutes on a pair it cannot rescue.
    MapOptions early = options;
    early.foldover_free_early = true;
    early.subdivide_retry_ratio = 0;
    if (retry(early, true)) return true;
  }
  if (retries && q.inverted > 0 && options.subdivide_ratio == 0 &&
      options.subdivide_retry_ratio > 0) {
    // Last, so that every pair the retries above map keeps its result; one run without retries
    // of its own, so that a pair refused anyway costs one run more (MapOptions).
    MapOptions subdivided = options;
    subdivided.subdivide_ratio = options.subdivide_retry_ratio;
    if (retry(subdivided, false)) return true;
  }
  if (q.inverted > 0) {
    why = inverted_message(st);
    return false;
  }
  // Fields at the mapped points (field_transfer.h).
  const TetLocator locator(source);
  out.fields = transfer_fields(source, canonical, out.vertices, st.on_surface, st.where, locator);
  return true;
}

}  // namespace

bool map_sample(const mesh::Sample& source, const mesh::Sample& canonical, mesh::MappedSample& out,
                std::string& why, MapStats* stats, const MapOptions& options) {
  return map_runs(source, canonical, out, why, stats, options, true);
}

}  // namespace cadinterp::mapping
