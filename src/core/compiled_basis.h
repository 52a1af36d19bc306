// The evaluation form of a basis: flat arrays per element, point location, and psi_k(x),
// grad psi_k(x) for the samples of the element holding x (Eq. 3, Eq. 13), with no allocation
// per call. This is what an asset stores and what the runtime evaluates.
#pragma once

#include <cstdint>
#include <vector>

#include "core/basis.h"

namespace cadinterp::core {

/// Scratch for evaluation; one per thread. Sized once by CompiledBasis::make_workspace.
struct EvalWorkspace {
  std::vector<double> u;     ///< K    point in unit coordinates
  std::vector<double> psi;   ///< max #T
  std::vector<double> dpsi;  ///< K * max #T, direction-major
};

/// Result of an evaluation; pointers stay valid until the next call with the same workspace
/// (psi, dpsi) or for the lifetime of the CompiledBasis (samples).
struct BasisWeights {
  int element = -1;
  int count = 0;                 ///< #T
  const int* samples = nullptr;  ///< #T sample ids
  const double* psi = nullptr;   ///< #T  psi_k(x)
  const double* dpsi = nullptr;  ///< K by #T, dpsi[d * #T + t] = d psi_t / d x_d (real units)
};

class CompiledBasis {
 public:
  /// Flattens `basis` for the parameter box [lo, hi] (K values each, lo < hi).
  /// `infeasible`, if given, has one flag per sample; an element whose terms include an
  /// infeasible sample is marked infeasible (never interpolated across), except that with
  /// `corner_fallback` a cubic element whose corners are all feasible gets its corner fallback
  /// (Basis::corner_fallback_basis) instead: the choice AdaptiveOptions::corner_fallback makes
  /// during sampling. `fallback`, if given, has one flag per element (the tree's leaves in
  /// order): a flagged cubic element whose corners are all feasible gets its corner fallback
  /// although its own terms are feasible (the builder's choice for an element one of whose
  /// terms cannot be mapped onto its canonical mesh). Throws std::invalid_argument for bounds
  /// that are not K finite increasing pairs, an infeasibility flag count other than the sample
  /// count or a fallback flag count other than the element count.
  static CompiledBasis compile(const Basis& basis, const std::vector<double>& lo,
                               const std::vector<double>& hi,
                               const std::vector<bool>* infeasible = nullptr,
                               bool corner_fallback = true,
                               const std::vector<bool>* fallback = nullptr);

  int dim() const { return p_.K; }
  Degree degree() const { return p_.degree; }
  int element_count() const { return static_cast<int>(p_.elem_term_begin.size()) - 1; }
  int sample_count() const { return static_cast<int>(p_.sample_unit.size()) / p_.K; }
  const std::vector<double>& lower() const { return p_.lo; }
  const std::vector<double>& upper() const { return p_.hi; }

  /// Sample k's position in real parameter coordinates, written to x (K values).
  void sample_position(int k, double* x) const;
  /// Element e's box in real coordinates.
  void element_box(int e, double* lo, double* hi) const;
  /// Samples with psi != 0 on element e.
  const int* element_samples(int e, int* count) const;
  bool element_feasible(int e) const { return p_.elem_feasible[static_cast<std::size_t>(e)] != 0; }
  /// Whether element e of a cubic basis interpolates on its corner fallback
  /// (Basis::corner_fallback_basis): its terms are exactly the 2^K samples at its box's corners,
  /// so psi is multilinear on it. A cubic element's own B-splines always reach a sample beyond
  /// its corners, so the terms tell the two apart without a flag in the asset. False for a
  /// linear basis.
  bool element_on_corner_fallback(int e) const;
  /// Whether element e interpolates with cubic B-splines: a cubic basis's element that is not
  /// on its corner fallback. What the error model's shape and factor follow
  /// (format/error_model.h).
  bool element_cubic(int e) const {
    return p_.degree == Degree::Cubic && !element_on_corner_fallback(e);
  }
  int max_terms() const { return max_terms_; }
  int max_bsplines() const { return max_bsplines_; }

  /// The element holding x (real coordinates), -1 if x is outside the box or not finite.
  /// Points on faces are assigned as KdTree::locate_unit does.
  int locate(const double* x) const;

  EvalWorkspace make_workspace() const;

  /// psi and (if want_grad) grad psi at x, for the element `element` (any x: points on or near
  /// the element's faces give that element's one-sided limits). No allocation.
  void eval_element(int element, const double* x, EvalWorkspace& ws, bool want_grad,
                    BasisWeights* out) const;

  /// locate + eval_element. Returns false (out untouched) when x is outside the domain.
  bool eval(const double* x, EvalWorkspace& ws, bool want_grad, BasisWeights* out) const;

  /// Every array of a compiled basis; what an asset stores (fileformat/cadinterp.fbs, Basis).
  struct Parts {
    int K = 0;
    Degree degree = Degree::Linear;
    std::vector<double> lo, hi;       ///< K each: the parameter box
    std::vector<double> sample_unit;  ///< #S by K, unit coordinates

    // Point location: per node the split direction (-1 leaf), the split coordinate in unit
    // coordinates, the two children (2 per node, always after their parent), and for a leaf
    // its element index.
    std::vector<std::int8_t> node_dir;
    std::vector<double> node_split;
    std::vector<std::int32_t> node_child;
    std::vector<std::int32_t> node_elem;

    // Per element e: box (unit; lo..., hi...), feasibility, B-splines
    // [elem_bs_begin[e], elem_bs_begin[e+1]) with centre and inverse knot spacing per direction,
    // terms [elem_term_begin[e], elem_term_begin[e+1]) of term_sample. B-spline b (global index)
    // has coefficients [bs_col_begin[b], bs_col_begin[b+1]) of (col_term, col_value), col_term
    // indexing its element's terms.
    std::vector<double> elem_box;  ///< #E by 2K
    std::vector<std::uint8_t> elem_feasible;
    std::vector<std::int64_t> elem_bs_begin;      ///< #E + 1
    std::vector<std::int64_t> elem_term_begin;    ///< #E + 1
    std::vector<double> bs_centre, bs_inv_width;  ///< #B by K
    std::vector<std::int64_t> bs_col_begin;       ///< #B + 1
    std::vector<std::int32_t> term_sample;
    std::vector<std::int32_t> col_term;
    std::vector<double> col_value;
  };

  const Parts& parts() const { return p_; }

  /// Builds a basis from arrays of untrusted origin (an asset file). Every size, index, range
  /// and value is checked first, so that evaluation can never read out of bounds or loop;
  /// throws std::invalid_argument naming the first violation.
  static CompiledBasis from_parts(Parts parts);

 private:
  Parts p_;
  std::vector<double> inv_extent_;
  int max_terms_ = 0, max_bsplines_ = 0;
};

/// Evaluates one ElementBasis of a live Basis at unit point u (for the adaptive driver and
/// tests; the runtime uses CompiledBasis). psi: #T values; dpsi (optional): K by #T.
void eval_element_basis(const Basis& basis, const ElementBasis& eb, const double* u, double* psi,
                        double* dpsi);

}  // namespace cadinterp::core
