// Two-level preconditioned conjugate gradient: Jacobi plus a coarse correction on aggregates of
// nodes, whose coarse space holds each aggregate's rigid-body modes (elasticity: 3 translations,
// 3 rotations) or its constant (heat), smoothed once by damped Jacobi (smoothed aggregation,
// Vanek-Mandel-Brezina 1996). Additive: M^-1 r = D^-1 r + P (P^T K P)^-1 P^T r, SPD for any P.
// The coarse space carries the low-energy modes (bending of the whole part) that make
// Jacobi-CG's iteration count grow like 1/h: ~100 iterations instead of ~800 at 62k unknowns.
// Additive with the scalar Jacobi smoother, because the richer variants cost more than they
// save: a multiplicative (balancing) cycle takes fewer iterations but extra products with K in
// each, and a 3x3 block-Jacobi smoother saves 2 of ~100 iterations (docs/physics-solvers.md,
// "The two-level CG's blocks").
//
// Everything works on node blocks (C = 3 elastic, 1 thermal unknowns per node), because the
// solve is memory-bound and the scalar sparse formats spend as many bytes on indices as on
// values: K is streamed as symmetric 3x3 blocks (half the values, one index per block), P is
// stored as one dense C x M block per (node, aggregate) pair in single precision (M = 6 modes
// or 1), and the setup (the smoothing K P_tent and the coarse matrix P^T K P) multiplies these
// blocks directly rather than through Eigen's scalar sparse-sparse products, which sort every
// column and would be most of the setup. On elastic systems the blocks make a solve 2-3x faster
// than scalar storage, with the same iterations (physics_solver_bench; docs/physics-solvers.md,
// "The two-level CG's blocks").
#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "physics_internal.h"

namespace cadinterp::physics::detail {
namespace {

// Nodes per aggregate: measured on the cantilever box (physics_solver_bench): 50 gives a
// coarse matrix too large to factor cheaply, 300 too few modes (iterations double)
// (docs/physics-solvers.md, "The two-level CG's blocks").
constexpr std::size_t kNodesPerAggregate = 100;

// K as symmetric node blocks: each node's C x C diagonal block, and each pair of neighbouring
// nodes m > b once, as the block K(m, b) (K(b, m) is its transpose). The CG streams K once per
// iteration: this layout streams half its values and one index per block instead of one per
// value (62k elastic unknowns: 12 MB instead of 32 MB).
template <int C>
class SymmetricNodeBlocks {
 public:
  SymmetricNodeBlocks(const SparseMatrix& K, const NodeGraph& graph) {
    const std::size_t n = graph.start.size() - 1;
    // The block reads below (here and in multiply_K) rely on System's layout of K.
    if (static_cast<std::size_t>(K.rows()) != n * C || !K.isCompressed() ||
        static_cast<std::size_t>(K.nonZeros()) != graph.neighbors.size() * C * C) {
      throw Error("physics: internal error: the two-level solver needs the system's node layout");
    }
    const int* outer = K.outerIndexPtr();
    const double* values = K.valuePtr();
    diag_.resize(n * C * C);
    start_.resize(n + 1);
    start_[0] = 0;
    for (std::size_t b = 0; b < n; ++b) {
      std::size_t upper = 0;
      for (std::size_t k = graph.start[b]; k < graph.start[b + 1]; ++k)
        upper += graph.neighbors[k] > b ? 1 : 0;
      start_[b + 1] = start_[b] + upper;
    }
    index_.resize(start_[n]);
    upper_.resize(start_[n] * C * C);
    // System's layout (physics_system.cpp): column (b, j) holds K(m C + i, b C + j) for each
    // neighbour m of b in order, all i, from outer[b C + j].
    for (std::size_t b = 0; b < n; ++b) {
      std::size_t u = start_[b];
      for (std::size_t k = graph.start[b]; k < graph.start[b + 1]; ++k) {
        const std::uint32_t m = graph.neighbors[k];
        if (m < b) continue;
        double* block = m == b ? &diag_[b * C * C] : &upper_[u * C * C];
        if (m > b) index_[u++] = m;
        const std::size_t local = k - graph.start[b];
        for (int j = 0; j < C; ++j) {
          const double* column = values + outer[b * C + static_cast<std::size_t>(j)] + local * C;
          for (int i = 0; i < C; ++i) block[i * C + j] = column[i];
        }
      }
    }
  }

  /// y = K x; returns x . y (fused: y_b is final once node b is done, as later nodes only add
  /// to their upper neighbours, so the CG's p . K p costs no extra pass over the vectors).
  double multiply(const double* x, double* y) const {
    double dot = 0.0;
    const std::size_t n = start_.size() - 1;
    std::fill(y, y + n * C, 0.0);
    for (std::size_t b = 0; b < n; ++b) {
      const double* xb = x + b * C;
      const double* d = &diag_[b * C * C];
      double yb[C];
      for (int i = 0; i < C; ++i) {
        double s = 0.0;
        for (int j = 0; j < C; ++j) s += d[i * C + j] * xb[j];
        yb[i] = s;
      }
      for (std::size_t k = start_[b]; k < start_[b + 1]; ++k) {
        const double* B = &upper_[k * C * C];
        const double* xm = x + std::size_t{index_[k]} * C;
        double* ym = y + std::size_t{index_[k]} * C;
        for (int i = 0; i < C; ++i) {
          double s = 0.0;
          for (int j = 0; j < C; ++j) s += B[i * C + j] * xb[j];
          ym[i] += s;
        }
        for (int j = 0; j < C; ++j) {
          double s = 0.0;
          for (int i = 0; i < C; ++i) s += B[i * C + j] * xm[i];
          yb[j] += s;
        }
      }
      for (int i = 0; i < C; ++i) {
        y[b * C + i] += yb[i];
        dot += xb[i] * y[b * C + i];
      }
    }
    return dot;
  }

 private:
  std::vector<double> diag_;
  std::vector<std::size_t> start_;
  std::vector<std::uint32_t> index_;
  std::vector<double> upper_;
};

// A matrix with C rows per node and M coarse columns per aggregate: per node, a list of
// (aggregate a, dense C x M block, row-major), aggregates increasing. P, K P_tent and K P all
// have this shape: a node's unknowns all see the same aggregates. M is the number of rigid-body
// modes (6 elastic, 1 thermal) whatever the QR kept: a mode it dropped is a zero column, so
// every block has the same compile-time size (the loops unroll; with a per-aggregate width the
// preconditioner spent a quarter of its time in loop control).
struct NodeAggregateBlocks {
  std::vector<std::size_t> start{0};    // per node: its blocks [start[i], start[i+1])
  std::vector<std::int32_t> aggregate;  // per block
  std::vector<double> value;            // per block: C x M values from block * C * M
};

// (K B) for B in node-aggregate blocks, K read in node blocks from System's CSC layout:
// (K B)_i = sum over neighbours m of K_im B_m, accumulated per aggregate in a scratch slot.
template <int C, int M>
NodeAggregateBlocks multiply_K(const SparseMatrix& K, const NodeGraph& graph,
                               const NodeAggregateBlocks& B, std::size_t aggregates) {
  const std::size_t n = graph.start.size() - 1;
  const int* outer = K.outerIndexPtr();
  const double* values = K.valuePtr();
  NodeAggregateBlocks out;
  out.start.reserve(n + 1);
  out.value.reserve(B.value.size() * 3);
  std::vector<int> slot(aggregates, -1);
  std::vector<std::int32_t> touched;
  std::vector<double> acc;
  for (std::size_t i = 0; i < n; ++i) {
    touched.clear();
    for (std::size_t l = graph.start[i]; l < graph.start[i + 1]; ++l) {
      const std::size_t m = graph.neighbors[l];
      const std::size_t local = l - graph.start[i];
      // K_im[j][r] = K(i C + j, m C + r) = K(m C + r, i C + j): column (i, j) of the CSC.
      double Kim[C * C];
      for (int j = 0; j < C; ++j) {
        const double* column = values + outer[i * C + static_cast<std::size_t>(j)] + local * C;
        for (int r = 0; r < C; ++r) Kim[j * C + r] = column[r];
      }
      for (std::size_t bb = B.start[m]; bb < B.start[m + 1]; ++bb) {
        const std::int32_t a = B.aggregate[bb];
        int& s = slot[static_cast<std::size_t>(a)];
        if (s < 0) {
          s = static_cast<int>(touched.size());
          touched.push_back(a);
          acc.resize(touched.size() * C * M, 0.0);
        }
        double* A = &acc[static_cast<std::size_t>(s) * C * M];
        const double* Bm = &B.value[bb * C * M];
        for (int j = 0; j < C; ++j) {
          for (int r = 0; r < C; ++r) {
            const double kv = Kim[j * C + r];
            for (int k = 0; k < M; ++k) A[j * M + k] += kv * Bm[r * M + k];
          }
        }
      }
    }
    std::sort(touched.begin(), touched.end());
    for (const std::int32_t a : touched) {
      int& s = slot[static_cast<std::size_t>(a)];
      const double* A = &acc[static_cast<std::size_t>(s) * C * M];
      out.aggregate.push_back(a);
      out.value.insert(out.value.end(), A, A + C * M);
      s = -1;
    }
    acc.clear();
    out.start.push_back(out.aggregate.size());
  }
  return out;
}

// Aggregates: the nodes in each cell of a regular grid sized for ~kNodesPerAggregate nodes
// per non-empty cell (a few bisection steps on the cell size): a coarse space small enough for
// a cheap sparse Cholesky, rich enough (6 modes each) to carry the global bending. Sets each
// node's aggregate in `label`; returns the number of aggregates.
std::size_t aggregate_nodes(const std::vector<double>& nodes, std::size_t n,
                            std::vector<std::int32_t>& label) {
  const std::size_t wanted = std::max<std::size_t>(1, n / kNodesPerAggregate);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (std::size_t i = 0; i < n; ++i) {
    lo = lo.cwiseMin(Eigen::Map<const Eigen::Vector3d>(&nodes[3 * i]));
    hi = hi.cwiseMax(Eigen::Map<const Eigen::Vector3d>(&nodes[3 * i]));
  }
  label.assign(n, 0);
  std::vector<std::uint64_t> keys(n), sorted;
  double cell = (hi - lo).maxCoeff() + 1e-300;
  double lo_cell = 0, hi_cell = cell;  // cells too small (many) .. too big (few)
  for (int step = 0; step < 9; ++step) {
    for (std::size_t i = 0; i < n; ++i) {
      std::uint64_t key = 0;
      for (int k = 0; k < 3; ++k) {
        key = key * 2097152u +
              static_cast<std::uint64_t>((nodes[3 * i + k] - lo[k]) / cell) % 2097152u;
      }
      keys[i] = key;
    }
    sorted = keys;
    std::sort(sorted.begin(), sorted.end());
    sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
    if (step == 8) break;
    if (sorted.size() > wanted) {
      lo_cell = cell;
    } else {
      hi_cell = cell;
    }
    cell = lo_cell > 0 ? 0.5 * (lo_cell + hi_cell) : 0.5 * hi_cell;
  }
  for (std::size_t i = 0; i < n; ++i) {
    label[i] = static_cast<std::int32_t>(std::lower_bound(sorted.begin(), sorted.end(), keys[i]) -
                                         sorted.begin());
  }
  return sorted.size();
}

// Tentative prolongator: each aggregate's modes, orthonormalized (QR) and with dependent
// ones (an aggregate on a line has no rotation about it) dropped. One block per node. Sets each
// aggregate's number of kept modes in `rank`.
template <int C, int M>
NodeAggregateBlocks tentative_prolongator(const std::vector<double>& nodes,
                                          const std::vector<std::int32_t>& label,
                                          std::size_t aggregates, std::vector<int>& rank) {
  const std::size_t n = label.size();
  constexpr auto c = static_cast<std::size_t>(C);
  // Members of each aggregate, in node order.
  std::vector<std::vector<std::uint32_t>> members(aggregates);
  for (std::size_t i = 0; i < n; ++i) members[label[i]].push_back(static_cast<std::uint32_t>(i));
  rank.assign(aggregates, 0);
  NodeAggregateBlocks T;
  T.start.assign(n + 1, 0);
  T.aggregate.resize(n);
  T.value.assign(n * C * M, 0.0);
  std::vector<Eigen::MatrixXd> Q(aggregates);
  for (std::size_t g = 0; g < aggregates; ++g) {
    const std::vector<std::uint32_t>& group = members[g];
    const auto rows = static_cast<Eigen::Index>(group.size() * c);
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(rows, M);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (std::uint32_t i : group) centre += Eigen::Map<const Eigen::Vector3d>(&nodes[3 * i]);
    centre /= static_cast<double>(group.size());
    double radius = 0.0;
    for (std::uint32_t i : group) {
      radius = std::max(radius, (Eigen::Map<const Eigen::Vector3d>(&nodes[3 * i]) - centre).norm());
    }
    if (!(radius > 0)) radius = 1.0;  // a single node: only its translations survive the QR
    for (std::size_t m = 0; m < group.size(); ++m) {
      const auto r0 = static_cast<Eigen::Index>(m * c);
      if (C == 1) {
        B(r0, 0) = 1.0;
        continue;
      }
      // Offsets in units of the aggregate's radius: the QR rank test is then unit-free.
      const Eigen::Vector3d d =
          (Eigen::Map<const Eigen::Vector3d>(&nodes[3 * group[m]]) - centre) / radius;
      for (int k = 0; k < 3; ++k) {
        B(r0 + k, k) = 1.0;
        const Eigen::Vector3d rot = Eigen::Vector3d::Unit(k).cross(d);
        for (int i = 0; i < 3; ++i) B(r0 + i, 3 + k) = rot[i];
      }
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(B);
    qr.setThreshold(1e-8);
    rank[g] = static_cast<int>(qr.rank());
    Q[g] = qr.householderQ() * Eigen::MatrixXd::Identity(rows, rank[g]);
  }
  for (std::size_t i = 0; i < n; ++i) {
    T.start[i + 1] = i + 1;
    T.aggregate[i] = label[i];
    const std::size_t g = static_cast<std::size_t>(label[i]);
    // The node's position in its aggregate: members are in node order.
    const auto m = static_cast<Eigen::Index>(
        std::lower_bound(members[g].begin(), members[g].end(), static_cast<std::uint32_t>(i)) -
        members[g].begin());
    for (std::size_t j = 0; j < c; ++j)
      for (int k = 0; k < rank[g]; ++k)
        T.value[(i * c + j) * M + static_cast<std::size_t>(k)] =
            Q[g](m * static_cast<Eigen::Index>(c) + static_cast<Eigen::Index>(j), k);
  }
  return T;
}

// Smoothed aggregation: P = (I - omega D^-1 K) P_tent lowers the energy of the coarse
// functions (Vanek, Mandel, Brezina 1996), omega = 4 / (3 rho(D^-1 K)) with rho estimated
// by 6 power iterations (enough: any P gives an SPD preconditioner). Returns P in double and
// sets `P_single` to the same values in single precision.
template <int C, int M>
NodeAggregateBlocks smoothed_prolongator(const SparseMatrix& K, const NodeGraph& graph,
                                         const SymmetricNodeBlocks<C>& Kb,
                                         const Eigen::VectorXd& inv_diag,
                                         const std::vector<std::int32_t>& label,
                                         const NodeAggregateBlocks& T, std::size_t aggregates,
                                         std::vector<float>& P_single) {
  const std::size_t n = graph.start.size() - 1;
  constexpr auto c = static_cast<std::size_t>(C);
  double rho = 0.0;
  {
    Eigen::VectorXd v = Eigen::VectorXd::Ones(K.rows()), w(K.rows());
    for (int i = 0; i < 6; ++i) {
      (void)Kb.multiply(v.data(), w.data());
      w = inv_diag.cwiseProduct(w);
      rho = w.norm() / v.norm();
      v = w / w.norm();
    }
  }
  const double omega = 4.0 / (3.0 * rho);
  NodeAggregateBlocks P = multiply_K<C, M>(K, graph, T, aggregates);  // K P_tent, then P
  P_single.assign(P.value.size(), 0.0f);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t bb = P.start[i]; bb < P.start[i + 1]; ++bb) {
      double* v = &P.value[bb * C * M];
      const double* t = P.aggregate[bb] == label[i] ? &T.value[i * C * M] : nullptr;
      for (std::size_t j = 0; j < c; ++j) {
        const double scale = omega * inv_diag[static_cast<Eigen::Index>(i * c + j)];
        for (std::size_t k = 0; k < M; ++k) {
          const std::size_t e = j * M + k;
          // Rounded to single precision here, and the coarse matrix below is made of exactly
          // these values: the preconditioner applies P and P^T from the float copy (half the
          // bytes) and stays exactly symmetric. P only shapes the preconditioner: the CG
          // residual is computed in double with K, to the same tolerance.
          const float rounded = static_cast<float>((t ? t[e] : 0.0) - scale * v[e]);
          P_single[bb * C * M + e] = rounded;
          v[e] = static_cast<double>(rounded);
        }
      }
    }
  }
  return P;
}

// The coarse matrix in compressed-column arrays (symmetric, rows sorted in each column).
struct CoarseMatrix {
  std::vector<int> outer, inner;
  std::vector<double> values;
};

// The coarse matrix P^T (K P), one block row per aggregate a: the nodes whose P has a block
// of a, each times its row of K P, accumulated in a dense row buffer over the coarse columns.
template <int C, int M>
CoarseMatrix coarse_matrix(const SparseMatrix& K, const NodeGraph& graph,
                           const NodeAggregateBlocks& P, const std::vector<int>& rank,
                           std::size_t aggregates) {
  const std::size_t n = graph.start.size() - 1;
  constexpr auto c = static_cast<std::size_t>(C);
  const std::size_t coarse_n = aggregates * M;
  const NodeAggregateBlocks KP = multiply_K<C, M>(K, graph, P, aggregates);
  std::vector<std::size_t> by_aggregate_start(aggregates + 1, 0);
  for (const std::int32_t a : P.aggregate) ++by_aggregate_start[static_cast<std::size_t>(a) + 1];
  for (std::size_t a = 0; a < aggregates; ++a) by_aggregate_start[a + 1] += by_aggregate_start[a];
  std::vector<std::pair<std::uint32_t, std::size_t>> by_aggregate(P.aggregate.size());
  {
    std::vector<std::size_t> fill(by_aggregate_start.begin(), by_aggregate_start.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t bb = P.start[i]; bb < P.start[i + 1]; ++bb)
        by_aggregate[fill[static_cast<std::size_t>(P.aggregate[bb])]++] = {
            static_cast<std::uint32_t>(i), bb};
  }
  CoarseMatrix kc;
  kc.outer.assign(coarse_n + 1, 0);
  std::vector<double> row(M * coarse_n, 0.0);
  std::vector<char> seen(aggregates, 0);
  std::vector<std::int32_t> touched;
  for (std::size_t a = 0; a < aggregates; ++a) {
    touched.clear();
    for (std::size_t q = by_aggregate_start[a]; q < by_aggregate_start[a + 1]; ++q) {
      const std::size_t i = by_aggregate[q].first;
      const double* Pa = &P.value[by_aggregate[q].second * C * M];
      for (std::size_t kb = KP.start[i]; kb < KP.start[i + 1]; ++kb) {
        const auto b = static_cast<std::size_t>(KP.aggregate[kb]);
        if (!seen[b]) {
          seen[b] = 1;
          touched.push_back(KP.aggregate[kb]);
        }
        const double* KPb = &KP.value[kb * C * M];
        for (std::size_t k = 0; k < M; ++k) {
          double* out = &row[k * coarse_n + b * M];
          for (std::size_t k2 = 0; k2 < M; ++k2) {
            double s = 0.0;
            for (std::size_t j = 0; j < c; ++j) s += Pa[j * M + k] * KPb[j * M + k2];
            out[k2] += s;
          }
        }
      }
    }
    std::sort(touched.begin(), touched.end());
    // Columns a M + k of the (symmetric) coarse matrix, rows sorted. A mode the QR dropped
    // (k >= rank[a]) has a zero column in P, hence a zero row and column here: its diagonal
    // is set to 1 so that the matrix stays definite (its coarse unknown stays 0).
    for (std::size_t k = 0; k < M; ++k) {
      for (const std::int32_t b : touched) {
        const std::size_t col0 = static_cast<std::size_t>(b) * M;
        double* in = &row[k * coarse_n + col0];
        for (std::size_t k2 = 0; k2 < M; ++k2) {
          const bool dropped =
              static_cast<std::size_t>(b) == a && k2 == k && k >= static_cast<std::size_t>(rank[a]);
          kc.inner.push_back(static_cast<int>(col0 + k2));
          kc.values.push_back(dropped ? 1.0 : in[k2]);
          in[k2] = 0.0;
        }
      }
      kc.outer[a * M + k + 1] = static_cast<int>(kc.inner.size());
    }
    for (const std::int32_t b : touched) seen[static_cast<std::size_t>(b)] = 0;
  }
  return kc;
}

// The preconditioner M^-1 r = D^-1 r + P (P^T K P)^-1 P^T r, from P's pattern, its
// single-precision values and the coarse matrix's Cholesky factor.
template <int C, int M>
struct TwoLevelPreconditioner {
  const NodeAggregateBlocks& P;  // its pattern (start, aggregate)
  const std::vector<float>& P_single;
  const Eigen::VectorXd& inv_diag;
  const Eigen::SimplicialLLT<SparseMatrix>& coarse;
  // Allocated once: a 60k-unknown vector is 0.5 MB, which glibc maps and unmaps (page faults
  // included) on each temporary.
  Eigen::VectorXd coarse_r, coarse_x;

  // out = M^-1 res; returns res . out (fused into the last pass, like the CG's other dot
  // products).
  double operator()(const Eigen::VectorXd& res, Eigen::VectorXd& out) {
    const std::size_t n = P.start.size() - 1;
    constexpr auto c = static_cast<std::size_t>(C);
    // coarse_r = P^T res (a scatter into the small coarse vector), out = D^-1 res + P coarse_x;
    // the blocks of a node are consecutive in P_single.
    coarse_r.setZero();
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t bb = P.start[i]; bb < P.start[i + 1]; ++bb) {
        const float* v = &P_single[bb * C * M];
        double* cr = coarse_r.data() + static_cast<std::size_t>(P.aggregate[bb]) * M;
        for (std::size_t j = 0; j < c; ++j) {
          const double rj = res[static_cast<Eigen::Index>(i * c + j)];
          for (std::size_t k = 0; k < M; ++k) cr[k] += static_cast<double>(v[j * M + k]) * rj;
        }
      }
    }
    coarse_x = coarse.solve(coarse_r);
    double dot = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      double s[C] = {};
      for (std::size_t bb = P.start[i]; bb < P.start[i + 1]; ++bb) {
        const float* v = &P_single[bb * C * M];
        const double* cx = coarse_x.data() + static_cast<std::size_t>(P.aggregate[bb]) * M;
        for (std::size_t j = 0; j < c; ++j)
          for (std::size_t k = 0; k < M; ++k) s[j] += static_cast<double>(v[j * M + k]) * cx[k];
      }
      for (std::size_t j = 0; j < c; ++j) {
        const auto e = static_cast<Eigen::Index>(i * c + j);
        out[e] = inv_diag[e] * res[e] + s[j];
        dot += res[e] * out[e];
      }
    }
    return dot;
  }
};

// Preconditioned CG (the textbook loop; Eigen's needs a preconditioner class), its vector
// updates and dot products fused into as few passes as the recurrences allow. Sets the result's
// x and iterations.
template <int C, class Precondition>
void conjugate_gradient(const SymmetricNodeBlocks<C>& Kb, const Eigen::VectorXd& f,
                        double tolerance, Precondition& precondition, LinearSolveResult& result) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(f.size());
  Eigen::VectorXd r = f;
  Eigen::VectorXd z(f.size()), q(f.size());
  const double target = tolerance * f.norm();
  double rz = precondition(r, z);
  Eigen::VectorXd p = z;
  double rr = r.squaredNorm();
  const Eigen::Index size = f.size();
  const int max_iterations = static_cast<int>(std::max<Eigen::Index>(1000, size));
  int it = 0;
  for (; it < max_iterations && std::sqrt(rr) > target; ++it) {
    const double pq = Kb.multiply(p.data(), q.data());
    if (!(pq > 0)) {
      throw Error("physics: singular system: conjugate gradient met a non-positive curvature");
    }
    const double alpha = rz / pq;
    rr = 0.0;
    for (Eigen::Index e = 0; e < size; ++e) {
      x[e] += alpha * p[e];
      r[e] -= alpha * q[e];
      rr += r[e] * r[e];
    }
    const double rz_next = precondition(r, z);
    const double beta = rz_next / rz;
    for (Eigen::Index e = 0; e < size; ++e) p[e] = z[e] + beta * p[e];
    rz = rz_next;
  }
  if (!(r.norm() <= target) || !x.allFinite()) {
    throw Error("physics: two-level conjugate gradient did not converge in " + std::to_string(it) +
                " iterations (singular system?)");
  }
  result.x = std::move(x);
  result.iterations = it;
}

template <int C, int M>
LinearSolveResult two_level(const SparseMatrix& K, const Eigen::VectorXd& f, const NodeGraph& graph,
                            const std::vector<double>& nodes, double tolerance) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = graph.start.size() - 1;
  std::vector<std::int32_t> label;
  const std::size_t aggregates = aggregate_nodes(nodes, n, label);
  std::vector<int> rank;
  NodeAggregateBlocks T = tentative_prolongator<C, M>(nodes, label, aggregates, rank);
  const SymmetricNodeBlocks<C> Kb(K, graph);
  const Eigen::VectorXd inv_diag = K.diagonal().cwiseInverse();
  std::vector<float> P_single;
  NodeAggregateBlocks P =
      smoothed_prolongator<C, M>(K, graph, Kb, inv_diag, label, T, aggregates, P_single);
  T = NodeAggregateBlocks{};
  CoarseMatrix kc = coarse_matrix<C, M>(K, graph, P, rank, aggregates);
  const auto coarse_dim = static_cast<Eigen::Index>(aggregates * M);
  const SparseMatrix Kc = Eigen::Map<const SparseMatrix>(
      coarse_dim, coarse_dim, static_cast<Eigen::Index>(kc.values.size()), kc.outer.data(),
      kc.inner.data(), kc.values.data());
  Eigen::SimplicialLLT<SparseMatrix> coarse(Kc);
  // Only P's pattern and its single-precision values are used from here on.
  std::vector<double>().swap(P.value);
  if (coarse.info() != Eigen::Success) {
    throw Error("physics: singular system: the coarse matrix is not positive definite");
  }
  TwoLevelPreconditioner<C, M> precondition{
      P, P_single, inv_diag, coarse, Eigen::VectorXd(coarse_dim), Eigen::VectorXd(coarse_dim)};
  LinearSolveResult result;
  conjugate_gradient(Kb, f, tolerance, precondition, result);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace

LinearSolveResult solve_two_level(const SparseMatrix& K, const Eigen::VectorXd& f,
                                  const NodeGraph& graph, const std::vector<double>& nodes,
                                  int components, double tolerance) {
  if (components == 3) return two_level<3, 6>(K, f, graph, nodes, tolerance);  // rigid modes
  if (components == 1) return two_level<1, 1>(K, f, graph, nodes, tolerance);  // constant
  throw Error("physics: the two-level solver handles 1 or 3 unknowns per node, not " +
              std::to_string(components));
}

}  // namespace cadinterp::physics::detail
