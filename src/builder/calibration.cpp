// The error model's calibration on held-out points (calibration.h).
#include "builder/calibration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "builder/located_errors.h"
#include "format/error_model.h"
#include "mesh/surface_distance.h"

namespace cadinterp::builder {

namespace {

// The points' generator: fixed, so that a build asks the same points again (a sample store
// answers them), and apart from the ones any measurement draws.
constexpr std::uint64_t kCalibrationSeed = 0x63616c6962726174ull;

// Element e's floor for quantity q (geometry_floor, or the field's field_floors entry).
double floor_of(const format::ElementData& ed, std::size_t q) {
  if (q == 0) return ed.geometry_floor;
  return ed.field_floors.empty() ? 0.0 : ed.field_floors[q - 1];
}

// The least v in [lo, hi] at which `bounds` holds (to 1e-12 of hi), for a predicate that is
// monotone in v and holds at hi: the estimate the runtime reports is nondecreasing in both the
// factor and the floor, so its formula (format::error_model_reported) is bisected rather than
// inverted, and stays the one place that says how an estimate is reported.
template <class Bounds>
double least_bounding(double lo, double hi, Bounds bounds) {
  for (int i = 0; i < 64 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = (lo + hi) / 2;
    (bounds(mid) ? hi : lo) = mid;
  }
  return hi;
}

}  // namespace

HeldOutPoints ask_held_out_points(const BuildOptions& opt, MeshProblem& problem,
                                  const core::CompiledBasis& cb, BuildReport& details) {
  HeldOutPoints h;
  if (opt.calibration_points <= 0) return h;
  const int K = cb.dim();
  const std::vector<double>& lower = cb.lower();
  const std::vector<double>& upper = cb.upper();
  h.in_element.resize(static_cast<std::size_t>(cb.element_count()));
  // Drawn all at once (the same points at any thread count) and asked in one wave.
  std::mt19937_64 rng(kCalibrationSeed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<double> flat;
  for (int i = 0; i < opt.calibration_points; ++i) {
    std::vector<double> x(static_cast<std::size_t>(K));
    for (std::size_t d = 0; d < x.size(); ++d) x[d] = lower[d] + (upper[d] - lower[d]) * unit(rng);
    const int e = cb.locate(x.data());
    if (e < 0 || !cb.element_feasible(e)) continue;
    h.in_element[static_cast<std::size_t>(e)].push_back(static_cast<int>(h.x.size()));
    h.row.push_back(problem.rows() + static_cast<int>(h.x.size()));
    h.element.push_back(e);
    flat.insert(flat.end(), x.begin(), x.end());
    h.x.push_back(std::move(x));
  }
  h.error.resize(h.x.size());
  if (h.x.empty()) return h;
  std::vector<char> feasible(h.x.size(), 0);
  // The report's samples (the basis') and points requested (the refinement's) stay as the
  // refinement left them.
  const int samples = details.counts.samples, requested = details.points_requested;
  problem.evaluate(h.row, flat, feasible);
  details.counts.samples = samples;
  details.points_requested = requested;
  return h;
}

void stored_errors(const format::ElementData& ed, const int* terms, int n,
                   const core::BasisWeights& w, const mesh::Sample& truth,
                   std::vector<double>& out) {
  const std::size_t nv3 = ed.canonical.size(), nv = nv3 / 3, ntets = ed.tets.size() / 4;
  std::vector<double> V(nv3, 0.0);
  std::vector<double> F(ed.fields.empty() ? 0 : ed.fields[0].size(), 0.0);
  for (int t = 0; t < n; ++t) {
    double psi = 0;
    for (int j = 0; j < w.count; ++j)
      if (w.samples[j] == terms[t]) psi = w.psi[j];
    if (psi == 0) continue;
    const std::vector<float>& pos = ed.positions[static_cast<std::size_t>(t)];
    for (std::size_t i = 0; i < nv3; ++i) V[i] += psi * pos[i];
    if (!F.empty()) {
      const std::vector<float>& f = ed.fields[static_cast<std::size_t>(t)];
      for (std::size_t i = 0; i < F.size(); ++i) F[i] += psi * f[i];
    }
  }
  const std::size_t nfields = truth.fields.size();
  out.assign(1 + nfields, -1.0);
  out[0] = mesh::symmetric_hausdorff(V, ed.triangles, truth.vertices, truth.triangles, 1) /
           truth.bbox_diagonal();
  if (!nfields) return;
  // Where the host's mesh at x has the stored combinatorics, vertex v is one point of the solid
  // in both (no mapped vertex slid: the measurements' rule, builder_e2e.h).
  const bool same = truth.vertices.size() == nv3 && truth.tets == ed.tets;
  std::vector<std::size_t> offset(nfields);
  std::vector<int> located(nfields, -1);
  std::vector<double> e(nfields, 0.0), ones(nfields, 1.0);
  std::size_t at = 0;
  for (std::size_t f = 0; f < nfields; ++f) {
    const mesh::Field& tf = truth.fields[f];
    const auto C = static_cast<std::size_t>(tf.components);
    offset[f] = at;
    const bool vertex = tf.location == CADINTERP_PER_VERTEX;
    at += (vertex ? nv : ntets) * C;
    if (same) {
      for (std::size_t i = 0; i < tf.values.size(); ++i)
        e[f] = std::max(e[f], std::abs(F[offset[f] + i] - tf.values[i]));
    } else if (vertex) {
      located[f] = static_cast<int>(f);
    } else {
      e[f] = -1;  // a per-tet field on other tets: not compared
    }
  }
  if (!same)
    located_errors(
        truth, static_cast<std::uint32_t>(nv), located, ones,
        [&](std::uint32_t v, double* p) {
          for (std::size_t c = 0; c < 3; ++c) p[c] = V[3 * std::size_t(v) + c];
        },
        [&](std::size_t f, std::uint32_t v, std::size_t c) {
          return F[offset[f] + v * static_cast<std::size_t>(truth.fields[f].components) + c];
        },
        [&](std::size_t f, std::uint32_t, double err) { e[f] = std::max(e[f], err); });
  for (std::size_t f = 0; f < nfields; ++f)
    if (e[f] >= 0) out[1 + f] = e[f] / field_error_scale(truth.fields[f].values);
}

double calibration_need(double est, bool cubic, bool geometry, double floor, double error) {
  auto reported = [&](double c) {
    return format::error_model_reported(c * est, cubic, geometry, floor);
  };
  if (reported(0) >= error) return 0;
  if (!(est >= kCalibrationLeastEstimate)) return std::numeric_limits<double>::infinity();
  // Bracket the least factor, then bisect.
  double lo = 0, hi = 1;
  while (reported(hi) < error) {
    lo = hi;
    hi *= 2;
    if (hi > 1e300) return std::numeric_limits<double>::infinity();
  }
  return least_bounding(lo, hi, [&](double c) { return reported(c) >= error; });
}

void calibration_ranks(int n, int& lower, int& upper) {
  // The binomial distribution's CDF summed from its pmf in logarithms (n may be 100000).
  const double lp = std::log(kCalibrationCoverage), lq = std::log1p(-kCalibrationCoverage);
  const double lgn = std::lgamma(n + 1.0);
  lower = upper = 0;
  double cdf = 0;  // P(Binomial <= j)
  for (int j = 0; j < n && upper == 0; ++j) {
    cdf += std::exp(lgn - std::lgamma(j + 1.0) - std::lgamma(n - j + 1.0) + j * lp + (n - j) * lq);
    // P(Binomial >= j + 1) = 1 - cdf.
    if (1 - cdf >= kCalibrationConfidence) lower = j + 1;
    if (cdf >= kCalibrationConfidence) upper = j + 1;
  }
}

double calibration_factor(std::vector<double>& needs, double least) {
  int lower = 0, upper = 0;
  calibration_ranks(static_cast<int>(needs.size()), lower, upper);
  if (upper == 0) return 1.0;
  std::sort(needs.begin(), needs.end());
  const bool short_of = lower > 0 && needs[static_cast<std::size_t>(lower - 1)] > 1;
  const bool beyond = needs[static_cast<std::size_t>(upper - 1)] < 1;
  if (!short_of && !beyond) return 1.0;
  const double c = needs[static_cast<std::size_t>(upper - 1)];
  // Infinite: too many points err where the shaped estimate is 0, which no factor changes.
  return std::isfinite(c) ? std::max(c, least) : 1.0;
}

double calibration_floor_need(const CalibrationPoint& p) {
  auto reported = [&](double F) {
    return format::error_model_reported(p.est, p.cubic, p.geometry, p.floor + F);
  };
  if (reported(0) >= p.error) return 0;
  // The reported estimate is at least the floor, so F = error bounds.
  return least_bounding(0.0, p.error, [&](double F) { return reported(F) >= p.error; });
}

CalibrationChoice calibrate_quantity(const std::vector<CalibrationPoint>& points, double least) {
  CalibrationChoice choice;
  std::vector<double> needs;
  for (const CalibrationPoint& p : points)
    needs.push_back(calibration_need(p.est, p.cubic, p.geometry, p.floor, p.error));
  choice.factor = calibration_factor(needs, least);  // sorts needs
  int lower = 0, upper = 0;
  calibration_ranks(static_cast<int>(points.size()), lower, upper);
  if (lower == 0 || upper == 0 || !(needs[static_cast<std::size_t>(lower - 1)] > 1))
    return choice;  // kept, or lowered
  std::vector<double> floors;
  for (const CalibrationPoint& p : points) floors.push_back(calibration_floor_need(p));
  std::sort(floors.begin(), floors.end());
  const double F = floors[static_cast<std::size_t>(upper - 1)];
  if (choice.factor == 1.0) return {1.0, F};  // the factor's bracket is infinite
  // The median over the points of estimate / error with the factor c and the floor F added.
  auto median_ratio = [&](double c, double add) {
    std::vector<double> r;
    for (const CalibrationPoint& p : points)
      if (p.error > 0)
        r.push_back(format::error_model_reported(c * p.est, p.cubic, p.geometry, p.floor + add) /
                    p.error);
    if (r.empty()) return 0.0;
    std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
    return r[r.size() / 2];
  };
  if (median_ratio(1.0, F) < median_ratio(choice.factor, 0.0)) return {1.0, F};
  return choice;
}

void calibrate_error_models(const BuildOptions& opt, const core::CompiledBasis& cb,
                            const HeldOutPoints& held_out,
                            std::vector<format::ElementData>& elements, BuildReport& details) {
  if (held_out.x.empty()) return;
  const int K = cb.dim();
  const std::size_t W = static_cast<std::size_t>(K + 1);
  const auto modelled =
      std::find_if(elements.begin(), elements.end(),
                   [](const format::ElementData& ed) { return !ed.error_model.empty(); });
  if (modelled == elements.end()) return;
  const std::size_t Q = modelled->error_model.size() / W;

  // Per quantity, each measured point's estimate and error.
  std::vector<std::vector<CalibrationPoint>> points(Q);
  int count = 0;
  for (std::size_t i = 0; i < held_out.x.size(); ++i) {
    const std::vector<double>& err = held_out.error[i];
    const int e = held_out.element[i];
    const format::ElementData& ed = elements[static_cast<std::size_t>(e)];
    if (err.size() != Q || ed.error_model.size() != Q * W) continue;
    ++count;
    double lo[core::kMaxDim], hi[core::kMaxDim], t[core::kMaxDim];
    cb.element_box(e, lo, hi);
    for (int d = 0; d < K; ++d)
      t[d] = (held_out.x[i][static_cast<std::size_t>(d)] - lo[d]) / (hi[d] - lo[d]);
    const bool cubic = cb.element_cubic(e);
    for (std::size_t q = 0; q < Q; ++q) {
      const double est = format::error_model_estimate(ed.error_model.data() + q * W, K, cubic, t);
      if (est < 0 || err[q] < 0) continue;
      points[q].push_back({est, cubic, q == 0, floor_of(ed, q), err[q]});
    }
  }

  const double least = 1.0 / (opt.degree == core::Degree::Cubic ? format::kErrorModelSafetyCubic
                                                                : format::kErrorModelSafetyLinear);
  details.calibrated_points = count;
  details.calibration.assign(Q, 1.0);
  details.calibration_floors.assign(Q, 0.0);
  for (std::size_t q = 0; q < Q; ++q) {
    const CalibrationChoice c = calibrate_quantity(points[q], least);
    details.calibration[q] = c.factor;
    details.calibration_floors[q] = c.floor;
  }
  for (std::size_t e = 0; e < elements.size(); ++e) {
    format::ElementData& ed = elements[e];
    if (ed.error_model.size() != Q * W) continue;
    for (std::size_t q = 0; q < Q; ++q)
      for (std::size_t j = 0; j < W; ++j)
        if (ed.error_model[q * W + j] >= 0) ed.error_model[q * W + j] *= details.calibration[q];
    for (std::size_t q = 0; q < Q; ++q) {
      const double F = details.calibration_floors[q];
      if (!(F > 0)) continue;
      if (q == 0) {
        ed.geometry_floor += F;
      } else {
        if (ed.field_floors.empty()) ed.field_floors.assign(Q - 1, 0.0);
        ed.field_floors[q - 1] += F;
      }
    }
    if (ed.error_estimate >= 0)
      ed.error_estimate =
          format::error_model_with_floor(format::error_model_max(ed.error_model.data(), K),
                                         cb.element_cubic(static_cast<int>(e)), ed.geometry_floor);
  }
}

}  // namespace cadinterp::builder
