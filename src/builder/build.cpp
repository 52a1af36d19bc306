#include "builder/build.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <exception>
#include <iterator>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "builder/sample_store.h"
#include "mesh/surface_distance.h"
#include "cadinterp/cadinterp_version.h"
#include "core/adaptive.h"
#include "mapping/canonical_refine.h"
#include "mapping/field_transfer.h"
#include "mapping/interior_solve.h"
#include "mapping/mesh_mapper.h"
#include "mapping/neighbour_transfer.h"

namespace cadinterp::builder {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Adds the wall time of a scope to `total` when the scope ends, by return or by exception, so a
// failed build still reports where its time went. `excluded` (may be null) is a stage timed
// inside this one: its growth during the scope is subtracted.
class StageTimer {
 public:
  StageTimer(double& total, const double* excluded = nullptr)
      : total_(total), excluded_(excluded), excluded0_(excluded ? *excluded : 0.0) {}
  ~StageTimer() { total_ += seconds_since(t0_) - (excluded_ ? *excluded_ - excluded0_ : 0.0); }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  double& total_;
  const double* excluded_;
  double excluded0_;
  Clock::time_point t0_ = Clock::now();
};

// Counts `message` among the first kMaxReasons distinct ones (first-seen order), or in `other`.
void count_reason(std::vector<BuildReport::Reason>& reasons, int& other, const std::string& message,
                  const std::vector<double>& x) {
  for (BuildReport::Reason& r : reasons)
    if (r.message == message) {
      ++r.count;
      return;
    }
  if (reasons.size() < BuildReport::kMaxReasons) {
    reasons.push_back({message, 1, x});
    return;
  }
  ++other;
}

// "'a' x3; 'b' x1; 2 more with other messages": the first `shown` reasons, for exception
// messages (each message cut to 200 characters: hosts may return long diagnostics).
std::string reasons_text(const std::vector<BuildReport::Reason>& reasons, int other,
                         std::size_t shown = 3) {
  std::string t;
  int hidden = other;
  for (std::size_t i = 0; i < reasons.size(); ++i) {
    if (i >= shown) {
      hidden += reasons[i].count;
      continue;
    }
    std::string m = reasons[i].message;
    if (m.size() > 200) m = m.substr(0, 197) + "...";
    if (!t.empty()) t += "; ";
    t += "'" + m + "' x" + std::to_string(reasons[i].count);
  }
  if (hidden > 0)
    t += (t.empty() ? "" : "; ") + std::to_string(hidden) + " more with other messages";
  return t;
}

std::string hex_double(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

// The field layout every feasible sample of a build must share (cadinterp_sample_add_field).
struct FieldSignature {
  std::vector<std::string> names;
  std::vector<int> locations, components;
  static FieldSignature of(const Sample& s) {
    FieldSignature f;
    for (const Field& x : s.fields) {
      f.names.push_back(x.name);
      f.locations.push_back(x.location);
      f.components.push_back(x.components);
    }
    return f;
  }
  bool operator==(const FieldSignature& o) const {
    return names == o.names && locations == o.locations && components == o.components;
  }
};

// The driver's problem over meshes: rows are host samples (from the store or the executor);
// errors are measured on meshes mapped into the element's canonical combinatorics.
class MeshProblem final : public core::AdaptiveProblem {
 public:
  MeshProblem(const Host& host, const BuildOptions& opt, const Mapper& mapper, Executor& exec,
              SampleStore* store, BuildReport& report, Clock::time_point start)
      : host_(host),
        opt_(opt),
        mapper_(mapper),
        exec_(exec),
        store_(store),
        details_(report),
        report_(report.counts),
        start_(start) {}

  void evaluate(const std::vector<int>& rows, const std::vector<double>& x,
                std::vector<char>& feasible) override {
    const StageTimer timer(details_.sampling_seconds);
    details_.points_requested += static_cast<int>(rows.size());
    // Until the basis exists, `samples` says how many points were asked for (BuildReport).
    report_.samples = details_.points_requested;
    const std::size_t K = static_cast<std::size_t>(host_.dim());
    std::vector<std::vector<double>> pending;
    std::vector<int> pending_rows;
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
          bad->message = "the host's fields differ from those of the build's first sample";
          s = bad;
        }
      }
      feasible[i] = s->feasible ? 1 : 0;
      if (!s->feasible) {
        ++report_.infeasible_points;
        count_reason(details_.infeasible_reasons, details_.other_infeasible_points, s->message,
                     points_[r]);
      }
      if (classes_.size() <= r) classes_.resize(r + 1, -1);
      if (s->feasible) classes_[r] = combinatorics_class(*s);
    }
    report_progress(0);
  }

  double interpolation_error(int at, int centre, const int* terms, const double* psi,
                             int n) override {
    const Sample& canon = sample(centre);
    const std::size_t nv3 = canon.vertices.size();
    std::vector<double> V(nv3, 0.0);
    const std::size_t nfields = canon.fields.size();
    std::vector<std::vector<double>> F(nfields);
    for (std::size_t f = 0; f < nfields; ++f) F[f].assign(canon.fields[f].values.size(), 0.0);
    View m;
    for (int t = 0; t < n; ++t) {
      if (!view(terms[t], centre, m)) return std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < nv3; ++i) V[i] += psi[t] * m.vertices[i];
      for (std::size_t f = 0; f < nfields; ++f)
        for (std::size_t i = 0; i < F[f].size(); ++i) F[f][i] += psi[t] * m.fields[f][i];
    }
    const Sample& truth = sample(at);
    const double target = truth.bbox_diagonal() * opt_.geometry_tolerance;
    double err = -1;
    if (classes_[static_cast<std::size_t>(at)] == classes_[static_cast<std::size_t>(centre)]) {
      // Same mesh: the largest vertex displacement bounds the Hausdorff distance from above
      // (corresponding triangles are within it everywhere), and settles most tests in O(V);
      // only above the target is the exact distance worth its cost.
      double d2 = 0;
      for (std::size_t i = 0; i < nv3; i += 3) {
        double q = 0;
        for (std::size_t c = 0; c < 3; ++c)
          q += (V[i + c] - truth.vertices[i + c]) * (V[i + c] - truth.vertices[i + c]);
        d2 = std::max(d2, q);
      }
      if (std::sqrt(d2) <= target) err = std::sqrt(d2) / target;
    }
    if (err < 0)
      err = symmetric_hausdorff(V, canon.triangles, truth.vertices, truth.triangles) / target;
    if (nfields) {
      if (!view(at, centre, m)) return std::numeric_limits<double>::infinity();
      for (std::size_t f = 0; f < nfields; ++f) {
        const std::vector<double>& tv = truth.fields[f].values;
        const auto mm = std::minmax_element(tv.begin(), tv.end());
        // A constant field is measured against its magnitude instead (and 1 if it is 0).
        double range = *mm.second - *mm.first;
        if (!(range > 0)) range = std::max(std::abs(*mm.first), 1.0);
        double e = 0;
        for (std::size_t i = 0; i < F[f].size(); ++i)
          e = std::max(e, std::abs(F[f][i] - m.fields[f][i]));
        err = std::max(err, e / (range * opt_.field_tolerance));
      }
    }
    return err;
  }

  double midpoint_error(int a, int b, int c) override {
    const int terms[2] = {a, b};
    const double psi[2] = {0.5, 0.5};
    return interpolation_error(c, c, terms, psi, 2);
  }

  const Sample& sample(int row) const { return *samples_[static_cast<std::size_t>(row)]; }
  const std::vector<double>& point(int row) const { return points_[static_cast<std::size_t>(row)]; }
  int rows() const { return static_cast<int>(samples_.size()); }

  /// Row `src`'s vertices and fields in the combinatorics of row `canon`: the source's own
  /// arrays where the two share combinatorics (identity, no copy), else the mapper's result,
  /// kept in a cache of bounded size. False (see why()) when the mapper cannot map them.
  struct View {
    const double* vertices = nullptr;
    std::vector<const double*> fields;
    std::shared_ptr<const MappedSample> hold;  // keeps a cached map alive while viewed
  };
  /// Thread-safe: the driver's errors() runs it from several threads.
  bool view(int src, int canon, View& v) {
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
      std::lock_guard<std::mutex> lock(maps_mu_);
      if (failures_.count(key)) return false;
      auto it = maps_.find(key);
      if (it != maps_.end()) found = it->second.first;
    }
    if (!found) {
      // Mapped outside the lock (mapping is the expensive part); two threads may map the same
      // pair, with the same deterministic result.
      auto m = std::make_shared<MappedSample>();
      std::string why;
      const bool ok = mapper_.map(sample(src), sample(canon), *m, why);
      std::string unsimulated;
      const bool simulated =
          ok && opt_.simulate_mapped && simulate_on_mapped(src, sample(canon), *m, unsimulated);
      std::lock_guard<std::mutex> lock(maps_mu_);
      if (ok && opt_.simulate_mapped) count_simulated(simulated, unsimulated);
      if (!ok) {
        failures_.emplace(key, why);
        return false;
      }
      std::size_t bytes = m->vertices.size() * sizeof(double);
      for (const auto& f : m->fields) bytes += f.size() * sizeof(double);
      // Oldest entries go first once the cache is over budget (maps are recomputed on demand).
      while (!order_.empty() && map_bytes_ + bytes > kMapCacheBytes) {
        auto old = maps_.find(order_.front());
        order_.pop_front();
        if (old == maps_.end()) continue;
        map_bytes_ -= old->second.second;
        maps_.erase(old);
      }
      if (maps_.emplace(key, std::make_pair(m, bytes)).second) {
        order_.push_back(key);
        map_bytes_ += bytes;
      }
      found = m;
    }
    v.hold = found;
    v.vertices = found->vertices.data();
    for (const auto& f : found->fields) v.fields.push_back(f.data());
    return true;
  }
  /// simulate_mapped: replaces the carried fields of `m` (row src mapped onto `canon`'s mesh)
  /// by the host's simulate at row src's x on that mesh. False with `why` (m untouched) where
  /// the regions cannot be placed, the host fails, or it returns other fields.
  bool simulate_on_mapped(int src, const Sample& canon, MappedSample& m, std::string& why) const {
    const Sample& s = sample(src);
    Sample mesh;
    if (!mapping::mesh_for_simulation(s, canon, m.vertices, mesh, why)) return false;
    const Sample r = host_.simulate(point(src).data(), mesh);
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

  /// Counts one simulate_mapped outcome (the caller holds maps_mu_ or runs alone).
  void count_simulated(bool simulated, const std::string& unsimulated) {
    if (simulated) {
      ++details_.mapped_simulated;
    } else if (details_.mapped_simulate_failures++ == 0) {
      details_.first_mapped_simulate_failure = unsimulated;
    }
  }
  /// True when rows a and b share combinatorics (their terms are blended without a mapping).
  bool same_class(int a, int b) const {
    return classes_[static_cast<std::size_t>(a)] == classes_[static_cast<std::size_t>(b)];
  }
  const Mapper& mapper() const { return mapper_; }

  const std::string& why(int src, int canon) {
    std::lock_guard<std::mutex> lock(maps_mu_);
    return failures_[std::make_pair(src, canon)];
  }

  /// The wave's refinement tests on the executor's thread count (each is independent).
  void errors(const std::vector<ErrorQuery>& q, std::vector<double>& out) override {
    out.assign(q.size(), 0.0);
    const std::size_t threads =
        std::min<std::size_t>(q.size(), static_cast<std::size_t>(std::max(1, exec_.concurrency())));
    if (threads <= 1) return AdaptiveProblem::errors(q, out);
    std::atomic<std::size_t> next{0};
    std::exception_ptr failure;
    std::mutex failure_mu;
    auto work = [&] {
      try {
        for (std::size_t i; (i = next.fetch_add(1)) < q.size();) out[i] = error(q[i]);
      } catch (...) {
        std::lock_guard<std::mutex> lock(failure_mu);
        if (!failure) failure = std::current_exception();
        next = q.size();
      }
    };
    std::vector<std::thread> pool;
    for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
    if (failure) std::rethrow_exception(failure);
  }

  /// Calls the progress callback; returns true to cancel.
  bool report_progress(int queued) {
    if (!opt_.progress) return false;
    cadinterp_progress p{};
    p.samples_done = done_;
    p.samples_queued = queued;
    p.elements = elements_;
    p.seconds = std::chrono::duration<double>(Clock::now() - start_).count();
    const int evaluated = report_.host_evaluations;
    p.eta_seconds = evaluated > 0 && queued > 0
                        ? host_seconds_done_ / evaluated * queued / std::max(1, exec_.concurrency())
                        : (queued > 0 ? -1.0 : 0.0);
    return opt_.progress(p);
  }
  void on_wave(int elements) override {
    elements_ = elements;
    report_.elements = elements;
  }

 private:
  static constexpr std::size_t kMapCacheBytes = std::size_t(512) << 20;

  // Rows with identical meshes (vertex count, tets, triangles, tags) share a class: the identity
  // mapping holds between them. Classes are numbered in row order, so deterministically.
  int combinatorics_class(const Sample& s) {
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

  const Host& host_;
  const BuildOptions& opt_;
  const Mapper& mapper_;
  Executor& exec_;
  SampleStore* store_;
  BuildReport& details_;
  cadinterp_build_report& report_;  // details_.counts
  Clock::time_point start_;
  std::vector<std::shared_ptr<const Sample>> samples_;  // per row
  std::vector<std::vector<double>> points_;             // per row
  std::optional<FieldSignature> signature_;
  std::vector<int> classes_;                    // per row (-1: infeasible)
  std::vector<const Sample*> representatives_;  // per class
  std::map<std::uint64_t, std::vector<int>> class_by_hash_;
  std::map<std::pair<int, int>, std::pair<std::shared_ptr<MappedSample>, std::size_t>> maps_;
  std::deque<std::pair<int, int>> order_;  // insertion order of maps_ (eviction)
  std::map<std::pair<int, int>, std::string> failures_;
  std::size_t map_bytes_ = 0;
  std::mutex maps_mu_;  // guards maps_, order_, failures_, map_bytes_
  int done_ = 0, elements_ = 0;
  double host_seconds_done_ = 0;
  bool cancel_ = false;
};

std::vector<float> to_float(const std::vector<double>& v) {
  return std::vector<float>(v.begin(), v.end());
}

}  // namespace

std::string store_fingerprint(const Host& host) {
  std::string fp = host.name() + "|" + host.identity() + "|K=" + std::to_string(host.dim());
  for (int d = 0; d < host.dim(); ++d)
    fp += "|" + host.names()[static_cast<std::size_t>(d)] + "[" +
          hex_double(host.lower()[static_cast<std::size_t>(d)]) + "," +
          hex_double(host.upper()[static_cast<std::size_t>(d)]) + "]";
  return fp;
}

const Mapper& default_mapper() {
  static const mapping::MeshMapper mesh;
  return mesh;
}

std::string options_json(const BuildOptions& o, const char* mapper_name) {
  return std::string("{\"degree\":") + std::to_string(static_cast<int>(o.degree)) +
         ",\"geometry_tolerance\":\"" + hex_double(o.geometry_tolerance) +
         "\",\"field_tolerance\":\"" + hex_double(o.field_tolerance) +
         "\",\"max_samples\":" + std::to_string(o.max_samples) +
         ",\"max_depth\":" + std::to_string(o.max_depth) + ",\"position_max_abs_error\":\"" +
         hex_double(o.position_max_abs_error) + "\",\"mapper\":\"" + mapper_name + "\"" +
         // Only a non-default transfer is recorded, so that default assets keep their bytes.
         (o.degree == core::Degree::Cubic && o.neighbour_transfer != NeighbourTransfer::Fallback
              ? std::string(",\"neighbour_transfer\":\"") +
                    (o.neighbour_transfer == NeighbourTransfer::Always ? "always" : "direct") + "\""
              : std::string()) +
         (o.simulate_mapped ? ",\"simulate_mapped\":true" : "") +
         ",\"canonical_refinement\":" + std::to_string(o.canonical_refinement) + "}";
}

namespace {

BuildResult build_stages(const Host& host, const BuildOptions& opt, BuildReport& details,
                         Clock::time_point start) {
  if (!(opt.geometry_tolerance > 0) || !(opt.field_tolerance > 0))
    throw std::invalid_argument("build: tolerances must be positive");
  if (opt.max_samples < 2) throw std::invalid_argument("build: max_samples must be at least 2");
  if (opt.max_depth < 1 || opt.max_depth >= core::kMaxLevel)
    throw std::invalid_argument("build: max_depth must be 1.." +
                                std::to_string(core::kMaxLevel - 1));
  if (opt.threads < 0) throw std::invalid_argument("build: threads must be >= 0");
  if (!(opt.position_max_abs_error >= 0))
    throw std::invalid_argument("build: position_max_abs_error must be >= 0");
  if (opt.simulate_mapped && !host.has_simulate())
    throw std::invalid_argument("build: simulate_mapped needs a host with a simulate callback");

  BuildResult out;
  cadinterp_build_report& rep = details.counts;
  const Mapper& mapper = opt.mapper ? *opt.mapper : default_mapper();
  const int threads = opt.threads > 0
                          ? opt.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  ThreadPoolExecutor pool(host, threads);
  Executor& exec = opt.executor ? *opt.executor : pool;

  std::unique_ptr<SampleStore> store;
  if (!opt.store_path.empty()) {
    const StageTimer timer(details.store_seconds);
    store = std::make_unique<SampleStore>(opt.store_path, store_fingerprint(host));
  }

  MeshProblem problem(host, opt, mapper, exec, store.get(), details, start);
  core::AdaptiveOptions ao;
  ao.degree = opt.degree;
  ao.tolerance = 1.0;  // errors are already relative to their targets
  ao.max_samples = opt.max_samples;
  ao.max_level = opt.max_depth;
  std::optional<StageTimer> refining(std::in_place, details.refinement_seconds,
                                     &details.sampling_seconds);
  core::AdaptiveRun run = core::adaptive_run(host.dim(), host.lower(), host.upper(), problem, ao);
  refining.reset();
  const StageTimer elements_timer(details.elements_seconds);

  const core::Basis& basis = run.basis;
  const int S = basis.sample_count();
  const std::vector<int> leaves = basis.tree().leaves();
  rep.samples = S;
  rep.elements = static_cast<int>(leaves.size());
  std::vector<bool> infeasible_sample(static_cast<std::size_t>(S));
  bool any = false;
  for (int k = 0; k < S; ++k) {
    const bool ok =
        run.row_feasible[static_cast<std::size_t>(run.sample_row[static_cast<std::size_t>(k)])] !=
        0;
    infeasible_sample[static_cast<std::size_t>(k)] = !ok;
    any = any || ok;
  }
  if (!any)
    throw BuildInfeasible(
        "the host failed at every sample point (" + std::to_string(rep.infeasible_points) +
        " points: " + reasons_text(details.infeasible_reasons, details.other_infeasible_points) +
        ")");
  for (int r = 0; r < problem.rows(); ++r)
    if (!problem.sample(r).feasible)
      out.infeasible.push_back({problem.point(r), problem.sample(r).message});

  core::CompiledBasis cb =
      core::CompiledBasis::compile(basis, host.lower(), host.upper(), &infeasible_sample);
  format::AssetContent& c = out.content;
  std::vector<std::uint8_t> element_ok(leaves.size(), 1);

  // Per element: canonical mesh = the host at its centre (§4.2); each term's sample mapped into
  // it. An element whose centre failed or whose terms cannot be mapped is infeasible.
  const bool cubic = opt.degree == core::Degree::Cubic;
  // The cubic neighbour transfer (§5.3, Fig. 15). A cubic element's terms include samples of
  // adjacent elements (Bbar(e)). Such a sample k can be mapped into the element's canonical mesh
  // directly (one §6 mapping, like every other term), or carried from the neighbour l''s
  // canonical mesh, where it is mapped anyway, through a sample s on both closed elements:
  // F: p_s^l -> p_s^{l'} computed once by barycentric coordinates (NeighbourBridge), so k still
  // goes through one homeomorphic mapping and errors do not accumulate. Measured on cubic
  // builds (cadinterp-mapping-report cubic, 120 samples; src/mapping/README.md), every
  // neighbour sample both ways against its own host sample (symmetric Hausdorff / diagonal):
  // foldplate (edge=10, neighbours across its B-rep topology change), 1841 neighbour terms:
  // direct max 1.2e-15, bridge max 1.7e-3 (mean 5.9e-5); plate (edge=8): both exact to rounding.
  // The direct mapping never failed. The bridge is not free of error (p_s^l's vertices are
  // interpolated in p_s^{l'}'s tets, a second discretization on top of the §6 mapping), so the
  // direct mapping stays the rule and the bridge is the fallback where it fails (e.g. a
  // neighbour sample whose layout cannot be paired with this element's canonical mesh while
  // both pair with the shared sample's). NeighbourTransfer::Always is kept for measurement.
  // Which neighbour and shared sample are used is a function of the tree alone: deterministic
  // at any thread count.
  const core::KdTree& tree = basis.tree();
  const int K = host.dim();
  auto bridge = [&](int leaf, int crow, int k, MappedSample& res) {
    const core::IBox& box = tree.node(leaf).box;
    const core::IPoint& pk = basis.sample(k);
    std::vector<int> around;
    tree.leaves_containing(pk, around);
    std::sort(around.begin(), around.end());
    for (int nb : around) {
      if (nb == leaf || !core::boxes_touch(tree.node(nb).box, box, K)) continue;
      const int nrow = run.centre_row[static_cast<std::size_t>(nb)];
      if (nrow < 0 || !problem.sample(nrow).feasible) continue;
      // The shared sample: a sample on both closed elements (B(l) and B(l'), not necessarily a
      // term: psi_s may vanish on l), feasible, nearest to k on the integer grid (smallest id on
      // ties).
      int s = -1;
      double best = std::numeric_limits<double>::infinity();
      const std::vector<int>& mine = basis.element_samples(leaf);
      const std::vector<int>& theirs = basis.element_samples(nb);
      std::vector<int> both;
      std::set_intersection(mine.begin(), mine.end(), theirs.begin(), theirs.end(),
                            std::back_inserter(both));
      for (int cand : both) {
        const int row = run.sample_row[static_cast<std::size_t>(cand)];
        if (cand == k || row < 0 || !problem.sample(row).feasible) continue;
        const core::IPoint& ps = basis.sample(cand);
        double d = 0;
        for (int a = 0; a < K; ++a)
          d += std::abs(static_cast<double>(ps[static_cast<std::size_t>(a)]) -
                        static_cast<double>(pk[static_cast<std::size_t>(a)]));
        if (d < best) {
          best = d;
          s = cand;
        }
      }
      if (s < 0) continue;
      const int krow = run.sample_row[static_cast<std::size_t>(k)];
      const int srow = run.sample_row[static_cast<std::size_t>(s)];
      MeshProblem::View pk_n, ps_n, ps_l;
      if (!problem.view(krow, nrow, pk_n) || !problem.view(srow, nrow, ps_n) ||
          !problem.view(srow, crow, ps_l))
        continue;
      const Sample& ncanon = problem.sample(nrow);
      const Sample& canon = problem.sample(crow);
      const std::size_t nv3 = ncanon.vertices.size();
      const mapping::NeighbourBridge br(
          ncanon, std::vector<double>(ps_n.vertices, ps_n.vertices + nv3), canon,
          std::vector<double>(ps_l.vertices, ps_l.vertices + canon.vertices.size()));
      MappedSample in;
      in.vertices.assign(pk_n.vertices, pk_n.vertices + nv3);
      for (std::size_t f = 0; f < ncanon.fields.size(); ++f)
        in.fields.emplace_back(pk_n.fields[f], pk_n.fields[f] + ncanon.fields[f].values.size());
      std::string why;
      if (!br.apply(in, res, why)) continue;
      // Never emit inverted tets (as the mapper itself refuses them).
      if (mapping::tet_quality(res.vertices, canon.tets).inverted > 0) {
        ++out.neighbour.bridge_inverted;
        continue;
      }
      return true;
    }
    ++out.neighbour.bridge_failed;
    return false;
  };
  // Both routes against the term's own sample (measurement only).
  auto compare_routes = [&](int row, int crow, const MappedSample* viab) {
    MeshProblem::View d;
    if (!viab || !problem.view(row, crow, d)) return;
    const Sample& src = problem.sample(row);
    const Sample& canon = problem.sample(crow);
    const double diag = src.bbox_diagonal();
    const std::vector<double> dv(d.vertices, d.vertices + canon.vertices.size());
    const double hd = symmetric_hausdorff(dv, canon.triangles, src.vertices, src.triangles) / diag;
    const double hb =
        symmetric_hausdorff(viab->vertices, canon.triangles, src.vertices, src.triangles) / diag;
    NeighbourTransferStats& st = out.neighbour;
    ++st.compared;
    st.bridged_better += hb < hd ? 1 : 0;
    st.direct_hausdorff_max = std::max(st.direct_hausdorff_max, hd);
    st.bridged_hausdorff_max = std::max(st.bridged_hausdorff_max, hb);
    st.direct_hausdorff_sum += hd;
    st.bridged_hausdorff_sum += hb;
    st.direct_min_sj =
        std::min(st.direct_min_sj, mapping::tet_quality(dv, canon.tets).min_scaled_jacobian);
    st.bridged_min_sj = std::min(
        st.bridged_min_sj, mapping::tet_quality(viab->vertices, canon.tets).min_scaled_jacobian);
  };
  const Sample* field_source = nullptr;
  for (std::size_t e = 0; e < leaves.size(); ++e) {
    format::ElementData ed;
    const int leaf = leaves[e];
    const double err = run.leaf_error[static_cast<std::size_t>(leaf)];
    ed.error_estimate = std::isfinite(err) ? err * opt.geometry_tolerance : -1.0;
    const int crow = run.centre_row[static_cast<std::size_t>(leaf)];
    int n = 0;
    const int* terms = cb.element_samples(static_cast<int>(e), &n);
    const bool samples_feasible =
        cb.element_feasible(static_cast<int>(e)) && crow >= 0 && problem.sample(crow).feasible;
    bool ok = samples_feasible;
    MeshProblem::View m;
    // Per term: nullptr where the term's view (direct mapping or identity) is used, else its
    // sample carried from a neighbour element through a shared sample (§5.3).
    std::vector<std::unique_ptr<MappedSample>> bridged(static_cast<std::size_t>(n));
    for (int t = 0; ok && t < n; ++t) {
      const int row = run.sample_row[static_cast<std::size_t>(terms[t])];
      bool direct = false;
      bool outside = false;
      outside = cubic && !core::box_contains(tree.node(leaf).box, basis.sample(terms[t]), K);
      if (outside) ++out.neighbour.neighbour_terms;
      if (outside &&
          (opt.neighbour_transfer == NeighbourTransfer::Always || opt.measure_neighbour_transfer)) {
        auto b = std::make_unique<MappedSample>();
        if (bridge(leaf, crow, terms[t], *b)) bridged[static_cast<std::size_t>(t)] = std::move(b);
      }
      if (opt.measure_neighbour_transfer && outside)
        compare_routes(row, crow, bridged[static_cast<std::size_t>(t)].get());
      if (opt.neighbour_transfer != NeighbourTransfer::Always)
        bridged[static_cast<std::size_t>(t)].reset();
      if (!bridged[static_cast<std::size_t>(t)]) direct = problem.view(row, crow, m);
      if (!direct && !bridged[static_cast<std::size_t>(t)] && outside) {
        ++out.neighbour.direct_failed;
        if (opt.neighbour_transfer == NeighbourTransfer::Fallback) {
          auto b = std::make_unique<MappedSample>();
          if (bridge(leaf, crow, terms[t], *b)) bridged[static_cast<std::size_t>(t)] = std::move(b);
        }
      }
      if (bridged[static_cast<std::size_t>(t)]) {
        ++out.neighbour.bridged;
      } else if (!direct) {
        const std::string& why = problem.why(row, crow);
        // The recorded point is the element's centre; the message names the term's own sample
        // as well, so that the failing pair can be mapped again on its own.
        std::string term = "element " + std::to_string(e) + ", term sample at (";
        for (std::size_t d = 0; d < problem.point(row).size(); ++d) {
          char v[32];
          std::snprintf(v, sizeof v, "%s%.6g", d ? ", " : "", problem.point(row)[d]);
          term += v;
        }
        out.infeasible.push_back({problem.point(crow), term + "): " + why});
        count_reason(details.element_reasons, details.other_infeasible_elements, why, {});
        ok = false;
      }
    }
    // Canonical refinement (mapping/canonical_refine.h): where a mapped term's boundary departs
    // from its own by more than 0.7 x the geometry tolerance (a bend of the term's shape under a
    // canonical triangle), the element's canonical mesh is refined there and every term mapped
    // again onto it. Elements with a term carried by the cubic neighbour transfer keep theirs
    // (the bridge is defined on the canonical sample's own mesh).
    Sample refined;
    std::vector<MappedSample> remapped;
    bool use_refined = false;
    if (ok && opt.canonical_refinement > 0 &&
        std::none_of(bridged.begin(), bridged.end(), [](const auto& b) { return b != nullptr; })) {
      const Sample& canon = problem.sample(crow);
      const double tolerance = 0.7 * opt.geometry_tolerance;
      // The terms as mapped already (every view exists: the loop above mapped them), from which
      // refinement starts.
      std::vector<const Sample*> sources;
      bool departs = false;
      for (int t = 0; t < n; ++t) {
        const int row = run.sample_row[static_cast<std::size_t>(terms[t])];
        sources.push_back(&problem.sample(row));
        problem.view(row, crow, m);
        MappedSample& r = remapped.emplace_back();
        r.vertices.assign(m.vertices, m.vertices + canon.vertices.size());
        for (std::size_t k = 0; k < canon.fields.size(); ++k)
          r.fields.emplace_back(m.fields[k], m.fields[k] + canon.fields[k].values.size());
        departs = departs || (!problem.same_class(row, crow) &&
                              mapping::mapped_departure(problem.sample(row), canon, r.vertices,
                                                        tolerance, nullptr) > tolerance);
      }
      if (departs) {
        mapping::RefineOptions ro;
        ro.tolerance = tolerance;
        ro.rounds = opt.canonical_refinement;
        ro.threads = std::max(1, exec.concurrency());
        mapping::RefineStats rs;
        std::string why;
        if (mapping::refine_canonical(sources, canon, problem.mapper(), refined, remapped, why, &rs,
                                      ro) &&
            rs.rounds > 0) {
          use_refined = true;
          ++details.refined_elements;
          details.refined_vertices += static_cast<int>(rs.added_vertices);
          for (int t = 0; opt.simulate_mapped && t < n; ++t) {
            std::string unsimulated;
            const bool simulated = problem.simulate_on_mapped(
                run.sample_row[static_cast<std::size_t>(terms[t])], refined,
                remapped[static_cast<std::size_t>(t)], unsimulated);
            problem.count_simulated(simulated, unsimulated);
          }
        }
      }
    }
    if (ok) {
      const Sample& canon = use_refined ? refined : problem.sample(crow);
      if (!field_source) field_source = &problem.sample(crow);
      const std::size_t nv3 = canon.vertices.size();
      ed.vertex_count = static_cast<std::uint32_t>(canon.vertex_count());
      ed.tets = canon.tets;
      ed.triangles = canon.triangles;
      ed.triangle_tags = canon.triangle_tags;
      ed.canonical = to_float(canon.vertices);
      // One term at a time: a view stays valid only until the next view() call.
      for (int t = 0; t < n; ++t) {
        const MappedSample* b = use_refined ? &remapped[static_cast<std::size_t>(t)]
                                            : bridged[static_cast<std::size_t>(t)].get();
        if (b) {
          m.vertices = b->vertices.data();
          m.fields.clear();
          for (const auto& f : b->fields) m.fields.push_back(f.data());
          m.hold.reset();
        } else {
          problem.view(run.sample_row[static_cast<std::size_t>(terms[t])], crow, m);
        }
        ed.positions.emplace_back(m.vertices, m.vertices + nv3);
        if (!canon.fields.empty()) {
          std::vector<float> f;
          for (std::size_t k = 0; k < canon.fields.size(); ++k)
            f.insert(f.end(), m.fields[k], m.fields[k] + canon.fields[k].values.size());
          ed.fields.push_back(std::move(f));
        }
      }
      rep.stored_meshes += n;
      if (std::isfinite(err)) rep.max_error = std::max(rep.max_error, err);
    } else {
      element_ok[e] = 0;
      ++rep.infeasible_elements;
      if (samples_feasible) ++details.unmapped_elements;
    }
    c.elements.push_back(std::move(ed));
  }
  if (!field_source) {
    std::string why =
        "no element could be built (all " + std::to_string(leaves.size()) + " infeasible)";
    if (!details.element_reasons.empty())
      why +=
          "; elements: " + reasons_text(details.element_reasons, details.other_infeasible_elements);
    if (!details.infeasible_reasons.empty())
      why +=
          "; points: " + reasons_text(details.infeasible_reasons, details.other_infeasible_points);
    throw BuildInfeasible(why);
  }

  core::CompiledBasis::Parts parts = cb.parts();
  for (std::size_t e = 0; e < leaves.size(); ++e)
    parts.elem_feasible[e] = static_cast<std::uint8_t>(parts.elem_feasible[e] && element_ok[e]);
  out.basis =
      std::make_unique<core::CompiledBasis>(core::CompiledBasis::from_parts(std::move(parts)));
  c.basis = out.basis.get();
  for (int d = 0; d < host.dim(); ++d)
    c.parameters.push_back(
        {host.names()[static_cast<std::size_t>(d)], host.units()[static_cast<std::size_t>(d)],
         host.lower()[static_cast<std::size_t>(d)], host.upper()[static_cast<std::size_t>(d)]});
  for (const Field& f : field_source->fields)
    c.fields.push_back(
        {f.name, f.location == 0 ? format::FieldLocation::Vertex : format::FieldLocation::Tet,
         f.components, f.unit});
  for (const Region& r : field_source->regions) c.regions.push_back({r.name, r.kind, r.face_tags});
  c.builder_version = std::to_string(CADINTERP_VERSION_MAJOR) + "." +
                      std::to_string(CADINTERP_VERSION_MINOR) + "." +
                      std::to_string(CADINTERP_VERSION_PATCH);
  c.host = host.name();
  c.options_json = options_json(opt, mapper.name());
  for (const InfeasiblePoint& f : out.infeasible) c.infeasible.push_back({f.x, f.message});

  rep.budget_exhausted = run.budget_exhausted ? 1 : 0;
  return out;
}

}  // namespace

BuildResult build(const Host& host, const BuildOptions& opt, BuildReport* report) {
  const auto start = Clock::now();
  BuildReport local;
  BuildReport& details = report ? *report : local;
  details = BuildReport{};
  // Whatever ends the build, the report says how far it got: every stage writes its counts
  // into `details` as it goes, and only the wall time and the failure are added here.
  try {
    BuildResult out = build_stages(host, opt, details, start);
    details.counts.wall_seconds = seconds_since(start);
    out.report = details.counts;
    out.details = details;
    return out;
  } catch (const std::exception& e) {
    details.counts.wall_seconds = seconds_since(start);
    details.failure = e.what();
    throw;
  } catch (...) {
    details.counts.wall_seconds = seconds_since(start);
    details.failure = "unknown exception";
    throw;
  }
}

}  // namespace cadinterp::builder
