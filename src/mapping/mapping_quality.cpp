#include "mapping/mapping_quality.h"

#include <algorithm>
#include <cmath>

#include "mapping/interior_solve.h"
#include "mesh/surface_distance.h"

namespace cadinterp::mapping {

namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, i == 0 ? 0 : i - 1)];
}

// Per canonical vertex, max over components |mapped - value_at(v)| / the source field's range,
// for per-vertex field f of the source; vertices where value_at returns false are left out.
template <class ValueAt>
std::vector<double> vertex_errors(const mesh::Sample& source, const mesh::MappedSample& mapped,
                                  std::size_t f, ValueAt&& value_at) {
  std::vector<double> errors;
  const mesh::Field& sf = source.fields[f];
  const auto C = static_cast<std::size_t>(sf.components);
  const auto mm = std::minmax_element(sf.values.begin(), sf.values.end());
  const double range = sf.values.empty() ? 1 : std::max(*mm.second - *mm.first, 1e-300);
  const std::size_t nv = mapped.vertices.size() / 3;
  std::vector<double> value(C);
  for (std::size_t v = 0; v < nv; ++v) {
    if (!value_at(v, value.data())) continue;
    double e = 0;
    for (std::size_t c = 0; c < C; ++c)
      e = std::max(e, std::abs(mapped.fields[f][v * C + c] - value[c]) / range);
    errors.push_back(e);
  }
  return errors;
}

}  // namespace

std::vector<FieldError> compare_fields(const mesh::Sample& source, const mesh::MappedSample& mapped,
                                       const mesh::Sample& reference) {
  std::vector<FieldError> out;
  for (std::size_t f = 0; f < source.fields.size() && f < mapped.fields.size(); ++f) {
    const mesh::Field& sf = source.fields[f];
    if (sf.location != 0) continue;
    const auto r =
        std::find_if(reference.fields.begin(), reference.fields.end(), [&](const mesh::Field& g) {
          return g.name == sf.name && g.location == 0 && g.components == sf.components;
        });
    if (r == reference.fields.end() || r->values.size() != mapped.fields[f].size()) continue;
    const auto C = static_cast<std::size_t>(sf.components);
    const std::vector<double> e = vertex_errors(source, mapped, f, [&](std::size_t v, double* x) {
      for (std::size_t c = 0; c < C; ++c) x[c] = r->values[v * C + c];
      return true;
    });
    FieldError fe;
    fe.name = sf.name;
    fe.max = e.empty() ? 0 : *std::max_element(e.begin(), e.end());
    fe.p99 = percentile(e, 0.99);
    out.push_back(fe);
  }
  return out;
}

double tagged_area(const std::vector<double>& vertices, const mesh::Sample& mesh,
                   const std::vector<std::int32_t>& tags) {
  double area = 0;
  for (std::size_t f = 0; f < mesh.triangle_count(); ++f) {
    if (std::find(tags.begin(), tags.end(), mesh.triangle_tags[f]) == tags.end()) continue;
    const double* p[3];
    for (int k = 0; k < 3; ++k)
      p[k] = &vertices[3 * std::size_t(mesh.triangles[3 * f + std::size_t(k)])];
    double u[3], v[3];
    for (int a = 0; a < 3; ++a) {
      u[a] = p[1][a] - p[0][a];
      v[a] = p[2][a] - p[0][a];
    }
    const double c[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                         u[0] * v[1] - u[1] * v[0]};
    area += 0.5 * std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
  }
  return area;
}

PairQuality measure_pair(const mesh::Sample& source, const mesh::Sample& canonical,
                         const mesh::MappedSample& mapped, const FieldTruth& truth) {
  PairQuality q;
  const double diag = source.bbox_diagonal();
  const mesh::SurfaceIndex src(source.vertices, source.triangles);
  const mesh::SurfaceIndex map(mapped.vertices, canonical.triangles);
  std::vector<double> d = mesh::vertex_distances(mapped.vertices, canonical.triangles, src);
  const std::vector<double> back = mesh::vertex_distances(source.vertices, source.triangles, map);
  d.insert(d.end(), back.begin(), back.end());
  for (double& x : d) x /= diag;
  if (!d.empty()) {
    const std::size_t at =
        static_cast<std::size_t>(std::max_element(d.begin(), d.end()) - d.begin());
    q.hausdorff_max = d[at];
    // vertex_distances gives one value per boundary vertex (one referenced by a triangle) of
    // its mesh, in vertex order: the mapped ones first.
    const std::size_t mapped_count = d.size() - back.size();
    const bool from_source = at >= mapped_count;
    const mesh::Sample& mesh = from_source ? source : canonical;
    const std::vector<double>& x = from_source ? source.vertices : mapped.vertices;
    std::vector<char> used(x.size() / 3, 0);
    for (std::uint32_t i : mesh.triangles) used[i] = 1;
    std::size_t v = 0;
    for (std::size_t k = from_source ? at - mapped_count : at;; ++v)
      if (used[v] && k-- == 0) break;
    for (int a = 0; a < 3; ++a) q.hausdorff_at[a] = x[3 * v + std::size_t(a)];
    q.hausdorff_at_source = from_source;
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
      if (mesh.triangles[i] == v) {
        q.hausdorff_tag = mesh.triangle_tags[i / 3];
        break;
      }
  }
  q.hausdorff_p99 = percentile(d, 0.99);

  const TetQuality t = tet_quality(mapped.vertices, canonical.tets);
  q.min_scaled_jacobian = t.min_scaled_jacobian;
  q.inverted = t.inverted;

  for (const mesh::Region& r : source.regions) {
    const auto it = std::find_if(canonical.regions.begin(), canonical.regions.end(),
                                 [&](const mesh::Region& c) { return c.name == r.name; });
    if (it == canonical.regions.end()) {
      q.region_area_error = std::max(q.region_area_error, 1.0);  // the region got lost
      continue;
    }
    const double a = tagged_area(source.vertices, source, r.face_tags);
    const double b = tagged_area(mapped.vertices, canonical, it->face_tags);
    if (a > 0) q.region_area_error = std::max(q.region_area_error, std::abs(b / a - 1));
  }

  if (truth) {
    std::vector<double> errors;
    for (std::size_t f = 0; f < source.fields.size() && f < mapped.fields.size(); ++f) {
      if (source.fields[f].location != 0) continue;
      const std::vector<double> e = vertex_errors(source, mapped, f, [&](std::size_t v, double* x) {
        return truth(static_cast<int>(f), &mapped.vertices[3 * v], x);
      });
      errors.insert(errors.end(), e.begin(), e.end());
    }
    q.field_max = errors.empty() ? 0 : *std::max_element(errors.begin(), errors.end());
    q.field_p99 = percentile(errors, 0.99);
  }
  return q;
}

}  // namespace cadinterp::mapping
