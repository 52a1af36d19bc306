// The adaptive sampling problem over meshes (mesh_problem.h, paper §4.2): host samples per row,
// the refinement test on mapped meshes, and the bounded cache of mapped rows.
#include "builder/mesh_problem.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "builder/located_errors.h"
#include "mapping/field_transfer.h"
#include "mapping/parallel_for.h"
#include "mesh/surface_distance.h"

namespace cadinterp::builder {

FieldSignature FieldSignature::of(const Sample& s) {
  FieldSignature f;
  for (const Field& x : s.fields) {
    f.names.push_back(x.name);
    f.locations.push_back(x.location);
    f.components.push_back(x.components);
  }
  for (const mesh::Output& o : s.outputs) f.outputs.push_back(o.name);
  return f;
}

void MeshProblem::evaluate(const std::vector<int>& rows, const std::vector<double>& x,
                           std::vector<char>& feasible) {
  const StageTimer timer(details_.sampling_seconds);
  details_.points_requested += static_cast<int>(rows.size());
  // Until the basis exists, `samples` says how many points were asked for (BuildReport).
  report_.samples = details_.points_requested;
  const std::size_t K = static_cast<std::size_t>(host_.dim());
  std::vector<std::vector<double>> pending;
  std::vector<int> pending_rows;
  std::vector<char> from_host(rows.size(), 0);  // per row of the wave: evaluated by the host
  for (std::size_t i = 0; i < rows.size(); ++i) {
    std::vector<double> xi(x.begin() + static_cast<std::ptrdiff_t>(i * K),
                           x.begin() + static_cast<std::ptrdiff_t>((i + 1) * K));
    const auto r = static_cast<std::size_t>(rows[i]);
    if (samples_.size() <= r) {
      samples_.resize(r + 1);
      points_.resize(r + 1);
    }
    points_[r] = xi;
    Sample s;
    if (store_ && store_->get(xi, s)) {
      ++report_.store_hits;
      samples_[r] = std::make_shared<const Sample>(std::move(s));
    } else {
      pending.push_back(std::move(xi));
      pending_rows.push_back(rows[i]);
      from_host[i] = 1;
    }
  }
  done_ += static_cast<int>(rows.size() - pending.size());  // store hits count as done
  std::size_t delivered = 0;
  const bool complete = exec_.run(
      pending,
      [&](std::size_t i, Sample&& s) {
        if (store_) store_->put(pending[i], s);
        ++report_.host_evaluations;
        report_.host_seconds += s.host_seconds;
        samples_[static_cast<std::size_t>(pending_rows[i])] =
            std::make_shared<const Sample>(std::move(s));
        ++done_;
        ++delivered;
        host_seconds_done_ += samples_[static_cast<std::size_t>(pending_rows[i])]->host_seconds;
        cancel_ = cancel_ || report_progress(static_cast<int>(pending.size() - delivered));
      },
      [&] { return cancel_; });
  if (!complete || cancel_) throw BuildCancelled();
  // Decided in row order, after the whole wave: the outcome cannot depend on which thread
  // finished first.
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto r = static_cast<std::size_t>(rows[i]);
    std::shared_ptr<const Sample>& s = samples_[r];
    if (s->feasible) {
      const FieldSignature sig = FieldSignature::of(*s);
      if (!signature_) {
        signature_ = sig;
      } else if (!(sig == *signature_)) {
        auto bad = std::make_shared<Sample>();
        bad->message = "the host's fields or outputs differ from those of the build's first sample";
        s = bad;
      }
    }
    feasible[i] = s->feasible ? 1 : 0;
    if (!s->feasible) {
      ++report_.infeasible_points;
      report_.infeasible_host_evaluations += from_host[i];
      count_reason(details_.infeasible_reasons, details_.other_infeasible_points, s->message,
                   points_[r]);
    }
    if (classes_.size() <= r) classes_.resize(r + 1, -1);
    if (s->feasible) classes_[r] = combinatorics_class(*s);
  }
  report_progress(0);
}

bool MeshProblem::quantity_errors(int at, int centre, const int* terms, const double* psi, int n,
                                  double geometry_cutoff, std::vector<double>& out, bool located) {
  const Sample& canon = sample(centre);
  const std::size_t nv3 = canon.vertices.size();
  std::vector<double> V(nv3, 0.0);
  const std::size_t nfields = canon.fields.size();
  std::vector<std::vector<double>> F(nfields);
  for (std::size_t f = 0; f < nfields; ++f) F[f].assign(canon.fields[f].values.size(), 0.0);
  const Sample& truth = sample(at);
  // Located per-vertex fields need row `at` as it is, not mapped onto `centre`.
  const bool all_located =
      located && std::all_of(truth.fields.begin(), truth.fields.end(),
                             [](const Field& f) { return f.location == CADINTERP_PER_VERTEX; });
  if (spare_threads_ > 1 && !map_terms(nfields && !all_located ? at : -1, centre, terms, n))
    return false;
  View m;
  for (int t = 0; t < n; ++t) {
    if (!view(terms[t], centre, m)) return false;
    for (std::size_t i = 0; i < nv3; ++i) V[i] += psi[t] * m.vertices[i];
    for (std::size_t f = 0; f < nfields; ++f)
      for (std::size_t i = 0; i < F[f].size(); ++i) F[f][i] += psi[t] * m.fields[f][i];
  }
  const double diagonal = truth.bbox_diagonal();
  out.assign(1 + nfields, 0.0);
  out[0] = -1;
  if (classes_[static_cast<std::size_t>(at)] == classes_[static_cast<std::size_t>(centre)]) {
    // Same mesh: the largest vertex displacement bounds the Hausdorff distance from above
    // (corresponding triangles are within it everywhere), and settles most tests in O(V);
    // only above the cutoff is the exact distance worth its cost.
    double d2 = 0;
    for (std::size_t i = 0; i < nv3; i += 3) {
      double q = 0;
      for (std::size_t c = 0; c < 3; ++c)
        q += (V[i + c] - truth.vertices[i + c]) * (V[i + c] - truth.vertices[i + c]);
      d2 = std::max(d2, q);
    }
    if (std::sqrt(d2) <= geometry_cutoff * diagonal) out[0] = std::sqrt(d2) / diagonal;
  }
  if (out[0] < 0)
    out[0] = symmetric_hausdorff(V, canon.triangles, truth.vertices, truth.triangles,
                                 hausdorff_threads_) /
             diagonal;
  if (!nfields) return true;
  std::vector<double> e(nfields, 0.0);
  // Located where a row is mapped (a term, or `at` itself, of other combinatorics than the
  // canonical mesh): a mapped vertex slides within its face (§6), so vertex i of the interpolant
  // and of row `at` are not one point of the solid, and compared vertex by vertex a field with a
  // gradient along the surface errs by that gradient times the slide even where the interpolant
  // is exact. Each per-vertex field is compared with row `at`'s own field located at the
  // interpolated positions instead, as measure_accuracy compares an asset with its host where
  // the meshes differ (located_errors.h). Where no row is mapped, vertex i is one point of the
  // solid in every row and the comparison stays vertex by vertex.
  const auto cls = [&](int row) { return classes_[static_cast<std::size_t>(row)]; };
  const bool locate =
      located && (cls(at) != cls(centre) ||
                  std::any_of(terms, terms + n, [&](int t) { return cls(t) != cls(centre); }));
  if (locate) {
    std::vector<int> compared(nfields, -1);
    for (std::size_t f = 0; f < nfields; ++f)
      if (truth.fields[f].location == CADINTERP_PER_VERTEX) compared[f] = static_cast<int>(f);
    located_errors(
        truth, static_cast<std::uint32_t>(nv3 / 3), compared, std::vector<double>(nfields, 1.0),
        [&](std::uint32_t v, double* p) {
          for (std::size_t c = 0; c < 3; ++c) p[c] = V[3 * std::size_t(v) + c];
        },
        [&](std::size_t f, std::uint32_t v, std::size_t c) {
          return F[f][v * static_cast<std::size_t>(truth.fields[f].components) + c];
        },
        [&](std::size_t f, std::uint32_t, double err) { e[f] = std::max(e[f], err); });
  }
  if (!locate || !all_located) {
    if (!view(at, centre, m)) return false;
    for (std::size_t f = 0; f < nfields; ++f) {
      if (locate && truth.fields[f].location == CADINTERP_PER_VERTEX) continue;
      for (std::size_t i = 0; i < F[f].size(); ++i)
        e[f] = std::max(e[f], std::abs(F[f][i] - m.fields[f][i]));
    }
  }
  for (std::size_t f = 0; f < nfields; ++f)
    out[1 + f] = e[f] / field_error_scale(truth.fields[f].values);
  return true;
}

double MeshProblem::interpolation_error(int at, int centre, const int* terms, const double* psi,
                                        int n) {
  std::vector<double> q;
  if (!quantity_errors(at, centre, terms, psi, n, opt_.geometry_tolerance, q))
    return std::numeric_limits<double>::infinity();
  double err = q[0] / opt_.geometry_tolerance;
  for (std::size_t f = 1; f < q.size(); ++f) err = std::max(err, q[f] / opt_.field_tolerance);
  const Sample& truth = sample(at);
  // Scalar outputs: relative to their magnitude (a scalar has no range of values), with the
  // field tolerance, so the refinement bounds their interpolation error as it bounds the fields'.
  for (std::size_t o = 0; o < truth.outputs.size(); ++o) {
    double interpolated = 0, scale = std::abs(truth.outputs[o].value);
    for (int t = 0; t < n; ++t) {
      const Sample& term = sample(terms[t]);
      if (o >= term.outputs.size()) return std::numeric_limits<double>::infinity();  // failed
      const double v = term.outputs[o].value;
      interpolated += psi[t] * v;
      scale = std::max(scale, std::abs(v));
    }
    if (scale > 0)
      err = std::max(
          err, std::abs(interpolated - truth.outputs[o].value) / (scale * opt_.field_tolerance));
  }
  return err;
}

double MeshProblem::midpoint_error(int a, int b, int c) {
  const int terms[2] = {a, b};
  const double psi[2] = {0.5, 0.5};
  return interpolation_error(c, c, terms, psi, 2);
}

bool MeshProblem::view(int src, int canon, View& v) {
  v.fields.clear();
  v.hold.reset();
  if (classes_[static_cast<std::size_t>(src)] == classes_[static_cast<std::size_t>(canon)]) {
    const Sample& s = sample(src);
    v.vertices = s.vertices.data();
    for (const Field& f : s.fields) v.fields.push_back(f.values.data());
    return true;
  }
  const auto key = std::make_pair(src, canon);
  std::shared_ptr<const MappedSample> found;
  {
    // A pair another thread is mapping is waited for rather than mapped twice: the wait ends
    // no later than this thread's own mapping would, and spends no core.
    std::unique_lock<std::mutex> lock(maps_mu_);
    for (;;) {
      if (failures_.count(key)) return false;
      auto it = maps_.find(key);
      if (it != maps_.end()) {
        found = it->second.map;
        recent_.splice(recent_.end(), recent_, it->second.recent);
        break;
      }
      if (mapping_.insert(key).second) break;  // this thread maps it
      mapped_cv_.wait(lock);
    }
  }
  if (!found) {
    // Mapped outside the lock (mapping is the expensive part).
    struct Done {  // however the mapping ends (a cancelled simulation throws), waiters wake
      MeshProblem& p;
      std::pair<int, int> key;
      ~Done() {
        {
          std::lock_guard<std::mutex> lock(p.maps_mu_);
          p.mapping_.erase(key);
        }
        p.mapped_cv_.notify_all();
      }
    } done{*this, key};
    auto m = std::make_shared<MappedSample>();
    std::string why;
    const bool ok = mapper_.map(sample(src), sample(canon), *m, why);
    std::string unsimulated;
    const bool simulated =
        ok && opt_.simulate_mapped && simulate_on_mapped(src, sample(canon), *m, unsimulated);
    std::lock_guard<std::mutex> lock(maps_mu_);
    ++details_.maps;
    if (!mapped_.insert(key).second) ++details_.maps_again;
    if (ok && opt_.simulate_mapped) count_simulated(simulated, unsimulated);
    if (!ok) {
      failures_.emplace(key, why);
      return false;
    }
    std::size_t bytes = m->vertices.size() * sizeof(double);
    for (const auto& f : m->fields) bytes += f.size() * sizeof(double);
    // The least recently viewed maps go first once the cache is over budget (they are mapped
    // again on demand, which only costs time: a map is deterministic).
    while (!recent_.empty() && map_bytes_ + bytes > cache_budget_) {
      auto old = maps_.find(recent_.front());
      recent_.pop_front();
      map_bytes_ -= old->second.bytes;
      maps_.erase(old);
    }
    recent_.push_back(key);
    maps_.emplace(key, CachedMap{m, bytes, std::prev(recent_.end())});
    map_bytes_ += bytes;
    found = m;
  }
  v.hold = found;
  v.vertices = found->vertices.data();
  for (const auto& f : found->fields) v.fields.push_back(f.data());
  return true;
}

bool MeshProblem::simulate_on_mapped(int src, const Sample& canon, MappedSample& m,
                                     std::string& why) const {
  const Sample& s = sample(src);
  Sample mesh;
  if (!mapping::mesh_for_simulation(s, canon, m.vertices, mesh, why)) return false;
  const Sample r = exec_.simulate(point(src), mesh);
  if (!r.feasible) {
    why = r.message;
    return false;
  }
  std::vector<std::vector<double>> fields;
  for (const Field& f : s.fields) {
    const auto it = std::find_if(r.fields.begin(), r.fields.end(), [&](const Field& g) {
      return g.name == f.name && g.location == f.location && g.components == f.components;
    });
    if (it == r.fields.end()) {
      why = "simulate on the mapped mesh gave no field '" + f.name + "' like the sample's";
      return false;
    }
    fields.push_back(it->values);
  }
  m.fields = std::move(fields);
  return true;
}

void MeshProblem::count_simulated(bool simulated, const std::string& unsimulated) {
  if (simulated) {
    ++details_.mapped_simulated;
  } else if (details_.mapped_simulate_failures++ == 0) {
    details_.first_mapped_simulate_failure = unsimulated;
  }
}

const std::string& MeshProblem::why(int src, int canon) {
  std::lock_guard<std::mutex> lock(maps_mu_);
  return failures_[std::make_pair(src, canon)];
}

bool MeshProblem::map_terms(int at, int centre, const int* terms, int n) {
  std::vector<int> rows(terms, terms + n), todo;
  if (at >= 0) rows.push_back(at);
  {
    std::lock_guard<std::mutex> lock(maps_mu_);
    for (int row : rows) {
      const auto key = std::make_pair(row, centre);
      if (failures_.count(key)) return false;
      if (!same_class(row, centre) && !maps_.count(key)) todo.push_back(row);
    }
  }
  std::sort(todo.begin(), todo.end());
  todo.erase(std::unique(todo.begin(), todo.end()), todo.end());
  // One term the mapper refuses fails the whole test, so the others need not be mapped.
  std::atomic<bool> refused{false};
  mapping::parallel_for(todo.size(), spare_threads_, [&](std::size_t i) {
    View v;
    if (!refused.load(std::memory_order_relaxed) && !view(todo[i], centre, v))
      refused.store(true, std::memory_order_relaxed);
  });
  return !refused.load();
}

void MeshProblem::errors(const std::vector<ErrorQuery>& q, std::vector<double>& out) {
  out.assign(q.size(), 0.0);
  const int threads = std::max(1, exec_.concurrency());
  // A wave with fewer tests than threads lends the spare ones to each test: to its two
  // Hausdorff directions, and to mapping its terms (a cubic test has up to 4^K terms, each a
  // mapping that takes seconds on a CAD mesh). Otherwise one thread per test: a thread more per
  // test would only oversubscribe the cores, and a 1-thread build stays serial.
  const bool spare = q.size() < static_cast<std::size_t>(threads);
  hausdorff_threads_ = spare ? 2 : 1;
  spare_threads_ = spare ? threads / static_cast<int>(std::max<std::size_t>(1, q.size())) : 1;
  mapping::parallel_for(q.size(), threads, [&](std::size_t i) { out[i] = error(q[i]); });
  // The element stage calls quantity_errors from its own threads, one element each.
  spare_threads_ = 1;
}

bool MeshProblem::report_progress(int queued) {
  const int evaluated = report_.host_evaluations;
  return send_progress(
      queued, evaluated > 0 && queued > 0
                  ? host_seconds_done_ / evaluated * queued / std::max(1, exec_.concurrency())
                  : (queued > 0 ? -1.0 : 0.0));
}

bool MeshProblem::report_stage_progress(double eta_seconds) {
  return send_progress(0, eta_seconds);
}

bool MeshProblem::send_progress(int queued, double eta_seconds) {
  if (!opt_.progress) return false;
  cadinterp_progress p{};
  p.samples_done = done_;
  p.samples_queued = queued;
  p.elements = elements_;
  p.seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  p.eta_seconds = eta_seconds;
  return opt_.progress(p);
}

void MeshProblem::on_wave(int elements) {
  elements_ = elements;
  report_.elements = elements;
}

int MeshProblem::combinatorics_class(const Sample& s) {
  std::uint64_t h = s.vertex_count();
  auto mix = [&h](std::uint64_t v) { h = (h ^ v) * 0x100000001b3ull; };
  for (std::uint32_t v : s.tets) mix(v);
  for (std::uint32_t v : s.triangles) mix(v);
  for (std::int32_t v : s.triangle_tags) mix(static_cast<std::uint32_t>(v));
  for (int c : class_by_hash_[h])
    if (same_combinatorics(s, *representatives_[static_cast<std::size_t>(c)])) return c;
  const int c = static_cast<int>(representatives_.size());
  representatives_.push_back(&s);
  class_by_hash_[h].push_back(c);
  return c;
}

}  // namespace cadinterp::builder
