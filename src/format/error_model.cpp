// The per-element error model's shape (error_model.h).
#include "format/error_model.h"

#include <algorithm>

namespace cadinterp::format {

namespace {

// The per-direction error e_d of a linear element (see error_model_estimate).
double direction_error(const double* row, int K, int d) {
  const double centre = row[0], e = row[1 + d];
  return e < 0 ? centre : std::max(e, centre / K);
}

}  // namespace

double error_model_estimate(const double* row, int K, bool cubic, const double* t) {
  if (!(row[0] >= 0)) return -1.0;
  if (cubic) return error_model_max(row, K, true);
  double est = 0;
  for (int d = 0; d < K; ++d) {
    const double u = std::clamp(t[d], 0.0, 1.0);
    est += direction_error(row, K, d) * 4 * u * (1 - u);
  }
  return est;
}

double error_model_max(const double* row, int K, bool cubic) {
  if (!(row[0] >= 0)) return -1.0;
  double m = cubic ? row[0] : 0.0;
  for (int d = 0; d < K; ++d) m = cubic ? std::max(m, row[1 + d]) : m + direction_error(row, K, d);
  return m;
}

double error_model_reported(double est, bool cubic, bool geometry) {
  if (!(est >= 0)) return -1.0;
  const double v = est * (cubic ? kErrorModelSafetyCubic : kErrorModelSafetyLinear);
  return geometry ? std::max(v, kGeometryFloor) : v;
}

}  // namespace cadinterp::format
