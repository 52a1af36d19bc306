#include "format/synthetic_asset.h"

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "cadinterp/cadinterp_version.h"

namespace cadinterp::format {

namespace {

constexpr double kExtent[3] = {1.0, 0.5, 0.25};
const char* const kNames[4] = {"bend", "twist", "taper", "stretch"};
const char* const kUnits[4] = {"1/m", "rad/m", "1", "1"};

double signed_volume(const float* a, const float* b, const float* c, const float* d) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
          u[2] * (v[0] * w[1] - v[1] * w[0])) /
         6.0;
}

}  // namespace

BoxMesh synthetic_box(const SyntheticSpec& spec) {
  const int nx = spec.cells[0], ny = spec.cells[1], nz = spec.cells[2];
  if (nx < 1 || ny < 1 || nz < 1) throw std::invalid_argument("synthetic_box: cells must be >= 1");
  BoxMesh m;
  auto vid = [&](int i, int j, int k) {
    return static_cast<std::uint32_t>(i + (nx + 1) * (j + (ny + 1) * k));
  };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        m.rest.push_back(static_cast<float>(kExtent[0] * i / nx));
        m.rest.push_back(static_cast<float>(kExtent[1] * j / ny));
        m.rest.push_back(static_cast<float>(kExtent[2] * k / nz));
      }
  m.vertex_count = static_cast<std::uint32_t>(m.rest.size() / 3);
  // Kuhn subdivision: 6 tets around the cell diagonal c0-c7 (corner bits: x=1, y=2, z=4);
  // neighbouring cells then share face diagonals, so the mesh is conforming.
  const int perms[6][3] = {{1, 2, 4}, {1, 4, 2}, {2, 1, 4}, {2, 4, 1}, {4, 1, 2}, {4, 2, 1}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        std::uint32_t c[8];
        for (int b = 0; b < 8; ++b) c[b] = vid(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
        for (const auto& p : perms) {
          std::array<std::uint32_t, 4> t = {c[0], c[p[0]], c[p[0] | p[1]], c[7]};
          if (signed_volume(&m.rest[t[0] * 3], &m.rest[t[1] * 3], &m.rest[t[2] * 3],
                            &m.rest[t[3] * 3]) < 0)
            std::swap(t[2], t[3]);
          m.tets.insert(m.tets.end(), t.begin(), t.end());
        }
      }
  // Boundary: two triangles per boundary quad, split along the quad's min-max corner diagonal
  // (the Kuhn face diagonal), oriented outward.
  const int n[3] = {nx, ny, nz};
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      for (int u = 0; u < n[a]; ++u)
        for (int v = 0; v < n[b]; ++v) {
          auto corner = [&](int du, int dv) {
            int ijk[3];
            ijk[axis] = side ? n[axis] : 0;
            ijk[a] = u + du;
            ijk[b] = v + dv;
            return vid(ijk[0], ijk[1], ijk[2]);
          };
          const std::uint32_t lo = corner(0, 0), hi = corner(1, 1);
          for (const std::uint32_t mid : {corner(1, 0), corner(0, 1)}) {
            std::array<std::uint32_t, 3> t = {lo, mid, hi};
            // Outward: the normal's `axis` component has the sign of the side.
            const float* p0 = &m.rest[t[0] * 3];
            const float* p1 = &m.rest[t[1] * 3];
            const float* p2 = &m.rest[t[2] * 3];
            const double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
            const double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
            const double nrm =
                e1[(axis + 1) % 3] * e2[(axis + 2) % 3] - e1[(axis + 2) % 3] * e2[(axis + 1) % 3];
            if ((nrm > 0) != (side == 1)) std::swap(t[1], t[2]);
            m.triangles.insert(m.triangles.end(), t.begin(), t.end());
            m.tags.push_back(2 * axis + side);
          }
        }
    }
  return m;
}

bool synthetic_host(const SyntheticSpec& spec, const double* x, std::vector<float>& positions,
                    std::vector<float>& fields) {
  return synthetic_host(spec, synthetic_box(spec), x, positions, fields);
}

bool synthetic_host(const SyntheticSpec& spec, const BoxMesh& box, const double* x,
                    std::vector<float>& positions, std::vector<float>& fields) {
  if (spec.infeasible_corner) {
    bool all = true;
    for (int d = 0; d < spec.K; ++d) all = all && x[d] > 0.8;
    if (all) return false;
  }
  double p[4] = {0, 0, 0, 0};
  for (int d = 0; d < spec.K && d < 4; ++d) p[d] = x[d];
  positions.resize(box.rest.size());
  for (std::size_t v = 0; v < box.vertex_count; ++v) {
    const double X = box.rest[3 * v], Y0 = box.rest[3 * v + 1], Z0 = box.rest[3 * v + 2];
    double Y = 0.25 + (Y0 - 0.25) * (1.0 - 0.3 * p[2] * X);  // taper
    double Z = Z0;
    const double th = 0.6 * p[1] * X;  // twist about the box's centre line
    const double dy = Y - 0.25, dz = Z - 0.125;
    Y = 0.25 + std::cos(th) * dy - std::sin(th) * dz;
    Z = 0.125 + std::sin(th) * dy + std::cos(th) * dz;
    Z += 0.3 * p[0] * X * X;                                        // bend
    positions[3 * v] = static_cast<float>(X * (1.0 + 0.5 * p[3]));  // stretch
    positions[3 * v + 1] = static_cast<float>(Y);
    positions[3 * v + 2] = static_cast<float>(Z);
  }
  fields.clear();
  if (!spec.fields) return true;
  for (std::size_t v = 0; v < box.vertex_count; ++v) {  // "temperature", per vertex
    const double X = positions[3 * v], Y = positions[3 * v + 1], Z = positions[3 * v + 2];
    fields.push_back(static_cast<float>(20.0 + 5.0 * std::sin(2.0 * X + p[0]) * std::cos(3.0 * Y) +
                                        10.0 * p[1] * Z));
  }
  for (std::size_t t = 0; t < box.tets.size(); t += 4) {  // "stress", per tet
    double c[3] = {0, 0, 0};
    for (int i = 0; i < 4; ++i)
      for (int d = 0; d < 3; ++d) c[d] += 0.25 * positions[3 * box.tets[t + i] + d];
    fields.push_back(
        static_cast<float>((1.0 + p[0]) * (1.2 - c[0]) + 0.5 * p[2] * c[1] + p[1] * c[2]));
  }
  return true;
}

double synthetic_output(const SyntheticSpec& spec, const double* x) {
  double v = 1.0 + 0.5 * std::sin(3.0 * x[0]);
  for (int d = 0; d < spec.K; ++d) v += (d + 1) * x[d] * x[d];
  return v;
}

SyntheticAsset make_synthetic_asset(const SyntheticSpec& spec) {
  if (spec.K < 1 || spec.K > 4) throw std::invalid_argument("synthetic asset: K must be 1..4");
  const BoxMesh box = synthetic_box(spec);
  const std::size_t V = box.vertex_count, T = box.tets.size() / 4;
  const std::size_t npos = 3 * V, nfield = spec.fields ? V + T : 0;
  const std::vector<double> lo(static_cast<std::size_t>(spec.K), 0.0), hi(lo.size(), 1.0);

  std::vector<float> pos, fld;
  const core::HostFunction host = [&](const double* x, double* out) {
    if (!synthetic_host(spec, box, x, pos, fld)) return false;
    for (std::size_t i = 0; i < npos; ++i) out[i] = pos[i];
    for (std::size_t i = 0; i < nfield; ++i) out[npos + i] = fld[i];
    return true;
  };
  core::AdaptiveOptions opt;
  opt.degree = spec.degree;
  opt.tolerance = spec.tolerance;
  opt.max_samples = spec.max_samples;
  opt.check_face_centres = spec.check_face_centres;
  // Geometry drives refinement (fields are O(10) where positions are O(0.1)).
  opt.metric = [npos](const double* a, const double* t, int) {
    return core::max_norm_error(a, t, static_cast<int>(npos));
  };
  const core::AdaptiveResult r =
      core::adaptive_sample(spec.K, static_cast<int>(npos + nfield), lo, hi, host, opt);

  SyntheticAsset out;
  out.samples = r.basis.sample_count();
  out.basis = std::make_unique<core::CompiledBasis>(
      core::CompiledBasis::compile(r.basis, lo, hi, &r.infeasible));
  AssetContent& c = out.content;
  c.basis = out.basis.get();
  for (int d = 0; d < spec.K; ++d) c.parameters.push_back({kNames[d], kUnits[d], 0.0, 1.0});
  if (spec.fields) {
    c.fields.push_back({"temperature", FieldLocation::Vertex, 1, spec.field_units ? "K" : ""});
    c.fields.push_back({"stress", FieldLocation::Tet, 1, spec.field_units ? "MPa" : ""});
  }
  if (spec.outputs) {
    OutputInfo o;
    o.name = "energy";
    o.unit = "J";
    for (int k = 0; k < out.samples; ++k) {
      double x[core::kMaxDim];
      out.basis->sample_position(k, x);
      o.values.push_back(r.infeasible[static_cast<std::size_t>(k)]
                             ? std::numeric_limits<double>::quiet_NaN()
                             : synthetic_output(spec, x));
    }
    c.outputs.push_back(std::move(o));
  }
  c.regions.push_back({"clamp", "fixed", {0}});
  c.regions.push_back({"tip load", "force", {1}});
  c.builder_version = std::to_string(CADINTERP_VERSION_MAJOR) + "." +
                      std::to_string(CADINTERP_VERSION_MINOR) + "." +
                      std::to_string(CADINTERP_VERSION_PATCH);
  c.host = "synthetic box";
  c.options_json = "{\"K\":" + std::to_string(spec.K) +
                   ",\"degree\":" + std::to_string(static_cast<int>(spec.degree)) +
                   ",\"tolerance\":" + std::to_string(spec.tolerance) +
                   ",\"max_samples\":" + std::to_string(spec.max_samples) + "}";

  const core::CompiledBasis& cb = *out.basis;
  for (int e = 0; e < cb.element_count(); ++e) {
    ElementData ed;
    const int leaf = r.basis.tree().leaves()[static_cast<std::size_t>(e)];
    const double err = r.leaf_error[static_cast<std::size_t>(leaf)];
    ed.error_estimate = std::isfinite(err) ? err : -1.0;  // negative: not measured
    if (cb.element_feasible(e)) {
      double blo[core::kMaxDim], bhi[core::kMaxDim], centre[core::kMaxDim];
      cb.element_box(e, blo, bhi);
      for (int d = 0; d < spec.K; ++d) centre[d] = 0.5 * (blo[d] + bhi[d]);
      int n = 0;
      const int* terms = cb.element_samples(e, &n);
      ed.vertex_count = box.vertex_count;
      ed.tets = box.tets;
      ed.triangles = box.triangles;
      ed.triangle_tags = box.tags;
      for (int t = 0; t < n; ++t) {
        const double* v = &r.values[static_cast<std::size_t>(terms[t]) * (npos + nfield)];
        ed.positions.emplace_back(v, v + npos);
        if (nfield) ed.fields.emplace_back(v + npos, v + npos + nfield);
      }
      // Canonical mesh: the host at the element centre (§4.2); where the centre itself is
      // infeasible, the element's first sample.
      ed.canonical = synthetic_host(spec, box, centre, pos, fld) ? pos : ed.positions.front();
    }
    c.elements.push_back(std::move(ed));
  }
  return out;
}

SyntheticSpec benchmark_fixture_spec() {
  SyntheticSpec spec;
  spec.K = 3;
  spec.cells[0] = 80;
  spec.cells[1] = 40;
  spec.cells[2] = 30;
  spec.fields = true;
  spec.max_samples = 27;
  spec.tolerance = 1e9;
  spec.check_face_centres = false;
  return spec;
}

}  // namespace cadinterp::format
