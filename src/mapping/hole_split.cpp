// Patches with holes subdivided into disks (paper §6.2; Kraevoy and Sheffer's layout): a face
// with a hole, or faces merged around one, is split by two paths from its first loop to a hole
// or slit open by one, between the same anchors on both sides (or new anchors placed alike), in
// rounds until every patch is a disk whose loop carries anchors. Owns split_patches_with_holes,
// called by build_layout (layout_build.cpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "mapping/hole_split.h"
#include "mapping/layout_paths.h"
#include "mapping/mapping_state.h"

namespace cadinterp::mapping {

namespace {

// Traces the paths (pairs of anchors) on both sides and keeps them when the two layouts
// still have the same patch keys.
bool try_split(HoleTry& t, const std::vector<std::pair<int, int>>& paths) {
  MappingState& st = t.st;
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& src_tol = st.src_tol;
  const auto& can_tol = st.can_tol;
  const auto& corr = st.corr;
  const auto& sp = st.sp;
  auto& src_cuts = st.src_cuts;
  auto& can_cuts = st.can_cuts;
  auto& src_traced = st.src_traced;
  auto& can_traced = st.can_traced;
  const auto& src_anchor_of_all = st.src_anchor_of_all;
  const auto& can_anchor_of_all = st.can_anchor_of_all;
  const auto& c = t.c;
  const auto& src_of = t.src_of;
  const auto& can_of = t.can_of;
  const auto& sidx = t.sidx;
  const auto& holed = t.holed;
  const auto& hole_index = t.hole_index;
  const auto& slack = t.slack;
  std::vector<char> try_cuts[2] = {src_cuts, can_cuts};
  std::vector<std::vector<std::uint32_t>> try_traced[2];
  bool ok = true;
  for (int side = 0; side < 2 && ok; ++side) {
    const Surface& surf = side == 0 ? ss : cs;
    std::vector<char>& cuts = try_cuts[side];
    const std::vector<int>& of = side == 0 ? src_of : can_of;
    const int patch = static_cast<int>(side == 0 ? sidx : holed);
    const double tol = side == 0 ? src_tol : can_tol;
    for (const auto& [x, y] : paths) {
      const Anchor& ax = corr.anchors[static_cast<std::size_t>(x)];
      const Anchor& ay = corr.anchors[static_cast<std::size_t>(y)];
      const int vx = vertex_at(surf, side == 0 ? ax.source : ax.canonical, tol);
      const int vy = vertex_at(surf, side == 0 ? ay.source : ay.canonical, tol);
      std::vector<std::uint32_t> chain;
      if (vx >= 0 && vy >= 0) {
        chain = shortest_path(surf, cuts, static_cast<std::uint32_t>(vx),
                              static_cast<std::uint32_t>(vy), &of, patch);
        // A coarse mesh may have no vertex off the loops between them (a small hole near
        // the rim: one triangle row): the path may then touch loops away from anchors, and
        // build_patches cuts the patch open there; the anchors' cyclic order is unchanged.
        if (chain.size() < 2) {
          std::vector<char> never(surf.sample->vertex_count(), 0);
          for (int v : side == 0 ? src_anchor_of_all : can_anchor_of_all)
            if (v >= 0) never[static_cast<std::size_t>(v)] = 1;
          // A slit may not touch the two loops it joins away from its ends either: the
          // piece between it and the loop would be enclosed without an anchor.
          if (paths.size() == 1) {
            const Patch& pp = side == 0 ? sp[sidx] : c;
            for (std::uint32_t v : pp.loop) never[v] = 1;
            for (std::uint32_t v : pp.holes[hole_index].vertices) never[v] = 1;
          }
          // Nor the first path of this split: touching it would enclose anchorless bits.
          for (const auto& ch : try_traced[side])
            for (std::uint32_t v : ch) never[v] = 1;
          chain = shortest_path(surf, cuts, static_cast<std::uint32_t>(vx),
                                static_cast<std::uint32_t>(vy), &of, patch, &never);
        }
      }
      if (chain.size() < 2) {
        ok = false;
        break;
      }
      cut_along(surf, chain, cuts);
      try_traced[side].push_back(std::move(chain));
    }
  }
  for (std::size_t k = 0; ok && k < paths.size(); ++k)
    ok = paths_run_alike(ss, try_traced[0][k], cs, try_traced[1][k], slack);
  if (!ok || !st.layouts_agree(try_cuts[0], try_cuts[1])) return false;
  src_cuts = std::move(try_cuts[0]);
  can_cuts = std::move(try_cuts[1]);
  for (auto& ch : try_traced[0]) src_traced.push_back(std::move(ch));
  for (auto& ch : try_traced[1]) can_traced.push_back(std::move(ch));
  return true;
}

// A new anchor on the hole loop, on the far side from anchor b (a quarter to three
// quarters of the loop's arc length from it), at the canonical vertex nearest first-loop
// anchor a and on the source at the same fraction of its loop from b, as (c) places its
// new anchors; -1 where either side has no such vertex that a path can leave by.
int far_side_anchor(HoleTry& t, int b, int a) {
  MappingState& st = t.st;
  const auto& cs = st.cs;
  const auto& sp = st.sp;
  const auto& src_anchor_of = st.src_anchor_of;
  const auto& can_anchor_of = st.can_anchor_of;
  const auto& hole = t.hole;
  const auto& sidx = t.sidx;
  const auto& hole_index = t.hole_index;
  const auto& leaves = t.leaves;
  const Loop* loops[2] = {&sp[sidx].holes[hole_index], &hole};
  double from[2];
  for (int side = 0; side < 2; ++side) {
    const Loop& l = *loops[side];
    const auto k = std::find(l.anchors.begin(), l.anchors.end(), b);
    if (k == l.anchors.end()) return -1;
    from[side] = l.anchor_s[static_cast<std::size_t>(k - l.anchors.begin())];
  }
  auto fraction = [&](int side, std::size_t i) {
    const double L = loops[side]->s.back();
    return std::fmod(loops[side]->s[i] - from[side] + 2 * L, L) / L;
  };
  auto candidate = [&](int side, std::size_t i) {
    const std::uint32_t v = loops[side]->vertices[i];
    return (side == 0 ? src_anchor_of : can_anchor_of)[v] < 0 && leaves[side][v] &&
           occurs_once(loops[side]->vertices, v);
  };
  std::int64_t pick[2] = {-1, -1};
  double want = -1, best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < hole.vertices.size(); ++i) {
    const double f = fraction(1, i);
    if (f < 0.25 || f > 0.75 || !candidate(1, i)) continue;
    const double d = dist(cs.position(hole.vertices[i]), t.canon_pos(a));
    if (d < best) {
      best = d;
      pick[1] = hole.vertices[i];
      want = f;
    }
  }
  if (pick[1] < 0) return -1;
  std::vector<std::pair<std::uint32_t, double>> at_source;
  for (std::size_t i = 0; i < loops[0]->vertices.size(); ++i)
    if (candidate(0, i)) at_source.emplace_back(loops[0]->vertices[i], fraction(0, i));
  pick[0] = nearest_fraction(at_source, want);
  if (pick[0] < 0) return -1;
  return st.push_anchor(static_cast<std::uint32_t>(pick[0]), static_cast<std::uint32_t>(pick[1]));
}

// Two paths, first loop -> hole, between the same anchors on both sides. Candidates: each
// anchor a1 of the first loop, nearest the hole first (canonical positions), with the
// first-loop anchor half-way round from it (a2) and, on the hole, the anchor nearest a1
// (b1) and the one half-way round from that (b2). A candidate is kept when both paths exist
// on both sides and the two layouts still have the same patch keys (a path leaving an
// anchor into a one-triangle wedge, measured on the OpenCASCADE hub, has none).
bool split_by_two_paths(HoleTry& t, const std::vector<std::pair<double, std::size_t>>& order) {
  MappingState& st = t.st;
  const auto& c = t.c;
  const auto& hole = t.hole;
  auto& tried = t.tried;
  const std::size_t M = c.anchors.size();
  bool split = false;
  for (const auto& [d0, i] : order) {
    (void)d0;
    const int a1 = c.anchors[i], a2 = c.anchors[(i + M / 2) % M];
    const std::size_t nearest = t.nearest_on_hole(a1).first;
    const int b1 = hole.anchors[nearest];
    const int b2 = hole.anchors[(nearest + hole.anchors.size() / 2) % hole.anchors.size()];
    ++tried;
    // Where the hole's anchors are one vertex (a closed CAD edge's vertex, which is the
    // end of that edge twice), both paths would end there: the piece holding the hole
    // then wraps round it, a thin strip between a path and the rim on one side and a wide
    // one on the other, and the disk maps squeeze its rim's first row of triangles flat
    // (the OpenCASCADE mount's bolt holes at chord angle 0.2: the bottom face's row beside
    // the rim, 0.66 mm wide on the canonical, mapped to 0.01 mm; the tets on it inverted).
    // The second path ends instead at a new anchor on the far side of the hole.
    if (t.same_vertex(b1, b2)) {
      const int m = far_side_anchor(t, b1, a2);
      if (m >= 0) {
        if (try_split(t, {{a1, b1}, {a2, m}})) {
          split = true;
          break;
        }
        st.pop_anchor();
      }
    }
    if (try_split(t, {{a1, b1}, {a2, b2}})) {
      split = true;
      break;
    }
  }
  return split;
}

// Otherwise one path, a slit from the first loop to the hole: the patch stays one piece,
// cut open along the slit like a periodic face along its seam (patch_layout.h), which makes
// it a disk whose loop runs round the first loop, along the slit, round the hole and back.
// On a face with many holes (the OpenCASCADE hub's flange: rim, bore and five bolt holes)
// the two-path split runs out of anchor pairs whose paths avoid each other and the other
// holes on both sides; a slit needs one path and one anchor per loop, and the next round
// connects the next hole to the loop this one joined (a spanning tree of slits).
// Candidates: every (first-loop vertex, hole anchor) pair by increasing canonical distance,
// up to 24.
bool slit_to_hole_anchor(HoleTry& t, const std::vector<std::pair<double, std::size_t>>& all_first) {
  const auto& c = t.c;
  const auto& hole = t.hole;
  const auto& short_only = t.short_only;
  const auto& near = t.near;
  auto& tried = t.tried;
  bool split = false;
  std::vector<std::tuple<double, int, int>> slits;
  for (const auto& o : all_first) {
    const int a = c.anchors[o.second];
    if (!t.usable(a)) continue;
    for (int b : hole.anchors)
      if (t.usable(b)) slits.emplace_back(dist(t.canon_pos(a), t.canon_pos(b)), a, b);
  }
  std::sort(slits.begin(), slits.end());
  slits.erase(std::unique(slits.begin(), slits.end()), slits.end());
  if (short_only)
    slits.erase(std::remove_if(slits.begin(), slits.end(),
                               [&](const std::tuple<double, int, int>& slit) {
                                 return std::get<0>(slit) > 1.5 * near;
                               }),
                slits.end());
  if (slits.size() > 24) slits.resize(24);
  for (const auto& [d0, a, b] : slits) {
    (void)d0;
    ++tried;
    if (try_split(t, {{a, b}})) {
      split = true;
      break;
    }
  }
  return split;
}

// A hole with anchors: the two-path split (a), else one slit to a hole anchor (b), else a slit
// from a hole anchor to a new anchor on the first loop (c). Candidates from the first loop's
// anchors, nearest the hole first.
bool join_anchored_hole(HoleTry& t) {
  const MappingState& st = t.st;
  const auto& can_anchor_of_all = st.can_anchor_of_all;
  const auto& c = t.c;
  const auto& short_only = t.short_only;
  const std::size_t M = c.anchors.size();
  std::vector<std::pair<double, std::size_t>> order;
  for (std::size_t i = 0; i < M; ++i) order.emplace_back(t.nearest_on_hole(c.anchors[i]).second, i);
  std::sort(order.begin(), order.end());
  // An anchor where earlier splits met occurs several times on the loop, and several
  // anchors may share one vertex (a closed edge's vertex): try each vertex once.
  std::vector<int> seen;
  order.erase(std::remove_if(order.begin(), order.end(),
                             [&](const std::pair<double, std::size_t>& o) {
                               const int a =
                                   can_anchor_of_all[static_cast<std::size_t>(c.anchors[o.second])];
                               if (std::find(seen.begin(), seen.end(), a) != seen.end())
                                 return true;
                               seen.push_back(a);
                               return false;
                             }),
              order.end());
  const std::vector<std::pair<double, std::size_t>> all_first = order;
  if (order.size() > 12) order.resize(12);
  if (!short_only && M >= 2 && t.hole.anchors.size() >= 2 && split_by_two_paths(t, order))
    return true;
  return slit_to_hole_anchor(t, all_first) || slit_to_new_loop_anchor(t);
}

// One hole of canonical patch `holed` in one pass of a round; true where it was split off or
// joined (the layout then changed).
bool try_hole(MappingState& st, std::size_t holed, std::size_t sidx, std::size_t hole_index,
              double near, int pass, std::size_t& tried) {
  const Patch& c = st.cp[holed];
  const Loop& hole = c.holes[hole_index];
  // Pass 2 (only where the passes before split nothing): new slit starts for a hole without
  // anchor (d, hole_new_anchors.cpp); and for the one hole of an annulus, the general order again
  // with paths that run alike up to a quarter of the hole's diameter. Two paths between the same
  // anchors of an annulus differ in kind only by their winding round the hole, and one
  // that winds half a turn more runs about the hole's diameter away from the other; closer
  // than that they differ by the meshes (the OpenCASCADE hub's rim face at a chord angle of
  // 0.2: one row of triangles on the canonical, where the slit is one edge, and a vertex
  // inside the row on the source, where it bends by most of an edge: 2.65 mm off on a slit
  // of 8.6 mm, in an annulus whose hole is 110 mm across).
  const bool annulus = pass == 2 && !hole.anchors.empty();
  if (annulus && c.holes.size() != 1) return false;
  HoleTry t{st,
            c,
            holed,
            sidx,
            hole,
            hole_index,
            near,
            pass,
            annulus ? 0.25 * hole.s.back() / M_PI : 0,
            pass == 0,
            patch_of_triangles(st.ss, st.sp),
            patch_of_triangles(st.cs, st.cp),
            {},
            tried};
  for (int side = 0; side < 2; ++side) {
    const Surface& surf = side == 0 ? st.ss : st.cs;
    const std::vector<char>& cuts = side == 0 ? st.src_cuts : st.can_cuts;
    const std::vector<int>& of = side == 0 ? t.src_of : t.can_of;
    const int patch = static_cast<int>(side == 0 ? sidx : holed);
    t.leaves[side].assign(surf.sample->vertex_count(), 0);
    for (int h = 0; h < 3 * surf.triangles(); ++h)
      if (of[static_cast<std::size_t>(h / 3)] == patch && !cuts[static_cast<std::size_t>(h)])
        t.leaves[side][surf.from(h)] = 1;
  }
  return hole.anchors.empty() ? slit_anchorless_hole(t) : join_anchored_hole(t);
}

// Every patch a disk whose loop carries anchors, or false with why.
bool every_patch_is_a_disk(MappingState& st) {
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& sp = st.sp;
  const auto& cp = st.cp;
  auto& why = st.why;
  for (const auto* side : {&sp, &cp})
    for (const Patch& q : *side) {
      const Surface& surf = side == &sp ? ss : cs;
      const std::string what =
          std::string(side == &sp ? "source" : "canonical") + " patch of " +
          std::to_string(q.triangles.size()) + " triangles (face tag " +
          std::to_string(surf.sample->triangle_tags[static_cast<std::size_t>(q.triangles[0])]) +
          ")";
      if (q.genus > 0) {
        why = "mapping: " + what + " has " + std::to_string(q.genus) +
              " handles that no cut along faces of one side only removes; patches with "
              "handles are not supported";
        return false;
      }
      if (q.anchors.empty() || !q.holes.empty()) {
        why = "mapping: " + what + " has " + std::to_string(q.holes.size() + 1) +
              " boundary loops without matched control point (no slit from a neighbour "
              "reached them)";
        return false;
      }
    }
  return true;
}

}  // namespace

// Patches with holes (a face with a hole, faces merged around one) are subdivided: two shortest
// paths from the first loop to a hole, between the same anchors on both sides, split such a patch
// into two disks; repeated until every patch is a disk.
bool split_patches_with_holes(MappingState& st) {
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& src_tol = st.src_tol;
  const auto& can_tol = st.can_tol;
  const auto& src_anchor = st.src_anchor;
  const auto& can_anchor = st.can_anchor;
  const auto& src_cuts = st.src_cuts;
  const auto& can_cuts = st.can_cuts;
  auto& sp = st.sp;
  auto& cp = st.cp;
  auto& why = st.why;
  const auto& corr = st.corr;
  for (int round = 0;; ++round) {
    if (!build_patches(ss, src_cuts, src_anchor, src_tol, true, sp, why)) {
      why = "mapping: source layout: " + why;
      return false;
    }
    if (!build_patches(cs, can_cuts, can_anchor, can_tol, true, cp, why)) {
      why = "mapping: canonical layout: " + why;
      return false;
    }
    // The first patch with holes whose first loop has an anchor (one whose loops have none, a
    // face cut off by separate_faces, waits until a neighbour's slit anchors one of them).
    std::size_t holed = 0;
    while (holed < cp.size() && (cp[holed].holes.empty() || cp[holed].anchors.empty())) ++holed;
    if (holed == cp.size()) return every_patch_is_a_disk(st);
    const Patch& c = cp[holed];
    std::size_t sidx = 0;
    const std::vector<int> key = c.key();
    while (sidx < sp.size() && sp[sidx].key() != key) ++sidx;
    if (sidx == sp.size() || round >= 64 || c.anchors.empty()) {
      why = "mapping: a patch with " + std::to_string(c.holes.size() + 1) +
            " boundary loops could not be subdivided into disks (" +
            (sidx == sp.size() ? "no source patch with the same anchors"
                               : "no anchor on its first loop") +
            ")";
      return false;
    }
    // The holes in turn (the first that can be joined or split off; the loop order is the
    // same on both sides, by smallest anchor): a hole that no path reaches now may be
    // reachable once another is joined.
    bool split = false;
    std::size_t tried = 0;
    //
    // A patch with several holes (the OpenCASCADE hub's flange: rim, bore and five bolt holes)
    // first gets a tree of short slits, as Prim's algorithm grows a spanning tree: the hole
    // nearest the first loop (canonical positions, from its anchors to the loop's vertices)
    // joins it by a slit not much longer than that distance (to an anchor, or to a new one), and
    // the next round measures from the grown loop. The two-path splits and the long slits of the
    // general order below run from the first loop's anchors, which on a face bounded by circles
    // are a seam's ends: paths across the whole face, round holes not yet joined, that trap
    // later holes or go round a hole one way on one side and the other way on the other (the
    // hub: 2 of 10 pairs folded over the flange). Only where no short slit exists does the
    // general order run.
    std::vector<std::pair<double, std::size_t>> hole_order;
    for (std::size_t h = 0; h < c.holes.size(); ++h) {
      double near = std::numeric_limits<double>::infinity();
      for (int b : c.holes[h].anchors)
        for (std::uint32_t v : c.loop)
          near = std::min(
              near, dist(corr.anchors[static_cast<std::size_t>(b)].canonical, cs.position(v)));
      if (c.holes[h].anchors.empty())  // (d): from the hole's vertices
        for (std::uint32_t u : c.holes[h].vertices)
          for (std::uint32_t v : c.loop)
            near = std::min(near, dist(cs.position(u), cs.position(v)));
      hole_order.emplace_back(near, h);
    }
    if (c.holes.size() > 1) std::stable_sort(hole_order.begin(), hole_order.end());
    const int first_pass = c.holes.size() > 1 ? 0 : 1;
    for (int pass = first_pass; pass < 3 && !split; ++pass)
      for (const auto& [near, hole_index] : hole_order) {
        if (split) break;
        split = try_hole(st, holed, sidx, hole_index, near, pass, tried);
      }
    if (!split) {
      why =
          "mapping: no paths split a patch with a hole the same way on both sides (anchors "
          "not at mesh vertices, blocked, or the layouts differ after the split; " +
          std::to_string(tried) + " candidates tried)";
      return false;
    }
  }
  return true;
}

}  // namespace cadinterp::mapping
