#include "core/bspline.h"

#include <cmath>

namespace cadinterp::core {

RefinementMask refinement_mask(Degree g) {
  if (g == Degree::Linear) return {3, {0.5, 1.0, 0.5, 0.0, 0.0}, -1};  // Eq. 5
  return {5, {0.125, 0.5, 0.75, 0.5, 0.125}, -2};                      // Eq. 12
}

void bspline_1d(Degree g, double t, bool left_limit, double* value, double* deriv) {
  // Index of the unit knot span [s, s+1) holding t (or (s, s+1] for a left limit).
  double s = std::floor(t);
  if (left_limit && s == t) s -= 1.0;
  const int r = support_radius(g);
  if (s < -r || s >= r) {
    *value = 0.0;
    *deriv = 0.0;
    return;
  }
  if (g == Degree::Linear) {
    if (s < 0) {  // piece on [-1,0]
      *value = 1.0 + t;
      *deriv = 1.0;
    } else {  // piece on [0,1]
      *value = 1.0 - t;
      *deriv = -1.0;
    }
    return;
  }
  // Uniform cubic B-spline, one polynomial per knot span.
  const int span = static_cast<int>(s);
  switch (span) {
    case -2: {
      const double u = 2.0 + t;
      *value = u * u * u / 6.0;
      *deriv = u * u / 2.0;
      break;
    }
    case -1:
      *value = (4.0 - 6.0 * t * t - 3.0 * t * t * t) / 6.0;
      *deriv = -2.0 * t - 1.5 * t * t;
      break;
    case 0:
      *value = (4.0 - 6.0 * t * t + 3.0 * t * t * t) / 6.0;
      *deriv = -2.0 * t + 1.5 * t * t;
      break;
    default: {
      const double u = 2.0 - t;
      *value = u * u * u / 6.0;
      *deriv = -u * u / 2.0;
      break;
    }
  }
}

IBox support_box(const BsplineKey& key, Degree g, int K) {
  IBox b;
  for (int d = 0; d < K; ++d) {
    const Coord half = width_at(key.level[d]) * support_radius(g);
    b.lo[d] = key.centre[d] - half;
    b.hi[d] = key.centre[d] + half;
  }
  return b;
}

}  // namespace cadinterp::core
