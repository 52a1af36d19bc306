// The adaptive sampling problem over meshes (paper §4.2): what core::adaptive_run asks of the
// builder. It owns the build's rows (host samples, from the sample store or the executor), their
// combinatorics classes, and the cache of rows mapped into other rows' canonical meshes (§6);
// the refinement test is the error of build.h over those maps. The element stage
// (element_stage.h) reads the same rows and maps after the refinement.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "builder/build.h"
#include "builder/sample_store.h"
#include "builder/stage_report.h"
#include "core/adaptive.h"

namespace cadinterp::builder {

// The field layout every feasible sample of a build must share (cadinterp_sample_add_field).
struct FieldSignature {
  std::vector<std::string> names;
  std::vector<int> locations, components;
  std::vector<std::string> outputs;  ///< the scalar outputs' names, in order
  static FieldSignature of(const Sample& s);
  bool operator==(const FieldSignature& o) const {
    return names == o.names && locations == o.locations && components == o.components &&
           outputs == o.outputs;
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
        start_(start),
        cache_budget_(opt.map_cache_bytes ? opt.map_cache_bytes : default_map_cache_bytes()) {}

  /// A wave of rows: from the store where it has them, else from the host through the
  /// executor (each stored as it arrives); feasibility and reasons decided in row order.
  /// Throws BuildCancelled when the progress callback or the executor cancels.
  void evaluate(const std::vector<int>& rows, const std::vector<double>& x,
                std::vector<char>& feasible) override;
  /// The refinement test of build.h on the terms mapped into the canonical mesh of `centre`
  /// (infinity where a term cannot be mapped).
  double interpolation_error(int at, int centre, const int* terms, const double* psi,
                             int n) override;
  double midpoint_error(int a, int b, int c) override;
  /// The refinement test's measures, per quantity and unscaled by the tolerances: out[0] the
  /// geometric error relative to the bbox diagonal of row `at` (the largest vertex displacement
  /// where rows share combinatorics and it is at most geometry_cutoff, an upper bound of the
  /// symmetric Hausdorff distance, else that distance), out[1 + f] field f's largest error
  /// relative to its range in row `at`. False where a term cannot be mapped. Thread-safe.
  /// With `located`, each per-vertex field is compared at the interpolated vertex positions with
  /// row `at`'s own field located there (barycentric in its tets), as measure_accuracy compares
  /// an asset with its host (located_errors.h), where a term or `at` is mapped onto `centre`'s
  /// combinatorics; else, and for per-tet fields, value by value with row `at` in the canonical
  /// mesh of `centre`.
  bool quantity_errors(int at, int centre, const int* terms, const double* psi, int n,
                       double geometry_cutoff, std::vector<double>& out, bool located = false);
  /// The wave's refinement tests on the executor's thread count (each is independent).
  void errors(const std::vector<ErrorQuery>& q, std::vector<double>& out) override;
  void on_wave(int elements) override;

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
  /// Thread-safe: the driver's errors() runs it from several threads. A pair another thread is
  /// mapping is waited for, not mapped again, so each pair is mapped once while it is cached.
  bool view(int src, int canon, View& v);
  /// simulate_mapped: replaces the carried fields of `m` (row src mapped onto `canon`'s mesh)
  /// by the host's simulate at row src's x on that mesh. False with `why` (m untouched) where
  /// the regions cannot be placed, the host fails, or it returns other fields.
  bool simulate_on_mapped(int src, const Sample& canon, MappedSample& m, std::string& why) const;
  /// Counts one simulate_mapped outcome (the caller holds maps_mu_ or runs alone).
  void count_simulated(bool simulated, const std::string& unsimulated);
  /// True when rows a and b share combinatorics (their terms are blended without a mapping).
  bool same_class(int a, int b) const {
    return classes_[static_cast<std::size_t>(a)] == classes_[static_cast<std::size_t>(b)];
  }
  const Mapper& mapper() const { return mapper_; }
  /// The mapper's message for a pair view() could not map.
  const std::string& why(int src, int canon);

  /// Calls the progress callback; returns true to cancel.
  bool report_progress(int queued);
  /// Calls the progress callback for a stage after sampling (every sample done, none queued)
  /// with `eta_seconds` left (< 0: unknown); returns true to cancel.
  bool report_stage_progress(double eta_seconds);

 private:
  // Maps the distinct rows one test views (its terms, and `at` unless it is -1) that are not in
  // the cache onto `centre`, on spare_threads_ threads, so that the test's sum, in term order,
  // finds them there and its result does not depend on the thread count. False as soon as one
  // row cannot be mapped (the test fails then whatever the others give).
  bool map_terms(int at, int centre, const int* terms, int n);

  // Rows with identical meshes (vertex count, tets, triangles, tags) share a class: the identity
  // mapping holds between them. Classes are numbered in row order, so deterministically.
  int combinatorics_class(const Sample& s);
  bool send_progress(int queued, double eta_seconds);

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
  // The map cache: pairs (source row, canonical row) to their maps, least recently viewed first
  // in `recent_` (evicted first once map_bytes_ would exceed cache_budget_).
  struct CachedMap {
    std::shared_ptr<MappedSample> map;
    std::size_t bytes = 0;
    std::list<std::pair<int, int>>::iterator recent;
  };
  std::map<std::pair<int, int>, CachedMap> maps_;
  std::list<std::pair<int, int>> recent_;
  std::map<std::pair<int, int>, std::string> failures_;
  const std::size_t cache_budget_;
  std::size_t map_bytes_ = 0;
  std::set<std::pair<int, int>> mapping_;  // pairs a thread is mapping now
  std::set<std::pair<int, int>> mapped_;   // pairs mapped so far (a map again counts in details_)
  std::condition_variable mapped_cv_;      // signalled when a pair leaves mapping_
  std::mutex maps_mu_;  // guards maps_, recent_, failures_, map_bytes_, mapping_, mapped_
  // Threads each refinement test's symmetric Hausdorff distance may use (set by errors()).
  int hausdorff_threads_ = 1;
  // Threads each refinement test may map its terms on (set by errors() for its wave; 1 outside
  // it, where the element stage runs one element per thread).
  int spare_threads_ = 1;
  int done_ = 0, elements_ = 0;
  double host_seconds_done_ = 0;
  bool cancel_ = false;
};

}  // namespace cadinterp::builder
