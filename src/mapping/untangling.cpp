// What stays inverted after the interior solve (paper §6.2 (interior mapping)): the surface map
// relaxed across the traced layout paths (path_release.h), boundary vertices moved within the
// source surface (boundary_untangle.h), and the interior untangled as a whole (foldover_free.h),
// each followed by the interior solve and kept where fewer tets stay inverted. Owns
// untangle_mapping.
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "mapping/mapping_state.h"
#include "mapping/path_release.h"

namespace cadinterp::mapping {

namespace {

// Where tets stay inverted: the surface relaxed across the traced paths
// (release_traced_paths), kept when the interior then has fewer inverted tets.
bool release_paths(MappingState& st) {
  const auto& source = st.source;
  const auto& canonical = st.canonical;
  const auto& options = st.options;
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& can_keys = st.can_keys;
  const auto& can_tol = st.can_tol;
  const auto& can_traced = st.can_traced;
  const auto& can_anchor_of = st.can_anchor_of;
  const auto& V = st.V;
  auto& where = st.where;
  auto& dofs = st.dofs;
  const auto& dof_of = st.dof_of;
  auto& surface_map = st.surface_map;
  auto& out = st.out;
  auto& q = st.q;
  auto& unreleased = st.unreleased;
  const std::vector<char> cad_cuts = st.cuts_of(cs, can_keys, {}, can_tol);
  std::vector<char> on_cad(V, 0);
  for (int h = 0; h < 3 * cs.triangles(); ++h)
    if (cad_cuts[std::size_t(h)]) on_cad[cs.from(h)] = on_cad[cs.to(h)] = 1;
  // Within 3 surface rings of a traced path.
  std::vector<int> ring(V, -1);
  std::vector<std::uint32_t> front;
  for (const auto& chain : can_traced)
    for (std::uint32_t v : chain)
      if (ring[v] < 0) {
        ring[v] = 0;
        front.push_back(v);
      }
  std::vector<std::vector<std::uint32_t>> next_to(V);
  for (int h = 0; h < 3 * cs.triangles(); ++h) next_to[cs.from(h)].push_back(cs.to(h));
  for (int r = 1; r <= 3; ++r) {
    std::vector<std::uint32_t> grown;
    for (std::uint32_t v : front)
      for (std::uint32_t u : next_to[v])
        if (ring[u] < 0) {
          ring[u] = r;
          grown.push_back(u);
        }
    front.swap(grown);
  }
  std::vector<std::uint32_t> movable;
  for (std::uint32_t v = 0; v < V; ++v)
    if (ring[v] >= 0 && !on_cad[v] && can_anchor_of[v] < 0) movable.push_back(v);
  std::vector<SurfacePoint> released_where = where;
  std::vector<double> released = surface_map;
  release_traced_paths(
      source, ss, canonical, movable, options.release_sweeps, released_where,
      [&st](const SurfacePoint& pt, double* x) { st.place_point(pt, x); }, released);
  const std::vector<double> kept_map = surface_map, kept_out = out.vertices;
  surface_map = released;
  TetQuality q2;
  if (!solve_interior(st, q2)) return false;
  if (q2.inverted == 0) {
    q = q2;
    where = std::move(released_where);
  } else if (q2.inverted < q.inverted) {
    // Fewer, not none: the boundary untangling (untangle_mapping) runs from here, and once more
    // from the state before the release (kept in `unreleased`), the better result kept. The
    // untangling's parameters of the released vertices (disk coordinates) no longer say
    // where they are, so there it leaves them where the release put them.
    unreleased = std::make_unique<MappingState::Unreleased>(
        MappingState::Unreleased{kept_map, kept_out, where, dofs, q});
    q = q2;
    where = std::move(released_where);
    for (std::uint32_t v : movable)
      if (dof_of[v] >= 0) dofs[static_cast<std::size_t>(dof_of[v])].dims = 0;
  } else {
    surface_map = kept_map;
    out.vertices = kept_out;
  }
  return true;
}

// Boundary untangling (boundary_untangle.h): tets that stay inverted after the interior solve,
// most of them with all four vertices on the boundary (measured on the OpenCASCADE press and
// mount), get their boundary vertices moved within the source surface, then the interior is
// solved again for the moved boundary; repeated while it helps.
bool untangle_surface(MappingState& st) {
  const auto& canonical = st.canonical;
  const auto& options = st.options;
  const auto& sp = st.sp;
  const auto& source_of = st.source_of;
  const auto& source_disks = st.source_disks;
  const auto& source_locators = st.source_locators;
  const auto& V = st.V;
  const auto& on_surface = st.on_surface;
  auto& where = st.where;
  auto& dofs = st.dofs;
  const auto& dof_of = st.dof_of;
  auto& surface_map = st.surface_map;
  auto& out = st.out;
  auto& q = st.q;
  auto& boundary_moved = st.boundary_moved;
  auto point_of = [&](const BoundaryDof& d, const double* p, SurfacePoint& pt) {
    const std::size_t pi = static_cast<std::size_t>(d.patch);
    if (d.dims == 1) {
      pt = loop_point(sp[static_cast<std::size_t>(source_of[pi])], p[0]);
      return true;
    }
    if (std::hypot(p[0], p[1]) > 0.999) return false;  // inner vertices stay off the circle
    pt = disk_point(*source_disks[pi], *source_locators[pi], p);
    return true;
  };
  const PlaceFn place = [&](const BoundaryDof& d, const double* p, double* x) {
    SurfacePoint pt;
    if (!point_of(d, p, pt)) return false;
    st.place_point(pt, x);
    return true;
  };
  std::vector<char> free_vertex(V);
  for (std::size_t v = 0; v < V; ++v) free_vertex[v] = on_surface[v] ? 0 : 1;
  const std::vector<BoundaryDof> initial = dofs;
  std::vector<double> best = out.vertices;
  std::vector<BoundaryDof> best_dofs = dofs;
  TetQuality best_q = q;
  for (int pass = 0; pass < options.boundary_untangle_passes && best_q.inverted > 0; ++pass) {
    const BoundaryUntangleResult r =
        untangle_boundary(canonical.tets, dof_of, dofs, place, min_six_volume(out.vertices),
                          out.vertices, &free_vertex);
    q = tet_quality(out.vertices, canonical.tets);
    if (q.inverted < best_q.inverted) {
      best = out.vertices;
      best_dofs = dofs;
      best_q = q;
    }
    if (best_q.inverted == 0 || r.moved == 0) break;
    // The interior once more for the moved boundary (the harmonic solve spreads the boundary
    // moves into the interior, which the local search alone cannot), then the next pass.
    for (std::size_t v = 0; v < V; ++v)
      if (on_surface[v])
        for (std::size_t a = 0; a < 3; ++a) surface_map[3 * v + a] = out.vertices[3 * v + a];
    if (!solve_interior(st, q)) return false;
    if (q.inverted < best_q.inverted) {
      best = out.vertices;
      best_dofs = dofs;
      best_q = q;
    }
  }
  out.vertices = std::move(best);
  dofs = std::move(best_dofs);
  q = best_q;
  // The surface points of the moved boundary vertices (the field transfer's weights).
  for (std::size_t i = 0; i < dofs.size(); ++i) {
    if (dofs[i].p[0] == initial[i].p[0] && dofs[i].p[1] == initial[i].p[1]) continue;
    point_of(dofs[i], dofs[i].p, where[dofs[i].vertex]);
    ++boundary_moved;
  }
  return true;
}

}  // namespace

bool untangle_mapping(MappingState& st) {
  const auto& options = st.options;
  const auto& can_traced = st.can_traced;
  auto& surface_map = st.surface_map;
  auto& out = st.out;
  auto& where = st.where;
  auto& dofs = st.dofs;
  auto& q = st.q;
  const auto& folded = st.folded;
  auto& unreleased = st.unreleased;
  auto& boundary_moved = st.boundary_moved;
  if (q.inverted > 0 && !folded && options.release_sweeps > 0 && !can_traced.empty() &&
      !release_paths(st))
    return false;
  if (q.inverted > 0 && !folded && options.boundary_untangle_passes > 0) {
    if (!untangle_surface(st)) return false;
    if (q.inverted > 0 && unreleased) {
      // Once more from the state before the release; the fewer inverted tets kept.
      const std::vector<double> r_vertices = out.vertices, r_map = surface_map;
      const std::vector<SurfacePoint> r_where = where;
      const std::size_t r_moved = boundary_moved;
      const TetQuality r_q = q;
      surface_map = unreleased->surface_map;
      out.vertices = unreleased->vertices;
      where = unreleased->where;
      dofs = unreleased->dofs;
      q = unreleased->q;
      boundary_moved = 0;
      if (!untangle_surface(st)) return false;
      if (r_q.inverted < q.inverted) {
        out.vertices = r_vertices;
        surface_map = r_map;
        where = r_where;
        boundary_moved = r_moved;
        q = r_q;
      }
    }
  }
  if (q.inverted > 0 && options.foldover_free && !options.foldover_free_early) {
    // Last resort (MapOptions::foldover_free): from the best state so far.
    untangle_whole(st, q);
    // And the boundary untangling once more, from the untangled interior: a tet left inverted
    // across a boundary triangle may have vertices the first passes could not move while the
    // interior around it was still folded, and can move them now.
    if (q.inverted > 0 && !folded && options.boundary_untangle_passes > 0 && !untangle_surface(st))
      return false;
  }
  return true;
}

}  // namespace cadinterp::mapping
