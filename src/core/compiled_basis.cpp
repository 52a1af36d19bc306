#include "core/compiled_basis.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

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
                                     const std::vector<bool>* infeasible) {
  const int K = basis.dim();
  if (static_cast<int>(lo.size()) != K || static_cast<int>(hi.size()) != K)
    throw std::invalid_argument("CompiledBasis::compile: domain bounds need K values");
  for (int d = 0; d < K; ++d)
    if (!(std::isfinite(lo[d]) && std::isfinite(hi[d]) && lo[d] < hi[d]))
      throw std::invalid_argument("CompiledBasis::compile: empty or non-finite domain");
  if (infeasible && static_cast<int>(infeasible->size()) != basis.sample_count())
    throw std::invalid_argument("CompiledBasis::compile: one infeasibility flag per sample");

  CompiledBasis c;
  c.K_ = K;
  c.degree_ = basis.degree();
  c.lo_ = lo;
  c.hi_ = hi;
  for (int d = 0; d < K; ++d) c.inv_extent_.push_back(1.0 / (hi[d] - lo[d]));
  for (int k = 0; k < basis.sample_count(); ++k)
    for (int d = 0; d < K; ++d) c.sample_unit_.push_back(to_unit(basis.sample(k)[d]));

  const KdTree& tree = basis.tree();
  std::vector<std::int32_t> elem_of_node(static_cast<std::size_t>(tree.node_count()), -1);
  const std::vector<int>& leaves = tree.leaves();
  for (std::size_t e = 0; e < leaves.size(); ++e)
    elem_of_node[static_cast<std::size_t>(leaves[e])] = static_cast<std::int32_t>(e);
  for (int n = 0; n < tree.node_count(); ++n) {
    const KdTree::Node& node = tree.node(n);
    c.node_dir_.push_back(node.split_dir);
    c.node_split_.push_back(
        node.child[1] >= 0 ? to_unit(tree.node(node.child[1]).box.lo[node.split_dir]) : 0.0);
    c.node_child_.push_back(node.child[0]);
    c.node_child_.push_back(node.child[1]);
    c.node_elem_.push_back(elem_of_node[static_cast<std::size_t>(n)]);
  }

  c.elem_bs_begin_.push_back(0);
  c.elem_term_begin_.push_back(0);
  c.bs_col_begin_.push_back(0);
  for (int leaf : leaves) {
    const ElementBasis eb = basis.element_basis(leaf);
    const IBox& box = tree.node(leaf).box;
    for (int d = 0; d < K; ++d) c.elem_box_.push_back(to_unit(box.lo[d]));
    for (int d = 0; d < K; ++d) c.elem_box_.push_back(to_unit(box.hi[d]));
    for (const BsplineKey& key : eb.bsplines)
      for (int d = 0; d < K; ++d) {
        c.bs_centre_.push_back(to_unit(key.centre[d]));
        c.bs_inv_width_.push_back(1.0 / to_unit(width_at(key.level[d])));
      }
    bool feasible = true;
    for (int k : eb.terms) {
      c.term_sample_.push_back(k);
      if (infeasible && (*infeasible)[static_cast<std::size_t>(k)]) feasible = false;
    }
    c.feasible_.push_back(feasible ? 1 : 0);
    const auto col0 = static_cast<std::int64_t>(c.col_term_.size());
    for (std::size_t j = 1; j < eb.col_begin.size(); ++j)
      c.bs_col_begin_.push_back(col0 + eb.col_begin[j]);
    c.col_term_.insert(c.col_term_.end(), eb.col_term.begin(), eb.col_term.end());
    c.col_value_.insert(c.col_value_.end(), eb.col_value.begin(), eb.col_value.end());
    c.elem_bs_begin_.push_back(static_cast<std::int64_t>(c.bs_centre_.size()) / K);
    c.elem_term_begin_.push_back(static_cast<std::int64_t>(c.term_sample_.size()));
    c.max_terms_ = std::max(c.max_terms_, static_cast<int>(eb.terms.size()));
    c.max_bsplines_ = std::max(c.max_bsplines_, static_cast<int>(eb.bsplines.size()));
  }
  return c;
}

void CompiledBasis::sample_position(int k, double* x) const {
  for (int d = 0; d < K_; ++d)
    x[d] = lo_[d] + (hi_[d] - lo_[d]) * sample_unit_[static_cast<std::size_t>(k * K_ + d)];
}

void CompiledBasis::element_box(int e, double* lo, double* hi) const {
  const double* b = elem_box_.data() + static_cast<std::ptrdiff_t>(e) * 2 * K_;
  for (int d = 0; d < K_; ++d) {
    lo[d] = lo_[d] + (hi_[d] - lo_[d]) * b[d];
    hi[d] = lo_[d] + (hi_[d] - lo_[d]) * b[K_ + d];
  }
}

const int* CompiledBasis::element_samples(int e, int* count) const {
  const auto begin = elem_term_begin_[static_cast<std::size_t>(e)];
  *count = static_cast<int>(elem_term_begin_[static_cast<std::size_t>(e) + 1] - begin);
  return term_sample_.data() + begin;
}

int CompiledBasis::locate(const double* x) const {
  double u[kMaxDim];
  for (int d = 0; d < K_; ++d) {
    if (!(x[d] >= lo_[d] && x[d] <= hi_[d])) return -1;  // also rejects NaN
    // x == hi must map to exactly 1 so that it lands in the last element.
    u[d] = x[d] == hi_[d] ? 1.0 : (x[d] - lo_[d]) * inv_extent_[d];
  }
  int n = 0;
  while (node_dir_[static_cast<std::size_t>(n)] >= 0) {
    const auto i = static_cast<std::size_t>(n);
    n = node_child_[2 * i + (u[node_dir_[i]] >= node_split_[i] ? 1 : 0)];
  }
  return node_elem_[static_cast<std::size_t>(n)];
}

EvalWorkspace CompiledBasis::make_workspace() const {
  EvalWorkspace ws;
  ws.u.resize(static_cast<std::size_t>(K_));
  ws.psi.resize(static_cast<std::size_t>(max_terms_));
  ws.dpsi.resize(static_cast<std::size_t>(K_ * max_terms_));
  return ws;
}

void CompiledBasis::eval_element(int e, const double* x, EvalWorkspace& ws, bool want_grad,
                                 BasisWeights* out) const {
  const auto ei = static_cast<std::size_t>(e);
  for (int d = 0; d < K_; ++d) ws.u[static_cast<std::size_t>(d)] = (x[d] - lo_[d]) * inv_extent_[d];
  // Keep a point on the element's upper face exactly on it (the one-sided-limit test in the
  // kernel compares against the stored dyadic face).
  for (int d = 0; d < K_; ++d)
    if (x[d] == hi_[d]) ws.u[static_cast<std::size_t>(d)] = 1.0;
  const auto bs0 = elem_bs_begin_[ei];
  const auto t0 = elem_term_begin_[ei];
  const KernelInput in{K_,
                       degree_,
                       elem_box_.data() + static_cast<std::ptrdiff_t>(e) * 2 * K_,
                       static_cast<int>(elem_bs_begin_[ei + 1] - bs0),
                       bs_centre_.data() + bs0 * K_,
                       bs_inv_width_.data() + bs0 * K_,
                       bs_col_begin_.data() + bs0,
                       col_term_.data(),
                       col_value_.data(),
                       static_cast<int>(elem_term_begin_[ei + 1] - t0)};
  eval_kernel(in, ws.u.data(), ws.psi.data(), want_grad ? ws.dpsi.data() : nullptr);
  if (want_grad)  // chain rule: u_d = (x_d - lo_d) / (hi_d - lo_d)
    for (int d = 0; d < K_; ++d)
      for (int t = 0; t < in.nt; ++t)
        ws.dpsi[static_cast<std::size_t>(d * in.nt + t)] *= inv_extent_[d];
  out->element = e;
  out->count = in.nt;
  out->samples = term_sample_.data() + t0;
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
