// The common layout (paper §6.2): the cuts that divide both samples' boundaries into patches
// with the same anchors in the same cyclic order, so that every canonical patch has a source
// patch to be mapped onto. Owns the layout's driver (build_layout) and its stages but the hole
// rounds (hole_split.cpp): faces merged across one-sided CAD edges separated again, one-sided
// CAD edges traced on the other side, large patches subdivided, paths measured along their
// geodesics, patches paired; and the MappingState's layout helpers.
#include <algorithm>
#include <cmath>
#include <iterator>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "mapping/geodesic.h"
#include "mapping/layout_paths.h"
#include "mapping/mapping_state.h"

namespace cadinterp::mapping {

namespace {

// Loops without any anchor: only separate_faces makes them, and only new anchors (hole_split.cpp,
// (d)) remove them; a split or slit that encloses a piece without anchor makes one more.
std::size_t anchorless(const std::vector<Patch>& patches) {
  std::size_t n = 0;
  for (const Patch& q : patches) {
    n += q.anchors.empty() ? 1 : 0;
    for (const Loop& l : q.holes) n += l.anchors.empty() ? 1 : 0;
  }
  return n;
}

// Faces merged across CAD edges of one side only (layout_cuts: their edge keys differ, so
// their borders are not cut) are separated again where both layouts allow it. Merging keeps the
// layouts alike, but the disk map of a merged patch does not know the border between its
// faces, which is often a sharp edge: canonical vertices on it land beside it on the source
// and cut its corner, and tets at it flatten. Measured on the OpenCASCADE press across the
// ram bore's cut into the throat fillet (the bore's wall, the throat's ceiling and the fillet
// merge: the bore's rim, a 90-degree edge, is new on both sides): Hausdorff up to 9.7e-3 of the
// diagonal, regions off by up to 16 %, 6 of 10 pairs with tets inverted at the rim. And on
// the hub across its switch from round to obround bolt holes: the floor and the bottom joined
// by five walls of faces of one side only, a patch with handles. Candidates, in turn: the
// faces of one side only (one group per side: the hub's walls), then each face of both sides
// that shares a patch with another face (by tag); each is cut off its patch on both sides
// (separate_faces) and kept when the two layouts still have the same patch keys. The loops
// such a cut makes carry no anchor when their CAD edges are new on both sides; the rounds
// of split_patches_with_holes (hole_split.cpp) add one to each, case (d).
void separate_merged_faces(MappingState& st) {
  const auto& source = st.source;
  const auto& canonical = st.canonical;
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& src_tol = st.src_tol;
  const auto& can_tol = st.can_tol;
  const auto& src_anchor = st.src_anchor;
  const auto& can_anchor = st.can_anchor;
  auto& src_cuts = st.src_cuts;
  auto& can_cuts = st.can_cuts;
  auto& src_face_cuts = st.src_face_cuts;
  auto& can_face_cuts = st.can_face_cuts;
  auto tags_of = [](const mesh::Sample& x) {
    std::vector<std::int32_t> t(x.triangle_tags);
    std::sort(t.begin(), t.end());
    t.erase(std::unique(t.begin(), t.end()), t.end());
    return t;
  };
  const std::vector<std::int32_t> src_tags = tags_of(source), can_tags = tags_of(canonical);
  std::vector<std::int32_t> one_src, one_can, both;
  std::set_difference(src_tags.begin(), src_tags.end(), can_tags.begin(), can_tags.end(),
                      std::back_inserter(one_src));
  std::set_difference(can_tags.begin(), can_tags.end(), src_tags.begin(), src_tags.end(),
                      std::back_inserter(one_can));
  std::set_intersection(src_tags.begin(), src_tags.end(), can_tags.begin(), can_tags.end(),
                        std::back_inserter(both));
  std::vector<Patch> tsp, tcp;
  std::string ignored;
  bool current = false;  // tsp and tcp are the layouts of src_cuts and can_cuts
  // Tags of faces that share a patch with another face, on either side.
  auto merged_tags = [&]() {
    std::set<std::int32_t> merged;
    for (int side = 0; side < 2; ++side)
      for (const Patch& q : side == 0 ? tsp : tcp) {
        const std::vector<std::int32_t>& tags = (side == 0 ? source : canonical).triangle_tags;
        const std::int32_t first = tags[static_cast<std::size_t>(q.triangles[0])];
        bool several = false;
        for (int f : q.triangles) several = several || tags[static_cast<std::size_t>(f)] != first;
        if (several)
          for (int f : q.triangles) merged.insert(tags[static_cast<std::size_t>(f)]);
      }
    return merged;
  };
  std::set<std::int32_t> merged;
  for (std::size_t candidate = 0; candidate <= both.size(); ++candidate) {
    if (!current) {
      if (!build_patches(ss, src_cuts, src_anchor, src_tol, true, tsp, ignored) ||
          !build_patches(cs, can_cuts, can_anchor, can_tol, true, tcp, ignored))
        break;  // split_patches_with_holes reports it
      merged = merged_tags();
      current = true;
    }
    std::vector<std::int32_t> group_s, group_c;
    if (candidate == 0) {
      group_s = one_src;
      group_c = one_can;
    } else if (merged.count(both[candidate - 1])) {
      group_s = group_c = {both[candidate - 1]};
    }
    if (group_s.empty() && group_c.empty()) continue;
    std::vector<char> try_src = src_cuts, try_can = can_cuts;
    const std::size_t ns = separate_faces(ss, tsp, group_s, try_src);
    const std::size_t nc = separate_faces(cs, tcp, group_c, try_can);
    if (ns + nc == 0 || !st.layouts_agree(try_src, try_can, true)) continue;
    for (std::size_t h = 0; h < try_src.size(); ++h) src_face_cuts[h] |= try_src[h] && !src_cuts[h];
    for (std::size_t h = 0; h < try_can.size(); ++h) can_face_cuts[h] |= try_can[h] && !can_cuts[h];
    src_cuts = std::move(try_src);
    can_cuts = std::move(try_can);
    current = false;
  }
}

// The keys of the patches beside the cuts that `after` adds to `before` (sorted); false where
// the layout cannot be built.
bool keys_beside(const Surface& s, const std::vector<char>& before, const std::vector<char>& after,
                 const std::vector<const double*>& anchors, double tol,
                 std::vector<std::vector<int>>& keys) {
  std::vector<Patch> patches;
  std::string ignored;
  if (!build_patches(s, after, anchors, tol, true, patches, ignored)) return false;
  const std::vector<int> of = patch_of_triangles(s, patches);
  std::set<int> beside;
  for (std::size_t h = 0; h < after.size(); ++h)
    if (after[h] && !before[h]) beside.insert(of[h / 3]);
  keys.clear();
  for (int q : beside)
    if (q >= 0) keys.push_back(patches[static_cast<std::size_t>(q)].key());
  std::sort(keys.begin(), keys.end());
  return true;
}

struct Proposal {
  std::set<Id> src_keys, can_keys;
  std::vector<std::vector<std::uint32_t>> src_traced, can_traced;
  std::vector<char> src_cuts, can_cuts;
};

// Each CAD edge of one side only, shortest first, becomes a layout path where the other side has
// a path between the same anchors that passes the checks below; otherwise its faces merge on
// both sides.
void trace_one_sided_edges(MappingState& st) {
  const auto& source = st.source;
  const auto& canonical = st.canonical;
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& src_tol = st.src_tol;
  const auto& can_tol = st.can_tol;
  const auto& src_anchor = st.src_anchor;
  const auto& can_anchor = st.can_anchor;
  const auto& corr = st.corr;
  auto& src_keys = st.src_keys;
  auto& can_keys = st.can_keys;
  auto& src_traced = st.src_traced;
  auto& can_traced = st.can_traced;
  auto& src_cuts = st.src_cuts;
  auto& can_cuts = st.can_cuts;
  auto& rejected_paths = st.rejected_paths;
  const auto& src_anchor_of = st.src_anchor_of;
  const auto& can_anchor_of = st.can_anchor_of;
  for (const OneSidedEdge& e : one_sided_edges(source, canonical, corr, src_tol, can_tol)) {
    const Surface& other = e.in_source ? cs : ss;
    const double tol = e.in_source ? can_tol : src_tol;
    const Anchor& a0 = corr.anchors[static_cast<std::size_t>(e.anchor[0])];
    const Anchor& a1 = corr.anchors[static_cast<std::size_t>(e.anchor[1])];
    const int v0 = vertex_at(other, e.in_source ? a0.canonical : a0.source, tol);
    const int v1 = vertex_at(other, e.in_source ? a1.canonical : a1.source, tol);
    if (v0 < 0 || v1 < 0) continue;
    const std::vector<char>& other_cuts = e.in_source ? can_cuts : src_cuts;
    auto propose = [&](std::vector<std::uint32_t> chain) {
      Proposal n{src_keys, can_keys, src_traced, can_traced, {}, {}};
      if (e.in_source) {
        n.src_keys.insert(e.key);
        n.can_traced.push_back(std::move(chain));
      } else {
        n.can_keys.insert(e.key);
        n.src_traced.push_back(std::move(chain));
      }
      n.src_cuts = st.cuts_of(ss, n.src_keys, n.src_traced, src_tol);
      n.can_cuts = st.cuts_of(cs, n.can_keys, n.can_traced, can_tol);
      return n;
    };
    // Kraevoy–Sheffer's cyclic-order check at both ends before the path is accepted: a path that
    // leaves an anchor between other neighbours than its counterpart does would make patches
    // that cannot be paired (or pair them twisted); such a candidate is dropped and its faces
    // merge on both sides instead.
    auto cyclic_ok = [&](const Proposal& n) {
      for (int end = 0; end < 2; ++end) {
        const Anchor& a = corr.anchors[static_cast<std::size_t>(e.anchor[end])];
        const int vs = vertex_at(ss, a.source, src_tol), vc = vertex_at(cs, a.canonical, can_tol);
        if (vs < 0 || vc < 0) continue;
        if (!cyclic_order_agrees(
                {&ss, &src_cuts, &n.src_cuts, static_cast<std::uint32_t>(vs), &src_anchor_of},
                {&cs, &can_cuts, &n.can_cuts, static_cast<std::uint32_t>(vc), &can_anchor_of}))
          return false;
      }
      return true;
    };
    // Whether the patches beside the new cut have the same keys on both sides. The shortest
    // route can pass a hole of the face on the wrong side: on the OpenCASCADE press, a ram bore
    // whose rim cuts the throat fillet's edge with the ceiling on one side only splits that
    // edge in two; the other side's edge (whole, its bore in the ceiling) is traced round the
    // bore through the ceiling, leaving the bore in the fillet's patch, and the two layouts
    // cannot be paired (the builder refused 2 of its 32 elements for it). Returns 1 where they
    // agree; 0 where they differ only in which patch holds a loop without any anchor, which no
    // later path can change (the pairing of patches would fail); -1 otherwise (another
    // one-sided edge not yet traced may still differ), or where a layout cannot be built.
    auto beside = [&](const Proposal& n) {
      std::vector<std::vector<int>> ks, kc;
      if (!keys_beside(ss, src_cuts, n.src_cuts, src_anchor, src_tol, ks) ||
          !keys_beside(cs, can_cuts, n.can_cuts, can_anchor, can_tol, kc))
        return -1;
      if (ks == kc) return 1;
      // Patch::key marks each further loop by -1 before its anchors: an anchorless one is a -1
      // followed by another or by the end.
      auto anchored = [](std::vector<std::vector<int>> keys) {
        for (std::vector<int>& k : keys) {
          std::vector<int> kept;
          for (std::size_t i = 0; i < k.size(); ++i)
            if (k[i] != -1 || (i + 1 < k.size() && k[i + 1] != -1)) kept.push_back(k[i]);
          k = std::move(kept);
        }
        std::sort(keys.begin(), keys.end());
        return keys;
      };
      return anchored(ks) == anchored(kc) ? 0 : -1;
    };
    std::vector<std::uint32_t> chain = shortest_path(
        other, other_cuts, static_cast<std::uint32_t>(v0), static_cast<std::uint32_t>(v1));
    if (chain.size() < 2) continue;
    Proposal next = propose(std::move(chain));
    bool cyclic = cyclic_ok(next);
    int fit = cyclic ? beside(next) : -1;
    if (fit < 1) {
      // Then the shortest route within each face beside the edge (on its own side), so that a
      // hole the edge passes stays on the side it is on there: the first whose patches agree.
      const std::vector<char>& own_before = e.in_source ? src_cuts : can_cuts;
      const std::vector<char>& own_after = e.in_source ? next.src_cuts : next.can_cuts;
      const mesh::Sample& own = e.in_source ? source : canonical;
      std::set<std::int32_t> faces;
      for (std::size_t h = 0; h < own_after.size(); ++h)
        if (own_after[h] && !own_before[h]) faces.insert(own.triangle_tags[h / 3]);
      const std::vector<std::int32_t>& other_tags =
          (e.in_source ? canonical : source).triangle_tags;
      for (std::int32_t tag : faces) {
        std::vector<int> in_face(other_tags.size());
        for (std::size_t f = 0; f < other_tags.size(); ++f)
          in_face[f] = other_tags[f] == tag ? 0 : 1;
        std::vector<std::uint32_t> within =
            shortest_path(other, other_cuts, static_cast<std::uint32_t>(v0),
                          static_cast<std::uint32_t>(v1), &in_face, 0);
        if (within.size() < 2) continue;
        Proposal n = propose(std::move(within));
        if (cyclic_ok(n) && beside(n) == 1) {
          next = std::move(n);
          cyclic = true;
          fit = 1;
          break;
        }
      }
    }
    // No route keeps a hole without anchor on the same side of the path on both: the faces
    // merge on both sides instead, the hole inside (measured on the OpenCASCADE press, a ram
    // bore of 30 mm whose rim leaves no vertex of the fillet between it and the plate's edge).
    if (!cyclic || fit == 0) {
      ++rejected_paths;
      continue;
    }
    src_keys = std::move(next.src_keys);
    can_keys = std::move(next.can_keys);
    src_traced = std::move(next.src_traced);
    can_traced = std::move(next.can_traced);
    src_cuts = std::move(next.src_cuts);
    can_cuts = std::move(next.can_cuts);
  }
}

// §6.2, last: "more edges are added to further subdivide large patches for better
// parametrization ... only if the shortest path length is significantly smaller than the path
// that connects these two points on the patch layout" (Kraevoy and Sheffer's criterion: a
// disk whose loop runs far round between two anchors that lie near each other across it is
// folded, and its mean-value map squeezes the part beyond the narrows). Candidates: pairs of
// anchors on one canonical patch's loop, not neighbours on it, whose shortest path inside the
// patch is under MapOptions::subdivide_ratio of the shorter way round the loop between them;
// the lowest ratio first. Each is traced on both sides in the patch that still holds both
// anchors, and kept when the two paths run alike and the layouts still agree.
bool subdivide_large_patches(MappingState& st) {
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& src_tol = st.src_tol;
  const auto& can_tol = st.can_tol;
  const auto& src_anchor = st.src_anchor;
  const auto& can_anchor = st.can_anchor;
  const auto& options = st.options;
  auto& why = st.why;
  auto& sp = st.sp;
  auto& cp = st.cp;
  auto& src_cuts = st.src_cuts;
  auto& can_cuts = st.can_cuts;
  auto& src_traced = st.src_traced;
  auto& can_traced = st.can_traced;
  const auto& src_anchor_of_all = st.src_anchor_of_all;
  const auto& can_anchor_of_all = st.can_anchor_of_all;
  auto& subdivided = st.subdivided;
  struct Candidate {
    double ratio;
    int a, b;
  };
  std::vector<Candidate> candidates;
  {
    const std::vector<int> can_of = patch_of_triangles(cs, cp);
    for (std::size_t pi = 0; pi < cp.size(); ++pi) {
      const Patch& c = cp[pi];
      const double L = c.loop_s.back();
      // Anchor occurrences at vertices the loop passes once, in loop order.
      std::vector<std::pair<int, double>> at;
      for (std::size_t k = 0; k < c.anchors.size(); ++k) {
        const int v = can_anchor_of_all[static_cast<std::size_t>(c.anchors[k])];
        if (v >= 0 && occurs_once(c.loop, static_cast<std::uint32_t>(v)) &&
            (at.empty() || at.back().first != c.anchors[k]))
          at.emplace_back(c.anchors[k], c.anchor_s[k]);
      }
      if (at.size() < 4) continue;
      std::vector<char> targets(cs.sample->vertex_count(), 0);
      for (const auto& [m, arc] : at) {
        (void)arc;
        targets[static_cast<std::size_t>(can_anchor_of_all[static_cast<std::size_t>(m)])] = 1;
      }
      for (std::size_t i = 0; i < at.size(); ++i) {
        const std::vector<double> d = path_lengths_from(
            cs, can_cuts,
            static_cast<std::uint32_t>(can_anchor_of_all[static_cast<std::size_t>(at[i].first)]),
            targets, can_of, static_cast<int>(pi));
        for (std::size_t j = i + 2; j < at.size(); ++j) {
          if (i == 0 && j + 1 == at.size()) continue;  // neighbours round the loop's end
          const double gap = std::fabs(at[j].second - at[i].second);
          const double route = std::min(gap, L - gap);
          const double D =
              d[static_cast<std::size_t>(can_anchor_of_all[static_cast<std::size_t>(at[j].first)])];
          if (route > 0 && D < options.subdivide_ratio * route)
            candidates.push_back({D / route, at[i].first, at[j].first});
        }
      }
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
    return std::tie(x.ratio, x.a, x.b) < std::tie(y.ratio, y.a, y.b);
  });
  // Each trial traces two paths and compares two layouts: the best 32 only.
  if (candidates.size() > 32) candidates.resize(32);
  std::vector<int> of[2] = {patch_of_triangles(ss, sp), patch_of_triangles(cs, cp)};
  // The patch of `patches` whose loop passes both anchor vertices once, or -1.
  auto holding = [&](const std::vector<Patch>& patches, int va, int vb) {
    for (std::size_t pi = 0; pi < patches.size(); ++pi) {
      const std::vector<std::uint32_t>& loop = patches[pi].loop;
      if (occurs_once(loop, static_cast<std::uint32_t>(va)) &&
          occurs_once(loop, static_cast<std::uint32_t>(vb)))
        return static_cast<int>(pi);
    }
    return -1;
  };
  for (const Candidate& k : candidates) {
    const int va[2] = {src_anchor_of_all[static_cast<std::size_t>(k.a)],
                       can_anchor_of_all[static_cast<std::size_t>(k.a)]};
    const int vb[2] = {src_anchor_of_all[static_cast<std::size_t>(k.b)],
                       can_anchor_of_all[static_cast<std::size_t>(k.b)]};
    const int pc = holding(cp, va[1], vb[1]);
    if (pc < 0 || va[0] < 0 || vb[0] < 0) continue;
    const int ps = holding(sp, va[0], vb[0]);
    if (ps < 0 || sp[static_cast<std::size_t>(ps)].key() != cp[static_cast<std::size_t>(pc)].key())
      continue;
    std::vector<std::uint32_t> chain[2];
    std::vector<char> try_cuts[2] = {src_cuts, can_cuts};
    for (int side = 0; side < 2; ++side) {
      const Surface& surf = side == 0 ? ss : cs;
      chain[side] =
          shortest_path(surf, try_cuts[side], static_cast<std::uint32_t>(va[side]),
                        static_cast<std::uint32_t>(vb[side]), &of[side], side == 0 ? ps : pc);
      cut_along(surf, chain[side], try_cuts[side]);
    }
    if (chain[0].size() < 2 || chain[1].size() < 2 ||
        !paths_run_alike(ss, chain[0], cs, chain[1]) || !st.layouts_agree(try_cuts[0], try_cuts[1]))
      continue;
    src_cuts = std::move(try_cuts[0]);
    can_cuts = std::move(try_cuts[1]);
    src_traced.push_back(std::move(chain[0]));
    can_traced.push_back(std::move(chain[1]));
    if (!build_patches(ss, src_cuts, src_anchor, src_tol, true, sp, why) ||
        !build_patches(cs, can_cuts, can_anchor, can_tol, true, cp, why)) {
      why = "mapping: layout after subdividing a patch: " + why;
      return false;
    }
    of[0] = patch_of_triangles(ss, sp);
    of[1] = patch_of_triangles(cs, cp);
    ++subdivided;
  }
  return true;
}

}  // namespace

std::vector<char> MappingState::cuts_of(const Surface& s, const std::set<Id>& keys,
                                        const std::vector<std::vector<std::uint32_t>>& traced,
                                        double tol) const {
  std::vector<char> cuts = layout_cuts(s, keys, tol);
  const std::vector<char>& faces = &s == &ss ? src_face_cuts : can_face_cuts;
  for (std::size_t h = 0; h < cuts.size(); ++h) cuts[h] |= faces[h];
  for (const auto& chain : traced) cut_along(s, chain, cuts);
  return cuts;
}

bool MappingState::layouts_agree(const std::vector<char>& try_src, const std::vector<char>& try_can,
                                 bool new_anchorless) const {
  std::vector<Patch> tsp, tcp;
  std::string ignored;
  if (!build_patches(ss, try_src, src_anchor, src_tol, true, tsp, ignored) ||
      !build_patches(cs, try_can, can_anchor, can_tol, true, tcp, ignored) ||
      tsp.size() != tcp.size() ||
      (!new_anchorless && (anchorless(tsp) > anchorless(sp) || anchorless(tcp) > anchorless(cp))))
    return false;
  std::vector<std::vector<int>> ks, kc;
  for (const Patch& patch : tsp) ks.push_back(patch.key());
  for (const Patch& patch : tcp) kc.push_back(patch.key());
  std::sort(ks.begin(), ks.end());
  std::sort(kc.begin(), kc.end());
  return ks == kc;
}

void MappingState::refresh_anchors() {
  src_anchor.clear();
  can_anchor.clear();
  for (const Anchor& a : corr.anchors) {
    src_anchor.push_back(a.source);
    can_anchor.push_back(a.canonical);
  }
}

int MappingState::push_anchor(std::uint32_t ps, std::uint32_t pc) {
  Anchor na;
  na.id = {-1, static_cast<std::int64_t>(corr.anchors.size())};
  for (int a = 0; a < 3; ++a) {
    na.source[a] = source.vertices[3 * std::size_t(ps) + std::size_t(a)];
    na.canonical[a] = canonical.vertices[3 * std::size_t(pc) + std::size_t(a)];
  }
  corr.anchors.push_back(na);
  refresh_anchors();
  const int m = static_cast<int>(corr.anchors.size() - 1);
  src_anchor_of[ps] = m;
  can_anchor_of[pc] = m;
  src_anchor_of_all.push_back(static_cast<int>(ps));
  can_anchor_of_all.push_back(static_cast<int>(pc));
  return m;
}

void MappingState::pop_anchor() {
  src_anchor_of[static_cast<std::size_t>(src_anchor_of_all.back())] = -1;
  can_anchor_of[static_cast<std::size_t>(can_anchor_of_all.back())] = -1;
  src_anchor_of_all.pop_back();
  can_anchor_of_all.pop_back();
  corr.anchors.pop_back();
  refresh_anchors();
}

bool MappingState::add_new_anchor(const std::vector<std::uint32_t>& chain_s,
                                  const std::vector<std::uint32_t>& chain_c) {
  push_anchor(chain_s.back(), chain_c.back());
  std::vector<char> try_src = src_cuts, try_can = can_cuts;
  cut_along(ss, chain_s, try_src);
  cut_along(cs, chain_c, try_can);
  if (!layouts_agree(try_src, try_can)) {
    pop_anchor();
    return false;
  }
  src_cuts = std::move(try_src);
  can_cuts = std::move(try_can);
  src_traced.push_back(chain_s);
  can_traced.push_back(chain_c);
  return true;
}

bool occurs_once(const std::vector<std::uint32_t>& loop, std::uint32_t v) {
  return std::count(loop.begin(), loop.end(), v) == 1;
}

// §6.2: the common layout. CAD paths of both samples first; then each CAD edge of one side only,
// shortest first, where the other side has a path between the same anchors; patches with holes
// subdivided into disks; large patches subdivided (MapOptions::subdivide_ratio); the traced paths
// measured along their geodesics; the patches paired.
bool build_layout(MappingState& st) {
  const auto& ss = st.ss;
  const auto& cs = st.cs;
  const auto& src_tol = st.src_tol;
  const auto& can_tol = st.can_tol;
  const auto& options = st.options;
  auto& why = st.why;
  const auto& corr = st.corr;
  auto& src_anchor = st.src_anchor;
  auto& can_anchor = st.can_anchor;
  auto& src_keys = st.src_keys;
  auto& can_keys = st.can_keys;
  auto& src_traced = st.src_traced;
  auto& can_traced = st.can_traced;
  auto& src_face_cuts = st.src_face_cuts;
  auto& can_face_cuts = st.can_face_cuts;
  auto& src_anchor_of = st.src_anchor_of;
  auto& can_anchor_of = st.can_anchor_of;
  auto& src_anchor_of_all = st.src_anchor_of_all;
  auto& can_anchor_of_all = st.can_anchor_of_all;
  auto& src_cuts = st.src_cuts;
  auto& can_cuts = st.can_cuts;
  auto& sp = st.sp;
  auto& cp = st.cp;
  auto& source_of = st.source_of;
  for (const Anchor& a : corr.anchors) {
    src_anchor.push_back(a.source);
    can_anchor.push_back(a.canonical);
  }
  src_keys = corr.common_edges;
  can_keys = corr.common_edges;
  src_face_cuts.assign(3 * std::size_t(ss.triangles()), 0);
  can_face_cuts.assign(3 * std::size_t(cs.triangles()), 0);
  src_anchor_of = anchor_vertices(ss, src_anchor, src_tol);
  can_anchor_of = anchor_vertices(cs, can_anchor, can_tol);
  src_cuts = st.cuts_of(ss, src_keys, src_traced, src_tol);
  can_cuts = st.cuts_of(cs, can_keys, can_traced, can_tol);
  separate_merged_faces(st);
  trace_one_sided_edges(st);
  // Surface vertices of the anchors: what a hole-splitting path may never pass through.
  for (const Anchor& a : corr.anchors) {
    src_anchor_of_all.push_back(vertex_at(ss, a.source, src_tol));
    can_anchor_of_all.push_back(vertex_at(cs, a.canonical, can_tol));
  }
  if (!split_patches_with_holes(st)) return false;
  if (options.subdivide_ratio > 0 && !subdivide_large_patches(st)) return false;
  // §6.2: the traced paths refined to their geodesics once the layout is chosen: measured
  // along them (geodesic.h).
  if (options.geodesic_paths) {
    measure_traced_paths_along_geodesics(ss, src_traced, sp);
    measure_traced_paths_along_geodesics(cs, can_traced, cp);
  }
  if (!pair_patches(sp, cp, source_of, why)) {
    why = "mapping: " + why;
    return false;
  }
  return true;
}

}  // namespace cadinterp::mapping
