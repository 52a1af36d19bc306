#include "mapping/smooth_surface.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cadinterp::mapping {

namespace {

using Vec = std::array<double, 3>;

Vec sub(const double* a, const double* b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec& a) { return std::sqrt(dot(a, a)); }

// Faces whose normals at a common vertex differ by less than this meet tangentially (a fillet
// against its neighbours, up to the meshes' normal error) or nearly so: a point of their common
// edge uses the mean normal (the cross product below would have no direction); above it the
// edge is a crease and follows its own curve. The faces' own normals are never merged: a
// shallow crease (the analytic foldplate's fold) stays sharp.
constexpr double kTangentSine = 0.1;  // about 6 degrees

// A face's triangles around a vertex deviate from their mean normal by less than this on any
// smooth face a mesher resolves (OpenCASCADE's default angular deflection is 0.5 rad between
// neighbouring triangles, half of that from the mean); a fold of a tag at a vertex (a box
// corner: 45 degrees from the mean) is no smooth face.
constexpr double kSmoothCosine = 0.82;  // about 35 degrees

}  // namespace

SmoothSurface::SmoothSurface(const mesh::Sample& s, double alpha) : s_(&s), alpha_(alpha) {
  normals_.resize(s.vertex_count());
  const std::size_t F = s.triangle_count();
  for (std::size_t f = 0; f < F; ++f) {
    const std::uint32_t* t = &s.triangles[3 * f];
    const std::int32_t tag = f < s.triangle_tags.size() ? s.triangle_tags[f] : 0;
    std::array<std::uint32_t, 3> key = {t[0], t[1], t[2]};
    std::sort(key.begin(), key.end());
    triangle_tag_.emplace(key, tag);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k], b = t[(k + 1) % 3];
      const auto e = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = edge_tags_.find(e);
      if (it == edge_tags_.end())
        edge_tags_.emplace(e, std::make_pair(tag, tag));
      else
        it->second.second = tag;
    }
    const double* x[3] = {&s.vertices[3 * std::size_t(t[0])], &s.vertices[3 * std::size_t(t[1])],
                          &s.vertices[3 * std::size_t(t[2])]};
    Vec n = cross(sub(x[1], x[0]), sub(x[2], x[0]));
    const double len = norm(n);
    if (!(len > 0)) continue;  // a degenerate triangle has no direction to contribute
    for (double& c : n) c /= len;
    // Angle weights (Thürmer & Wüthrich): the normal does not depend on how the face's
    // triangles fan around the vertex.
    for (int k = 0; k < 3; ++k) {
      const Vec u = sub(x[(k + 1) % 3], x[k]), w = sub(x[(k + 2) % 3], x[k]);
      const double nu = norm(u), nw = norm(w);
      if (!(nu > 0 && nw > 0)) continue;
      const double angle = std::acos(std::clamp(dot(u, w) / (nu * nw), -1.0, 1.0));
      auto& list = normals_[t[k]];
      auto slot =
          std::find_if(list.begin(), list.end(), [&](const auto& e) { return e.first == tag; });
      if (slot == list.end()) {
        list.emplace_back(tag, Vec{0, 0, 0});
        slot = list.end() - 1;
      }
      for (int a = 0; a < 3; ++a) slot->second[std::size_t(a)] += angle * n[std::size_t(a)];
    }
  }
  // A face tag that folds sharply at a vertex (a constructed mesh or a host that tags several
  // B-rep faces alike: measured on the voxel plate of mapping_test_util.h, one tag per hole wall
  // round its corners) has no tangent plane there: its normal is dropped, and points of its
  // triangles at that vertex stay on the flat triangles.
  std::vector<std::vector<std::pair<std::int32_t, Vec>>> unit_of(normals_);
  for (auto& list : unit_of)
    for (auto& e : list) {
      const double len = norm(e.second);
      if (len > 0)
        for (double& c : e.second) c /= len;
    }
  for (std::size_t f = 0; f < F; ++f) {
    const std::uint32_t* t = &s.triangles[3 * f];
    const std::int32_t tag = f < s.triangle_tags.size() ? s.triangle_tags[f] : 0;
    const double* x[3] = {&s.vertices[3 * std::size_t(t[0])], &s.vertices[3 * std::size_t(t[1])],
                          &s.vertices[3 * std::size_t(t[2])]};
    Vec n = cross(sub(x[1], x[0]), sub(x[2], x[0]));
    const double len = norm(n);
    if (!(len > 0)) continue;
    for (double& c : n) c /= len;
    for (int k = 0; k < 3; ++k) {
      auto& list = unit_of[t[k]];
      for (std::size_t i = 0; i < list.size(); ++i)
        if (list[i].first == tag && dot(list[i].second, n) < kSmoothCosine)
          normals_[t[k]][i].second = Vec{0, 0, 0};
    }
  }
  for (auto& list : normals_)
    for (auto& e : list) {
      const double len = norm(e.second);
      if (len > 0)
        for (double& c : e.second) c /= len;
    }
}

const SmoothSurface::Vec* SmoothSurface::normal(std::uint32_t v, std::int32_t tag) const {
  for (const auto& [t, n] : normals_[v])
    if (t == tag) return norm(n) > 0 ? &n : nullptr;
  return nullptr;
}

void SmoothSurface::position(const SurfacePoint& p, double* x) const {
  // The distinct vertices with weight, and the flat combination.
  std::uint32_t v[3];
  double w[3];
  int m = 0;
  for (int k = 0; k < 3; ++k) {
    if (!(p.w[k] != 0)) continue;
    int j = 0;
    while (j < m && v[j] != p.v[k]) ++j;
    if (j == m) {
      v[m] = p.v[k];
      w[m++] = 0;
    }
    w[j] += p.w[k];
  }
  Vec flat = {0, 0, 0};
  for (int k = 0; k < 3; ++k)
    for (int a = 0; a < 3; ++a)
      flat[std::size_t(a)] += p.w[k] * s_->vertices[3 * std::size_t(p.v[k]) + std::size_t(a)];
  for (int a = 0; a < 3; ++a) x[a] = flat[std::size_t(a)];
  if (m < 2 || alpha_ == 0) return;  // a vertex is where it is
  auto pos = [&](std::uint32_t u) { return &s_->vertices[3 * std::size_t(u)]; };
  // Phong: the mean of the flat point's projections onto the vertices' tangent planes (or,
  // on a crease, tangent lines), blended with the flat point by alpha.
  Vec phong = {0, 0, 0};
  if (m == 3) {
    std::array<std::uint32_t, 3> key = {v[0], v[1], v[2]};
    std::sort(key.begin(), key.end());
    const auto it = triangle_tag_.find(key);
    if (it == triangle_tag_.end()) return;
    for (int k = 0; k < 3; ++k) {
      const Vec* n = normal(v[k], it->second);
      if (!n) return;
      const Vec d = sub(flat.data(), pos(v[k]));
      const double h = dot(d, *n);
      for (std::size_t a = 0; a < 3; ++a) phong[a] += w[k] * (flat[a] - h * (*n)[a]);
    }
  } else {
    const auto it = edge_tags_.find(std::make_pair(std::min(v[0], v[1]), std::max(v[0], v[1])));
    if (it == edge_tags_.end()) return;
    const auto [ta, tb] = it->second;
    for (int k = 0; k < 2; ++k) {
      const Vec* na = normal(v[k], ta);
      const Vec* nb = normal(v[k], tb);
      if (!na || !nb) return;
      const Vec d = sub(flat.data(), pos(v[k]));
      const Vec t = cross(*na, *nb);
      const double sine = norm(t);
      if (sine < kTangentSine) {
        // One face, or tangent faces: the tangent plane of the mean normal.
        Vec n = {(*na)[0] + (*nb)[0], (*na)[1] + (*nb)[1], (*na)[2] + (*nb)[2]};
        const double len = norm(n);
        if (!(len > 0)) return;
        for (double& c : n) c /= len;
        const double h = dot(d, n);
        for (std::size_t a = 0; a < 3; ++a) phong[a] += w[k] * (flat[a] - h * n[a]);
      } else {
        // A crease: the tangent line of the edge curve (in both faces' tangent planes).
        const double s = dot(d, t) / (sine * sine);
        for (std::size_t a = 0; a < 3; ++a) phong[a] += w[k] * (pos(v[k])[a] + s * t[a]);
      }
    }
  }
  for (std::size_t a = 0; a < 3; ++a) x[a] = (1 - alpha_) * flat[a] + alpha_ * phong[a];
}

}  // namespace cadinterp::mapping
