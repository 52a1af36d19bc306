#include "mapping/patch_layout.h"

#include <algorithm>
#include <iterator>
#include <cmath>
#include <map>
#include <numeric>
#include <unordered_map>

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

double distance(const double* a, const double* b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
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
  return k;
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
  std::vector<std::pair<double, int>> found;
  for (std::size_t m = 0; m < anchor_positions.size(); ++m) {
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
  // Start the cyclic order at the smallest anchor index, so both sides agree.
  const auto first =
      std::min_element(found.begin(), found.end(),
                       [](const auto& a, const auto& b) { return a.second < b.second; }) -
      found.begin();
  std::rotate(found.begin(), found.begin() + first, found.end());
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
  // Patches numbered by their first triangle: deterministic.
  std::vector<int> patch_of(static_cast<std::size_t>(F));
  std::map<int, int> number;
  out.clear();
  for (int f = 0; f < F; ++f) {
    const int r = find_root(parent, f);
    auto it = number.find(r);
    if (it == number.end()) {
      it = number.emplace(r, static_cast<int>(out.size())).first;
      out.emplace_back();
    }
    patch_of[static_cast<std::size_t>(f)] = it->second;
    out[static_cast<std::size_t>(it->second)].triangles.push_back(f);
  }

  for (std::size_t pi = 0; pi < out.size(); ++pi) {
    Patch& p = out[pi];
    // Boundary half-edges: those whose twin lies in another patch (or nowhere).
    std::map<std::uint32_t, int> outgoing;  // ordered: loops are traced deterministically
    std::vector<std::uint32_t> verts;
    int border = 0;
    bool pinched = false;
    for (int f : p.triangles)
      for (int k = 0; k < 3; ++k) {
        const int h = 3 * f + k;
        verts.push_back(s.from(h));
        const int t = s.twin[static_cast<std::size_t>(h)];
        if (t >= 0 && patch_of[static_cast<std::size_t>(t / 3)] == static_cast<int>(pi)) continue;
        ++border;
        if (!outgoing.emplace(s.from(h), h).second) pinched = true;
      }
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    if (border == 0 || pinched) {
      why = describe(p, s) + " is not a disk (" +
            (pinched ? "pinched boundary" : "a closed surface without boundary") + ")";
      return false;
    }
    // Trace every loop, each from its smallest vertex.
    std::vector<Loop> loops;
    std::map<std::uint32_t, char> visited;
    for (const auto& [start, h0] : outgoing) {
      (void)h0;
      if (visited.count(start)) continue;
      Loop l;
      std::uint32_t v = start;
      do {
        l.vertices.push_back(v);
        visited.emplace(v, 1);
        auto it = outgoing.find(v);
        if (it == outgoing.end() || l.vertices.size() > outgoing.size()) {
          why = describe(p, s) + " has a broken boundary loop";
          return false;
        }
        v = s.to(it->second);
      } while (v != start);
      if (!measure_loop(s, anchor_positions, tolerance, l)) {
        why = describe(p, s) + " has a boundary loop without matched control point";
        return false;
      }
      loops.push_back(std::move(l));
    }
    const long T = static_cast<long>(p.triangles.size());
    const long euler = static_cast<long>(verts.size()) - (3 * T + border) / 2 + T;
    const long disk_with_holes = 2 - static_cast<long>(loops.size());
    if (euler != disk_with_holes || (loops.size() > 1 && !allow_holes)) {
      why = describe(p, s) + " is not a disk (Euler characteristic " + std::to_string(euler) +
            ", " + std::to_string(loops.size()) + " boundary loops)" +
            (euler != disk_with_holes ? "; patches with handles are not supported" : "");
      return false;
    }
    std::sort(loops.begin(), loops.end(),
              [](const Loop& a, const Loop& b) { return a.anchors[0] < b.anchors[0]; });
    p.loop = std::move(loops[0].vertices);
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
        why += " (nearest: source patch " + std::to_string(best) + ", " +
               std::to_string(source[best].anchors.size()) + " anchors, " +
               std::to_string(best_common) + " in common; " + std::to_string(only_c.size()) +
               " only in the canonical's, " + std::to_string(only_s.size()) +
               " only in the source's" +
               (only_c.empty() && only_s.empty() ? ": the same anchors in another order" : "") +
               ")";
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
