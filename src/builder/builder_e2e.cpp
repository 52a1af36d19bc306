#include "builder/builder_e2e.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>

#include "mesh/surface_distance.h"
#include "cadinterp/cadinterp.h"
#include "mapping/field_transfer.h"

namespace cadinterp::builder {

namespace {

/// max - min of a host field, the scale of its relative errors (never 0).
double value_range(const std::vector<double>& values) {
  const auto mm = std::minmax_element(values.begin(), values.end());
  return std::max(*mm.second - *mm.first, 1e-300);
}

double percentile99(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::floor(0.99 * static_cast<double>(v.size() - 1)))];
}

struct AssetCloser {
  void operator()(cadinterp_asset* a) const { cadinterp_close(a); }
};
struct WorkspaceDestroyer {
  void operator()(cadinterp_workspace* w) const { cadinterp_workspace_destroy(w); }
};

}  // namespace

BuildOutcome build_asset(const cadinterp_host& host, const cadinterp_build_options& options,
                         const std::string& output_path) {
  BuildOutcome r;
  r.report.struct_size = sizeof r.report;
  r.stages.struct_size = sizeof r.stages;
  cadinterp_builder* b = nullptr;
  r.status = cadinterp_builder_create(&host, &options, &b);
  if (r.status != CADINTERP_OK) {
    r.error = cadinterp_builder_create_error();
    return r;
  }
  r.status = cadinterp_builder_run(b, output_path.c_str());
  r.error = cadinterp_builder_error(b);
  cadinterp_builder_report(b, &r.report);
  cadinterp_builder_stages(b, &r.stages);
  // The builder owns the message: copied before it goes, the dangling pointer cleared.
  if (r.stages.first_mapped_simulate_failure)
    r.first_mapped_simulate_failure = r.stages.first_mapped_simulate_failure;
  r.stages.first_mapped_simulate_failure = nullptr;
  cadinterp_builder_destroy(b);
  return r;
}

cadinterp_host SplitHost::host() const {
  cadinterp_host h = *below;
  h.identity = identity.c_str();
  h.user = const_cast<SplitHost*>(this);
  h.regenerate = [](void* u, const double* x, cadinterp_sample* out) {
    const auto* s = static_cast<const SplitHost*>(u);
    const cadinterp_host* in = x[s->parameter] <= s->split ? s->below : s->above;
    return in->regenerate(in->user, x, out);
  };
  h.references = [](void* u, const double* x, cadinterp_sample* out) {
    const auto* s = static_cast<const SplitHost*>(u);
    const cadinterp_host* in = x[s->parameter] <= s->split ? s->below : s->above;
    return in->references(in->user, x, out);
  };
  h.simulate = [](void* u, const double* x, const cadinterp_host_mesh* mesh,
                  cadinterp_sample* out) {
    const auto* s = static_cast<const SplitHost*>(u);
    const cadinterp_host* in = x[s->parameter] <= s->split ? s->below : s->above;
    return in->simulate(in->user, x, mesh, out);
  };
  return h;
}

AccuracyReport measure_accuracy(const std::string& asset_path, const Host& host, int points,
                                unsigned seed, const FieldTruthAt& field_truth, bool count_lost,
                                bool on_evaluated_mesh) {
  cadinterp_asset* raw = nullptr;
  if (cadinterp_open(asset_path.c_str(), &raw) != CADINTERP_OK)
    throw std::runtime_error("cannot open " + asset_path + ": " + cadinterp_open_error());
  std::unique_ptr<cadinterp_asset, AssetCloser> asset(raw);
  cadinterp_workspace* wraw = nullptr;
  if (cadinterp_workspace_create(asset.get(), &wraw) != CADINTERP_OK)
    throw std::runtime_error("cannot create a workspace");
  std::unique_ptr<cadinterp_workspace, WorkspaceDestroyer> ws(wraw);

  // Per-vertex fields are compared; per-tet fields follow the same blend.
  std::vector<int> fields;
  for (int f = 0; f < cadinterp_field_count(asset.get()); ++f) {
    cadinterp_field_info info;
    if (cadinterp_field(asset.get(), f, &info) == CADINTERP_OK &&
        info.location == CADINTERP_PER_VERTEX)
      fields.push_back(f);
  }

  std::mt19937 rng(seed);
  AccuracyReport r;
  for (int f : fields) {
    cadinterp_field_info info;
    cadinterp_field(asset.get(), f, &info);
    r.field_names.emplace_back(info.name);
  }
  std::vector<double> geo, fld;
  // Per field, the error at each compared point (the max over its vertices).
  std::vector<std::vector<double>> by_field(fields.size());
  std::vector<double> point_field(fields.size());
  std::vector<std::vector<double>> pooled(fields.size());  // every vertex value's error
  auto note = [&point_field, &pooled](std::size_t k, double err, double& point_max) {
    point_max = std::max(point_max, err);
    point_field[k] = std::max(point_field[k], err);
    pooled[k].push_back(err);
  };
  auto finish_point = [&](double point_max) {
    fld.push_back(point_max);
    for (std::size_t k = 0; k < fields.size(); ++k) by_field[k].push_back(point_field[k]);
    ++r.field_points;
  };
  // The asset's regions, and per point the evaluated mesh's topology: where the host's
  // boundary-condition faces lie on that mesh.
  Sample evaluated;
  for (int g = 0; g < cadinterp_region_count(asset.get()); ++g) {
    cadinterp_region_info info;
    if (cadinterp_region(asset.get(), g, &info) != CADINTERP_OK) continue;
    evaluated.regions.push_back(
        {info.name, info.kind,
         std::vector<std::int32_t>(info.face_tags, info.face_tags + info.face_tag_count)});
  }
  std::vector<std::vector<double>> own_pooled(fields.size());
  std::vector<double> own_max(fields.size(), 0.0);
  const int K = host.dim();
  for (int i = 0; i < points; ++i) {
    std::vector<double> x(static_cast<std::size_t>(K));
    for (int d = 0; d < K; ++d)
      x[static_cast<std::size_t>(d)] =
          std::uniform_real_distribution<double>(host.lower()[static_cast<std::size_t>(d)],
                                                 host.upper()[static_cast<std::size_t>(d)])(rng);
    ++r.points;
    std::fill(point_field.begin(), point_field.end(), 0.0);
    cadinterp_mesh m;
    const cadinterp_status st =
        cadinterp_eval(ws.get(), x.data(), fields.data(), static_cast<int>(fields.size()), &m);
    if (st == CADINTERP_E_INFEASIBLE) {
      ++r.infeasible;
      // Whether the host could have answered: the part of the feasible box the asset lost
      // (elements refused around it) rather than points the host itself refuses.
      if (count_lost && host.evaluate(x.data()).feasible) ++r.lost;
      continue;
    }
    if (st != CADINTERP_OK)
      throw std::runtime_error(std::string("eval failed: ") + cadinterp_workspace_error(ws.get()));
    const Sample truth = host.evaluate(x.data());
    if (!truth.feasible) continue;  // the runtime interpolated across a point the host refuses
    const std::vector<double> V(m.positions, m.positions + 3 * m.vertex_count);
    const std::vector<std::uint32_t> F(m.triangles, m.triangles + 3 * m.triangle_count);
    geo.push_back(symmetric_hausdorff(V, F, truth.vertices, truth.triangles) /
                  truth.bbox_diagonal());
    if (on_evaluated_mesh) {
      evaluated.tets.assign(m.tets, m.tets + 4 * std::size_t(m.tet_count));
      evaluated.triangles = F;
      evaluated.triangle_tags.assign(m.triangle_tags, m.triangle_tags + m.triangle_count);
      Sample mesh;
      std::string why;
      Sample own;
      if (mapping::mesh_for_simulation(truth, evaluated, V, mesh, why)) {
        own = host.simulate(x.data(), mesh);
        why = own.message;
      }
      if (!own.feasible) {
        if (r.evaluated_mesh_refused++ == 0) r.evaluated_mesh_first_refusal = why;
      } else {
        ++r.evaluated_mesh_points;
        for (std::size_t k = 0; k < fields.size(); ++k) {
          const auto fi = static_cast<std::size_t>(fields[k]);
          if (fi >= truth.fields.size()) continue;
          const Field& tf = truth.fields[fi];
          const auto of = std::find_if(own.fields.begin(), own.fields.end(),
                                       [&](const Field& f) { return f.name == tf.name; });
          if (of == own.fields.end() ||
              of->values.size() != std::size_t(m.vertex_count) * std::size_t(tf.components))
            continue;
          const double range = value_range(tf.values);
          for (std::size_t j = 0; j < of->values.size(); ++j) {
            const double e = std::abs(static_cast<double>(m.fields[k][j]) - of->values[j]) / range;
            own_max[k] = std::max(own_max[k], e);
            own_pooled[k].push_back(e);
          }
        }
      }
    }
    if (field_truth) {
      double e = 0;
      for (std::size_t k = 0; k < fields.size(); ++k) {
        const auto fi = static_cast<std::size_t>(fields[k]);
        if (fi >= truth.fields.size()) continue;
        const double range = value_range(truth.fields[fi].values);
        const auto C = static_cast<std::size_t>(truth.fields[fi].components);
        std::vector<double> value(C);
        for (std::uint32_t v = 0; v < m.vertex_count; ++v) {
          const double p[3] = {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
          if (!field_truth(fields[k], x.data(), p, value.data())) continue;
          for (std::size_t c = 0; c < C; ++c)
            note(k, std::abs(static_cast<double>(m.fields[k][v * C + c]) - value[c]) / range, e);
        }
      }
      finish_point(e);
      continue;
    }
    const bool same = truth.vertex_count() == m.vertex_count && truth.tet_count() == m.tet_count &&
                      std::equal(truth.tets.begin(), truth.tets.end(), m.tets);
    if (!same) {
      // A mapped element (§6): the evaluated mesh is not the host's, so the truth at each
      // evaluated vertex is the host's field interpolated barycentrically in the host's tet that
      // contains the vertex (the nearest tet for boundary vertices a geometry error outside).
      const mapping::TetLocator locator(truth);
      double e = 0;
      for (std::uint32_t v = 0; v < m.vertex_count; ++v) {
        const double p[3] = {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
        double w[4];
        const int t = locator.locate(p, w);
        if (t < 0) continue;
        for (std::size_t k = 0; k < fields.size(); ++k) {
          const auto fi = static_cast<std::size_t>(fields[k]);
          if (fi >= truth.fields.size()) continue;
          const mesh::Field& tf = truth.fields[fi];
          const auto C = static_cast<std::size_t>(tf.components);
          const double range = value_range(tf.values);
          for (std::size_t c = 0; c < C; ++c) {
            double want = 0;
            for (std::size_t j = 0; j < 4; ++j)
              want += w[j] * tf.values[truth.tets[4 * static_cast<std::size_t>(t) + j] * C + c];
            note(k, std::abs(static_cast<double>(m.fields[k][v * C + c]) - want) / range, e);
          }
        }
      }
      finish_point(e);
      continue;
    }
    double e = 0;
    for (std::size_t k = 0; k < fields.size(); ++k) {
      const auto fi = static_cast<std::size_t>(fields[k]);
      if (fi >= truth.fields.size()) continue;
      const std::vector<double>& tv = truth.fields[fi].values;
      const double range = value_range(tv);
      for (std::size_t v = 0; v < tv.size(); ++v)
        note(k, std::abs(static_cast<double>(m.fields[k][v]) - tv[v]) / range, e);
    }
    finish_point(e);
  }
  for (std::size_t k = 0; k < fields.size(); ++k) {
    const std::vector<double>& f = by_field[k];
    r.field_max_by_field.push_back(f.empty() ? 0.0 : *std::max_element(f.begin(), f.end()));
    r.field_p99_by_field.push_back(percentile99(f));
    r.field_vertex_p99_by_field.push_back(percentile99(std::move(pooled[k])));
    r.evaluated_mesh_max_by_field.push_back(own_max[k]);
    r.evaluated_mesh_vertex_p99_by_field.push_back(percentile99(std::move(own_pooled[k])));
  }
  if (!geo.empty()) r.geometry_max = *std::max_element(geo.begin(), geo.end());
  if (!fld.empty()) r.field_max = *std::max_element(fld.begin(), fld.end());
  r.geometry_p99 = percentile99(geo);
  r.field_p99 = percentile99(fld);
  return r;
}

}  // namespace cadinterp::builder
