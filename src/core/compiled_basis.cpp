#include "core/compiled_basis.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace cadinterp::core {

namespace {

// The evaluation kernel shared by CompiledBasis and eval_element_basis.
//   phi_b(u) = prod_d B((u_d - c_bd) * inv_w_bd)          (tensor product, §4.1)
//   psi_t(u) = sum_b alpha_t^b phi_b(u)                      (Eq. 6 restricted to e, Eq. 3)
// Coefficients are stored per B-spline (a few each), and a B-spline that vanishes at u together
// with its gradient (some direction has value and derivative 0) is skipped: cost is the number of
// B-splines nonzero at u times their coefficient counts, not #T * #B.
// On the element's upper face in direction d, the polynomial pieces are taken from the left so
// that the result is the element's own one-sided limit.
struct KernelInput {
  int K;
  Degree degree;
  const double* box;  // 2K: lo..., hi...
  int nb;
  const double* centre;     // nb by K
  const double* inv_width;  // nb by K
  const std::int64_t* col;  // nb + 1 offsets into col_term / col_value (may start above 0)
  const std::int32_t* col_term;
  const double* col_value;
  int nt;
};

void eval_kernel(const KernelInput& in, const double* u, double* psi, double* dpsi) {
  const int K = in.K;
  std::fill(psi, psi + in.nt, 0.0);
  if (dpsi) std::fill(dpsi, dpsi + static_cast<std::ptrdiff_t>(K) * in.nt, 0.0);
  for (int b = 0; b < in.nb; ++b) {
    double val[kMaxDim], der[kMaxDim];
    bool vanishes = false;
    for (int d = 0; d < K; ++d) {
      const double iw = in.inv_width[b * K + d];
      const double t = (u[d] - in.centre[b * K + d]) * iw;
      bspline_1d(in.degree, t, u[d] >= in.box[K + d], &val[d], &der[d]);
      if (val[d] == 0.0 && der[d] == 0.0) {
        vanishes = true;
        break;
      }
      der[d] *= iw;
    }
    if (vanishes) continue;
    double phi = 1.0;
    for (int d = 0; d < K; ++d) phi *= val[d];
    const std::int64_t j0 = in.col[b], j1 = in.col[b + 1];
    for (std::int64_t j = j0; j < j1; ++j) psi[in.col_term[j]] += in.col_value[j] * phi;
    if (!dpsi) continue;
    for (int d = 0; d < K; ++d) {
      double g = der[d];
      for (int e = 0; e < K; ++e)
        if (e != d) g *= val[e];
      double* row = dpsi + static_cast<std::ptrdiff_t>(d) * in.nt;
      for (std::int64_t j = j0; j < j1; ++j) row[in.col_term[j]] += in.col_value[j] * g;
    }
  }
}

}  // namespace

CompiledBasis CompiledBasis::compile(const Basis& basis, const std::vector<double>& lo,
                                     const std::vector<double>& hi,
                                     const std::vector<bool>* infeasible, bool corner_fallback,
                                     const std::vector<bool>* fallback) {
  const int K = basis.dim();
  if (static_cast<int>(lo.size()) != K || static_cast<int>(hi.size()) != K)
    throw std::invalid_argument("CompiledBasis::compile: domain bounds need K values");
  for (int d = 0; d < K; ++d)
    if (!(std::isfinite(lo[d]) && std::isfinite(hi[d]) && lo[d] < hi[d]))
      throw std::invalid_argument("CompiledBasis::compile: empty or non-finite domain");
  if (infeasible && static_cast<int>(infeasible->size()) != basis.sample_count())
    throw std::invalid_argument("CompiledBasis::compile: one infeasibility flag per sample");
  const std::vector<int>& leaves = basis.tree().leaves();
  if (fallback && fallback->size() != leaves.size())
    throw std::invalid_argument("CompiledBasis::compile: one fallback flag per element");

  CompiledBasis c;
  c.p_.K = K;
  c.p_.degree = basis.degree();
  c.p_.lo = lo;
  c.p_.hi = hi;
  for (int k = 0; k < basis.sample_count(); ++k)
    for (int d = 0; d < K; ++d) c.p_.sample_unit.push_back(to_unit(basis.sample(k)[d]));

  const KdTree& tree = basis.tree();
  std::vector<std::int32_t> elem_of_node(static_cast<std::size_t>(tree.node_count()), -1);
  for (std::size_t e = 0; e < leaves.size(); ++e)
    elem_of_node[static_cast<std::size_t>(leaves[e])] = static_cast<std::int32_t>(e);
  for (int n = 0; n < tree.node_count(); ++n) {
    const KdTree::Node& node = tree.node(n);
    c.p_.node_dir.push_back(node.split_dir);
    c.p_.node_split.push_back(
        node.child[1] >= 0 ? to_unit(tree.node(node.child[1]).box.lo[node.split_dir]) : 0.0);
    c.p_.node_child.push_back(node.child[0]);
    c.p_.node_child.push_back(node.child[1]);
    c.p_.node_elem.push_back(elem_of_node[static_cast<std::size_t>(n)]);
  }

  c.p_.elem_bs_begin.push_back(0);
  c.p_.elem_term_begin.push_back(0);
  c.p_.bs_col_begin.push_back(0);
  auto feasible_terms = [&](const ElementBasis& eb) {
    return !infeasible || std::none_of(eb.terms.begin(), eb.terms.end(), [&](int k) {
      return (*infeasible)[static_cast<std::size_t>(k)];
    });
  };
  for (std::size_t e = 0; e < leaves.size(); ++e) {
    const int leaf = leaves[e];
    ElementBasis eb = basis.element_basis(leaf);
    bool feasible = feasible_terms(eb);
    const bool flagged = fallback && (*fallback)[e];
    ElementBasis corners;
    if ((!feasible || flagged) && (corner_fallback || flagged) &&
        basis.corner_fallback_basis(leaf, &corners) && feasible_terms(corners)) {
      eb = std::move(corners);
      feasible = true;
    }
    const IBox& box = tree.node(leaf).box;
    for (int d = 0; d < K; ++d) c.p_.elem_box.push_back(to_unit(box.lo[d]));
    for (int d = 0; d < K; ++d) c.p_.elem_box.push_back(to_unit(box.hi[d]));
    for (const BsplineKey& key : eb.bsplines)
      for (int d = 0; d < K; ++d) {
        c.p_.bs_centre.push_back(to_unit(key.centre[d]));
        c.p_.bs_inv_width.push_back(1.0 / to_unit(width_at(key.level[d])));
      }
    c.p_.term_sample.insert(c.p_.term_sample.end(), eb.terms.begin(), eb.terms.end());
    c.p_.elem_feasible.push_back(feasible ? 1 : 0);
    const auto col0 = static_cast<std::int64_t>(c.p_.col_term.size());
    for (std::size_t j = 1; j < eb.col_begin.size(); ++j)
      c.p_.bs_col_begin.push_back(col0 + eb.col_begin[j]);
    c.p_.col_term.insert(c.p_.col_term.end(), eb.col_term.begin(), eb.col_term.end());
    c.p_.col_value.insert(c.p_.col_value.end(), eb.col_value.begin(), eb.col_value.end());
    c.p_.elem_bs_begin.push_back(static_cast<std::int64_t>(c.p_.bs_centre.size()) / K);
    c.p_.elem_term_begin.push_back(static_cast<std::int64_t>(c.p_.term_sample.size()));
  }
  return from_parts(std::move(c.p_));
}

namespace {

[[noreturn]] void invalid(const std::string& what) {
  throw std::invalid_argument("compiled basis: " + what);
}

template <class T>
void require_size(const std::vector<T>& v, std::size_t n, const char* name) {
  if (v.size() != n)
    invalid(std::string(name) + " has " + std::to_string(v.size()) + " entries, expected " +
            std::to_string(n));
}

// Offsets: size n+1, starting at 0, non-decreasing, ending at `total`.
void require_offsets(const std::vector<std::int64_t>& v, std::size_t n, std::size_t total,
                     const char* name) {
  require_size(v, n + 1, name);
  if (v.front() != 0 || static_cast<std::size_t>(v.back()) != total)
    invalid(std::string(name) + " does not span its array");
  for (std::size_t i = 0; i < n; ++i)
    if (v[i + 1] < v[i]) invalid(std::string(name) + " decreases");
}

}  // namespace

CompiledBasis CompiledBasis::from_parts(Parts p) {
  const int K = p.K;
  if (K < 1 || K > kMaxDim) invalid("dimension " + std::to_string(K) + " outside 1..8");
  if (p.degree != Degree::Linear && p.degree != Degree::Cubic) invalid("unknown degree");
  const auto k = static_cast<std::size_t>(K);
  require_size(p.lo, k, "lower bounds");
  require_size(p.hi, k, "upper bounds");
  for (std::size_t d = 0; d < k; ++d)
    if (!(std::isfinite(p.lo[d]) && std::isfinite(p.hi[d]) && p.lo[d] < p.hi[d]))
      invalid("empty or non-finite parameter range");
  if (p.sample_unit.empty() || p.sample_unit.size() % k != 0) invalid("sample array size");
  for (double u : p.sample_unit)
    if (!(u >= 0.0 && u <= 1.0)) invalid("sample outside the unit box");
  const std::size_t samples = p.sample_unit.size() / k;

  // Tree: children come after their parent (so locate terminates), each node but the root has
  // one parent, each element is exactly one leaf.
  const std::size_t nodes = p.node_dir.size();
  if (nodes == 0) invalid("empty tree");
  require_size(p.node_split, nodes, "node splits");
  require_size(p.node_child, 2 * nodes, "node children");
  require_size(p.node_elem, nodes, "node elements");
  const std::size_t elems = p.elem_feasible.size();
  if (elems == 0) invalid("no elements");
  std::vector<char> has_parent(nodes, 0), elem_seen(elems, 0);
  for (std::size_t n = 0; n < nodes; ++n) {
    const int dir = p.node_dir[n];
    if (dir < -1 || dir >= K) invalid("split direction out of range");
    // Canonical form: fields unused by a node's kind hold fixed values, so no byte is ignored.
    if (dir < 0) {
      const std::int32_t e = p.node_elem[n];
      if (e < 0 || static_cast<std::size_t>(e) >= elems || elem_seen[static_cast<std::size_t>(e)]++)
        invalid("leaf element index out of range or repeated");
      if (p.node_split[n] != 0.0 || p.node_child[2 * n] != -1 || p.node_child[2 * n + 1] != -1)
        invalid("leaf with a split or children");
      continue;
    }
    if (p.node_elem[n] != -1) invalid("inner node with an element");
    if (!(p.node_split[n] > 0.0 && p.node_split[n] < 1.0)) invalid("split coordinate");
    for (int side = 0; side < 2; ++side) {
      const std::int32_t c = p.node_child[2 * n + static_cast<std::size_t>(side)];
      if (c <= static_cast<std::int32_t>(n) || static_cast<std::size_t>(c) >= nodes ||
          has_parent[static_cast<std::size_t>(c)]++)
        invalid("child index out of order, out of range or shared");
    }
  }
  for (std::size_t n = 1; n < nodes; ++n)
    if (!has_parent[n]) invalid("unreachable tree node");
  for (char seen : elem_seen)
    if (!seen) invalid("element without a leaf");
  require_size(p.elem_box, elems * 2 * k, "element boxes");

  // Elements.
  for (std::size_t e = 0; e < elems; ++e)
    for (std::size_t d = 0; d < k; ++d) {
      const double lo = p.elem_box[e * 2 * k + d], hi = p.elem_box[e * 2 * k + k + d];
      if (!(lo >= 0.0 && lo < hi && hi <= 1.0)) invalid("element box");
    }
  // Geometry of the tree: node boxes follow from halving (K-d tree, §4), so each split must be
  // its node's midpoint and each leaf's box must be its element's box. Dyadic values: exact.
  std::vector<double> node_box(nodes * 2 * k);
  for (std::size_t d = 0; d < k; ++d) node_box[k + d] = 1.0;
  for (std::size_t n = 0; n < nodes; ++n) {
    const double* b = &node_box[n * 2 * k];
    const int dir = p.node_dir[n];
    if (dir < 0) {
      const double* eb = &p.elem_box[static_cast<std::size_t>(p.node_elem[n]) * 2 * k];
      if (!std::equal(b, b + 2 * k, eb)) invalid("element box differs from its tree leaf");
      continue;
    }
    const auto dd = static_cast<std::size_t>(dir);
    const double mid = 0.5 * (b[dd] + b[k + dd]);
    if (p.node_split[n] != mid) invalid("split is not the midpoint of its node");
    for (int side = 0; side < 2; ++side) {
      double* cb =
          &node_box[static_cast<std::size_t>(p.node_child[2 * n + static_cast<std::size_t>(side)]) *
                    2 * k];
      std::copy(b, b + 2 * k, cb);
      cb[side == 0 ? k + dd : dd] = mid;
    }
  }
  if (p.bs_centre.size() % k != 0) invalid("B-spline centre array size");
  const std::size_t bsplines = p.bs_centre.size() / k;
  require_size(p.bs_inv_width, bsplines * k, "B-spline widths");
  require_offsets(p.elem_bs_begin, elems, bsplines, "element B-spline offsets");
  require_offsets(p.elem_term_begin, elems, p.term_sample.size(), "element term offsets");
  require_offsets(p.bs_col_begin, bsplines, p.col_term.size(), "B-spline coefficient offsets");
  require_size(p.col_value, p.col_term.size(), "coefficient values");
  // Every B-spline of the tree has knot spacing 2^-level (level 0..kMaxLevel) and a centre on
  // that spacing's grid within a few spacings of [0,1]: anything else did not come from a tree
  // and could make psi overflow.
  for (std::size_t i = 0; i < p.bs_centre.size(); ++i) {
    const double iw = p.bs_inv_width[i], c = p.bs_centre[i];
    int e = 0;
    if (!(iw >= 1.0 && iw <= std::ldexp(1.0, kMaxLevel)) || std::frexp(iw, &e) != 0.5)
      invalid("B-spline width is not a power of two of the tree");
    if (!(c >= -3.0 && c <= 4.0) || c * iw != std::floor(c * iw))
      invalid("B-spline centre is off its level's grid");
  }
  for (std::int32_t s : p.term_sample)
    if (s < 0 || static_cast<std::size_t>(s) >= samples) invalid("term sample out of range");
  // Refinement masks (Eq. 5, 12) are at most 1 and the cubic boundary extrapolation weights are
  // small integers per direction; 2^20 leaves room for any K and rejects garbage.
  for (double a : p.col_value)
    if (!(std::abs(a) <= 0x1p20)) invalid("coefficient not finite or out of range");

  CompiledBasis c;
  for (std::size_t e = 0; e < elems; ++e) {
    const std::int64_t nt = p.elem_term_begin[e + 1] - p.elem_term_begin[e];
    const std::int64_t nb = p.elem_bs_begin[e + 1] - p.elem_bs_begin[e];
    if (nt > std::numeric_limits<int>::max() || nb > std::numeric_limits<int>::max())
      invalid("element too large");
    for (std::int64_t b = p.elem_bs_begin[e]; b < p.elem_bs_begin[e + 1]; ++b)
      for (std::int64_t j = p.bs_col_begin[static_cast<std::size_t>(b)];
           j < p.bs_col_begin[static_cast<std::size_t>(b) + 1]; ++j) {
        const std::int32_t t = p.col_term[static_cast<std::size_t>(j)];
        if (t < 0 || t >= nt) invalid("coefficient term out of its element");
      }
    c.max_terms_ = std::max(c.max_terms_, static_cast<int>(nt));
    c.max_bsplines_ = std::max(c.max_bsplines_, static_cast<int>(nb));
  }
  for (std::size_t d = 0; d < k; ++d) c.inv_extent_.push_back(1.0 / (p.hi[d] - p.lo[d]));
  c.p_ = std::move(p);
  // The basis' defining property, checked where it is cheapest: the weights of each feasible
  // element sum to one at its centre (partition of unity, §4). Arrays that pass every check
  // above but were not built by Algorithm 1 fail here instead of interpolating garbage.
  EvalWorkspace ws = c.make_workspace();
  BasisWeights w;
  double lo[kMaxDim], hi[kMaxDim], x[kMaxDim];
  for (int e = 0; e < c.element_count(); ++e) {
    if (!c.element_feasible(e)) continue;
    c.element_box(e, lo, hi);
    for (std::size_t d = 0; d < k; ++d) x[d] = 0.5 * (lo[d] + hi[d]);
    c.eval_element(e, x, ws, false, &w);
    double sum = 0.0;
    for (int t = 0; t < w.count; ++t) sum += w.psi[t];
    if (!(std::abs(sum - 1.0) <= 1e-6))
      invalid("element " + std::to_string(e) + ": weights do not sum to one");
  }
  return c;
}

void CompiledBasis::sample_position(int k, double* x) const {
  for (int d = 0; d < p_.K; ++d)
    x[d] =
        p_.lo[d] + (p_.hi[d] - p_.lo[d]) * p_.sample_unit[static_cast<std::size_t>(k * p_.K + d)];
}

void CompiledBasis::element_box(int e, double* lo, double* hi) const {
  const double* b = p_.elem_box.data() + static_cast<std::ptrdiff_t>(e) * 2 * p_.K;
  for (int d = 0; d < p_.K; ++d) {
    lo[d] = p_.lo[d] + (p_.hi[d] - p_.lo[d]) * b[d];
    hi[d] = p_.lo[d] + (p_.hi[d] - p_.lo[d]) * b[p_.K + d];
  }
}

const int* CompiledBasis::element_samples(int e, int* count) const {
  const auto begin = p_.elem_term_begin[static_cast<std::size_t>(e)];
  *count = static_cast<int>(p_.elem_term_begin[static_cast<std::size_t>(e) + 1] - begin);
  return p_.term_sample.data() + begin;
}

bool CompiledBasis::element_on_corner_fallback(int e) const {
  const int K = p_.K;
  int n = 0;
  const int* terms = element_samples(e, &n);
  if (p_.degree != Degree::Cubic || n != (1 << K)) return false;
  // Unit coordinates of samples and boxes both come from to_unit of the same dyadic grid, so
  // a corner compares equal exactly.
  const double* box = p_.elem_box.data() + static_cast<std::ptrdiff_t>(e) * 2 * K;
  for (int t = 0; t < n; ++t)
    for (int d = 0; d < K; ++d) {
      const double u = p_.sample_unit[static_cast<std::size_t>(terms[t] * K + d)];
      if (u != box[d] && u != box[K + d]) return false;
    }
  return true;
}

int CompiledBasis::locate(const double* x) const {
  double u[kMaxDim];
  for (int d = 0; d < p_.K; ++d) {
    if (!(x[d] >= p_.lo[d] && x[d] <= p_.hi[d])) return -1;  // also rejects NaN
    // x == hi must map to exactly 1 so that it lands in the last element.
    u[d] = x[d] == p_.hi[d] ? 1.0 : (x[d] - p_.lo[d]) * inv_extent_[d];
  }
  int n = 0;
  while (p_.node_dir[static_cast<std::size_t>(n)] >= 0) {
    const auto i = static_cast<std::size_t>(n);
    n = p_.node_child[2 * i + (u[p_.node_dir[i]] >= p_.node_split[i] ? 1 : 0)];
  }
  return p_.node_elem[static_cast<std::size_t>(n)];
}

EvalWorkspace CompiledBasis::make_workspace() const {
  EvalWorkspace ws;
  ws.u.resize(static_cast<std::size_t>(p_.K));
  ws.psi.resize(static_cast<std::size_t>(max_terms_));
  ws.dpsi.resize(static_cast<std::size_t>(p_.K * max_terms_));
  return ws;
}

void CompiledBasis::eval_element(int e, const double* x, EvalWorkspace& ws, bool want_grad,
                                 BasisWeights* out) const {
  const auto ei = static_cast<std::size_t>(e);
  for (int d = 0; d < p_.K; ++d)
    ws.u[static_cast<std::size_t>(d)] = (x[d] - p_.lo[d]) * inv_extent_[d];
  // Keep a point on the element's upper face exactly on it (the one-sided-limit test in the
  // kernel compares against the stored dyadic face).
  for (int d = 0; d < p_.K; ++d)
    if (x[d] == p_.hi[d]) ws.u[static_cast<std::size_t>(d)] = 1.0;
  const auto bs0 = p_.elem_bs_begin[ei];
  const auto t0 = p_.elem_term_begin[ei];
  const KernelInput in{p_.K,
                       p_.degree,
                       p_.elem_box.data() + static_cast<std::ptrdiff_t>(e) * 2 * p_.K,
                       static_cast<int>(p_.elem_bs_begin[ei + 1] - bs0),
                       p_.bs_centre.data() + bs0 * p_.K,
                       p_.bs_inv_width.data() + bs0 * p_.K,
                       p_.bs_col_begin.data() + bs0,
                       p_.col_term.data(),
                       p_.col_value.data(),
                       static_cast<int>(p_.elem_term_begin[ei + 1] - t0)};
  eval_kernel(in, ws.u.data(), ws.psi.data(), want_grad ? ws.dpsi.data() : nullptr);
  if (want_grad)  // chain rule: u_d = (x_d - lo_d) / (hi_d - lo_d)
    for (int d = 0; d < p_.K; ++d)
      for (int t = 0; t < in.nt; ++t)
        ws.dpsi[static_cast<std::size_t>(d * in.nt + t)] *= inv_extent_[d];
  out->element = e;
  out->count = in.nt;
  out->samples = p_.term_sample.data() + t0;
  out->psi = ws.psi.data();
  out->dpsi = want_grad ? ws.dpsi.data() : nullptr;
}

bool CompiledBasis::eval(const double* x, EvalWorkspace& ws, bool want_grad,
                         BasisWeights* out) const {
  const int e = locate(x);
  if (e < 0) return false;
  eval_element(e, x, ws, want_grad, out);
  return true;
}

void eval_element_basis(const Basis& basis, const ElementBasis& eb, const double* u, double* psi,
                        double* dpsi) {
  const int K = basis.dim();
  const IBox& box = basis.tree().node(eb.leaf).box;
  std::vector<double> b(2 * static_cast<std::size_t>(K)), centre, inv_width;
  for (int d = 0; d < K; ++d) {
    b[static_cast<std::size_t>(d)] = to_unit(box.lo[d]);
    b[static_cast<std::size_t>(K + d)] = to_unit(box.hi[d]);
  }
  for (const BsplineKey& key : eb.bsplines)
    for (int d = 0; d < K; ++d) {
      centre.push_back(to_unit(key.centre[d]));
      inv_width.push_back(1.0 / to_unit(width_at(key.level[d])));
    }
  std::vector<std::int64_t> col(eb.col_begin.begin(), eb.col_begin.end());
  const KernelInput in{K,
                       basis.degree(),
                       b.data(),
                       static_cast<int>(eb.bsplines.size()),
                       centre.data(),
                       inv_width.data(),
                       col.data(),
                       eb.col_term.data(),
                       eb.col_value.data(),
                       static_cast<int>(eb.terms.size())};
  eval_kernel(in, u, psi, dpsi);
}

}  // namespace cadinterp::core
