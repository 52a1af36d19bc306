#include "mapping/path_release.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mapping/mean_value_param.h"
#include "mesh/surface_distance.h"

namespace cadinterp::mapping {

void release_traced_paths(const mesh::Sample& source, const Surface& ss,
                          const mesh::Sample& canonical, const std::vector<std::uint32_t>& movable,
                          int sweeps, std::vector<SurfacePoint>& where,
                          const std::function<void(const SurfacePoint&, double*)>& place,
                          std::vector<double>& x) {
  if (movable.empty() || sweeps <= 0) return;
  // Source: the triangles around each vertex.
  std::vector<std::vector<int>> around(source.vertex_count());
  for (int t = 0; t < ss.triangles(); ++t)
    for (int k = 0; k < 3; ++k) around[ss.from(3 * t + k)].push_back(t);
  // Canonical: mean-value weights of each movable vertex's surface neighbours.
  std::vector<int> slot(canonical.vertex_count(), -1);
  for (std::size_t i = 0; i < movable.size(); ++i) slot[movable[i]] = static_cast<int>(i);
  std::vector<std::vector<std::pair<std::uint32_t, double>>> nbr(movable.size());
  for (std::size_t f = 0; f < canonical.triangle_count(); ++f)
    for (std::size_t c = 0; c < 3; ++c) {
      const std::uint32_t i = canonical.triangles[3 * f + c];
      if (slot[i] < 0) continue;
      const std::uint32_t j = canonical.triangles[3 * f + (c + 1) % 3],
                          k = canonical.triangles[3 * f + (c + 2) % 3];
      const double* xi = &canonical.vertices[3 * std::size_t(i)];
      const double* xj = &canonical.vertices[3 * std::size_t(j)];
      const double* xk = &canonical.vertices[3 * std::size_t(k)];
      double wj, wk;
      if (!mean_value_corner_weights(xi, xj, xk, wj, wk)) continue;
      nbr[std::size_t(slot[i])].emplace_back(j, wj);
      nbr[std::size_t(slot[i])].emplace_back(k, wk);
    }
  std::vector<SurfacePoint> next(movable.size());
  std::vector<int> seen(source.triangle_count(), -1);
  int stamp = 0;
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    for (std::size_t i = 0; i < movable.size(); ++i) {
      const std::uint32_t v = movable[i];
      next[i] = where[v];
      double target[3] = {0, 0, 0}, wsum = 0;
      for (const auto& [j, w] : nbr[i]) {
        for (int a = 0; a < 3; ++a) target[a] += w * x[3 * std::size_t(j) + std::size_t(a)];
        wsum += w;
      }
      if (!(wsum > 0)) continue;
      constexpr double kDamping = 0.8;
      double goal[3];
      for (int a = 0; a < 3; ++a)
        goal[a] =
            x[3 * v + std::size_t(a)] + kDamping * (target[a] / wsum - x[3 * v + std::size_t(a)]);
      // The source triangles within 3 rings of the vertex's current triangle(s), in its face.
      const SurfacePoint& at = where[v];
      std::vector<int> front;
      ++stamp;
      for (int t : around[at.v[0]]) {
        bool has_all = true;
        for (int k = 0; k < 3; ++k) {
          if (at.w[k] <= 0) continue;
          const std::uint32_t* tv = &source.triangles[3 * std::size_t(t)];
          has_all = has_all && (tv[0] == at.v[k] || tv[1] == at.v[k] || tv[2] == at.v[k]);
        }
        if (has_all) front.push_back(t);
      }
      if (front.empty()) continue;
      const std::int32_t tag = source.triangle_tags[std::size_t(front[0])];
      std::vector<int> region;
      for (int t : front) seen[std::size_t(t)] = stamp;
      for (int ring = 0; ring <= 3 && !front.empty(); ++ring) {
        region.insert(region.end(), front.begin(), front.end());
        std::vector<int> grown;
        for (int t : front)
          for (int k = 0; k < 3; ++k) {
            const int o = ss.twin[std::size_t(3 * t + k)];
            if (o < 0) continue;
            const int u = o / 3;
            if (seen[std::size_t(u)] == stamp || source.triangle_tags[std::size_t(u)] != tag)
              continue;
            seen[std::size_t(u)] = stamp;
            grown.push_back(u);
          }
        front.swap(grown);
      }
      double best = std::numeric_limits<double>::infinity();
      for (int t : region) {
        const std::uint32_t* tv = &source.triangles[3 * std::size_t(t)];
        double w[3], p[3] = {0, 0, 0};
        mesh::closest_point_weights(goal, ss.position(tv[0]), ss.position(tv[1]),
                                    ss.position(tv[2]), w);
        for (int k = 0; k < 3; ++k)
          for (int a = 0; a < 3; ++a) p[a] += w[k] * ss.position(tv[k])[a];
        const double d = std::hypot(p[0] - goal[0], p[1] - goal[1], p[2] - goal[2]);
        if (d < best) {
          best = d;
          for (int k = 0; k < 3; ++k) {
            next[i].v[k] = tv[k];
            next[i].w[k] = w[k];
          }
        }
      }
    }
    for (std::size_t i = 0; i < movable.size(); ++i) {
      where[movable[i]] = next[i];
      place(next[i], &x[3 * std::size_t(movable[i])]);
    }
  }
}

}  // namespace cadinterp::mapping
