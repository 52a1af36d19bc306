// The element stage (element_stage.h): per element of the refined K-d tree, its canonical mesh,
// its terms in that mesh's combinatorics (§6; the cubic neighbour transfer of §5.3), the
// canonical refinement, and the element record the asset writer stores.
#include "builder/element_stage.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <thread>

#include "builder/stage_report.h"
#include "format/error_model.h"
#include "mapping/canonical_refine.h"
#include "mapping/interior_solve.h"
#include "mapping/neighbour_transfer.h"
#include "mapping/parallel_for.h"
#include "mesh/surface_distance.h"

namespace cadinterp::builder {

namespace {

std::vector<float> to_float(const std::vector<double>& v) {
  return std::vector<float>(v.begin(), v.end());
}

template <typename T>
void release(std::vector<T>& v) {
  std::vector<T>().swap(v);
}

// BuildOptions::encode_elements: the element's meshes encoded now, on the thread that built it,
// and its arrays released, so that the stage holds every element compressed: a cubic element of
// a four- or five-parameter model stores hundreds of terms of a float per vertex coordinate and
// field value (src/builder/README.md, "Memory"). The writer stores these blobs as they are, the
// same bytes it would encode from the arrays.
void encode_and_release(format::ElementData& ed, const format::WriteOptions& w) {
  ed.encoded = std::make_shared<const format::EncodedMeshes>(format::encode_element_meshes(ed, w));
  release(ed.tets);
  release(ed.triangles);
  release(ed.triangle_tags);
  release(ed.canonical);
  release(ed.positions);
  release(ed.fields);
}

// Per element: canonical mesh = the host at its centre (§4.2); each term's sample mapped into
// it. An element whose centre failed or whose terms cannot be mapped is infeasible.
//
// What building one element adds to the build's report and result. Elements are built on the
// executor's thread count, each into its own tally, and the tallies are merged in element order:
// the asset, the sums and the first reasons recorded do not depend on which thread built what.
struct ElementTally {
  format::ElementData ed;
  bool ok = false, samples_feasible = false;
  bool mapped = false;  // a term is stored other than as its sample's own mesh
  int stored_meshes = 0;
  bool refined = false;
  std::size_t refined_vertices = 0;
  NeighbourTransferStats neighbour;
  // The term that could not be mapped (at most one): its record and the mapper's reason.
  std::vector<std::pair<InfeasiblePoint, std::string>> refused;
  std::vector<std::pair<bool, std::string>> simulated;  // simulate_mapped outcomes, in order
  bool corner_fallback = false;  // built again on its corner fallback (fall_back_to_corners)
};

void add(NeighbourTransferStats& to, const NeighbourTransferStats& d) {
  to.neighbour_terms += d.neighbour_terms;
  to.direct_failed += d.direct_failed;
  to.bridged += d.bridged;
  to.bridge_failed += d.bridge_failed;
  to.compared += d.compared;
  to.bridged_better += d.bridged_better;
  to.bridge_inverted += d.bridge_inverted;
  to.direct_hausdorff_max = std::max(to.direct_hausdorff_max, d.direct_hausdorff_max);
  to.bridged_hausdorff_max = std::max(to.bridged_hausdorff_max, d.bridged_hausdorff_max);
  to.direct_hausdorff_sum += d.direct_hausdorff_sum;
  to.bridged_hausdorff_sum += d.bridged_hausdorff_sum;
  to.direct_min_sj = std::min(to.direct_min_sj, d.direct_min_sj);
  to.bridged_min_sj = std::min(to.bridged_min_sj, d.bridged_min_sj);
}

// The cubic neighbour transfer (§5.3, Fig. 15). A cubic element's terms include samples of
// adjacent elements (Bbar(e)). Such a sample k can be mapped into the element's canonical mesh
// directly (one §6 mapping, like every other term), or carried from the neighbour l''s
// canonical mesh, where it is mapped anyway, through a sample s on both closed elements:
// F: p_s^l -> p_s^{l'} computed once by barycentric coordinates (NeighbourBridge), so k still
// goes through one homeomorphic mapping and errors do not accumulate. The bridge is not free of
// error, though: p_s^l's vertices are interpolated in p_s^{l'}'s tets, a second discretization
// on top of the §6 mapping, which the direct route does not add (`cadinterp-mapping-report
// cubic` measures both routes against the host; docs/mapping-decisions.md, "Fields"). So the direct
// mapping is the rule and the bridge the fallback where it fails (e.g. a neighbour sample whose
// layout cannot be paired with this element's canonical mesh while both pair with the shared
// sample's). NeighbourTransfer::Always exists to measure the bridge. Which neighbour and shared
// sample are used is a function of the tree alone: deterministic at any thread count.
class ElementStage {
 public:
  ElementStage(const Host& host, const BuildOptions& opt, Executor& exec, MeshProblem& problem,
               const core::AdaptiveRun& run, core::CompiledBasis& cb,
               const std::vector<bool>& infeasible_sample, const std::vector<int>& leaves,
               BuildReport& details, BuildResult& out, std::vector<std::uint8_t>& element_ok,
               HeldOutPoints* held_out)
      : opt_(opt),
        exec_(exec),
        problem_(problem),
        run_(run),
        basis_(run.basis),
        tree_(run.basis.tree()),
        cb_(cb),
        infeasible_sample_(infeasible_sample),
        leaves_(leaves),
        details_(details),
        rep_(details.counts),
        out_(out),
        element_ok_(element_ok),
        held_out_(held_out),
        K_(host.dim()),
        cubic_(opt.degree == core::Degree::Cubic) {}

  // Elements are independent (each reads the rows and the thread-safe map cache, and writes
  // its own tally), so they are built in parallel; the canonical refinement inside one runs on
  // the same thread count, since a refined element can take far longer than the others.
  const Sample* run() {
    for (int r = 0; r < problem_.rows(); ++r) rows_by_point_.emplace(problem_.point(r), r);
    std::vector<ElementTally> tallies(leaves_.size());
    mapping::parallel_for(tallies.size(), exec_.concurrency(), [&](std::size_t e) {
      poll();
      build_element(e, tallies[e]);
      ++elements_done_;
    });
    fall_back_to_corners(tallies);
    set_field_floors(tallies);
    const Sample* field_source = nullptr;
    for (std::size_t e = 0; e < tallies.size(); ++e) merge(e, tallies[e], field_source);
    return field_source;
  }

 private:
  bool stop_requested();
  void poll();
  void build_element(std::size_t e, ElementTally& tally);
  void fall_back_to_corners(std::vector<ElementTally>& tallies);
  void merge(std::size_t e, ElementTally& tally, const Sample*& field_source);
  void set_field_floors(std::vector<ElementTally>& tallies) const;
  bool map_term(std::size_t e, int leaf, int crow, int k, std::unique_ptr<MappedSample>& bridged,
                ElementTally& tally);
  void refuse_term(std::size_t e, int row, int crow, ElementTally& tally);
  void write_element(format::ElementData& ed, const Sample& canon, int crow, const int* terms,
                     int n, const std::vector<const MappedSample*>& carried);
  bool refine(int crow, const int* terms, int n, Sample& refined,
              std::vector<MappedSample>& remapped, ElementTally& tally);
  bool bridge(int leaf, int crow, int k, MappedSample& res, NeighbourTransferStats& st);
  int shared_sample(int leaf, int nb, int k) const;
  bool carry(int k, int s, int nrow, int crow, MappedSample& res, NeighbourTransferStats& st);
  void compare_routes(int row, int crow, const MappedSample* viab, NeighbourTransferStats& st);
  void measure_error_model(std::size_t e, int leaf, int crow, format::ElementData& ed);
  double geometry_floor(int leaf, int crow, const int* terms, int n,
                        const std::vector<const MappedSample*>& carried,
                        const format::ElementData& ed);
  bool measure_at(std::size_t e, int at, int crow, const std::vector<double>& x,
                  std::vector<double>& q);
  int feasible_row(const std::vector<double>& x) const;
  void measure_held_out(std::size_t e, const format::ElementData& ed, const int* terms, int n);

  const BuildOptions& opt_;
  Executor& exec_;
  MeshProblem& problem_;
  const core::AdaptiveRun& run_;
  const core::Basis& basis_;
  const core::KdTree& tree_;
  core::CompiledBasis& cb_;  // recompiled by fall_back_to_corners
  const std::vector<bool>& infeasible_sample_;
  const std::vector<int>& leaves_;
  BuildReport& details_;
  cadinterp_build_report& rep_;  // details_.counts
  BuildResult& out_;
  std::vector<std::uint8_t>& element_ok_;
  HeldOutPoints* held_out_;  // may be null; each element writes only its own points' errors
  const int K_;
  const bool cubic_;
  std::map<std::vector<double>, int> rows_by_point_;  // the rows' x, exactly as evaluated
  const std::thread::id caller_ = std::this_thread::get_id();
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  std::atomic<int> elements_done_{0};
  std::atomic<bool> cancelled_{false};
};

// Progress and cancellation between terms (an element of a cubic 5-D asset maps hundreds of
// terms, minutes of work on CAD meshes). The callback may run only on the builder's calling
// thread (cadinterp_progress_fn), which builds elements too, so that thread reports; the others
// see its answer through cancelled_ and stop at their next term. The samples are all stored
// already, so a cancel loses only the element stage's own work.
bool ElementStage::stop_requested() {
  if (std::this_thread::get_id() == caller_ && !cancelled_) {
    const int done = elements_done_.load();
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    const double left = static_cast<double>(leaves_.size()) - done;
    if (problem_.report_stage_progress(done > 0 ? s / done * left : -1.0)) cancelled_ = true;
  }
  return cancelled_;
}

void ElementStage::poll() {
  if (stop_requested()) throw BuildCancelled();
}

// Element e (leaves_[e]): its terms, the canonical refinement where they depart from their own
// boundaries, and its record (kept in the tally, refused or not).
void ElementStage::build_element(std::size_t e, ElementTally& tally) {
  format::ElementData& ed = tally.ed;
  const int leaf = leaves_[e];
  ed.error_estimate = -1.0;  // measured below once the element is built
  const int crow = run_.centre_row[static_cast<std::size_t>(leaf)];
  int n = 0;
  const int* terms = cb_.element_samples(static_cast<int>(e), &n);
  tally.samples_feasible =
      cb_.element_feasible(static_cast<int>(e)) && crow >= 0 && problem_.sample(crow).feasible;
  bool ok = tally.samples_feasible;
  // Per term: nullptr where the term's view (direct mapping or identity) is used, else its
  // sample carried from a neighbour element through a shared sample (§5.3).
  std::vector<std::unique_ptr<MappedSample>> bridged(static_cast<std::size_t>(n));
  for (int t = 0; ok && t < n; ++t) {
    poll();
    ok = map_term(e, leaf, crow, terms[t], bridged[static_cast<std::size_t>(t)], tally);
  }
  Sample refined;
  std::vector<MappedSample> remapped;
  bool use_refined = false;
  // Elements with a term carried by the cubic neighbour transfer keep their canonical mesh (the
  // bridge is defined on the canonical sample's own mesh).
  if (ok && opt_.canonical_refinement > 0 &&
      std::none_of(bridged.begin(), bridged.end(), [](const auto& b) { return b != nullptr; }))
    use_refined = refine(crow, terms, n, refined, remapped, tally);
  poll();
  tally.ok = ok;
  if (!ok) return;
  const Sample& canon = use_refined ? refined : problem_.sample(crow);
  std::vector<const MappedSample*> carried(static_cast<std::size_t>(n));
  for (int t = 0; t < n; ++t)
    carried[static_cast<std::size_t>(t)] = use_refined ? &remapped[static_cast<std::size_t>(t)]
                                                       : bridged[static_cast<std::size_t>(t)].get();
  write_element(ed, canon, crow, terms, n, carried);
  tally.stored_meshes = n;
  for (int t = 0; t < n; ++t)
    tally.mapped = tally.mapped || carried[static_cast<std::size_t>(t)] ||
                   !problem_.same_class(run_.sample_row[static_cast<std::size_t>(terms[t])], crow);
  measure_error_model(e, leaf, crow, ed);
  if (!ed.error_model.empty()) {
    ed.geometry_floor = geometry_floor(leaf, crow, terms, n, carried, ed);
    if (ed.error_estimate >= 0)
      ed.error_estimate = format::error_model_with_floor(
          ed.error_estimate, cb_.element_cubic(static_cast<int>(e)), ed.geometry_floor);
  }
  if (held_out_) measure_held_out(e, ed, terms, n);
  if (opt_.encode_elements) encode_and_release(ed, asset_write_options(opt_));
}

// The held-out points in element e, where the host answered: the meshes the element stores
// (canonical refinement included), blended there, against the host's answer (calibration.h).
void ElementStage::measure_held_out(std::size_t e, const format::ElementData& ed, const int* terms,
                                    int n) {
  core::EvalWorkspace ws = cb_.make_workspace();
  for (int i : held_out_->in_element[e]) {
    const auto u = static_cast<std::size_t>(i);
    const Sample& truth = problem_.sample(held_out_->row[u]);
    if (!truth.feasible) continue;
    core::BasisWeights w;
    cb_.eval_element(static_cast<int>(e), held_out_->x[u].data(), ws, false, &w);
    stored_errors(ed, terms, n, w, truth, held_out_->error[u]);
  }
}

// A cubic element refused because one of its terms could not be mapped onto its canonical mesh
// (its samples all feasible; typically a neighbour sample of §5.3 across a change the mapper
// cannot bridge, two widths from the element) is built again on its corner fallback, as an
// element whose B-splines reach a failed sample is (core::CompiledBasis::compile): its 2^K
// corners, multilinear, which the linear build maps. Paper §4.2's locality holds there: the
// element needs only its own samples. The basis is recompiled with those elements flagged (the
// others keep their terms and records), and they are built on the build's threads again; one
// whose corners do not all map stays refused, for a corner's reason.
void ElementStage::fall_back_to_corners(std::vector<ElementTally>& tallies) {
  if (!cubic_) return;
  std::vector<bool> flags(leaves_.size(), false);
  std::vector<std::size_t> again;
  for (std::size_t e = 0; e < tallies.size(); ++e)
    if (!tallies[e].ok && tallies[e].samples_feasible && cb_.element_cubic(static_cast<int>(e))) {
      flags[e] = true;
      again.push_back(e);
    }
  if (again.empty()) return;
  const std::vector<double> lo = cb_.lower(), hi = cb_.upper();
  cb_ = core::CompiledBasis::compile(basis_, lo, hi, &infeasible_sample_, true, &flags);
  mapping::parallel_for(again.size(), exec_.concurrency(), [&](std::size_t i) {
    const std::size_t e = again[i];
    if (cb_.element_cubic(static_cast<int>(e))) return;  // no corner fallback: stays refused
    poll();
    ElementTally t;
    build_element(e, t);
    t.corner_fallback = true;
    tallies[e] = std::move(t);
  });
}

// The geometry's error at the element's own samples (format 1.3 ElementMeshes.geometry_floor),
// where the error model's shape is 0: at such a sample the element evaluates to the sample's
// stored mesh, in the canonical mesh's combinatorics, and the host answers with the sample's own
// mesh; the two differ where the term was mapped (§6), by how the two meshes' flat triangles
// cut the same surface. The largest symmetric Hausdorff distance over the samples in the
// element's box, relative to the sample's diagonal. A term stored as its sample's own mesh
// (its view, carried[t] null, of the canonical sample's combinatorics) adds nothing.
double ElementStage::geometry_floor(int leaf, int crow, const int* terms, int n,
                                    const std::vector<const MappedSample*>& carried,
                                    const format::ElementData& ed) {
  const core::IBox& box = tree_.node(leaf).box;
  double floor = 0;
  for (int t = 0; t < n; ++t) {
    const int row = run_.sample_row[static_cast<std::size_t>(terms[t])];
    if (!core::box_contains(box, basis_.sample(terms[t]), K_) ||
        (!carried[static_cast<std::size_t>(t)] && problem_.same_class(row, crow)))
      continue;
    const Sample& own = problem_.sample(row);
    const std::vector<float>& p = ed.positions[static_cast<std::size_t>(t)];
    const std::vector<double> stored(p.begin(), p.end());
    floor =
        std::max(floor, symmetric_hausdorff(stored, ed.triangles, own.vertices, own.triangles, 1) /
                            own.bbox_diagonal());
  }
  return floor;
}

// The fields' floors (format 1.3 ElementMeshes.field_floors): the part of a field's error that
// two meshes of one solid add, which the linear shape puts at 0 next to the samples. A term
// mapped from its own mesh (§6) carries its field as that mesh's discretization gave it, and the
// host's answer at a nearby x is another mesh's discretization: the two differ by as much next
// to a sample as between samples (the main job's von Mises: 0.17 of its range near the samples,
// 0.20 mid-element; docs/error-estimates.md). That difference is in every error the builder
// measures on such an element, so each element's smallest measured error (the centre's or a
// direction's) bounds it from above there; an element with large curvature bounds it loosely.
// The floor is the lower quartile of those smallest errors over the asset's linear elements with
// mapped terms, per field, and is given to each of them: the discretization difference is the
// host's, not an element's. Elements whose terms are all their samples' own meshes, and cubic
// elements, whose constant estimate is the largest error measured and already holds it, get
// none.
void ElementStage::set_field_floors(std::vector<ElementTally>& tallies) const {
  const std::size_t W = static_cast<std::size_t>(K_ + 1);
  auto floored = [&](std::size_t e) {
    const ElementTally& t = tallies[e];
    return t.ok && t.mapped && !t.ed.error_model.empty() && !cb_.element_cubic(static_cast<int>(e));
  };
  std::size_t fields = 0;
  for (std::size_t e = 0; e < tallies.size(); ++e)
    if (floored(e)) fields = tallies[e].ed.error_model.size() / W - 1;
  std::vector<double> floors(fields, 0.0);
  for (std::size_t f = 0; f < fields; ++f) {
    std::vector<double> smallest;
    for (std::size_t e = 0; e < tallies.size(); ++e) {
      if (!floored(e)) continue;
      const double* row = tallies[e].ed.error_model.data() + (1 + f) * W;
      if (!(row[0] >= 0)) continue;
      double m = row[0];
      for (std::size_t d = 1; d < W; ++d)
        if (row[d] >= 0) m = std::min(m, row[d]);
      smallest.push_back(m);
    }
    if (smallest.empty()) continue;
    const auto q = smallest.begin() + static_cast<std::ptrdiff_t>((smallest.size() - 1) / 4);
    std::nth_element(smallest.begin(), q, smallest.end());
    floors[f] = *q;
  }
  if (std::none_of(floors.begin(), floors.end(), [](double v) { return v > 0; })) return;
  for (std::size_t e = 0; e < tallies.size(); ++e)
    if (floored(e)) tallies[e].ed.field_floors = floors;
}

// The row whose x is exactly `x` (computed as the driver computes grid points) if the host
// answered there feasibly, else -1.
int ElementStage::feasible_row(const std::vector<double>& x) const {
  const auto it = rows_by_point_.find(x);
  return it != rows_by_point_.end() && problem_.sample(it->second).feasible ? it->second : -1;
}

// The element's interpolant at x (row `at`) against the host there, per quantity.
bool ElementStage::measure_at(std::size_t e, int at, int crow, const std::vector<double>& x,
                              std::vector<double>& q) {
  core::EvalWorkspace ws = cb_.make_workspace();
  core::BasisWeights w;
  cb_.eval_element(static_cast<int>(e), x.data(), ws, false, &w);
  std::vector<int> rows(static_cast<std::size_t>(w.count));
  for (int t = 0; t < w.count; ++t)
    rows[static_cast<std::size_t>(t)] = run_.sample_row[static_cast<std::size_t>(w.samples[t])];
  return problem_.quantity_errors(at, crow, rows.data(), w.psi, w.count, opt_.geometry_tolerance, q,
                                  true);
}

// The element's error model (format/error_model.h), measured against rows the driver already
// evaluated (no host call): per quantity, the error of the element's interpolant at its centre,
// and per direction d the midpoint error along d (linear, and a cubic element on its corner
// fallback, whose interpolant is multilinear) or the larger interpolant error at the two face
// centres along d (cubic). -1 where a face centre was never evaluated (the budget
// stopped the driver first, or reuse_face_centres skipped it) or cannot be mapped. The element's
// error_estimate is the model's largest geometry estimate.
void ElementStage::measure_error_model(std::size_t e, int leaf, int crow, format::ElementData& ed) {
  const auto& node = tree_.node(leaf);
  const std::vector<double>& lo = cb_.lower();
  const std::vector<double>& hi = cb_.upper();
  auto real = [&](const core::IPoint& p) {
    std::vector<double> x(static_cast<std::size_t>(K_));
    for (int d = 0; d < K_; ++d)
      x[static_cast<std::size_t>(d)] =
          lo[static_cast<std::size_t>(d)] +
          (hi[static_cast<std::size_t>(d)] - lo[static_cast<std::size_t>(d)]) *
              core::to_unit(p[static_cast<std::size_t>(d)]);
    return x;
  };
  core::IPoint c{};
  for (int d = 0; d < K_; ++d) c[d] = node.box.lo[d] + (node.box.hi[d] - node.box.lo[d]) / 2;
  const std::size_t Q = 1 + problem_.sample(crow).fields.size(),
                    W = static_cast<std::size_t>(K_ + 1);
  ed.error_model.assign(Q * W, -1.0);
  const bool cubic = cb_.element_cubic(static_cast<int>(e));
  std::vector<double> q;
  if (!measure_at(e, crow, crow, real(c), q)) return;
  for (std::size_t i = 0; i < Q; ++i) ed.error_model[i * W] = q[i];
  for (int d = 0; d < K_; ++d) {
    int face[2];
    std::vector<double> fx[2];
    for (int side = 0; side < 2; ++side) {
      core::IPoint p = c;
      p[d] = side ? node.box.hi[d] : node.box.lo[d];
      fx[side] = real(p);
      face[side] = feasible_row(fx[side]);
    }
    std::vector<double> worst(Q, -1.0);
    bool known = true;
    if (!cubic) {
      const double psi[2] = {0.5, 0.5};
      known = face[0] >= 0 && face[1] >= 0 &&
              problem_.quantity_errors(crow, crow, face, psi, 2, opt_.geometry_tolerance, q, true);
      if (known) worst = q;
    }
    for (int side = 0; cubic && known && side < 2; ++side) {
      known = face[side] >= 0 && measure_at(e, face[side], crow, fx[side], q);
      for (std::size_t i = 0; known && i < Q; ++i) worst[i] = std::max(worst[i], q[i]);
    }
    for (std::size_t i = 0; known && i < Q; ++i)
      ed.error_model[i * W + 1 + static_cast<std::size_t>(d)] = worst[i];
  }
  ed.error_estimate = format::error_model_max(ed.error_model.data(), K_);
}

// Adds element e's tally to the build's report and result (in element order, on one thread).
void ElementStage::merge(std::size_t e, ElementTally& tally, const Sample*& field_source) {
  add(out_.neighbour, tally.neighbour);
  for (const auto& [simulated, unsimulated] : tally.simulated)
    problem_.count_simulated(simulated, unsimulated);
  if (tally.refined) {
    ++details_.refined_elements;
    details_.refined_vertices += static_cast<int>(tally.refined_vertices);
  }
  for (auto& [point, why] : tally.refused) {
    out_.infeasible.push_back(std::move(point));
    count_reason(details_.element_reasons, details_.other_infeasible_elements, why, {});
  }
  if (tally.ok && tally.corner_fallback) ++details_.unmapped_fallbacks;
  if (tally.ok) {
    const int crow = run_.centre_row[static_cast<std::size_t>(leaves_[e])];
    if (!field_source) field_source = &problem_.sample(crow);
    rep_.stored_meshes += tally.stored_meshes;
    const double err = run_.leaf_error[static_cast<std::size_t>(leaves_[e])];
    if (std::isfinite(err)) rep_.max_error = std::max(rep_.max_error, err);
  } else {
    element_ok_[e] = 0;
    ++rep_.infeasible_elements;
    if (tally.samples_feasible) ++details_.unmapped_elements;
  }
  out_.content.elements.push_back(std::move(tally.ed));
}

// Term sample k of element e (leaf `leaf`, canonical row crow): true when its view in the
// canonical mesh exists, or when `bridged` holds it carried from a neighbour (§5.3: a cubic
// term outside the element, by opt_.neighbour_transfer). False, the reason recorded, otherwise.
bool ElementStage::map_term(std::size_t e, int leaf, int crow, int k,
                            std::unique_ptr<MappedSample>& bridged, ElementTally& tally) {
  NeighbourTransferStats& st = tally.neighbour;
  const int row = run_.sample_row[static_cast<std::size_t>(k)];
  bool direct = false;
  bool outside = false;
  outside = cubic_ && !core::box_contains(tree_.node(leaf).box, basis_.sample(k), K_);
  if (outside) ++st.neighbour_terms;
  if (outside &&
      (opt_.neighbour_transfer == NeighbourTransfer::Always || opt_.measure_neighbour_transfer)) {
    auto b = std::make_unique<MappedSample>();
    if (bridge(leaf, crow, k, *b, st)) bridged = std::move(b);
  }
  if (opt_.measure_neighbour_transfer && outside) compare_routes(row, crow, bridged.get(), st);
  if (opt_.neighbour_transfer != NeighbourTransfer::Always) bridged.reset();
  MeshProblem::View m;
  if (!bridged) direct = problem_.view(row, crow, m);
  if (!direct && !bridged && outside) {
    ++st.direct_failed;
    if (opt_.neighbour_transfer == NeighbourTransfer::Fallback) {
      auto b = std::make_unique<MappedSample>();
      if (bridge(leaf, crow, k, *b, st)) bridged = std::move(b);
    }
  }
  if (bridged) {
    ++st.bridged;
  } else if (!direct) {
    refuse_term(e, row, crow, tally);
    return false;
  }
  return true;
}

// Records why element e is refused: term row `row` cannot be mapped into row crow's mesh.
void ElementStage::refuse_term(std::size_t e, int row, int crow, ElementTally& tally) {
  const std::string& why = problem_.why(row, crow);
  // The recorded point is the element's centre; the message names the term's own sample
  // as well, so that the failing pair can be mapped again on its own.
  std::string term = "element " + std::to_string(e) + ", term sample at (";
  for (std::size_t d = 0; d < problem_.point(row).size(); ++d) {
    char v[32];
    std::snprintf(v, sizeof v, "%s%.6g", d ? ", " : "", problem_.point(row)[d]);
    term += v;
  }
  tally.refused.push_back({{problem_.point(crow), term + "): " + why}, why});
}

// The element record: its canonical mesh `canon` and per term the positions (and fields) in
// it, from carried[t] where the term is not row crow's view of its own sample.
void ElementStage::write_element(format::ElementData& ed, const Sample& canon, int crow,
                                 const int* terms, int n,
                                 const std::vector<const MappedSample*>& carried) {
  const std::size_t nv3 = canon.vertices.size();
  ed.vertex_count = static_cast<std::uint32_t>(canon.vertex_count());
  ed.tets = canon.tets;
  ed.triangles = canon.triangles;
  ed.triangle_tags = canon.triangle_tags;
  ed.canonical = to_float(canon.vertices);
  MeshProblem::View m;
  // One term at a time: a view stays valid only until the next view() call.
  for (int t = 0; t < n; ++t) {
    const MappedSample* b = carried[static_cast<std::size_t>(t)];
    if (b) {
      m.vertices = b->vertices.data();
      m.fields.clear();
      for (const auto& f : b->fields) m.fields.push_back(f.data());
      m.hold.reset();
    } else {
      problem_.view(run_.sample_row[static_cast<std::size_t>(terms[t])], crow, m);
    }
    ed.positions.emplace_back(m.vertices, m.vertices + nv3);
    if (!canon.fields.empty()) {
      std::vector<float> f;
      for (std::size_t k = 0; k < canon.fields.size(); ++k)
        f.insert(f.end(), m.fields[k], m.fields[k] + canon.fields[k].values.size());
      ed.fields.push_back(std::move(f));
    }
  }
}

// Canonical refinement (§6; mapping/canonical_refine.h): where a mapped term's boundary departs
// from its own by more than 0.7 x the geometry tolerance (a bend of the term's shape under a
// canonical triangle), the element's canonical mesh (row crow) is refined there and every term
// mapped again onto it. The threshold lies below the tolerance so that the refined pairs meet
// it. True when `refined` replaces the canonical mesh and remapped[t] term t's view in it.
bool ElementStage::refine(int crow, const int* terms, int n, Sample& refined,
                          std::vector<MappedSample>& remapped, ElementTally& tally) {
  const Sample& canon = problem_.sample(crow);
  const double tolerance = 0.7 * opt_.geometry_tolerance;
  // The terms as mapped already (every view exists: map_term mapped them), from which
  // refinement starts. Whether some term departs is refine_canonical's first measure (no round
  // when none does), so each term's surface is indexed once.
  std::vector<const Sample*> sources;
  MeshProblem::View m;
  for (int t = 0; t < n; ++t) {
    const int row = run_.sample_row[static_cast<std::size_t>(terms[t])];
    sources.push_back(&problem_.sample(row));
    problem_.view(row, crow, m);
    MappedSample& r = remapped.emplace_back();
    r.vertices.assign(m.vertices, m.vertices + canon.vertices.size());
    for (std::size_t k = 0; k < canon.fields.size(); ++k)
      r.fields.emplace_back(m.fields[k], m.fields[k] + canon.fields[k].values.size());
  }
  mapping::RefineOptions ro;
  ro.tolerance = tolerance;
  ro.rounds = opt_.canonical_refinement;
  ro.threads = std::max(1, exec_.concurrency());
  ro.cancelled = [this] { return stop_requested(); };
  mapping::RefineStats rs;
  std::string why;
  if (!mapping::refine_canonical(sources, canon, problem_.mapper(), refined, remapped, why, &rs,
                                 ro) ||
      rs.rounds <= 0)
    return false;
  tally.refined = true;
  tally.refined_vertices = rs.added_vertices;
  for (int t = 0; opt_.simulate_mapped && t < n; ++t) {
    std::string unsimulated;
    const bool simulated =
        problem_.simulate_on_mapped(run_.sample_row[static_cast<std::size_t>(terms[t])], refined,
                                    remapped[static_cast<std::size_t>(t)], unsimulated);
    tally.simulated.emplace_back(simulated, unsimulated);
  }
  return true;
}

// Sample k (outside element `leaf`, canonical row crow) carried from a neighbour element
// through a shared sample (§5.3): the first neighbour, in id order, whose box touches leaf's,
// whose centre is feasible and through which k can be carried.
bool ElementStage::bridge(int leaf, int crow, int k, MappedSample& res,
                          NeighbourTransferStats& st) {
  const core::IBox& box = tree_.node(leaf).box;
  const core::IPoint& pk = basis_.sample(k);
  std::vector<int> around;
  tree_.leaves_containing(pk, around);
  std::sort(around.begin(), around.end());
  for (int nb : around) {
    if (nb == leaf || !core::boxes_touch(tree_.node(nb).box, box, K_)) continue;
    const int nrow = run_.centre_row[static_cast<std::size_t>(nb)];
    if (nrow < 0 || !problem_.sample(nrow).feasible) continue;
    const int s = shared_sample(leaf, nb, k);
    if (s >= 0 && carry(k, s, nrow, crow, res, st)) return true;
  }
  ++st.bridge_failed;
  return false;
}

// The shared sample of elements `leaf` and `nb` for sample k: a sample on both closed elements
// (B(l) and B(l'), not necessarily a term: psi_s may vanish on l), feasible, nearest to k on the
// integer grid (smallest id on ties); -1 when there is none.
int ElementStage::shared_sample(int leaf, int nb, int k) const {
  const core::IPoint& pk = basis_.sample(k);
  int s = -1;
  double best = std::numeric_limits<double>::infinity();
  const std::vector<int>& mine = basis_.element_samples(leaf);
  const std::vector<int>& theirs = basis_.element_samples(nb);
  std::vector<int> both;
  std::set_intersection(mine.begin(), mine.end(), theirs.begin(), theirs.end(),
                        std::back_inserter(both));
  for (int cand : both) {
    const int row = run_.sample_row[static_cast<std::size_t>(cand)];
    if (cand == k || row < 0 || !problem_.sample(row).feasible) continue;
    const core::IPoint& ps = basis_.sample(cand);
    double d = 0;
    for (int a = 0; a < K_; ++a)
      d += std::abs(static_cast<double>(ps[static_cast<std::size_t>(a)]) -
                    static_cast<double>(pk[static_cast<std::size_t>(a)]));
    if (d < best) {
      best = d;
      s = cand;
    }
  }
  return s;
}

// p_k^l from p_k^{l'}: sample k in the neighbour's canonical mesh (row nrow) carried into this
// element's (row crow) by F: p_s^l -> p_s^{l'} of shared sample s (NeighbourBridge). False when
// a view or the bridge fails, or the result has inverted tets (never emitted, as the mapper
// itself refuses them).
bool ElementStage::carry(int k, int s, int nrow, int crow, MappedSample& res,
                         NeighbourTransferStats& st) {
  const int krow = run_.sample_row[static_cast<std::size_t>(k)];
  const int srow = run_.sample_row[static_cast<std::size_t>(s)];
  MeshProblem::View pk_n, ps_n, ps_l;
  if (!problem_.view(krow, nrow, pk_n) || !problem_.view(srow, nrow, ps_n) ||
      !problem_.view(srow, crow, ps_l))
    return false;
  const Sample& ncanon = problem_.sample(nrow);
  const Sample& canon = problem_.sample(crow);
  const std::size_t nv3 = ncanon.vertices.size();
  const mapping::NeighbourBridge br(
      ncanon, std::vector<double>(ps_n.vertices, ps_n.vertices + nv3), canon,
      std::vector<double>(ps_l.vertices, ps_l.vertices + canon.vertices.size()));
  MappedSample in;
  in.vertices.assign(pk_n.vertices, pk_n.vertices + nv3);
  for (std::size_t f = 0; f < ncanon.fields.size(); ++f)
    in.fields.emplace_back(pk_n.fields[f], pk_n.fields[f] + ncanon.fields[f].values.size());
  std::string why;
  if (!br.apply(in, res, why)) return false;
  if (mapping::tet_quality(res.vertices, canon.tets).inverted > 0) {
    ++st.bridge_inverted;
    return false;
  }
  return true;
}

// BuildOptions::measure_neighbour_transfer: both routes of term row `row` into row crow's mesh
// (the direct view, and `viab` carried through a shared sample) against the term's own sample.
void ElementStage::compare_routes(int row, int crow, const MappedSample* viab,
                                  NeighbourTransferStats& st) {
  MeshProblem::View d;
  if (!viab || !problem_.view(row, crow, d)) return;
  const Sample& src = problem_.sample(row);
  const Sample& canon = problem_.sample(crow);
  const double diag = src.bbox_diagonal();
  const std::vector<double> dv(d.vertices, d.vertices + canon.vertices.size());
  const double hd = symmetric_hausdorff(dv, canon.triangles, src.vertices, src.triangles) / diag;
  const double hb =
      symmetric_hausdorff(viab->vertices, canon.triangles, src.vertices, src.triangles) / diag;
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
}

}  // namespace

const Sample* map_elements(const Host& host, const BuildOptions& opt, Executor& exec,
                           MeshProblem& problem, const core::AdaptiveRun& run,
                           core::CompiledBasis& cb, const std::vector<bool>& infeasible_sample,
                           const std::vector<int>& leaves, BuildReport& details, BuildResult& out,
                           std::vector<std::uint8_t>& element_ok, HeldOutPoints* held_out) {
  return ElementStage(host, opt, exec, problem, run, cb, infeasible_sample, leaves, details, out,
                      element_ok, held_out)
      .run();
}

}  // namespace cadinterp::builder
