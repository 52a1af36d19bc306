#include "builder/builder_e2e.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>

#include "builder/surface_distance.h"
#include "cadinterp/cadinterp.h"

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
  cadinterp_builder* b = nullptr;
  r.status = cadinterp_builder_create(&host, &options, &b);
  if (r.status != CADINTERP_OK) {
    r.error = cadinterp_builder_open_error();
    return r;
  }
  r.status = cadinterp_builder_run(b, output_path.c_str());
  r.error = cadinterp_builder_error(b);
  cadinterp_builder_report(b, &r.report);
  cadinterp_builder_destroy(b);
  return r;
}

AccuracyReport measure_accuracy(const std::string& asset_path, const Host& host, int points,
                                unsigned seed, const FieldTruthAt& field_truth) {
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
  std::vector<double> geo, fld;
  const int K = host.dim();
  for (int i = 0; i < points; ++i) {
    std::vector<double> x(static_cast<std::size_t>(K));
    for (int d = 0; d < K; ++d)
      x[static_cast<std::size_t>(d)] =
          std::uniform_real_distribution<double>(host.lower()[static_cast<std::size_t>(d)],
                                                 host.upper()[static_cast<std::size_t>(d)])(rng);
    ++r.points;
    cadinterp_mesh m;
    const cadinterp_status st =
        cadinterp_eval(ws.get(), x.data(), fields.data(), static_cast<int>(fields.size()), &m);
    if (st == CADINTERP_E_INFEASIBLE) {
      ++r.infeasible;
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
            e = std::max(e,
                         std::abs(static_cast<double>(m.fields[k][v * C + c]) - value[c]) / range);
        }
      }
      fld.push_back(e);
      continue;
    }
    const bool same = truth.vertex_count() == m.vertex_count && truth.tet_count() == m.tet_count &&
                      std::equal(truth.tets.begin(), truth.tets.end(), m.tets);
    if (!same) continue;
    double e = 0;
    for (std::size_t k = 0; k < fields.size(); ++k) {
      const auto fi = static_cast<std::size_t>(fields[k]);
      if (fi >= truth.fields.size()) continue;
      const std::vector<double>& tv = truth.fields[fi].values;
      const double range = value_range(tv);
      for (std::size_t v = 0; v < tv.size(); ++v)
        e = std::max(e, std::abs(static_cast<double>(m.fields[k][v]) - tv[v]) / range);
    }
    fld.push_back(e);
  }
  if (!geo.empty()) r.geometry_max = *std::max_element(geo.begin(), geo.end());
  if (!fld.empty()) r.field_max = *std::max_element(fld.begin(), fld.end());
  r.geometry_p99 = percentile99(geo);
  r.field_p99 = percentile99(fld);
  return r;
}

}  // namespace cadinterp::builder
