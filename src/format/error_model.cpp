// The per-element error model's shape (error_model.h).
#include "format/error_model.h"

#include <algorithm>
#include <limits>

namespace cadinterp::format {

double error_model_estimate(const double* row, int K, bool cubic, const double* t) {
  if (!(row[0] >= 0)) return -1.0;
  if (cubic) return error_model_max(row, K);
  // sum_d e_d s_d(t) with s_d = 4 t_d (1 - t_d), scaled to the centre error row[0] at the
  // centre, and no less than any one direction's e_d s_d (see the header).
  double sum = 0, at_centre = 0, largest = 0, shape = 0;
  for (int d = 0; d < K; ++d) {
    const double u = std::clamp(t[d], 0.0, 1.0), s = 4 * u * (1 - u);
    const double e = row[1 + d] < 0 ? row[0] : row[1 + d];
    sum += e * s;
    at_centre += e;
    largest = std::max(largest, e * s);
    shape += s;
  }
  if (!(at_centre > 0)) return row[0] * shape / K;  // no direction errs: the centre's, evenly
  return std::max(row[0] * sum / at_centre, largest);
}

double error_model_max(const double* row, int K) {
  if (!(row[0] >= 0)) return -1.0;
  double m = row[0];
  for (int d = 0; d < K; ++d) m = std::max(m, row[1 + d]);
  return m;
}

double error_model_with_floor(double est, bool cubic, double floor) {
  return cubic ? std::max(est, floor) : est + floor;
}

double error_model_reported(double est, bool cubic, bool geometry, double floor) {
  if (!(est >= 0)) return -1.0;
  const double v = error_model_with_floor(
      est * (cubic ? kErrorModelSafetyCubic : kErrorModelSafetyLinear), cubic, floor);
  // Finite rows can still overflow here; the largest double says "no bound" and stays finite.
  return std::min(geometry ? std::max(v, kGeometryFloor) : v, std::numeric_limits<double>::max());
}

}  // namespace cadinterp::format
