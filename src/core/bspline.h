// Uniform B-splines of degree 1 and 3, their refinement relations, and tensor-product keys.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "core/grid.h"

namespace cadinterp::core {

enum class Degree : int { Linear = 1, Cubic = 3 };

/// Half-width of the support in knot spans: the linear hat spans (-1,1), the cubic (-2,2).
constexpr int support_radius(Degree g) { return g == Degree::Linear ? 1 : 2; }

/// Refinement mask a_{in} of one direction (Eq. 5 linear, Eq. 12 cubic):
/// phi_i^j = sum_t mask[t] phi^{j+1}_{2i + t - radius}, t = 0..2*radius.
struct RefinementMask {
  int count;
  std::array<double, 5> weight;
  int first_offset;  ///< index offset of the first child relative to 2i
};
RefinementMask refinement_mask(Degree g);

/// Value and derivative (with respect to t) of the 1-D B-spline centred at 0 with unit knot
/// spacing, at t. At a knot the polynomial piece is chosen from the right, or from the left when
/// `left_limit` is set; this makes one-sided limits on element faces exact (linear derivatives
/// jump at knots; values and cubic derivatives do not depend on the choice).
void bspline_1d(Degree g, double t, bool left_limit, double* value, double* deriv);

/// A tensor-product B-spline: per direction its level and its centre on the integer grid
/// (centre = index * width_at(level)); the knot spacing in direction d is width_at(level[d]).
struct BsplineKey {
  std::array<std::int8_t, kMaxDim> level{};
  IPoint centre{};
  bool operator==(const BsplineKey& o) const { return level == o.level && centre == o.centre; }
};

struct BsplineKeyHash {
  std::size_t operator()(const BsplineKey& k) const noexcept {
    std::size_t h = IPointHash{}(k.centre);
    for (auto l : k.level) h = h * 31u + static_cast<std::size_t>(l);
    return h;
  }
};

/// The open support of a B-spline as an integer box (its closure; interiors are compared with
/// boxes_overlap, which treats boxes as open).
IBox support_box(const BsplineKey& key, Degree g, int K);

}  // namespace cadinterp::core
