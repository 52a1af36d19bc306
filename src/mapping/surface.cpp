#include "mapping/surface.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace cadinterp::mapping {

bool build_surface(const mesh::Sample& s, Surface& out, std::string& why) {
  out.sample = &s;
  const int H = static_cast<int>(3 * s.triangle_count());
  out.twin.assign(static_cast<std::size_t>(H), -1);
  // Outgoing half-edges per vertex (counting sort by start vertex, in half-edge order).
  const std::size_t V = s.vertex_count();
  out.out_start.assign(V + 1, 0);
  for (int h = 0; h < H; ++h) ++out.out_start[out.from(h) + 1];
  for (std::size_t v = 0; v < V; ++v) out.out_start[v + 1] += out.out_start[v];
  out.out_edges.assign(static_cast<std::size_t>(H), 0);
  std::vector<int> fill(out.out_start.begin(), out.out_start.end() - 1);
  for (int h = 0; h < H; ++h) out.out_edges[static_cast<std::size_t>(fill[out.from(h)]++)] = h;
  out.by_x.clear();
  for (std::size_t v = 0; v < V; ++v)
    if (out.out_start[v + 1] > out.out_start[v]) out.by_x.push_back(static_cast<std::uint32_t>(v));
  std::sort(out.by_x.begin(), out.by_x.end(), [&s](std::uint32_t a, std::uint32_t b) {
    const double xa = s.vertices[3 * std::size_t(a)], xb = s.vertices[3 * std::size_t(b)];
    return xa < xb || (xa == xb && a < b);
  });
  // An oriented manifold has each directed edge at most once.
  for (int h = 0; h < H; ++h) {
    if (out.half_edge(out.from(h), out.to(h)) != h) {
      why = "boundary surface is not an oriented manifold (edge " + std::to_string(out.from(h)) +
            "-" + std::to_string(out.to(h)) + " used twice in one direction)";
      return false;
    }
    out.twin[static_cast<std::size_t>(h)] = out.half_edge(out.to(h), out.from(h));
  }
  return true;
}

double distance(const double* a, const double* b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}

}  // namespace cadinterp::mapping
