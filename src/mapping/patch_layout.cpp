#include "mapping/patch_layout.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>

namespace cadinterp::mapping {

namespace {

int find_root(std::vector<int>& parent, int x) {
  while (parent[static_cast<std::size_t>(x)] != x) {
    parent[static_cast<std::size_t>(x)] =
        parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
    x = parent[static_cast<std::size_t>(x)];
  }
  return x;
}

std::string describe(const Patch& p, const Surface& s) {
  return "patch of " + std::to_string(p.triangles.size()) + " triangles (face tag " +
         std::to_string(s.sample->triangle_tags[static_cast<std::size_t>(p.triangles[0])]) + ")";
}

}  // namespace

std::vector<int> Patch::key() const {
  std::vector<int> k = anchors;
  for (const Loop& l : holes) {
    k.push_back(-1);
    k.insert(k.end(), l.anchors.begin(), l.anchors.end());
  }
  if (genus > 0) {
    k.push_back(-2);
    k.push_back(genus);
  }
  return k;
}

std::size_t separate_faces(const Surface& s, const std::vector<Patch>& patches,
                           const std::vector<std::int32_t>& group, std::vector<char>& cuts) {
  const std::vector<std::int32_t>& tags = s.sample->triangle_tags;
  auto in_group = [&](int f) {
    return std::binary_search(group.begin(), group.end(), tags[static_cast<std::size_t>(f)]);
  };
  std::size_t cut = 0;
  for (const Patch& p : patches) {
    const std::int32_t first = tags[static_cast<std::size_t>(p.triangles[0])];
    if (std::all_of(p.triangles.begin(), p.triangles.end(),
                    [&](int f) { return tags[static_cast<std::size_t>(f)] == first; }))
      continue;
    for (int f : p.triangles)
      for (int k = 0; k < 3; ++k) {
        const int h = 3 * f + k, t = s.twin[static_cast<std::size_t>(h)];
        if (t < 0 || cuts[static_cast<std::size_t>(h)] || in_group(f) == in_group(t / 3)) continue;
        cuts[static_cast<std::size_t>(h)] = cuts[static_cast<std::size_t>(t)] = 1;
        ++cut;
      }
  }
  return cut;
}

std::vector<int> patch_of_triangles(const Surface& s, const std::vector<Patch>& patches) {
  std::vector<int> of(static_cast<std::size_t>(s.triangles()), -1);
  for (std::size_t p = 0; p < patches.size(); ++p)
    for (int f : patches[p].triangles) of[static_cast<std::size_t>(f)] = static_cast<int>(p);
  return of;
}

namespace {

// Arc lengths and anchors of a traced loop; false when it has no anchor.
bool measure_loop(const Surface& s, const std::vector<const double*>& anchor_positions,
                  double tolerance, Loop& l) {
  const std::size_t n = l.vertices.size();
  l.s.assign(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    l.s[i + 1] = l.s[i] + distance(s.position(l.vertices[i]), s.position(l.vertices[(i + 1) % n]));
  // An anchor at a loop vertex is found at every visit of that vertex (a seam's vertices are
  // visited twice, once per side); one between vertices (rounding) at its nearest segment.
  // The loop's box, widened by the tolerance: an anchor outside it is neither at a loop vertex
  // nor within the tolerance of a segment, so it is skipped without a scan of the loop.
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::numeric_limits<double>::infinity();
    hi[k] = -std::numeric_limits<double>::infinity();
  }
  for (std::uint32_t v : l.vertices)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], s.position(v)[k]);
      hi[k] = std::max(hi[k], s.position(v)[k]);
    }
  const double reach = 2 * tolerance;
  auto outside = [&](const double* p) {
    for (int k = 0; k < 3; ++k) {
      const double r = reach + 1e-12 * std::fabs(p[k]);
      if (p[k] < lo[k] - r || p[k] > hi[k] + r) return true;
    }
    return false;
  };
  std::vector<std::pair<double, int>> found;
  for (std::size_t m = 0; m < anchor_positions.size(); ++m) {
    if (outside(anchor_positions[m])) continue;
    bool at_vertex = false;
    for (std::size_t i = 0; i < n; ++i)
      if (distance(anchor_positions[m], s.position(l.vertices[i])) <= tolerance) {
        found.emplace_back(l.s[i], static_cast<int>(m));
        at_vertex = true;
      }
    if (at_vertex) continue;
    double best = tolerance, best_s = 0;
    bool on = false;
    for (std::size_t i = 0; i < n; ++i) {
      double t;
      const double d = point_segment_distance(anchor_positions[m], s.position(l.vertices[i]),
                                              s.position(l.vertices[(i + 1) % n]), t);
      if (d <= best) {
        best = d;
        best_s = l.s[i] + t * (l.s[i + 1] - l.s[i]);
        on = true;
      }
    }
    if (on) found.emplace_back(std::fmod(best_s, l.s[n]), static_cast<int>(m));
  }
  if (found.empty()) return false;
  std::sort(found.begin(), found.end());
  // Start the cyclic order at its lexicographically smallest rotation (the smallest anchor
  // index first; ties, when a seam anchor occurs twice, broken by what follows), so both sides
  // agree.
  const std::size_t M = found.size();
  std::size_t first = 0;
  for (std::size_t r = 1; r < M; ++r)
    for (std::size_t j = 0; j < M; ++j) {
      const int a = found[(r + j) % M].second, b = found[(first + j) % M].second;
      if (a != b) {
        if (a < b) first = r;
        break;
      }
    }
  std::rotate(found.begin(), found.begin() + static_cast<long>(first), found.end());
  for (const auto& [arc, m] : found) {
    l.anchors.push_back(m);
    l.anchor_s.push_back(arc);
  }
  return true;
}

}  // namespace

bool build_patches(const Surface& s, const std::vector<char>& cuts,
                   const std::vector<const double*>& anchor_positions, double tolerance,
                   bool allow_holes, std::vector<Patch>& out, std::string& why) {
  const int F = s.triangles();
  std::vector<int> parent(static_cast<std::size_t>(F));
  std::iota(parent.begin(), parent.end(), 0);
  for (int h = 0; h < 3 * F; ++h) {
    const int t = s.twin[static_cast<std::size_t>(h)];
    if (t < 0 || cuts[static_cast<std::size_t>(h)]) continue;
    const int a = find_root(parent, h / 3), b = find_root(parent, t / 3);
    if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
  }
  // Patches numbered by their first triangle: deterministic. `slot`: each triangle's place in
  // its patch's (increasing) list, so that half-edge 3 f + k is the patch's corner 3 slot + k.
  // (Vectors, not maps: a mapping builds the layouts a few hundred times.)
  std::vector<int> patch_of(static_cast<std::size_t>(F)), number(static_cast<std::size_t>(F), -1),
      slot(static_cast<std::size_t>(F));
  out.clear();
  for (int f = 0; f < F; ++f) {
    int& n = number[static_cast<std::size_t>(find_root(parent, f))];
    if (n < 0) {
      n = static_cast<int>(out.size());
      out.emplace_back();
    }
    patch_of[static_cast<std::size_t>(f)] = n;
    std::vector<int>& list = out[static_cast<std::size_t>(n)].triangles;
    slot[static_cast<std::size_t>(f)] = static_cast<int>(list.size());
    list.push_back(f);
  }

  for (std::size_t pi = 0; pi < out.size(); ++pi) {
    Patch& p = out[pi];
    // Boundary half-edges: those whose twin lies in another patch (or nowhere), and cut ones
    // whose twin lies in this patch (a seam: the patch is cut open along it, §6.2 requires
    // disks). Triangle corners are the local vertices, merged across the patch's inner
    // (uncut) edges: across half-edge h (a -> b) with twin t (b -> a), h's corner at a is
    // next(t)'s, and next(h)'s corner at b is t's.
    auto in_patch = [&](int h) {
      const int t = s.twin[static_cast<std::size_t>(h)];
      return t >= 0 && patch_of[static_cast<std::size_t>(t / 3)] == static_cast<int>(pi);
    };
    auto next = [](int h) { return 3 * (h / 3) + (h % 3 + 1) % 3; };
    // A half-edge of the patch -> its index among the patch's corners.
    auto corner = [&](int h) { return 3 * slot[static_cast<std::size_t>(h / 3)] + h % 3; };
    const std::size_t corners = 3 * p.triangles.size();
    std::vector<int> cparent(corners);
    std::iota(cparent.begin(), cparent.end(), 0);
    auto unite = [&](int h1, int h2) {
      const int a = find_root(cparent, corner(h1)), b = find_root(cparent, corner(h2));
      if (a != b) cparent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
    };
    for (int f : p.triangles)
      for (int k = 0; k < 3; ++k) {
        const int h = 3 * f + k;
        if (!in_patch(h) || cuts[static_cast<std::size_t>(h)]) continue;
        const int t = s.twin[static_cast<std::size_t>(h)];
        unite(h, next(t));
        unite(next(h), t);
      }
    // Local vertices numbered by first corner, in the patch's triangle order: deterministic.
    std::vector<int> local_of_root(corners, -1);
    p.corner_local.assign(corners, -1);
    p.local_vertices.clear();
    for (std::size_t ci = 0; ci < corners; ++ci) {
      int& local =
          local_of_root[static_cast<std::size_t>(find_root(cparent, static_cast<int>(ci)))];
      if (local < 0) {
        local = static_cast<int>(p.local_vertices.size());
        p.local_vertices.push_back(s.from(3 * p.triangles[ci / 3] + static_cast<int>(ci % 3)));
      }
      p.corner_local[ci] = local;
    }
    auto local_of = [&](int h) { return p.corner_local[static_cast<std::size_t>(corner(h))]; };
    const std::size_t local_count = p.local_vertices.size();
    // Local vertex -> its boundary half-edge (-1: none); loops are traced from the smallest.
    std::vector<int> outgoing(local_count, -1);
    int border = 0;
    bool pinched = false;
    for (int f : p.triangles)
      for (int k = 0; k < 3; ++k) {
        const int h = 3 * f + k;
        if (in_patch(h) && !cuts[static_cast<std::size_t>(h)]) continue;
        ++border;
        int& out_h = outgoing[static_cast<std::size_t>(local_of(h))];
        if (out_h >= 0)
          pinched = true;
        else
          out_h = h;
      }
    if (border == 0 || pinched) {
      why = describe(p, s) + " is not a disk (" +
            (pinched ? "pinched boundary" : "a closed surface without boundary") + ")";
      return false;
    }
    // Trace every loop, each from its smallest vertex.
    std::vector<Loop> loops;
    std::vector<char> visited(local_count, 0);
    for (int start = 0; start < static_cast<int>(local_count); ++start) {
      if (outgoing[static_cast<std::size_t>(start)] < 0 || visited[static_cast<std::size_t>(start)])
        continue;
      Loop l;
      int v = start;
      do {
        visited[static_cast<std::size_t>(v)] = 1;
        const int h = outgoing[static_cast<std::size_t>(v)];
        if (h < 0 || l.vertices.size() > static_cast<std::size_t>(border)) {
          why = describe(p, s) + " has a broken boundary loop";
          return false;
        }
        l.vertices.push_back(s.from(h));
        l.local.push_back(v);
        v = local_of(next(h));
      } while (v != start);
      if (!measure_loop(s, anchor_positions, tolerance, l) && !allow_holes) {
        why = describe(p, s) + " has a boundary loop without matched control point";
        return false;
      }
      loops.push_back(std::move(l));
    }
    const long T = static_cast<long>(p.triangles.size());
    const long euler = static_cast<long>(local_count) - (3 * T + border) / 2 + T;
    const long disk_with_holes = 2 - static_cast<long>(loops.size());
    if (!allow_holes && (euler != disk_with_holes || loops.size() > 1)) {
      why = describe(p, s) + " is not a disk (Euler characteristic " + std::to_string(euler) +
            ", " + std::to_string(loops.size()) + " boundary loops)" +
            (euler != disk_with_holes ? "; patches with handles are not supported" : "");
      return false;
    }
    // Euler characteristic 2 - 2 genus - loops (an orientable surface: the boundary is).
    p.genus = static_cast<int>((disk_with_holes - euler) / 2);
    // Loops with anchors first, by their smallest; loops without, by their smallest local
    // vertex (their traced start): deterministic, not comparable across the samples.
    std::sort(loops.begin(), loops.end(), [](const Loop& a, const Loop& b) {
      if (a.anchors.empty() != b.anchors.empty()) return b.anchors.empty();
      return a.anchors.empty() ? a.local[0] < b.local[0] : a.anchors[0] < b.anchors[0];
    });
    p.loop = std::move(loops[0].vertices);
    p.loop_local = std::move(loops[0].local);
    p.loop_s = std::move(loops[0].s);
    p.anchors = std::move(loops[0].anchors);
    p.anchor_s = std::move(loops[0].anchor_s);
    p.holes.assign(std::make_move_iterator(loops.begin() + 1),
                   std::make_move_iterator(loops.end()));
  }
  return true;
}

bool pair_patches(const std::vector<Patch>& source, const std::vector<Patch>& canonical,
                  std::vector<int>& source_of, std::string& why) {
  std::map<std::vector<int>, int> by_anchors;
  for (std::size_t i = 0; i < source.size(); ++i)
    if (!by_anchors.emplace(source[i].key(), static_cast<int>(i)).second) {
      why = "two source patches have the same matched control points";
      return false;
    }
  source_of.assign(canonical.size(), -1);
  for (std::size_t i = 0; i < canonical.size(); ++i) {
    auto it = by_anchors.find(canonical[i].key());
    if (it == by_anchors.end()) {
      // Name the nearest source patch (most anchors in common) and how the two differ: what
      // a host's ID problem or a layout difference looks like.
      std::vector<int> mine = canonical[i].key();
      std::sort(mine.begin(), mine.end());
      std::size_t best = 0, best_common = 0;
      std::vector<int> only_c, only_s;
      for (std::size_t j = 0; j < source.size(); ++j) {
        std::vector<int> theirs = source[j].key(), common;
        std::sort(theirs.begin(), theirs.end());
        std::set_intersection(mine.begin(), mine.end(), theirs.begin(), theirs.end(),
                              std::back_inserter(common));
        if (common.size() > best_common || j == 0) {
          best = j;
          best_common = common.size();
          only_c.clear();
          only_s.clear();
          std::set_difference(mine.begin(), mine.end(), theirs.begin(), theirs.end(),
                              std::back_inserter(only_c));
          std::set_difference(theirs.begin(), theirs.end(), mine.begin(), mine.end(),
                              std::back_inserter(only_s));
        }
      }
      why = "canonical patch " + std::to_string(i) + " (" +
            std::to_string(canonical[i].triangles.size()) + " triangles, " +
            std::to_string(canonical[i].anchors.size()) +
            " anchors) has no source patch with the same matched control points in the same "
            "cyclic order";
      if (!source.empty())
        why +=
            " (nearest: source patch " + std::to_string(best) + ", " +
            std::to_string(source[best].anchors.size()) + " anchors, " +
            std::to_string(best_common) + " in common; " + std::to_string(only_c.size()) +
            " only in the canonical's, " + std::to_string(only_s.size()) + " only in the source's" +
            (only_c.empty() && only_s.empty() ? ": the same anchors in another order" : "") + ")";
      return false;
    }
    source_of[i] = it->second;
  }
  if (source.size() != canonical.size()) {
    why = "the layouts have " + std::to_string(source.size()) + " and " +
          std::to_string(canonical.size()) + " patches";
    return false;
  }
  return true;
}

}  // namespace cadinterp::mapping
