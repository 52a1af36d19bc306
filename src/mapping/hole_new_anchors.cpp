// New anchors for patches with holes (paper §6.2; the Steiner points Kraevoy and Sheffer add):
// a slit to a hole loop without any anchor, and a slit from a hole anchor to a first-loop vertex
// that is no anchor, each ending at a new anchor placed alike on both sides (at the same fraction
// of the same CAD path, or in the same direction from a loop's centre). Called by
// split_patches_with_holes's rounds (hole_split.cpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "mapping/hole_split.h"
#include "mapping/layout_paths.h"
#include "mapping/mapping_state.h"

namespace cadinterp::mapping {

namespace {

// The anchors before and after loop vertex v of patch P's first loop.
std::pair<int, int> segment_of(const Patch& P, std::uint32_t v) {
  const double L = P.loop_s.back();
  const double s_p =
      P.loop_s[std::size_t(std::find(P.loop.begin(), P.loop.end(), v) - P.loop.begin())];
  // The last anchor at or before it along the loop (of several at one vertex, the last
  // in loop order), and the anchor after that one.
  const std::size_t Mp = P.anchors.size();
  std::size_t best = 0;
  double back = L + 1;
  for (std::size_t k = 0; k < Mp; ++k) {
    const double db = std::fmod(s_p - P.anchor_s[k] + 2 * L, L);
    if (db < back - 1e-12 * L ||
        (std::fabs(db - back) <= 1e-12 * L && P.anchor_s[(k + 1) % Mp] != P.anchor_s[k])) {
      back = db;
      best = k;
    }
  }
  return std::make_pair(P.anchors[best], P.anchors[(best + 1) % Mp]);
}

// P's first-loop vertices that are no anchor and occur once on it; with A >= 0 only
// those strictly between anchors A and B, each with its fraction of the arc length
// from A to B (`fraction`, may be null).
std::vector<char> loop_targets(const Patch& P, const std::vector<int>& anchor_of, int A, int B,
                               std::vector<std::pair<std::uint32_t, double>>* fraction = nullptr) {
  std::vector<char> t(anchor_of.size(), 0);
  const double Ls = P.loop_s.back();
  const std::size_t Ms = P.anchors.size();
  for (std::size_t k = 0; k < Ms; ++k) {
    if (A >= 0 && (P.anchors[k] != A || P.anchors[(k + 1) % Ms] != B)) continue;
    const double s0 = P.anchor_s[k];
    double len = std::fmod(P.anchor_s[(k + 1) % Ms] - s0 + 2 * Ls, Ls);
    if (Ms == 1) len = Ls;
    for (std::size_t i = 0; i < P.loop.size(); ++i) {
      const double r = std::fmod(P.loop_s[i] - s0 + 2 * Ls, Ls);
      const std::uint32_t v = P.loop[i];
      if ((A < 0 || (r > 0 && r < len)) && anchor_of[v] < 0 && occurs_once(P.loop, v)) {
        t[v] = 1;
        if (fraction && A >= 0) fraction->emplace_back(v, r / len);
      }
    }
    if (A < 0) break;
  }
  return t;
}

// The vertex of patch `to`'s first loop at the fraction of the CAD path between the same two
// anchors that vertex v has on patch `from`'s (the nearest one, among those `allowed` marks
// where given), so that a new anchor lies on the same CAD path on both sides; -1 where v is
// not strictly between two anchors or `to` has no such vertex.
std::int64_t at_same_fraction(const Patch& from, const std::vector<int>& from_anchor_of,
                              std::uint32_t v, const Patch& to,
                              const std::vector<int>& to_anchor_of,
                              const std::vector<char>* allowed) {
  const auto [A, B] = segment_of(from, v);
  std::vector<std::pair<std::uint32_t, double>> at_from, at_to;
  loop_targets(from, from_anchor_of, A, B, &at_from);
  loop_targets(to, to_anchor_of, A, B, &at_to);
  double want = -1;
  for (const auto& [x, f] : at_from)
    if (x == v) want = f;
  if (want < 0) return -1;
  if (allowed)
    at_to.erase(std::remove_if(at_to.begin(), at_to.end(),
                               [&](const auto& xf) { return !(*allowed)[xf.first]; }),
                at_to.end());
  return nearest_fraction(at_to, want);
}

// The loops a slit to a hole without anchor joins, per side (0 source, 1 canonical): the loop,
// its centre, and the vertices a slit may end at (those the loop passes once).
struct AnchorlessHole {
  const Surface* surf[2];
  const Loop* loop[2];
  double at[2][3];
  std::vector<char> targets[2];
  // The unit direction from the loop's centre to its vertex v.
  void direction(int side, std::uint32_t v, double* u) const {
    const double* p = surf[side]->position(v);
    const double n = dist(p, at[side]);
    for (int k = 0; k < 3; ++k) u[k] = n > 0 ? (p[k] - at[side][k]) / n : 0;
  }
};

// The centre of loop l: each vertex weighted by half its two edges' lengths.
void centre(const Surface& surf, const Loop& l, double* x) {
  const std::size_t n = l.vertices.size();
  x[0] = x[1] = x[2] = 0;
  for (std::size_t i = 0; i < n; ++i) {
    // Each vertex weighted by half its two edges' lengths.
    const double w =
        0.5 * (l.s[i + 1] - l.s[i] + (i > 0 ? l.s[i] - l.s[i - 1] : l.s[n] - l.s[n - 1]));
    for (int a = 0; a < 3; ++a) x[a] += w * surf.position(l.vertices[i])[a] / l.s[n];
  }
}

// The loop without anchor among P's holes whose centre lies nearest x.
const Loop* nearest_loop(const Surface& surf, const Patch& P, const double* x) {
  const Loop* best = nullptr;
  double bd = std::numeric_limits<double>::infinity();
  for (const Loop& l : P.holes) {
    if (!l.anchors.empty()) continue;
    double y[3];
    centre(surf, l, y);
    if (dist(x, y) < bd) {
      bd = dist(x, y);
      best = &l;
    }
  }
  return best;
}

// The slit from first-loop anchor a, traced alike on both sides; true when its end is
// a new anchor.
bool slit_to_anchorless(HoleTry& t, const AnchorlessHole& h, int a) {
  MappingState& st = t.st;
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& src_cuts = st.src_cuts;
  const auto& can_cuts = st.can_cuts;
  const auto& src_anchor_of_all = st.src_anchor_of_all;
  const auto& can_anchor_of_all = st.can_anchor_of_all;
  const auto& src_of = t.src_of;
  const auto& can_of = t.can_of;
  const auto& sidx = t.sidx;
  const auto& holed = t.holed;
  auto& tried = t.tried;
  const auto& surf = h.surf;
  const auto& loop = h.loop;
  const auto& targets = h.targets;
  const std::vector<char>* cuts[2] = {&src_cuts, &can_cuts};
  const std::vector<int>* of[2] = {&src_of, &can_of};
  const int patch[2] = {int(sidx), int(holed)};
  const int va[2] = {src_anchor_of_all[std::size_t(a)], can_anchor_of_all[std::size_t(a)]};
  std::vector<std::uint32_t> chain[2];
  // Either side may lead (the canonical first): its slit ends at the loop's vertex
  // nearest along the surface; the follower's at its loop's vertex in the same
  // direction from the loop's centre. Each side's nearest vertex on its own may lie far
  // round the loop from the other's (the press's ram bore where its rim cuts the throat
  // fillet: about 45 degrees, on a corner whose rim nears the plate's face), and another
  // face round the loop, anchored elsewhere (the bore's wall, by its top rim), is then
  // twisted between the two.
  for (int lead : {1, 0}) {
    ++tried;
    const int follow = 1 - lead;
    chain[lead] =
        shortest_path_to_any(*surf[lead], *cuts[lead], static_cast<std::uint32_t>(va[lead]),
                             targets[lead], *of[lead], patch[lead]);
    if (chain[lead].size() < 2) continue;
    double u[3], w[3], best = -2;
    h.direction(lead, chain[lead].back(), u);
    std::vector<char> target(surf[follow]->sample->vertex_count(), 0);
    std::uint32_t pick = 0;
    for (std::uint32_t v : loop[follow]->vertices) {
      if (!targets[follow][v]) continue;
      h.direction(follow, v, w);
      const double cosine = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
      if (cosine > best) {
        best = cosine;
        pick = v;
      }
    }
    if (best < -1) continue;  // no vertex the loop passes once
    target[pick] = 1;
    chain[follow] =
        shortest_path_to_any(*surf[follow], *cuts[follow], static_cast<std::uint32_t>(va[follow]),
                             target, *of[follow], patch[follow]);
    if (chain[follow].size() >= 2 && paths_run_alike(ss, chain[0], cs, chain[1])) break;
    chain[follow].clear();
  }
  return chain[0].size() >= 2 && chain[1].size() >= 2 && st.add_new_anchor(chain[0], chain[1]);
}

}  // namespace

// The vertex of (vertex, fraction) pairs whose fraction is nearest `want` (the first such in
// their order); -1 where there is none.
std::int64_t nearest_fraction(const std::vector<std::pair<std::uint32_t, double>>& at,
                              double want) {
  double best = std::numeric_limits<double>::infinity();
  std::int64_t pick = -1;
  for (const auto& [x, f] : at)
    if (std::fabs(f - want) < best) {
      best = std::fabs(f - want);
      pick = x;
    }
  return pick;
}

// (d) A hole loop without any anchor (separate_faces: the border of a face cut off
// its merged patch, whose CAD edges are new on both sides: the hub's bolt-hole rim on
// the floor or the bottom, or the wall's far rim once its near one is anchored; the
// press's ram bore rim): a slit from a first-loop anchor to the hole loop's
// vertex nearest along the surface on one side and to the vertex in the same direction
// from the loop's centre on the other, whose end becomes a new anchor. No
// ID names the source patch's loop that corresponds: it is the one whose centre lies
// nearest the canonical loop's, when the canonical loop is also the nearest to it
// (mutually nearest; the two samples are of one model, so such loops move with the
// parameters, by less than their spacing). The two slits must run alike too. Tried
// from the first-loop anchors nearest the hole (canonical, straight-line distance), up
// to 12; in the first pass only those within 1.5x the hole's distance.
bool slit_anchorless_hole(HoleTry& t) {
  MappingState& st = t.st;
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& sp = st.sp;
  const auto& corr = st.corr;
  const auto& src_anchor_of = st.src_anchor_of;
  const auto& can_anchor_of = st.can_anchor_of;
  const auto& can_anchor_of_all = st.can_anchor_of_all;
  const auto& c = t.c;
  const auto& hole = t.hole;
  const auto& sidx = t.sidx;
  const auto& pass = t.pass;
  const auto& short_only = t.short_only;
  const auto& near = t.near;
  const auto& leaves = t.leaves;
  bool split = false;
  double hc[3], hs[3];
  centre(cs, hole, hc);
  const Loop* match = nearest_loop(ss, sp[sidx], hc);
  if (match) centre(ss, *match, hs);
  if (!match || nearest_loop(cs, c, hs) != &hole) return false;
  AnchorlessHole h{{&ss, &cs}, {match, &hole}, {{hs[0], hs[1], hs[2]}, {hc[0], hc[1], hc[2]}}, {}};
  for (int side = 0; side < 2; ++side) {
    h.targets[side].assign(h.surf[side]->sample->vertex_count(), 0);
    for (std::uint32_t v : h.loop[side]->vertices)
      if (occurs_once(h.loop[side]->vertices, v)) h.targets[side][v] = 1;
  }
  std::vector<std::pair<double, int>> from;
  std::vector<int> seen;
  for (int a : c.anchors) {
    const int va = can_anchor_of_all[static_cast<std::size_t>(a)];
    if (std::find(seen.begin(), seen.end(), va) != seen.end() || !t.usable(a)) continue;
    seen.push_back(va);
    double d = std::numeric_limits<double>::infinity();
    for (std::uint32_t v : hole.vertices)
      d = std::min(d, dist(corr.anchors[static_cast<std::size_t>(a)].canonical, cs.position(v)));
    if (pass < 2 && (!short_only || d <= 1.5 * near)) from.emplace_back(d, a);
  }
  std::sort(from.begin(), from.end());
  if (from.size() > 12) from.resize(12);
  for (const auto& [d0, a] : from) {
    (void)d0;
    if (slit_to_anchorless(t, h, a)) {
      split = true;
      break;
    }
  }
  // Last (pass 2, only where the two passes before split nothing): a slit that starts at
  // a first-loop vertex that is no anchor, nearest the hole first (canonical,
  // straight-line), which becomes a new anchor too: on the source at the loop vertex
  // between the same two anchors at the same fraction of the arc length, as the
  // hole-anchor slits (slit_to_new_loop_anchor) place theirs, so that it lies on the same CAD path
  // on both sides. A first-loop anchor cannot start a slit when each of its wedges in the patch is
  // a single triangle between two loop edges, and on finer meshes that is every anchor near the
  // hole (the OpenCASCADE hub's flange at a chord angle of 0.2: the loop passes its anchors once
  // per wedge, up to three times; on one pair none at all, on another only one far round the
  // flange, whose slits found no path on the source or left layouts that differ). Up to 6 tried.
  if (!split && pass == 2) {
    const std::vector<char> loop_free = loop_targets(c, can_anchor_of, -1, -1);
    std::vector<std::pair<double, std::uint32_t>> starts;
    for (std::uint32_t v : c.loop) {
      if (!loop_free[v] || !leaves[1][v]) continue;
      double d = std::numeric_limits<double>::infinity();
      for (std::uint32_t u : hole.vertices) d = std::min(d, dist(cs.position(v), cs.position(u)));
      starts.emplace_back(d, v);
    }
    std::sort(starts.begin(), starts.end());
    std::size_t started = 0;
    for (const auto& [d0, v] : starts) {
      (void)d0;
      if (started == 6) break;
      const std::int64_t pick =
          at_same_fraction(c, can_anchor_of, v, sp[sidx], src_anchor_of, &leaves[0]);
      if (pick < 0) continue;
      ++started;
      const int a = st.push_anchor(static_cast<std::uint32_t>(pick), v);
      if (slit_to_anchorless(t, h, a)) {
        split = true;
        break;
      }
      st.pop_anchor();
    }
  }
  return split;
}

// Last, a slit from a hole anchor to the nearest vertex of the first loop that is no
// anchor, on each side, which becomes a new anchor (a Steiner point of the layout, as
// Kraevoy and Sheffer add): on a coarse mesh the hole may be one triangle row from the
// loop, so that no path between two anchors avoids touching a loop. The canonical side
// picks the vertex; the source side the vertex between the same two anchors of the same
// loop at the same fraction of the arc length (below), so the new anchor lies on the same
// CAD path on both sides and the neighbouring patch gets it too.
bool slit_to_new_loop_anchor(HoleTry& t) {
  MappingState& st = t.st;
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& sp = st.sp;
  const auto& src_cuts = st.src_cuts;
  const auto& can_cuts = st.can_cuts;
  const auto& src_anchor_of = st.src_anchor_of;
  const auto& can_anchor_of = st.can_anchor_of;
  const auto& src_anchor_of_all = st.src_anchor_of_all;
  const auto& can_anchor_of_all = st.can_anchor_of_all;
  const auto& c = t.c;
  const auto& hole = t.hole;
  const auto& src_of = t.src_of;
  const auto& can_of = t.can_of;
  const auto& sidx = t.sidx;
  const auto& holed = t.holed;
  auto& tried = t.tried;
  bool split = false;
  const Patch& s = sp[sidx];
  std::vector<int> hole_anchors(hole.anchors);
  std::sort(hole_anchors.begin(), hole_anchors.end());
  hole_anchors.erase(std::unique(hole_anchors.begin(), hole_anchors.end()), hole_anchors.end());
  for (int b : hole_anchors) {
    const int vb[2] = {src_anchor_of_all[static_cast<std::size_t>(b)],
                       can_anchor_of_all[static_cast<std::size_t>(b)]};
    if (vb[0] < 0 || vb[1] < 0) continue;
    const Surface* surf[2] = {&ss, &cs};
    const std::vector<char>* cuts[2] = {&src_cuts, &can_cuts};
    const std::vector<int>* of[2] = {&src_of, &can_of};
    const Patch* P[2] = {&s, &c};
    const std::vector<int>* anchor_of[2] = {&src_anchor_of, &can_anchor_of};
    const int patch[2] = {int(sidx), int(holed)};
    std::vector<std::uint32_t> chain[2];
    // Either side may lead: the canonical first, then the source.
    for (int lead : {1, 0}) {
      ++tried;
      const int follow = 1 - lead;
      chain[lead] = shortest_path_to_any(
          *surf[lead], *cuts[lead], static_cast<std::uint32_t>(vb[lead]),
          loop_targets(*P[lead], *anchor_of[lead], -1, -1), *of[lead], patch[lead]);
      if (chain[lead].size() < 2) continue;
      const auto [A, B] = segment_of(*P[lead], chain[lead].back());
      // The follower's new anchor at the leader's fraction of the CAD path from A to B
      // (the loop vertex nearest it), not simply the vertex nearest its hole: new anchors
      // at different fractions shift the rim's vertices along it against the canonical's
      // (the hub's cavity rim: pairs' Hausdorff max 1.33e-3 with the nearest vertex,
      // 9.06e-4 so), and differently in each sample of an element, so interpolating
      // between them cuts the circle's corners (the hub's build, cadinterp-occt-results:
      // geometry max 0.0054 of the diagonal, 0.0020 so).
      // Where the leader's vertex is no loop vertex strictly between A and B, any of the
      // follower's between them.
      const std::vector<char> allowed = loop_targets(*P[follow], *anchor_of[follow], A, B);
      const std::int64_t pick = at_same_fraction(*P[lead], *anchor_of[lead], chain[lead].back(),
                                                 *P[follow], *anchor_of[follow], nullptr);
      std::vector<char> target(allowed.size(), 0);
      if (pick >= 0) target[static_cast<std::size_t>(pick)] = 1;
      chain[follow] =
          shortest_path_to_any(*surf[follow], *cuts[follow], static_cast<std::uint32_t>(vb[follow]),
                               pick >= 0 ? target : allowed, *of[follow], patch[follow]);
      // The two slits must run alike.
      if (chain[follow].size() >= 2) {
        if (paths_run_alike(ss, chain[0], cs, chain[1])) break;
        chain[follow].clear();
      }
    }
    if (chain[0].size() < 2 || chain[1].size() < 2) continue;
    if (st.add_new_anchor(chain[0], chain[1])) {
      split = true;
      break;
    }
  }
  return split;
}

}  // namespace cadinterp::mapping
