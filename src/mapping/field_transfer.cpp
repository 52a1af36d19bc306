#include "mapping/field_transfer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>

namespace cadinterp::mapping {

namespace {

// The named regions each tag lies in (sorted names), for the tags of `s`'s regions.
std::map<std::int32_t, std::vector<std::string>> regions_of_tags(const mesh::Sample& s) {
  std::map<std::int32_t, std::vector<std::string>> in;
  for (const mesh::Region& r : s.regions)
    for (std::int32_t t : r.face_tags) in[t].push_back(r.name);
  for (auto& [t, names] : in) {
    std::sort(names.begin(), names.end());
    names.erase(std::unique(names.begin(), names.end()), names.end());
  }
  return in;
}

}  // namespace

bool mesh_for_simulation(const mesh::Sample& source, const mesh::Sample& canonical,
                         const std::vector<double>& positions, mesh::Sample& out,
                         std::string& why) {
  const auto in_source = regions_of_tags(source);
  const auto in_canonical = regions_of_tags(canonical);
  // A tag in no source region, for canonical faces in none whose own tag the source uses in one.
  std::int32_t unused = 0;
  for (std::int32_t t : source.triangle_tags) unused = std::max(unused, t);
  for (const auto& [t, names] : in_source) unused = std::max(unused, t);
  ++unused;
  static const std::vector<std::string> none;
  auto regions = [](const std::map<std::int32_t, std::vector<std::string>>& in,
                    std::int32_t t) -> const std::vector<std::string>& {
    const auto it = in.find(t);
    return it == in.end() ? none : it->second;
  };
  std::map<std::int32_t, std::int32_t> tag_of;
  for (std::int32_t t : canonical.triangle_tags) {
    if (tag_of.count(t)) continue;
    const std::vector<std::string>& want = regions(in_canonical, t);
    if (regions(in_source, t) == want) {
      tag_of[t] = t;
      continue;
    }
    if (want.empty()) {
      tag_of[t] = unused;
      continue;
    }
    const auto it = std::find_if(in_source.begin(), in_source.end(),
                                 [&](const auto& tn) { return tn.second == want; });
    if (it == in_source.end()) {
      why = "no face of the source lies in exactly the regions of canonical face tag " +
            std::to_string(t) + " (";
      for (std::size_t i = 0; i < want.size(); ++i) why += (i ? ", " : "") + want[i];
      why += ")";
      return false;
    }
    tag_of[t] = it->first;
  }
  out = mesh::Sample{};
  out.vertices = positions;
  out.tets = canonical.tets;
  out.triangles = canonical.triangles;
  out.triangle_tags.reserve(canonical.triangle_tags.size());
  for (std::int32_t t : canonical.triangle_tags) out.triangle_tags.push_back(tag_of[t]);
  return true;
}

TetLocator::TetLocator(const mesh::Sample& s) : s_(s) {
  const std::size_t V = s.vertex_count(), T = s.tet_count();
  if (T == 0) return;
  double hi[3] = {-1e300, -1e300, -1e300};
  for (int a = 0; a < 3; ++a) lo_[a] = 1e300;
  for (std::size_t v = 0; v < V; ++v)
    for (int a = 0; a < 3; ++a) {
      lo_[a] = std::min(lo_[a], s.vertices[3 * v + std::size_t(a)]);
      hi[a] = std::max(hi[a], s.vertices[3 * v + std::size_t(a)]);
    }
  // About one tet per cell.
  const double ext = std::max({hi[0] - lo_[0], hi[1] - lo_[1], hi[2] - lo_[2], 1e-300});
  double vol = 1;
  for (int a = 0; a < 3; ++a) vol *= std::max(hi[a] - lo_[a], ext * 1e-3);
  cell_ = std::cbrt(vol / static_cast<double>(T));
  for (int a = 0; a < 3; ++a)
    n_[a] = std::clamp(static_cast<int>((hi[a] - lo_[a]) / cell_) + 1, 1, 512);
  std::vector<std::uint32_t> count(
      static_cast<std::size_t>(n_[0]) * std::size_t(n_[1]) * std::size_t(n_[2]) + 1, 0);
  auto each_cell = [&](std::size_t t, auto&& fn) {
    int c0[3], c1[3];
    for (int a = 0; a < 3; ++a) {
      double l = 1e300, h = -1e300;
      for (int i = 0; i < 4; ++i) {
        const double x =
            s.vertices[3 * std::size_t(s.tets[4 * t + std::size_t(i)]) + std::size_t(a)];
        l = std::min(l, x);
        h = std::max(h, x);
      }
      c0[a] = cell_of(l, a);
      c1[a] = cell_of(h, a);
    }
    for (int k = c0[2]; k <= c1[2]; ++k)
      for (int j = c0[1]; j <= c1[1]; ++j)
        for (int i = c0[0]; i <= c1[0]; ++i)
          fn((std::size_t(k) * std::size_t(n_[1]) + std::size_t(j)) * std::size_t(n_[0]) +
             std::size_t(i));
  };
  for (std::size_t t = 0; t < T; ++t) each_cell(t, [&](std::size_t c) { ++count[c + 1]; });
  for (std::size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
  start_ = count;
  items_.resize(count.back());
  for (std::size_t t = 0; t < T; ++t)
    each_cell(t, [&](std::size_t c) { items_[count[c]++] = static_cast<std::uint32_t>(t); });
}

int TetLocator::cell_of(double x, int a) const {
  return std::clamp(static_cast<int>(std::floor((x - lo_[a]) / cell_)), 0, n_[a] - 1);
}

void TetLocator::weights(std::size_t t, const double* p, double w[4]) const {
  const double* q[4];
  for (int i = 0; i < 4; ++i) q[i] = &s_.vertices[3 * std::size_t(s_.tets[4 * t + std::size_t(i)])];
  double m[3][3], r[3];
  for (int a = 0; a < 3; ++a) {
    for (int i = 0; i < 3; ++i) m[a][i] = q[i + 1][a] - q[0][a];
    r[a] = p[a] - q[0][a];
  }
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  if (det == 0) {
    w[0] = 1;
    w[1] = w[2] = w[3] = -1e300;
    return;
  }
  // Cramer's rule, column i of m replaced by r.
  for (int i = 0; i < 3; ++i) {
    double c[3][3];
    for (int a = 0; a < 3; ++a)
      for (int j = 0; j < 3; ++j) c[a][j] = j == i ? r[a] : m[a][j];
    w[i + 1] = (c[0][0] * (c[1][1] * c[2][2] - c[1][2] * c[2][1]) -
                c[0][1] * (c[1][0] * c[2][2] - c[1][2] * c[2][0]) +
                c[0][2] * (c[1][0] * c[2][1] - c[1][1] * c[2][0])) /
               det;
  }
  w[0] = 1 - w[1] - w[2] - w[3];
}

int TetLocator::locate(const double* p, double w[4]) const {
  if (start_.empty()) return -1;
  int best_t = -1;
  double best = -std::numeric_limits<double>::infinity();
  int c[3];
  for (int a = 0; a < 3; ++a) c[a] = cell_of(p[a], a);
  // Rings of cells around p until a containing tet (or, past the mesh, a near one) is found.
  const int max_ring = std::max({n_[0], n_[1], n_[2]});
  for (int ring = 0; ring <= max_ring; ++ring) {
    for (int k = std::max(0, c[2] - ring); k <= std::min(n_[2] - 1, c[2] + ring); ++k)
      for (int j = std::max(0, c[1] - ring); j <= std::min(n_[1] - 1, c[1] + ring); ++j)
        for (int i = std::max(0, c[0] - ring); i <= std::min(n_[0] - 1, c[0] + ring); ++i) {
          if (std::max({std::abs(i - c[0]), std::abs(j - c[1]), std::abs(k - c[2])}) != ring)
            continue;
          const std::size_t cell =
              (std::size_t(k) * std::size_t(n_[1]) + std::size_t(j)) * std::size_t(n_[0]) +
              std::size_t(i);
          for (std::uint32_t x = start_[cell]; x < start_[cell + 1]; ++x) {
            double q[4];
            weights(items_[x], p, q);
            const double worst = std::min({q[0], q[1], q[2], q[3]});
            if (worst > best || (worst == best && static_cast<int>(items_[x]) < best_t)) {
              best = worst;
              best_t = static_cast<int>(items_[x]);
              std::copy(q, q + 4, w);
            }
          }
        }
    if (best >= -1e-12 || (best_t >= 0 && ring >= 1)) break;
  }
  if (best_t < 0) return -1;
  double sum = 0;
  for (int i = 0; i < 4; ++i) sum += (w[i] = std::max(0.0, w[i]));
  for (int i = 0; i < 4; ++i) w[i] /= sum;
  return best_t;
}

std::vector<std::vector<double>> transfer_fields(const mesh::Sample& source,
                                                 const mesh::Sample& canonical,
                                                 const std::vector<double>& mapped,
                                                 const std::vector<char>& on_surface,
                                                 const std::vector<SurfacePoint>& surface_points,
                                                 const TetLocator& locator) {
  std::vector<std::vector<double>> out;
  const std::size_t V = canonical.vertex_count(), T = canonical.tet_count();
  bool need_vertex = false, need_tet = false;
  for (const mesh::Field& f : source.fields) (f.location == 0 ? need_vertex : need_tet) = true;
  // Interior vertices: the source tet containing the mapped position.
  std::vector<int> vtet(V, -1);
  std::vector<double> vw(4 * V, 0.0);
  if (need_vertex)
    for (std::size_t v = 0; v < V; ++v)
      if (!on_surface[v]) vtet[v] = locator.locate(&mapped[3 * v], &vw[4 * v]);
  std::vector<int> ttet(T, -1);
  if (need_tet)
    for (std::size_t t = 0; t < T; ++t) {
      double c[3] = {0, 0, 0}, w[4];
      for (int i = 0; i < 4; ++i)
        for (int a = 0; a < 3; ++a)
          c[a] += 0.25 *
                  mapped[3 * std::size_t(canonical.tets[4 * t + std::size_t(i)]) + std::size_t(a)];
      ttet[t] = locator.locate(c, w);
    }
  for (const mesh::Field& f : source.fields) {
    const std::size_t C = static_cast<std::size_t>(f.components);
    std::vector<double> values;
    if (f.location == 0) {
      values.assign(V * C, 0.0);
      for (std::size_t v = 0; v < V; ++v) {
        double* dst = &values[v * C];
        if (on_surface[v]) {
          const SurfacePoint& sp = surface_points[v];
          for (int i = 0; i < 3; ++i)
            if (sp.w[i] != 0)
              for (std::size_t c = 0; c < C; ++c) dst[c] += sp.w[i] * f.values[sp.v[i] * C + c];
        } else if (vtet[v] >= 0) {
          const std::uint32_t* q = &source.tets[4 * std::size_t(vtet[v])];
          for (int i = 0; i < 4; ++i)
            for (std::size_t c = 0; c < C; ++c)
              dst[c] += vw[4 * v + std::size_t(i)] * f.values[q[i] * C + c];
        }
      }
    } else {
      values.assign(T * C, 0.0);
      for (std::size_t t = 0; t < T; ++t)
        if (ttet[t] >= 0) std::copy_n(&f.values[std::size_t(ttet[t]) * C], C, &values[t * C]);
    }
    out.push_back(std::move(values));
  }
  return out;
}

}  // namespace cadinterp::mapping
