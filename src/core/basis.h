// The adaptive basis: K-d tree, samples, and basis functions psi_k = sum_b alpha_k^b phi_b
// (Eq. 6), kept local, continuous and linearly precise under refinement (Algorithm 1, §5.2;
// cubic extension §5.3).
//
// Definitions used throughout (paper §4):
//   B(e)    samples lying on the closed element e (all samples of e lie on its boundary);
//   Bbar(e) cubic only: samples on the closed elements that share at least one point with e;
//   locality: alpha_k^b != 0 only if k is in B(e) (Bbar(e) for cubic) for every leaf e whose
//             interior meets the support of phi_b (Remark 1).
//
// Decisions on the points the paper leaves open:
//   * Cubic B-splines centred outside the domain have no sample. The level-0 basis gives each of
//     them the multilinear *extrapolation* weights of its centre with respect to the domain's
//     corners (e.g. 2 and -1 in 1-D), so sum_k alpha_k^b = 1 and sum_k alpha_k^b x_k = centre:
//     partition of unity and linear precision hold up to the boundary. In step 3, a point y
//     outside the domain is clamped to the domain; the common cuboid of the clamped point is
//     non-degenerate in every clamped direction, and y is expressed in its corners by multilinear
//     extrapolation, which keeps Eq. 9 and Eq. 11 exact.
//   * B-splines whose support no longer meets the domain after a refinement are dropped: they
//     are zero on the domain.
//   * y of Eq. 10 is the only non-dyadic quantity. It is snapped to the integer grid when within
//     kSnap grid units of it (a move of ~1e-13 of the domain), so that "y lies on a face" is
//     decided exactly and the common cuboid is the intersection the paper asks for.
#pragma once

#include <unordered_map>
#include <utility>
#include <vector>

#include "core/bspline.h"
#include "core/grid.h"
#include "core/kdtree.h"

namespace cadinterp::core {

/// One coefficient alpha_k^b of a B-spline: (sample id, value).
using Coefficient = std::pair<int, double>;

/// The element-local form of the basis on one leaf e: the B-splines phi_b overlapping e and the
/// samples k with psi_k != 0 on e ("terms"): psi_{terms[t]} = sum_b alpha_t^b phi_b on e (Eq. 3).
/// The coefficients are stored by B-spline (each has only a few): B-spline j owns entries
/// [col_begin[j], col_begin[j+1]) of (col_term, col_value), col_term indexing `terms`.
struct ElementBasis {
  int leaf = -1;
  std::vector<BsplineKey> bsplines;  ///< #B
  std::vector<int> terms;            ///< #T sample ids, increasing
  std::vector<int> col_begin;        ///< #B + 1
  std::vector<int> col_term;         ///< #nonzeros, index into terms
  std::vector<double> col_value;     ///< #nonzeros, alpha
};

class Basis {
 public:
  /// The level-0 basis on the unit box: one element, 2^K corner samples.
  Basis(int K, Degree degree);

  int dim() const { return tree_.dim(); }
  Degree degree() const { return degree_; }
  const KdTree& tree() const { return tree_; }

  int sample_count() const { return static_cast<int>(samples_.size()); }
  const IPoint& sample(int k) const { return samples_[static_cast<std::size_t>(k)]; }
  /// Sample id at grid point p, or -1.
  int find_sample(const IPoint& p) const;

  /// Algorithm 1: splits leaf `leaf` along `dir` and updates the basis. Returns the ids of the
  /// samples it created (step 1), in creation order. Throws std::invalid_argument for a non-leaf
  /// or a direction at kMaxLevel; std::logic_error if an invariant fails (a bug, never input).
  std::vector<int> refine(int leaf, int dir);

  /// B(e), increasing sample ids.
  const std::vector<int>& element_samples(int leaf) const {
    return leaf_samples_[static_cast<std::size_t>(leaf)];
  }

  /// The element-local form of the basis on `leaf` (see ElementBasis).
  ElementBasis element_basis(int leaf) const;

  /// The corner fallback of a cubic `leaf`, for an element whose cubic terms reach an
  /// infeasible sample while its own corners are feasible (the paper's locality, §4, applied to
  /// the cubic basis of §5.3, whose terms reach two elements beyond the box): the multilinear
  /// interpolant of the element's 2^K corner samples. It is written as the 4^K uniform cubic
  /// B-splines of the element's own knot spacing that are nonzero on it, each with the corners'
  /// multilinear weights at its centre as coefficients; uniform cubic B-splines reproduce
  /// linear functions, so on the element psi is exactly multilinear and any cubic-basis
  /// evaluator (CompiledBasis, an asset reader) evaluates it unchanged. The interpolant is
  /// continuous inside the element but not across its faces. Returns false (out untouched) for
  /// a linear basis, a non-leaf, or a corner that is not a sample (refine() never leaves one).
  bool corner_fallback_basis(int leaf, ElementBasis* out) const;

  /// Calls f(key, coefficients) for every live B-spline, in creation order.
  template <class F>
  void for_each_bspline(F&& f) const {
    for (const auto& b : bsplines_)
      if (b.alive) f(b.key, b.coeffs);
  }
  int bspline_count() const { return live_bsplines_; }

  /// Refinement finds the B-splines over an element through the per-leaf index (the live
  /// B-splines overlapping each leaf). With `on`, it scans every B-spline near the refined
  /// element instead, as the unindexed algorithm did: slower, the same basis; tests compare the
  /// two.
  void set_reference_search(bool on) { reference_search_ = on; }

 private:
  struct Bspline {
    BsplineKey key;
    IBox support;                     // support_box(key): tested against leaves at every step
    std::vector<Coefficient> coeffs;  // increasing sample id
    bool alive = true;
    int changed_in = 0;  // the refine() call that last set coeffs (0: the constructor)
  };

  int add_sample(const IPoint& p);
  bool is_sample_point(const IPoint& p, std::vector<int>& scratch) const;
  int bspline_id(const BsplineKey& key);  // creates an empty live B-spline if missing
  void set_coeffs(int b, std::vector<Coefficient> coeffs);
  void kill_bspline(int b);
  /// Live B-splines whose support meets the interior of any of `leaves`, increasing ids.
  std::vector<int> bsplines_overlapping(const std::vector<int>& leaves) const;
  bool overlaps_domain(const BsplineKey& key) const;
  /// Leaves holding a sample, cached while the tree does not change (within one refine step 3).
  using HolderCache = std::unordered_map<int, std::vector<int>>;
  bool sample_is_local(int k, const std::vector<int>& support_leaves, HolderCache& holders) const;

  // Algorithm 1 steps (refine.cpp).
  std::vector<int> add_split_samples(const IBox& parent, int dir, Coord mid);
  void uniformize(const IBox& box, const std::vector<int>& box_leaves, int dir, int min_level,
                  std::vector<int>& near);
  void index_bspline(int b, bool add);
  void refine_bsplines(const IBox& parent, const std::array<int, kMaxDim>& target,
                       const std::vector<int>& candidates);
  void enforce_locality(const std::vector<int>& candidates, const std::vector<int>& shrunk);
  std::vector<Coefficient> reallocate(const Bspline& b) const;

  Degree degree_;
  KdTree tree_;
  std::vector<IPoint> samples_;
  std::unordered_map<IPoint, int, IPointHash> sample_id_;
  std::vector<std::vector<int>> leaf_samples_;  // node id -> B(e) (leaves only)
  // node id -> live B-splines overlapping it, in ascending id order (index_bspline)
  std::vector<std::vector<int>> leaf_bsplines_;
  std::vector<Bspline> bsplines_;
  std::unordered_map<BsplineKey, int, BsplineKeyHash> bspline_id_;
  int live_bsplines_ = 0;
  bool reference_search_ = false;
  int refines_ = 0;  // refine() calls so far
};

/// Grid units within which y of Eq. 10 is snapped to the integer grid (see the file comment).
constexpr double kSnap = 1e-4;
/// Coefficients below this magnitude are rounding residue of cancellations and are dropped.
constexpr double kCoeffEpsilon = 1e-14;

}  // namespace cadinterp::core
