#include "core/adaptive.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <queue>
#include <stdexcept>
#include <unordered_map>

#include "core/compiled_basis.h"

namespace cadinterp::core {

double max_norm_error(const double* approx, const double* truth, int m) {
  double e = 0.0;
  for (int i = 0; i < m; ++i) e = std::max(e, std::abs(approx[i] - truth[i]));
  return e;
}

namespace {

// Host calls cached by grid point: every point is evaluated at most once per run.
class HostCache {
 public:
  HostCache(int K, int m, const std::vector<double>& lo, const std::vector<double>& hi,
            const HostFunction& f)
      : K_(K), m_(m), lo_(lo), hi_(hi), f_(f) {}

  /// The host's values at p, or nullptr when p is infeasible. The pointer stays valid for the
  /// cache's lifetime (rows are allocated one by one and never move).
  const double* at(const IPoint& p) {
    auto it = index_.find(p);
    if (it == index_.end()) {
      auto row = std::make_unique<double[]>(static_cast<std::size_t>(m_));
      double x[kMaxDim];
      for (int d = 0; d < K_; ++d) x[d] = lo_[d] + (hi_[d] - lo_[d]) * to_unit(p[d]);
      bool ok = f_(x, row.get());
      for (int i = 0; ok && i < m_; ++i) ok = std::isfinite(row[static_cast<std::size_t>(i)]);
      if (!ok) row.reset();
      it = index_.emplace(p, rows_.size()).first;
      rows_.push_back(std::move(row));
    }
    return rows_[it->second].get();
  }
  int calls() const { return static_cast<int>(rows_.size()); }

 private:
  int K_, m_;
  const std::vector<double>& lo_;
  const std::vector<double>& hi_;
  const HostFunction& f_;
  std::unordered_map<IPoint, std::size_t, IPointHash> index_;
  std::vector<std::unique_ptr<double[]>> rows_;  // null for infeasible points
};

int level_sum(const KdTree::Node& n, int K) {
  int s = 0;
  for (int d = 0; d < K; ++d) s += n.level[d];
  return s;
}

}  // namespace

AdaptiveResult adaptive_sample(int K, int m, const std::vector<double>& lo,
                               const std::vector<double>& hi, const HostFunction& f,
                               const AdaptiveOptions& opt) {
  if (m < 1) throw std::invalid_argument("adaptive_sample: m must be at least 1");
  if (static_cast<int>(lo.size()) != K || static_cast<int>(hi.size()) != K)
    throw std::invalid_argument("adaptive_sample: domain bounds need K values");
  for (int d = 0; d < K; ++d)
    if (!(std::isfinite(lo[d]) && std::isfinite(hi[d]) && lo[d] < hi[d]))
      throw std::invalid_argument("adaptive_sample: empty or non-finite domain");
  if (opt.max_level < 1 || opt.max_level >= kMaxLevel)
    throw std::invalid_argument("adaptive_sample: max_level outside 1..kMaxLevel-1");
  if (!(opt.tolerance >= 0.0)) throw std::invalid_argument("adaptive_sample: negative tolerance");
  if (!f) throw std::invalid_argument("adaptive_sample: no host function");
  const ErrorMetric metric = opt.metric ? opt.metric : ErrorMetric(max_norm_error);

  AdaptiveResult res{Basis(K, opt.degree)};
  Basis& basis = res.basis;
  const KdTree& tree = basis.tree();
  HostCache host(K, m, lo, hi, f);
  auto sample_ok = [&](int k) { return host.at(basis.sample(k)) != nullptr; };
  for (int k = 0; k < basis.sample_count(); ++k) sample_ok(k);

  auto split = [&](int leaf, int dir) {
    for (int k : basis.refine(leaf, dir)) sample_ok(k);
    ++res.splits;
  };
  // Initial refinement: once in every direction (§4.2).
  for (int d = 0; d < K; ++d) {
    const std::vector<int> leaves = tree.leaves();
    for (int leaf : leaves) split(leaf, d);
  }

  // Largest element first (smallest level sum), ties by node id: deterministic.
  using Entry = std::pair<int, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  std::vector<char> queued;
  auto push = [&](int leaf) {
    if (static_cast<int>(queued.size()) <= leaf)
      queued.resize(static_cast<std::size_t>(leaf) + 1, 0);
    if (queued[static_cast<std::size_t>(leaf)]) return;
    queued[static_cast<std::size_t>(leaf)] = 1;
    queue.emplace(level_sum(tree.node(leaf), K), leaf);
  };
  for (int leaf : tree.leaves()) push(leaf);
  res.leaf_error.assign(static_cast<std::size_t>(tree.node_count()),
                        std::numeric_limits<double>::quiet_NaN());

  std::vector<double> interp(static_cast<std::size_t>(m)), mean(static_cast<std::size_t>(m));
  while (!queue.empty()) {
    const int leaf = queue.top().second;
    queue.pop();
    queued[static_cast<std::size_t>(leaf)] = 0;
    if (!tree.is_leaf(leaf)) continue;
    const KdTree::Node node = tree.node(leaf);

    int widest = -1;  // splittable direction with the lowest level
    for (int d = 0; d < K; ++d)
      if (node.level[d] < opt.max_level && (widest < 0 || node.level[d] < node.level[widest]))
        widest = d;

    IPoint c{};
    for (int d = 0; d < K; ++d) c[d] = node.box.lo[d] + (node.box.hi[d] - node.box.lo[d]) / 2;
    const ElementBasis eb = basis.element_basis(leaf);
    const double* fc = host.at(c);
    const bool feasible = fc != nullptr && std::all_of(eb.terms.begin(), eb.terms.end(), sample_ok);

    int dir = -1;
    double err = std::numeric_limits<double>::infinity();
    if (!feasible) {
      if (opt.refine_infeasible) dir = widest;
    } else {
      // Error of the interpolant against the host at a grid point of the element.
      std::vector<double> psi(eb.terms.size());
      auto error_at = [&](const IPoint& p, const double* truth) {
        double u[kMaxDim];
        for (int d = 0; d < K; ++d) u[d] = to_unit(p[d]);
        eval_element_basis(basis, eb, u, psi.data(), nullptr);
        std::fill(interp.begin(), interp.end(), 0.0);
        for (std::size_t t = 0; t < eb.terms.size(); ++t) {
          const double* v = host.at(basis.sample(eb.terms[t]));
          for (int i = 0; i < m; ++i) interp[static_cast<std::size_t>(i)] += psi[t] * v[i];
        }
        return metric(interp.data(), truth, m);
      };
      err = error_at(c, fc);
      if (opt.check_face_centres)
        for (int d = 0; d < K && std::isfinite(err); ++d)
          for (int side = 0; side < 2; ++side) {
            IPoint p = c;
            p[d] = side ? node.box.hi[d] : node.box.lo[d];
            const double* fp = host.at(p);
            err = fp ? std::max(err, error_at(p, fp)) : std::numeric_limits<double>::infinity();
          }
      if (err > opt.tolerance && widest >= 0) {
        double best = -1.0;
        for (int d = 0; d < K; ++d) {
          if (node.level[d] >= opt.max_level) continue;
          IPoint a = c, b = c;
          a[d] = node.box.lo[d];
          b[d] = node.box.hi[d];
          const double* fa = host.at(a);
          const double* fb = host.at(b);
          double e = std::numeric_limits<double>::infinity();
          if (fa && fb) {
            for (int i = 0; i < m; ++i) mean[static_cast<std::size_t>(i)] = 0.5 * (fa[i] + fb[i]);
            e = metric(mean.data(), fc, m);
          }
          // Ties go to the coarser direction, then to the lower index.
          if (e > best || (e == best && node.level[d] < node.level[dir])) {
            best = e;
            dir = d;
          }
        }
        if (dir < 0) dir = widest;  // a metric returning NaN everywhere
      }
    }
    res.leaf_error[static_cast<std::size_t>(leaf)] = err;
    if (dir < 0) continue;
    if (basis.sample_count() >= opt.max_samples) {
      res.budget_exhausted = true;
      break;
    }

    // Leaves whose interpolant may change: those touching the element (linear), and for cubic
    // also their neighbours (Bbar reaches one element further).
    std::vector<int> affected;
    tree.leaves_touching(node.box, affected);
    split(leaf, dir);
    if (opt.degree == Degree::Cubic) {
      std::vector<int> ring;
      for (int n : affected)
        if (tree.is_leaf(n)) tree.leaves_touching(tree.node(n).box, ring);
      affected.insert(affected.end(), ring.begin(), ring.end());
    }
    const int kid0 = tree.node(leaf).child[0], kid1 = tree.node(leaf).child[1];
    push(kid0);
    push(kid1);
    for (int n : affected)
      if (tree.is_leaf(n)) push(n);
    res.leaf_error.resize(static_cast<std::size_t>(tree.node_count()),
                          std::numeric_limits<double>::quiet_NaN());
  }

  res.m = m;
  res.host_calls = host.calls();
  res.values.assign(static_cast<std::size_t>(basis.sample_count()) * static_cast<std::size_t>(m),
                    std::numeric_limits<double>::quiet_NaN());
  res.infeasible.assign(static_cast<std::size_t>(basis.sample_count()), true);
  for (int k = 0; k < basis.sample_count(); ++k) {
    const double* v = host.at(basis.sample(k));
    if (!v) continue;
    res.infeasible[static_cast<std::size_t>(k)] = false;
    std::copy(v, v + m, res.values.begin() + static_cast<std::ptrdiff_t>(k) * m);
  }
  res.leaf_error.resize(static_cast<std::size_t>(tree.node_count()),
                        std::numeric_limits<double>::quiet_NaN());
  return res;
}

}  // namespace cadinterp::core
