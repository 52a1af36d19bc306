#include "builder/builder_e2e.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>

#include "builder/located_errors.h"
#include "cadinterp/cadinterp.h"
#include "mapping/field_transfer.h"
#include "mapping/parallel_for.h"
#include "mesh/surface_distance.h"

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

// The next random point of a measurement: uniform in the host's box, drawn from `rng` (so that
// two measurements with one seed visit the same points).
std::vector<double> random_point(std::mt19937& rng, const Host& host) {
  std::vector<double> x(static_cast<std::size_t>(host.dim()));
  for (std::size_t d = 0; d < x.size(); ++d)
    x[d] = std::uniform_real_distribution<double>(host.lower()[d], host.upper()[d])(rng);
  return x;
}

// The next of a measurement's random points (at most `left`) to go to the hosts at once: a few
// per thread, so that the comparisons between batches are short pauses and few samples are held.
std::vector<std::vector<double>> next_batch(std::mt19937& rng, const Host& host, int left,
                                            int threads) {
  std::vector<std::vector<double>> xs;
  for (int i = 0; i < std::min(left, 4 * std::max(1, threads)); ++i)
    xs.push_back(random_point(rng, host));
  return xs;
}

// Each compared field's range in truth (located_errors' scale); 1 for a field not compared.
std::vector<double> truth_ranges(const Sample& truth, const std::vector<int>& truth_fields) {
  std::vector<double> range(truth_fields.size(), 1.0);
  for (std::size_t k = 0; k < truth_fields.size(); ++k)
    if (truth_fields[k] >= 0)
      range[k] = value_range(truth.fields[static_cast<std::size_t>(truth_fields[k])].values);
  return range;
}

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
  if (r.stages.calibration)
    r.calibration.assign(r.stages.calibration, r.stages.calibration + r.stages.calibration_count);
  if (r.stages.calibration_floors)
    r.calibration_floors.assign(r.stages.calibration_floors,
                                r.stages.calibration_floors + r.stages.calibration_count);
  r.stages.calibration = nullptr;
  r.stages.calibration_floors = nullptr;
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

namespace {

// One measurement (Table 2, ours): the opened asset, its per-vertex fields, and the errors
// gathered point by point. Each comparison of a point is one member, in the order measure_accuracy
// runs them.
class AccuracyRun {
 public:
  AccuracyRun(const std::string& asset_path, const Host& host, bool always_located = false)
      : host_(host), always_located_(always_located) {
    cadinterp_asset* raw = nullptr;
    if (cadinterp_open(asset_path.c_str(), &raw) != CADINTERP_OK)
      throw std::runtime_error("cannot open " + asset_path + ": " + cadinterp_open_error());
    asset_.reset(raw);
    // Per-vertex fields are compared; per-tet fields follow the same blend.
    for (int f = 0; f < cadinterp_field_count(asset_.get()); ++f) {
      cadinterp_field_info info;
      if (cadinterp_field(asset_.get(), f, &info) == CADINTERP_OK &&
          info.location == CADINTERP_PER_VERTEX)
        fields_.push_back(f);
    }
    for (int f : fields_) {
      cadinterp_field_info info;
      cadinterp_field(asset_.get(), f, &info);
      r_.field_names.emplace_back(info.name);
    }
    by_field_.resize(fields_.size());
    point_field_.resize(fields_.size());
    pooled_.resize(fields_.size());
    own_pooled_.resize(fields_.size());
    own_max_.assign(fields_.size(), 0.0);
    // The asset's regions, and per point the evaluated mesh's topology: where the host's
    // boundary-condition faces lie on that mesh.
    for (int g = 0; g < cadinterp_region_count(asset_.get()); ++g) {
      cadinterp_region_info info;
      if (cadinterp_region(asset_.get(), g, &info) != CADINTERP_OK) continue;
      evaluated_.regions.push_back(
          {info.name, info.kind,
           std::vector<std::int32_t>(info.face_tags, info.face_tags + info.face_tag_count)});
    }
  }

  // A batch of random points, each the asset against the host's regeneration there: known[i]
  // when the caller has it already, else the host is asked here. The host's calls (regenerate,
  // and with on_evaluated_mesh simulate on each evaluated mesh) run on `threads` threads; the
  // comparisons run here in the points' order, so the report does not depend on `threads`.
  void batch(const std::vector<std::vector<double>>& xs, const FieldTruthAt& field_truth,
             bool count_lost, bool on_evaluated_mesh, int threads, const Sample* known = nullptr) {
    const std::size_t n = xs.size();
    // Each point's evaluated mesh stays in its own workspace until the batch is compared.
    while (ws_.size() < n) {
      cadinterp_workspace* raw = nullptr;
      if (cadinterp_workspace_create(asset_.get(), &raw) != CADINTERP_OK)
        throw std::runtime_error("cannot create a workspace");
      ws_.emplace_back(raw);
    }
    std::vector<cadinterp_mesh> m(n);
    std::vector<cadinterp_status> st(n);
    for (std::size_t i = 0; i < n; ++i) {
      st[i] = cadinterp_eval(ws_[i].get(), xs[i].data(), fields_.data(),
                             static_cast<int>(fields_.size()), &m[i]);
      if (st[i] != CADINTERP_OK && st[i] != CADINTERP_E_INFEASIBLE)
        throw std::runtime_error(std::string("eval failed: ") +
                                 cadinterp_workspace_error(ws_[i].get()));
    }
    // The host where the runtime answers, and where it refuses with count_lost: whether the
    // host could have answered (the part of the feasible box the asset lost).
    std::vector<Sample> asked;
    if (!known) {
      asked.resize(n);
      mapping::parallel_for(n, threads, [&](std::size_t i) {
        if (st[i] == CADINTERP_OK || count_lost) asked[i] = host_.evaluate(xs[i].data());
      });
    }
    const Sample* truth = known ? known : asked.data();
    std::vector<Sample> own;
    std::vector<std::string> why;
    if (on_evaluated_mesh) simulate_on_evaluated_meshes(xs, st, m, truth, threads, own, why);
    for (std::size_t i = 0; i < n; ++i) {
      ++r_.points;
      if (st[i] == CADINTERP_E_INFEASIBLE) {
        ++r_.infeasible;
        if (count_lost && truth[i].feasible) ++r_.lost;
        continue;
      }
      // The runtime interpolated across a point the host refuses: nothing to compare.
      if (!truth[i].feasible) continue;
      compare(xs[i], m[i], truth[i], field_truth);
      if (on_evaluated_mesh) against_host_on_evaluated_mesh(m[i], truth[i], own[i], why[i]);
      note_estimates(xs[i]);
    }
  }

  // One point the runtime and the host both answer: geometry, then the fields against the
  // truth the host gives.
  void compare(const std::vector<double>& x, const cadinterp_mesh& m, const Sample& truth,
               const FieldTruthAt& field_truth) {
    std::fill(point_field_.begin(), point_field_.end(), 0.0);
    const std::vector<double> V(m.positions, m.positions + 3 * m.vertex_count);
    const std::vector<std::uint32_t> F(m.triangles, m.triangles + 3 * m.triangle_count);
    geo_.push_back(symmetric_hausdorff(V, F, truth.vertices, truth.triangles) /
                   truth.bbox_diagonal());
    if (field_truth)
      against_closed_form(x, truth, m, field_truth);
    else if (always_located_ || !same_mesh(truth, m))
      against_located_truth(truth, m);
    else
      against_same_mesh(truth, m);
  }

  // The asset's own error estimates at x next to the errors just measured (the point's last
  // geometry value and per-field maxima), per quantity.
  void note_estimates(const std::vector<double>& x) {
    int count = 0;
    cadinterp_error_estimates(asset_.get(), x.data(), nullptr, 0, &count);
    std::vector<double> est(static_cast<std::size_t>(count));
    if (cadinterp_error_estimates(asset_.get(), x.data(), est.data(), count, &count) !=
        CADINTERP_OK)
      return;
    estimates_.resize(1 + fields_.size());
    AccuracyReport::PointRecord rec{x, {est[0]}, {geo_.back()}};
    if (est[0] >= 0) estimates_[0].push_back({est[0], geo_.back()});
    for (std::size_t k = 0; k < fields_.size(); ++k) {
      const double e = est[1 + static_cast<std::size_t>(fields_[k])];
      if (e >= 0) estimates_[1 + k].push_back({e, point_field_[k]});
      rec.estimate.push_back(e);
      rec.error.push_back(point_field_[k]);
    }
    r_.per_point.push_back(std::move(rec));
  }

  // estimate_* of the report from the (estimate, true error) pairs of each quantity.
  void finish_estimates() {
    for (const auto& pairs : estimates_) {
      int covered = 0;
      std::vector<double> ratios;
      for (const auto& [est, truth] : pairs) {
        covered += est >= truth ? 1 : 0;
        if (truth > 1e-12) ratios.push_back(est / truth);
      }
      double median = 0, p10 = 0;
      if (!ratios.empty()) {
        std::sort(ratios.begin(), ratios.end());
        median = ratios[ratios.size() / 2];
        p10 = ratios[ratios.size() / 10];
      }
      r_.estimate_p10_ratio.push_back(p10);
      r_.estimate_points.push_back(static_cast<int>(pairs.size()));
      r_.estimate_coverage.push_back(
          pairs.empty() ? 0.0 : double(covered) / static_cast<double>(pairs.size()));
      r_.estimate_median_ratio.push_back(median);
    }
  }

  AccuracyReport finish() {
    if (!estimates_.empty() && !estimates_[0].empty()) finish_estimates();
    for (std::size_t k = 0; k < fields_.size(); ++k) {
      const std::vector<double>& f = by_field_[k];
      r_.field_max_by_field.push_back(f.empty() ? 0.0 : *std::max_element(f.begin(), f.end()));
      r_.field_p99_by_field.push_back(percentile99(f));
      r_.field_vertex_p99_by_field.push_back(percentile99(std::move(pooled_[k])));
      r_.evaluated_mesh_max_by_field.push_back(own_max_[k]);
      r_.evaluated_mesh_vertex_p99_by_field.push_back(percentile99(std::move(own_pooled_[k])));
    }
    if (!geo_.empty()) r_.geometry_max = *std::max_element(geo_.begin(), geo_.end());
    if (!fld_.empty()) r_.field_max = *std::max_element(fld_.begin(), fld_.end());
    r_.geometry_p99 = percentile99(geo_);
    r_.field_p99 = percentile99(fld_);
    return r_;
  }

 private:
  static bool same_mesh(const Sample& truth, const cadinterp_mesh& m) {
    return truth.vertex_count() == m.vertex_count && truth.tet_count() == m.tet_count &&
           std::equal(truth.tets.begin(), truth.tets.end(), m.tets);
  }

  // One vertex value's error of field k, into the point's maximum e.
  void note(std::size_t k, double err, double& e) {
    e = std::max(e, err);
    point_field_[k] = std::max(point_field_[k], err);
    pooled_[k].push_back(err);
  }
  void finish_point(double e) {
    fld_.push_back(e);
    for (std::size_t k = 0; k < fields_.size(); ++k) by_field_[k].push_back(point_field_[k]);
    ++r_.field_points;
  }

  // The host's own simulate on each evaluated mesh (no two-mesh discretization difference in
  // the truth), where the host's regions can be placed on that mesh: own[i], or why[i] it is
  // not there. The meshes are made here, the simulations run on `threads` threads.
  void simulate_on_evaluated_meshes(const std::vector<std::vector<double>>& xs,
                                    const std::vector<cadinterp_status>& st,
                                    const std::vector<cadinterp_mesh>& m, const Sample* truth,
                                    int threads, std::vector<Sample>& own,
                                    std::vector<std::string>& why) {
    const std::size_t n = xs.size();
    own.assign(n, Sample{});
    why.assign(n, std::string());
    std::vector<Sample> mesh(n);
    std::vector<char> ready(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
      if (st[i] != CADINTERP_OK || !truth[i].feasible) continue;
      evaluated_.tets.assign(m[i].tets, m[i].tets + 4 * std::size_t(m[i].tet_count));
      evaluated_.triangles.assign(m[i].triangles, m[i].triangles + 3 * m[i].triangle_count);
      evaluated_.triangle_tags.assign(m[i].triangle_tags, m[i].triangle_tags + m[i].triangle_count);
      const std::vector<double> V(m[i].positions, m[i].positions + 3 * m[i].vertex_count);
      ready[i] = mapping::mesh_for_simulation(truth[i], evaluated_, V, mesh[i], why[i]) ? 1 : 0;
    }
    mapping::parallel_for(n, threads, [&](std::size_t i) {
      if (!ready[i]) return;
      own[i] = host_.simulate(xs[i].data(), mesh[i]);
      why[i] = own[i].message;
    });
  }

  // The asset's fields against the host's simulate on the evaluated mesh (`own`, or `why` not).
  void against_host_on_evaluated_mesh(const cadinterp_mesh& m, const Sample& truth,
                                      const Sample& own, const std::string& why) {
    if (!own.feasible) {
      if (r_.evaluated_mesh_refused++ == 0) r_.evaluated_mesh_first_refusal = why;
      return;
    }
    ++r_.evaluated_mesh_points;
    for (std::size_t k = 0; k < fields_.size(); ++k) {
      const auto fi = static_cast<std::size_t>(fields_[k]);
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
        own_max_[k] = std::max(own_max_[k], e);
        own_pooled_[k].push_back(e);
      }
    }
  }

  // A host with a closed form: the true field at each evaluated vertex's position.
  void against_closed_form(const std::vector<double>& x, const Sample& truth,
                           const cadinterp_mesh& m, const FieldTruthAt& field_truth) {
    double e = 0;
    for (std::size_t k = 0; k < fields_.size(); ++k) {
      const auto fi = static_cast<std::size_t>(fields_[k]);
      if (fi >= truth.fields.size()) continue;
      const double range = value_range(truth.fields[fi].values);
      const auto C = static_cast<std::size_t>(truth.fields[fi].components);
      std::vector<double> value(C);
      for (std::uint32_t v = 0; v < m.vertex_count; ++v) {
        const double p[3] = {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
        if (!field_truth(fields_[k], x.data(), p, value.data())) continue;
        for (std::size_t c = 0; c < C; ++c)
          note(k, std::abs(static_cast<double>(m.fields[k][v * C + c]) - value[c]) / range, e);
      }
    }
    finish_point(e);
  }

  // A mapped element (§6): the evaluated mesh is not the host's, so the truth at each evaluated
  // vertex is the host's field interpolated barycentrically in the host's tet that contains the
  // vertex (the nearest tet for boundary vertices a geometry error outside).
  void against_located_truth(const Sample& truth, const cadinterp_mesh& m) {
    std::vector<int> truth_fields(fields_.size(), -1);
    for (std::size_t k = 0; k < fields_.size(); ++k)
      if (static_cast<std::size_t>(fields_[k]) < truth.fields.size()) truth_fields[k] = fields_[k];
    double e = 0;
    located_errors(
        truth, m.vertex_count, truth_fields, truth_ranges(truth, truth_fields),
        [&](std::uint32_t v, double* p) {
          for (std::size_t c = 0; c < 3; ++c) p[c] = m.positions[3 * v + c];
        },
        [&](std::size_t k, std::uint32_t v, std::size_t c) {
          const auto C = static_cast<std::size_t>(
              truth.fields[static_cast<std::size_t>(fields_[k])].components);
          return static_cast<double>(m.fields[k][v * C + c]);
        },
        [&](std::size_t k, std::uint32_t, double err) { note(k, err, e); });
    finish_point(e);
  }

  // The host's mesh itself: its field values vertex by vertex.
  void against_same_mesh(const Sample& truth, const cadinterp_mesh& m) {
    double e = 0;
    for (std::size_t k = 0; k < fields_.size(); ++k) {
      const auto fi = static_cast<std::size_t>(fields_[k]);
      if (fi >= truth.fields.size()) continue;
      const std::vector<double>& tv = truth.fields[fi].values;
      const double range = value_range(tv);
      for (std::size_t v = 0; v < tv.size(); ++v)
        note(k, std::abs(static_cast<double>(m.fields[k][v]) - tv[v]) / range, e);
    }
    finish_point(e);
  }

  const Host& host_;
  bool always_located_ = false;  // measure_accuracy_at's `located`
  std::unique_ptr<cadinterp_asset, AssetCloser> asset_;
  std::vector<std::unique_ptr<cadinterp_workspace, WorkspaceDestroyer>> ws_;  // per batch slot
  std::vector<int> fields_;
  AccuracyReport r_;
  std::vector<double> geo_, fld_;
  std::vector<std::vector<double>> by_field_;  // per field, each compared point's max error
  std::vector<double> point_field_;            // per field, this point's max error
  std::vector<std::vector<double>> pooled_;    // per field, every vertex value's error
  std::vector<std::vector<double>> own_pooled_;
  std::vector<double> own_max_;
  Sample evaluated_;
  // Per quantity (geometry, then fields_), per compared point: (estimate, true error).
  std::vector<std::vector<std::pair<double, double>>> estimates_;
};

}  // namespace

AccuracyReport measure_accuracy(const std::string& asset_path, const Host& host, int points,
                                unsigned seed, const FieldTruthAt& field_truth, bool count_lost,
                                bool on_evaluated_mesh, int threads) {
  AccuracyRun run(asset_path, host);
  std::mt19937 rng(seed);
  for (int done = 0; done < points;) {
    const std::vector<std::vector<double>> xs = next_batch(rng, host, points - done, threads);
    done += static_cast<int>(xs.size());
    run.batch(xs, field_truth, count_lost, on_evaluated_mesh, threads);
  }
  return run.finish();
}

AccuracyReport measure_accuracy_at(const std::string& asset_path, const Host& host,
                                   const std::vector<std::vector<double>>& xs, bool located,
                                   int threads) {
  for (const std::vector<double>& x : xs)
    if (x.size() != static_cast<std::size_t>(host.dim()))
      throw std::invalid_argument("measure_accuracy_at: a point has " + std::to_string(x.size()) +
                                  " coordinates, the host " + std::to_string(host.dim()));
  AccuracyRun run(asset_path, host, located);
  const std::size_t per_batch = 4 * static_cast<std::size_t>(std::max(1, threads));
  for (std::size_t i = 0; i < xs.size(); i += per_batch)
    run.batch({xs.begin() + static_cast<std::ptrdiff_t>(i),
               xs.begin() + static_cast<std::ptrdiff_t>(std::min(xs.size(), i + per_batch))},
              nullptr, false, false, threads);
  return run.finish();
}

TruthDependenceReport measure_truth_dependence(const Host& table, const Host& reference, int points,
                                               unsigned seed, const std::string& asset_path,
                                               int threads) {
  if (table.dim() != reference.dim() || table.lower() != reference.lower() ||
      table.upper() != reference.upper())
    throw std::invalid_argument("measure_truth_dependence: the hosts' parameter boxes differ");
  TruthDependenceReport r;
  std::unique_ptr<AccuracyRun> asset;
  if (!asset_path.empty()) asset = std::make_unique<AccuracyRun>(asset_path, reference);
  std::vector<std::vector<double>> pooled;
  // One point, the reference's answer against the table's.
  const auto compare = [&](const std::vector<double>& x, const Sample& other, const Sample& truth) {
    ++r.points;
    if (!truth.feasible || !other.feasible) {
      ++r.infeasible;
      return;
    }
    // The reference's per-vertex fields, matched with the table's by name, in the reference's
    // order (the first point fixes it).
    std::vector<int> truth_fields;
    std::vector<std::size_t> compared;
    for (std::size_t f = 0; f < other.fields.size(); ++f) {
      if (other.fields[f].location != CADINTERP_PER_VERTEX) continue;
      const auto it = std::find_if(truth.fields.begin(), truth.fields.end(), [&](const Field& t) {
        return t.name == other.fields[f].name && t.location == CADINTERP_PER_VERTEX &&
               t.components == other.fields[f].components;
      });
      if (it == truth.fields.end()) continue;
      compared.push_back(f);
      truth_fields.push_back(static_cast<int>(it - truth.fields.begin()));
    }
    if (r.field_names.empty()) {
      for (std::size_t f : compared) r.field_names.push_back(other.fields[f].name);
      r.max_by_field.assign(compared.size(), 0.0);
      r.max_x.resize(compared.size());
      r.max_at.resize(compared.size());
      pooled.resize(compared.size());
    }
    if (compared.size() != r.field_names.size())
      throw std::runtime_error("measure_truth_dependence: the hosts' fields change across x");
    ++r.compared;
    located_errors(
        truth, static_cast<std::uint32_t>(other.vertex_count()), truth_fields,
        truth_ranges(truth, truth_fields),
        [&](std::uint32_t v, double* p) {
          for (std::size_t c = 0; c < 3; ++c) p[c] = other.vertices[3 * std::size_t(v) + c];
        },
        [&](std::size_t k, std::uint32_t v, std::size_t c) {
          const Field& f = other.fields[compared[k]];
          return f.values[v * static_cast<std::size_t>(f.components) + c];
        },
        [&](std::size_t k, std::uint32_t v, double err) {
          if (err > r.max_by_field[k]) {
            r.max_by_field[k] = err;
            r.max_x[k] = x;
            for (std::size_t c = 0; c < 3; ++c)
              r.max_at[k][c] = other.vertices[3 * std::size_t(v) + c];
          }
          pooled[k].push_back(err);
        });
  };
  std::mt19937 rng(seed);
  for (int done = 0; done < points;) {
    const std::vector<std::vector<double>> xs = next_batch(rng, table, points - done, threads);
    done += static_cast<int>(xs.size());
    // Both hosts at every point of the batch: the reference's answers first, then the table's.
    const std::size_t n = xs.size();
    std::vector<Sample> answers(2 * n);
    mapping::parallel_for(2 * n, threads, [&](std::size_t j) {
      answers[j] = (j < n ? reference : table).evaluate(xs[j % n].data());
    });
    if (asset) asset->batch(xs, nullptr, false, false, threads, answers.data());
    for (std::size_t i = 0; i < n; ++i) compare(xs[i], answers[i], answers[n + i]);
  }
  for (auto& p : pooled) r.vertex_p99_by_field.push_back(percentile99(std::move(p)));
  if (asset) {
    r.asset = asset->finish();
    r.has_asset = true;
  }
  return r;
}

}  // namespace cadinterp::builder
