// The adaptive driver (paper §4.2). Why one file of over 800 lines: AdaptiveDriver's steps (the
// wave's points, its error queries, the probes for the split direction, the refinement toward the
// feasibility boundary with the cubic corner fallback, the split) all read and write one state
// (tree, basis, point rows, per-node direction estimates, queue) within a wave; spread over files
// they would pass that state around. The seams if it grows further: the direction probes
// (lazy_face_centres) and the feasibility group (usable_basis, refused, infeasible_split,
// any_own_sample_feasible, separating_direction), which reads only the basis and the rows'
// feasibility and could move behind a feasibility predicate; decide_wave's refused-first order
// would stay, since it interleaves that group with check_leaf.
#include "core/adaptive.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <queue>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

#include "core/compiled_basis.h"

namespace cadinterp::core {

double max_norm_error(const double* approx, const double* truth, int m) {
  double e = 0.0;
  for (int i = 0; i < m; ++i) e = std::max(e, std::abs(approx[i] - truth[i]));
  return e;
}

bool AdaptiveProblem::ErrorQuery::operator<(const ErrorQuery& o) const {
  return std::tie(midpoint, at, centre, terms, psi) <
         std::tie(o.midpoint, o.at, o.centre, o.terms, o.psi);
}

double AdaptiveProblem::error(const ErrorQuery& q) {
  return q.midpoint ? midpoint_error(q.terms[0], q.terms[1], q.at)
                    : interpolation_error(q.at, q.centre, q.terms.data(), q.psi.data(),
                                          static_cast<int>(q.terms.size()));
}

void AdaptiveProblem::errors(const std::vector<ErrorQuery>& queries, std::vector<double>& out) {
  out.resize(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) out[i] = error(queries[i]);
}

namespace {

// Rows by grid point: every point is evaluated at most once per run, in batches.
class PointRows {
 public:
  PointRows(int K, const std::vector<double>& lo, const std::vector<double>& hi,
            AdaptiveProblem& problem)
      : K_(K), lo_(lo), hi_(hi), problem_(problem) {}

  /// Evaluates those of `points` not seen before, in one problem.evaluate() call.
  void ensure(const std::vector<IPoint>& points) {
    std::vector<int> rows;
    std::vector<double> x;
    for (const IPoint& p : points) {
      if (index_.count(p)) continue;
      const int row = static_cast<int>(feasible_.size());
      index_.emplace(p, row);
      feasible_.push_back(0);
      rows.push_back(row);
      for (int d = 0; d < K_; ++d) x.push_back(lo_[d] + (hi_[d] - lo_[d]) * to_unit(p[d]));
    }
    if (rows.empty()) return;
    std::vector<char> ok(rows.size(), 0);
    problem_.evaluate(rows, x, ok);
    for (std::size_t i = 0; i < rows.size(); ++i) {
      feasible_[static_cast<std::size_t>(rows[i])] = ok[i] ? 1 : 0;
      failed_ += ok[i] ? 0 : 1;
    }
  }
  /// The row of p (evaluating it now if needed); *feasible tells whether the host succeeded.
  int row(const IPoint& p, bool* feasible = nullptr) {
    auto it = index_.find(p);
    if (it == index_.end()) {
      ensure({p});
      it = index_.find(p);
    }
    if (feasible) *feasible = feasible_[static_cast<std::size_t>(it->second)] != 0;
    return it->second;
  }
  /// The row of p if the host was asked already, else -1 (nothing is evaluated).
  int find(const IPoint& p) const {
    const auto it = index_.find(p);
    return it == index_.end() ? -1 : it->second;
  }
  bool feasible(const IPoint& p) {
    bool ok = false;
    row(p, &ok);
    return ok;
  }
  const std::vector<char>& feasible_rows() const { return feasible_; }
  /// Rows whose point is infeasible.
  int failed() const { return failed_; }

 private:
  int K_;
  const std::vector<double>& lo_;
  const std::vector<double>& hi_;
  AdaptiveProblem& problem_;
  std::unordered_map<IPoint, int, IPointHash> index_;
  std::vector<char> feasible_;
  int failed_ = 0;
};

int level_sum(const KdTree::Node& n, int K) {
  int s = 0;
  for (int d = 0; d < K; ++d) s += n.level[d];
  return s;
}

IPoint centre_of(const KdTree::Node& node, int K) {
  IPoint c{};
  for (int d = 0; d < K; ++d) c[d] = node.box.lo[d] + (node.box.hi[d] - node.box.lo[d]) / 2;
  return c;
}

// The value-vector problem of adaptive_sample: rows hold the host's m values.
class ValueProblem final : public AdaptiveProblem {
 public:
  ValueProblem(int K, int m, const HostFunction& f, const ErrorMetric& metric)
      : K_(K), m_(m), f_(f), metric_(metric) {}
  void evaluate(const std::vector<int>& rows, const std::vector<double>& x,
                std::vector<char>& feasible) override {
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const auto r = static_cast<std::size_t>(rows[i]);
      if (values_.size() <= r) values_.resize(r + 1);
      std::vector<double> v(static_cast<std::size_t>(m_));
      bool ok = f_(&x[i * static_cast<std::size_t>(K_)], v.data());
      for (int j = 0; ok && j < m_; ++j) ok = std::isfinite(v[static_cast<std::size_t>(j)]);
      feasible[i] = ok ? 1 : 0;
      if (ok) values_[r] = std::move(v);
    }
  }
  double interpolation_error(int at, int, const int* terms, const double* psi, int n) override {
    interp_.assign(static_cast<std::size_t>(m_), 0.0);
    for (int t = 0; t < n; ++t) {
      const double* v = value(terms[t]);
      for (int i = 0; i < m_; ++i) interp_[static_cast<std::size_t>(i)] += psi[t] * v[i];
    }
    return metric_(interp_.data(), value(at), m_);
  }
  double midpoint_error(int a, int b, int c) override {
    interp_.resize(static_cast<std::size_t>(m_));
    for (int i = 0; i < m_; ++i)
      interp_[static_cast<std::size_t>(i)] = 0.5 * (value(a)[i] + value(b)[i]);
    return metric_(interp_.data(), value(c), m_);
  }
  const double* value(int row) const { return values_[static_cast<std::size_t>(row)].data(); }

 private:
  int K_, m_;
  const HostFunction& f_;
  const ErrorMetric& metric_;
  std::vector<std::vector<double>> values_;  // per row; empty when infeasible
  std::vector<double> interp_;
};

// Checks adaptive_run's arguments; throws std::invalid_argument naming the first bad one.
void check_arguments(int K, const std::vector<double>& lo, const std::vector<double>& hi,
                     const AdaptiveOptions& opt) {
  if (static_cast<int>(lo.size()) != K || static_cast<int>(hi.size()) != K)
    throw std::invalid_argument("adaptive_sample: domain bounds need K values");
  for (int d = 0; d < K; ++d)
    if (!(std::isfinite(lo[d]) && std::isfinite(hi[d]) && lo[d] < hi[d]))
      throw std::invalid_argument("adaptive_sample: empty or non-finite domain");
  if (opt.max_level < 1 || opt.max_level >= kMaxLevel)
    throw std::invalid_argument("adaptive_sample: max_level outside 1..kMaxLevel-1");
  if (!(opt.tolerance >= 0.0)) throw std::invalid_argument("adaptive_sample: negative tolerance");
}

// One run of the adaptive driver (§4.2): the basis being refined, the rows of every point
// evaluated so far, the priority queue of elements to check, and the current wave's answers.
// Every stage below keeps the order of host evaluations and error queries fixed, so the result
// depends only on the values the problem returns.
class AdaptiveDriver {
 public:
  AdaptiveDriver(int K, const std::vector<double>& lo, const std::vector<double>& hi,
                 AdaptiveProblem& problem, const AdaptiveOptions& opt)
      : K_(K),
        problem_(problem),
        opt_(opt),
        res_{Basis(K, opt.degree)},
        basis_(res_.basis),
        tree_(basis_.tree()),
        rows_(K, lo, hi, problem) {}

  AdaptiveRun run() {
    evaluate_samples();
    initial_refinement();
    seed_queue();
    bool stop = false;
    while (!queue_.empty() && !stop) {
      const std::vector<int> wave = take_wave();
      ++res_.waves;
      problem_.on_wave(static_cast<int>(tree_.leaves().size()));
      evaluate_wave_points(wave);
      ask_wave_errors(wave);
      stop = !decide_wave(wave);
    }
    finish();
    return std::move(res_);
  }

 private:
  using Query = AdaptiveProblem::ErrorQuery;
  using Entry = std::pair<int, int>;  // level sum, node id

  // The host at every basis sample not evaluated yet (the corners of e_0 at the start, §4.2).
  void evaluate_samples() {
    std::vector<IPoint> pts;
    for (int k = 0; k < basis_.sample_count(); ++k) pts.push_back(basis_.sample(k));
    rows_.ensure(pts);
  }

  // Initial refinement: once in every direction (§4.2). The new samples of one direction are
  // one wave.
  void initial_refinement() {
    for (int d = 0; d < K_; ++d) {
      const std::vector<int> leaves = tree_.leaves();  // refine() changes the tree's list
      for (int leaf : leaves) {
        basis_.refine(leaf, d);
        ++res_.splits;
      }
      evaluate_samples();
    }
  }

  // Every leaf of the initial tree is checked (§4.2), and every node gets its result slots.
  void seed_queue() {
    for (int leaf : tree_.leaves()) push(leaf);
    res_.leaf_error.assign(static_cast<std::size_t>(tree_.node_count()),
                           std::numeric_limits<double>::quiet_NaN());
    res_.centre_row.assign(static_cast<std::size_t>(tree_.node_count()), -1);
  }

  // Queues a leaf once: the priority queue of §4.2 takes the largest element first (smallest
  // level sum), ties by node id, so the order is deterministic.
  void push(int leaf) {
    if (static_cast<int>(queued_.size()) <= leaf)
      queued_.resize(static_cast<std::size_t>(leaf) + 1, 0);
    if (queued_[static_cast<std::size_t>(leaf)]) return;
    queued_[static_cast<std::size_t>(leaf)] = 1;
    queue_.emplace(level_sum(tree_.node(leaf), K_), leaf);
  }

  bool terms_feasible(const ElementBasis& eb) {
    return std::all_of(eb.terms.begin(), eb.terms.end(),
                       [&](int k) { return rows_.feasible(basis_.sample(k)); });
  }

  // The element's basis as the asset will evaluate it (CompiledBasis::compile decides alike):
  // its own, or with corner_fallback the corner fallback of a cubic element whose terms reach an
  // infeasible sample while its corners are feasible. `usable` says whether the returned basis'
  // terms are all feasible; when not, the element's own basis is returned (its terms are what
  // infeasible_split reads).
  ElementBasis usable_basis(int leaf, bool* usable) {
    ElementBasis eb = basis_.element_basis(leaf);
    *usable = terms_feasible(eb);
    if (*usable || !opt_.corner_fallback) return eb;
    ElementBasis corners;
    if (basis_.corner_fallback_basis(leaf, &corners) && terms_feasible(corners)) {
      *usable = true;
      return corners;
    }
    return eb;
  }
  bool usable(int leaf) {
    bool ok = false;
    usable_basis(leaf, &ok);
    return ok;
  }

  void face_centres(const KdTree::Node& node, std::vector<IPoint>& out) const {
    const IPoint c = centre_of(node, K_);
    for (int d = 0; d < K_; ++d)
      for (int side = 0; side < 2; ++side) {
        IPoint p = c;
        p[d] = side ? node.box.hi[d] : node.box.lo[d];
        out.push_back(p);
      }
  }

  // The refinement test at grid point p (row prow) of an element: its terms and their weights
  // at p, against the host at p, in the combinatorics of the element's centre (row crow).
  Query error_query(const ElementBasis& eb, int crow, const IPoint& p, int prow) {
    Query q;
    q.at = prow;
    q.centre = crow;
    for (int k : eb.terms) q.terms.push_back(rows_.row(basis_.sample(k)));
    q.psi.resize(eb.terms.size());
    double u[kMaxDim];
    for (int d = 0; d < K_; ++d) u[d] = to_unit(p[d]);
    eval_element_basis(basis_, eb, u, q.psi.data(), nullptr);
    return q;
  }

  // The per-direction test along d (the two face centres against the centre, §4.2's distance
  // in each direction); false where a face centre is infeasible.
  bool midpoint_query(const KdTree::Node& node, int d, Query& q) {
    const IPoint c = centre_of(node, K_);
    IPoint a = c, b = c;
    a[d] = node.box.lo[d];
    b[d] = node.box.hi[d];
    bool oka = false, okb = false;
    q = Query{};
    q.midpoint = true;
    q.at = rows_.row(c);
    q.terms = {rows_.row(a, &oka), rows_.row(b, &okb)};
    return oka && okb;
  }

  // Asks the problem for qs together and memoises the answers for the current wave.
  void solve(std::vector<Query>& qs) {
    std::vector<double> out;
    problem_.errors(qs, out);
    for (std::size_t i = 0; i < qs.size(); ++i) memo_.emplace(std::move(qs[i]), out[i]);
    qs.clear();
  }

  double answer(const Query& q) {
    auto it = memo_.find(q);
    if (it == memo_.end()) {
      std::vector<Query> one{q};
      solve(one);
      it = memo_.find(q);
    }
    return it->second;
  }

  // One wave: every queued element that is still a leaf. Elements queued while the wave is
  // processed form the next.
  std::vector<int> take_wave() {
    std::vector<int> wave;
    while (!queue_.empty()) {
      const int leaf = queue_.top().second;
      queue_.pop();
      queued_[static_cast<std::size_t>(leaf)] = 0;
      if (tree_.is_leaf(leaf)) wave.push_back(leaf);
    }
    return wave;
  }

  // Decides the wave's elements (check_leaf); false when the sample budget stops the run. With
  // refine_infeasible the refused elements come first, largest first, and a split's children
  // that are still refused join them at once: a refused element answers nothing over its whole
  // box where one above tolerance answers with an error its estimate reports, so the budget
  // keeps the feasible space first, and the boundary is approached a level per split rather
  // than a wave per split (max_infeasible_points bounds what that costs).
  bool decide_wave(const std::vector<int>& wave) {
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> refused_queue;
    std::vector<int> rest;
    for (int leaf : wave)
      if (opt_.refine_infeasible && refused(leaf))
        refused_queue.emplace(level_sum(tree_.node(leaf), K_), leaf);
      else
        rest.push_back(leaf);
    while (!refused_queue.empty()) {
      const int leaf = refused_queue.top().second;
      refused_queue.pop();
      if (!tree_.is_leaf(leaf)) continue;
      if (!check_leaf(leaf)) return false;
      if (tree_.is_leaf(leaf)) continue;
      const KdTree::Node& parent = tree_.node(leaf);
      const int kids[2] = {parent.child[0], parent.child[1]};
      rows_.ensure({centre_of(tree_.node(kids[0]), K_), centre_of(tree_.node(kids[1]), K_)});
      for (int kid : kids)
        if (refused(kid)) refused_queue.emplace(level_sum(tree_.node(kid), K_), kid);
    }
    for (int leaf : rest)
      if (!check_leaf(leaf)) return false;
    return true;
  }

  // Whether the element answers nothing: its centre or one of its terms is infeasible.
  bool refused(int leaf) {
    return !rows_.feasible(centre_of(tree_.node(leaf), K_)) || !usable(leaf);
  }

  // The wave's points are evaluated together (§4.2's element centres, then the face centres of
  // the feasible elements), so the host can answer them in one batch.
  void evaluate_wave_points(const std::vector<int>& wave) {
    std::vector<IPoint> pts;
    for (int leaf : wave) pts.push_back(centre_of(tree_.node(leaf), K_));
    rows_.ensure(pts);
    pts.clear();
    for (int leaf : wave) {
      const KdTree::Node& node = tree_.node(leaf);
      if (rows_.feasible(centre_of(node, K_)) && usable(leaf)) face_centres(node, pts);
    }
    if (opt_.check_face_centres && !opt_.reuse_face_centres && !opt_.lazy_face_centres)
      rows_.ensure(pts);
  }

  // The face centres an element's test uses first: all of them, or with reuse_face_centres
  // and lazy_face_centres those the host has answered already (for a neighbour, for the
  // parent's split decision, or as samples).
  void test_faces(const KdTree::Node& node, std::vector<IPoint>& out) const {
    if (!opt_.check_face_centres) return;
    std::vector<IPoint> faces;
    face_centres(node, faces);
    for (const IPoint& p : faces)
      if (!(opt_.reuse_face_centres || opt_.lazy_face_centres) || rows_.find(p) >= 0)
        out.push_back(p);
  }

  // lazy_face_centres: the face centres the host has not answered yet. An element that passes
  // at its centre and at the answered ones is kept only if it passes at these too.
  void missing_faces(const KdTree::Node& node, std::vector<IPoint>& out) const {
    if (!opt_.check_face_centres || !opt_.lazy_face_centres) return;
    std::vector<IPoint> faces;
    face_centres(node, faces);
    for (const IPoint& p : faces)
      if (rows_.find(p) < 0) out.push_back(p);
  }

  // Per tree node and direction (lazy_face_centres): the midpoint error measured on the node or
  // inherited from an ancestor, and how many splits ago it was measured.
  struct DirectionEstimate {
    double error = std::numeric_limits<double>::quiet_NaN();  // NaN: unknown
    int age = 0;
  };
  DirectionEstimate& estimate(int node, int d) {
    if (static_cast<int>(estimates_.size()) <= node)
      estimates_.resize(static_cast<std::size_t>(tree_.node_count()));
    return estimates_[static_cast<std::size_t>(node)][static_cast<std::size_t>(d)];
  }

  // Whether the split-direction test along d asks the host: always, unless lazy_face_centres
  // finds a pair of answered points (answered_pair) or a young enough estimate.
  bool probes_direction(int leaf, const KdTree::Node& node, int d) {
    if (!opt_.lazy_face_centres) return true;
    Query q;
    double scale = 0;
    if (answered_pair(node, d, q, scale)) return false;
    const DirectionEstimate& e = estimate(leaf, d);
    return std::isnan(e.error) || e.age > opt_.inherited_direction_splits;
  }

  // The largest error of each of `leaves` at its feasible points at[l] (none: 0), asked for
  // together (problem.errors may answer them in parallel) and memoised for check_leaf.
  std::vector<double> max_errors(const std::vector<int>& leaves,
                                 const std::vector<std::vector<IPoint>>& at) {
    std::vector<Query> qs;
    std::vector<std::size_t> first;  // per leaf: its first query
    for (std::size_t l = 0; l < leaves.size(); ++l) {
      const int crow = rows_.row(centre_of(tree_.node(leaves[l]), K_));
      bool usable_terms = false;  // true: both callers pass usable leaves only
      const ElementBasis eb = usable_basis(leaves[l], &usable_terms);
      first.push_back(qs.size());
      for (const IPoint& p : at[l]) {
        bool pok = false;
        const int prow = rows_.row(p, &pok);
        if (pok) qs.push_back(error_query(eb, crow, p, prow));
      }
    }
    first.push_back(qs.size());
    std::vector<double> out;
    problem_.errors(qs, out);
    std::vector<double> err(leaves.size(), 0.0);
    for (std::size_t l = 0; l < leaves.size(); ++l)
      for (std::size_t i = first[l]; i < first[l + 1]; ++i) err[l] = std::max(err[l], out[i]);
    for (std::size_t i = 0; i < qs.size(); ++i) memo_.emplace(std::move(qs[i]), out[i]);
    return err;
  }

  // lazy_face_centres: the leaves that passed at their centre and answered face centres are
  // tested at their other face centres, evaluated in one batch; err is updated.
  void test_missing_faces(const std::vector<int>& leaves, std::vector<double>& err) {
    std::vector<int> passing;
    std::vector<std::size_t> index;
    std::vector<std::vector<IPoint>> at;
    std::vector<IPoint> batch;
    for (std::size_t l = 0; l < leaves.size(); ++l) {
      if (!(err[l] <= opt_.tolerance)) continue;
      std::vector<IPoint> faces;
      missing_faces(tree_.node(leaves[l]), faces);
      if (faces.empty()) continue;
      batch.insert(batch.end(), faces.begin(), faces.end());
      passing.push_back(leaves[l]);
      index.push_back(l);
      at.push_back(std::move(faces));
    }
    if (passing.empty()) return;
    rows_.ensure(batch);
    const std::vector<double> more = max_errors(passing, at);
    for (std::size_t i = 0; i < passing.size(); ++i)
      err[index[i]] = std::max(err[index[i]], more[i]);
  }

  // The wave's errors (§4.2's error at the element centre, and optionally at its face centres),
  // then the split directions of the elements above tolerance, asked for together
  // (problem.errors may answer them in parallel) on the basis as it stands. check_leaf looks
  // them up, and computes afresh only where an earlier split of the wave changed an element's
  // terms or weights.
  void ask_wave_errors(const std::vector<int>& wave) {
    memo_.clear();
    std::vector<int> leaves;
    std::vector<std::vector<IPoint>> at;
    for (int leaf : wave) {
      const KdTree::Node& node = tree_.node(leaf);
      const IPoint c = centre_of(node, K_);
      if (!rows_.feasible(c) || !usable(leaf)) continue;
      leaves.push_back(leaf);
      at.push_back({c});
      test_faces(node, at.back());
    }
    std::vector<double> err = max_errors(leaves, at);
    const std::size_t reach = budget_reach(err);
    leaves.resize(reach);
    err.resize(reach);
    test_missing_faces(leaves, err);
    std::vector<int> above;
    for (std::size_t l = 0; l < leaves.size(); ++l)
      if (err[l] > opt_.tolerance) above.push_back(leaves[l]);
    // The split directions' tests (below) need the face centres of every splittable direction
    // they probe, evaluated here in one batch and in the order the tests ask for them.
    std::vector<IPoint> split_faces;
    for (int leaf : above) {
      const KdTree::Node& node = tree_.node(leaf);
      std::vector<IPoint> faces;
      face_centres(node, faces);
      for (int d = 0; d < K_; ++d)
        if (node.level[d] < opt_.max_level && probes_direction(leaf, node, d))
          split_faces.insert(split_faces.end(), faces.begin() + 2 * d, faces.begin() + 2 * d + 2);
    }
    rows_.ensure(split_faces);
    std::vector<Query> qs;
    for (int leaf : above) {
      const KdTree::Node& node = tree_.node(leaf);
      Query q;
      double scale = 0;
      for (int d = 0; d < K_; ++d)
        if (node.level[d] < opt_.max_level && answered_pair(node, d, q, scale) && scale > 0)
          qs.push_back(q);
    }
    solve(qs);
  }

  // lazy_face_centres: how many of the wave's tested leaves (errors err, in check_leaf's order)
  // the remaining sample budget can reach: up to and including the one whose split would spend
  // it at the samples per split so far. Probing beyond would buy points the run never uses;
  // check_leaf evaluates them one by one should it get there.
  std::size_t budget_reach(const std::vector<double>& err) const {
    if (!opt_.lazy_face_centres) return err.size();
    const double per_split =
        adaptive_splits_ > 0 ? std::max(1.0, double(added_samples_) / adaptive_splits_) : 1.0;
    const double splits = std::ceil((opt_.max_samples - basis_.sample_count()) / per_split);
    std::size_t failing = 0;
    for (std::size_t l = 0; l < err.size(); ++l)
      if (err[l] > opt_.tolerance && static_cast<double>(++failing) >= splits) return l + 1;
    return err.size();
  }

  // The midpoint test along d on points the host has answered already: the element's two face
  // centres (scale 1), else with lazy_face_centres the two points 2 or 3 half-widths from its
  // centre (the centres of same-size neighbours, their far face centres), whose midpoint error
  // is the element's times 4 or 9 on a smooth function (it grows with the distance squared):
  // scale is 1/4 or 1/9. False when no such pair is answered, or (past scale 1) feasible.
  bool answered_pair(const KdTree::Node& node, int d, Query& q, double& scale) {
    const IPoint c = centre_of(node, K_);
    const Coord half = (node.box.hi[d] - node.box.lo[d]) / 2;
    for (int j = 1; j <= (opt_.lazy_face_centres ? 3 : 1); ++j) {
      IPoint a = c, b = c;
      a[d] -= j * half;
      b[d] += j * half;
      const int ra = rows_.find(a), rb = rows_.find(b);
      if (ra < 0 || rb < 0) continue;
      const bool ok = rows_.feasible_rows()[static_cast<std::size_t>(ra)] &&
                      rows_.feasible_rows()[static_cast<std::size_t>(rb)];
      if (j > 1 && !ok) continue;
      q = Query{};
      q.midpoint = true;
      q.at = rows_.row(c);
      q.terms = {ra, rb};
      scale = ok ? 1.0 / (j * j) : -1.0;
      return true;
    }
    return false;
  }

  // The splittable direction with the lowest level; -1 when every direction is at max_level.
  int widest_direction(const KdTree::Node& node) const {
    int widest = -1;
    for (int d = 0; d < K_; ++d)
      if (node.level[d] < opt_.max_level && (widest < 0 || node.level[d] < node.level[widest]))
        widest = d;
    return widest;
  }

  // The refinement test of §4.2: the error at the element's centre, and with check_face_centres
  // the largest over its face centres too; infinite where a face centre is infeasible. With
  // lazy_face_centres an element that fails before its unanswered face centres is not tested
  // at them: it is split either way.
  double element_error(const KdTree::Node& node, const ElementBasis& eb, const IPoint& c,
                       int crow) {
    double err = answer(error_query(eb, crow, c, crow));
    std::vector<IPoint> faces;
    test_faces(node, faces);
    err = max_face_error(eb, crow, faces, err);
    if (err <= opt_.tolerance) {
      faces.clear();
      missing_faces(node, faces);
      err = max_face_error(eb, crow, faces, err);
    }
    return err;
  }

  // The largest of err and the errors at `faces` (evaluated if needed); infinite where a face
  // centre is infeasible.
  double max_face_error(const ElementBasis& eb, int crow, const std::vector<IPoint>& faces,
                        double err) {
    for (const IPoint& p : faces) {
      if (!std::isfinite(err)) break;
      bool ok = false;
      const int prow = rows_.row(p, &ok);
      err = ok ? std::max(err, answer(error_query(eb, crow, p, prow)))
               : std::numeric_limits<double>::infinity();
    }
    return err;
  }

  // The split direction of §4.2: the direction whose midpoint test errs most. Ties go to the
  // coarser direction, then to the lower index; `widest` where the metric returns NaN
  // everywhere. With lazy_face_centres a direction that needs no probe uses its estimate unless
  // the host has answered both its face centres; the errors are kept for the children.
  int split_direction(int leaf, const KdTree::Node& node, int widest) {
    int dir = -1;
    double best = -1.0;
    for (int d = 0; d < K_; ++d) {
      if (node.level[d] >= opt_.max_level) continue;
      Query q;
      double scale = 0;
      double e = std::numeric_limits<double>::infinity();
      bool measured = true;
      if (answered_pair(node, d, q, scale)) {
        if (scale > 0) e = scale * answer(q);
      } else if (!probes_direction(leaf, node, d)) {
        e = estimate(leaf, d).error;
        measured = false;
      } else if (midpoint_query(node, d, q)) {
        e = answer(q);
      }
      if (opt_.lazy_face_centres && measured && std::isfinite(e)) estimate(leaf, d) = {e, 0};
      if (e > best || (e == best && dir >= 0 && node.level[d] < node.level[dir])) {
        best = e;
        dir = d;
      }
    }
    return dir < 0 ? widest : dir;
  }

  // Decides one leaf of the wave: records its centre row and error, and splits it when the
  // refinement test fails (or, with refine_infeasible, when it cannot be evaluated). Returns
  // false when the sample budget stops the run.
  bool check_leaf(int leaf) {
    if (!tree_.is_leaf(leaf)) return true;
    const KdTree::Node node = tree_.node(leaf);  // a copy: refine() grows the node list
    const int widest = widest_direction(node);

    const IPoint c = centre_of(node, K_);
    bool centre_ok = false;
    const int crow = rows_.row(c, &centre_ok);
    res_.centre_row[static_cast<std::size_t>(leaf)] = crow;
    bool terms_ok = false;
    const ElementBasis eb = usable_basis(leaf, &terms_ok);
    const bool feasible = centre_ok && terms_ok;

    int dir = -1;
    double err = std::numeric_limits<double>::infinity();
    if (!feasible) {
      if (opt_.refine_infeasible && widest >= 0)
        dir = infeasible_split(node, eb, centre_ok, widest);
    } else {
      err = element_error(node, eb, c, crow);
      if (err > opt_.tolerance && widest >= 0) dir = split_direction(leaf, node, widest);
    }
    res_.leaf_error[static_cast<std::size_t>(leaf)] = err;
    if (dir < 0) return true;
    if (basis_.sample_count() >= opt_.max_samples) {
      res_.budget_exhausted = true;
      return false;
    }
    if (!feasible) ++res_.infeasible_splits;
    split(leaf, node, dir);
    return true;
  }

  // The split of an element that depends on an infeasible sample (refine_infeasible), or -1:
  // none for an element wholly inside the infeasible region, nor once max_infeasible_points
  // points have failed.
  int infeasible_split(const KdTree::Node& node, const ElementBasis& eb, bool centre_ok,
                       int widest) {
    if (!centre_ok && !any_own_sample_feasible(node, eb)) {
      ++res_.interior_unsplit;
      return -1;
    }
    if (opt_.max_infeasible_points >= 0 && rows_.failed() >= opt_.max_infeasible_points) {
      ++res_.bound_unsplit;
      return -1;
    }
    // Split where the failure lies: a child on the feasible side becomes usable (linear, and
    // cubic through its corner fallback). Without the fallback a cubic element is refused for
    // terms up to two of its widths away in every direction, and sheds them fastest by
    // shrinking in all directions in turn (widest first): on a 2-D host failing in a 16 %
    // quarter disk, 600 samples refused 1.6 % more than the disk that way and 3.9 % when split
    // along the separating direction.
    return opt_.degree == Degree::Cubic && !opt_.corner_fallback
               ? widest
               : separating_direction(node, eb, widest);
  }

  // Whether a term in the element's closed box (its corners, and the samples of finer
  // neighbours on its faces) is feasible. If none is and the centre is not either, the element
  // lies inside the infeasible region as far as the samples can tell: each child keeps one of
  // its corners, so no child could become usable.
  bool any_own_sample_feasible(const KdTree::Node& node, const ElementBasis& eb) {
    for (int k : eb.terms) {
      const IPoint& p = basis_.sample(k);
      if (box_contains(node.box, p, K_) && rows_.feasible(p)) return true;
    }
    return false;
  }

  // The direction that separates the element's feasible terms from its infeasible ones best:
  // per splittable direction d, the pairs (feasible, infeasible) of terms strictly on opposite
  // sides of the mid-plane across d, counted from the four side counts. A split there puts the
  // feasible terms of those pairs in one child and the infeasible in the other, so the child on
  // the feasible side can lose its dependence on the failure; a cubic element's terms beyond
  // its box count too (they are why it is refused). Ties go to the coarser direction, then the
  // lower index; `widest` when no pair is separated (only the centre fails, say).
  int separating_direction(const KdTree::Node& node, const ElementBasis& eb, int widest) {
    // Where a corner fails, the corners alone are counted: the samples finer neighbours hang on
    // a large face would otherwise outvote them and pull the split across that face, a
    // direction the failure may not depend on (a 4-D host failing in two of its parameters
    // refused 24 % of its box at 120 and at 600 samples so).
    std::vector<IPoint> points;
    bool corner_fails = false;
    for (int m = 0; m < (1 << K_); ++m) {
      points.push_back(box_corner(node.box, m, K_));
      corner_fails = corner_fails || !rows_.feasible(points.back());
    }
    if (!corner_fails) {
      points.clear();
      for (int k : eb.terms) points.push_back(basis_.sample(k));
    }
    int dir = -1;
    long best = 0;
    for (int d = 0; d < K_; ++d) {
      if (node.level[d] >= opt_.max_level) continue;
      const Coord mid = node.box.lo[d] + (node.box.hi[d] - node.box.lo[d]) / 2;
      long count[2][2] = {{0, 0}, {0, 0}};  // [feasible][above the mid-plane]
      for (const IPoint& p : points) {
        if (p[d] == mid) continue;
        ++count[rows_.feasible(p) ? 1 : 0][p[d] > mid ? 1 : 0];
      }
      const long pairs = count[1][0] * count[0][1] + count[1][1] * count[0][0];
      if (pairs > best || (pairs == best && dir >= 0 && node.level[d] < node.level[dir])) {
        best = pairs;
        dir = pairs > 0 ? d : dir;
      }
    }
    return dir < 0 ? widest : dir;
  }

  // Splits a leaf and queues its children and the leaves whose interpolant may change (§4.2):
  // those touching the element (linear), and for cubic also their neighbours (Bbar reaches one
  // element further).
  void split(int leaf, const KdTree::Node& node, int dir) {
    std::vector<int> affected;
    tree_.leaves_touching(node.box, affected);
    const std::vector<int> added = basis_.refine(leaf, dir);
    ++res_.splits;
    ++adaptive_splits_;
    added_samples_ += static_cast<long>(added.size());
    {
      std::vector<IPoint> pts;
      for (int k : added) pts.push_back(basis_.sample(k));
      rows_.ensure(pts);  // the new samples are the centre (Eq. 10), already evaluated
    }
    if (opt_.degree == Degree::Cubic) {
      std::vector<int> ring;
      for (int n : affected)
        if (tree_.is_leaf(n)) tree_.leaves_touching(tree_.node(n).box, ring);
      affected.insert(affected.end(), ring.begin(), ring.end());
    }
    const int kid0 = tree_.node(leaf).child[0], kid1 = tree_.node(leaf).child[1];
    if (opt_.lazy_face_centres) inherit_direction_errors(leaf, dir, kid0, kid1);
    push(kid0);
    push(kid1);
    for (int n : affected)
      if (tree_.is_leaf(n)) push(n);
    res_.leaf_error.resize(static_cast<std::size_t>(tree_.node_count()),
                           std::numeric_limits<double>::quiet_NaN());
    res_.centre_row.resize(static_cast<std::size_t>(tree_.node_count()), -1);
  }

  // lazy_face_centres: the children have the parent's width in every direction but dir, so
  // they start from its direction errors; along dir the midpoint error of a smooth function
  // shrinks with the width squared. The children's own face centres replace these estimates
  // once the host has answered them.
  void inherit_direction_errors(int parent, int dir, int kid0, int kid1) {
    for (int d = 0; d < K_; ++d) {
      DirectionEstimate e = estimate(parent, d);
      if (d == dir) e.error *= 0.25;
      ++e.age;
      estimate(kid0, d) = e;
      estimate(kid1, d) = e;
    }
  }

  // Every leaf gets a centre row (its canonical mesh is the host at its centre, §4.2), also the
  // leaves the budget stopped before they were checked; then the rows of the samples.
  void finish() {
    {
      std::vector<IPoint> pts;
      for (int leaf : tree_.leaves()) pts.push_back(centre_of(tree_.node(leaf), K_));
      rows_.ensure(pts);
    }
    res_.leaf_error.resize(static_cast<std::size_t>(tree_.node_count()),
                           std::numeric_limits<double>::quiet_NaN());
    res_.centre_row.resize(static_cast<std::size_t>(tree_.node_count()), -1);
    for (int leaf : tree_.leaves()) {
      const IPoint c = centre_of(tree_.node(leaf), K_);
      bool ok = false;
      const int crow = rows_.row(c, &ok);
      res_.centre_row[static_cast<std::size_t>(leaf)] = crow;
      // Leaves left unchecked by the budget still get an estimate: the error at their centre,
      // which is evaluated anyway (it is their canonical point).
      double& err = res_.leaf_error[static_cast<std::size_t>(leaf)];
      bool terms_ok = false;
      const ElementBasis eb = usable_basis(leaf, &terms_ok);
      if (!std::isnan(err) || !ok || !terms_ok) continue;
      err = answer(error_query(eb, crow, c, crow));
    }
    res_.sample_row.resize(static_cast<std::size_t>(basis_.sample_count()));
    for (int k = 0; k < basis_.sample_count(); ++k)
      res_.sample_row[static_cast<std::size_t>(k)] = rows_.row(basis_.sample(k));
    res_.row_feasible = rows_.feasible_rows();
    res_.infeasible_rows = rows_.failed();
  }

  const int K_;
  AdaptiveProblem& problem_;
  const AdaptiveOptions& opt_;
  AdaptiveRun res_;
  Basis& basis_;
  const KdTree& tree_;
  PointRows rows_;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue_;
  std::vector<char> queued_;
  std::map<Query, double> memo_;                                   // the current wave's answers
  std::vector<std::array<DirectionEstimate, kMaxDim>> estimates_;  // per tree node
  int adaptive_splits_ = 0;  // splits after the initial refinement
  long added_samples_ = 0;   // the samples they added
};

}  // namespace

AdaptiveRun adaptive_run(int K, const std::vector<double>& lo, const std::vector<double>& hi,
                         AdaptiveProblem& problem, const AdaptiveOptions& opt) {
  check_arguments(K, lo, hi, opt);
  return AdaptiveDriver(K, lo, hi, problem, opt).run();
}

AdaptiveResult adaptive_sample(int K, int m, const std::vector<double>& lo,
                               const std::vector<double>& hi, const HostFunction& f,
                               const AdaptiveOptions& opt) {
  if (m < 1) throw std::invalid_argument("adaptive_sample: m must be at least 1");
  if (!f) throw std::invalid_argument("adaptive_sample: no host function");
  const ErrorMetric metric = opt.metric ? opt.metric : ErrorMetric(max_norm_error);
  ValueProblem problem(K, m, f, metric);
  AdaptiveRun run = adaptive_run(K, lo, hi, problem, opt);

  AdaptiveResult res{std::move(run.basis)};
  res.m = m;
  res.host_calls = static_cast<int>(run.row_feasible.size());
  res.infeasible_calls = run.infeasible_rows;
  res.splits = run.splits;
  res.budget_exhausted = run.budget_exhausted;
  res.leaf_error = std::move(run.leaf_error);
  const int S = res.basis.sample_count();
  res.values.assign(static_cast<std::size_t>(S) * static_cast<std::size_t>(m),
                    std::numeric_limits<double>::quiet_NaN());
  res.infeasible.assign(static_cast<std::size_t>(S), true);
  for (int k = 0; k < S; ++k) {
    const int r = run.sample_row[static_cast<std::size_t>(k)];
    if (!run.row_feasible[static_cast<std::size_t>(r)]) continue;
    res.infeasible[static_cast<std::size_t>(k)] = false;
    const double* v = problem.value(r);
    std::copy(v, v + m, res.values.begin() + static_cast<std::ptrdiff_t>(k) * m);
  }
  return res;
}

}  // namespace cadinterp::core
