// Brute-force grids over the free parameters (optimize_grid.h).
#include "optimize_grid.h"

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>

namespace cadinterp::cli {

std::vector<double> grid_points(const ParameterBox& box, int per_axis) {
  if (per_axis < 2) throw std::invalid_argument("a grid needs at least 2 points per parameter");
  const std::size_t K = box.lower.size();
  std::vector<int> counts(K);
  std::size_t total = 1;
  for (std::size_t d = 0; d < K; ++d) {
    counts[d] = box.lower[d] < box.upper[d] ? per_axis : 1;
    total *= static_cast<std::size_t>(counts[d]);
    if (total > kMaxGridPoints)
      throw std::invalid_argument("a grid of " + std::to_string(per_axis) +
                                  " points per free parameter has more than " +
                                  std::to_string(kMaxGridPoints) + " points");
  }
  std::vector<double> out;
  out.reserve(total * K);
  std::vector<int> index(K, 0);
  for (std::size_t p = 0; p < total; ++p) {
    for (std::size_t d = 0; d < K; ++d) {
      const double t = counts[d] == 1 ? 0.0 : static_cast<double>(index[d]) / (counts[d] - 1);
      // The end points exactly, so that a fixed or boundary value is never rounded out of range.
      out.push_back(index[d] == counts[d] - 1 ? box.upper[d]
                                              : box.lower[d] + t * (box.upper[d] - box.lower[d]));
    }
    for (std::size_t d = K; d-- > 0;) {  // the last parameter varies fastest
      if (++index[d] < counts[d]) break;
      index[d] = 0;
    }
  }
  return out;
}

GridSummary run_grid(const ParameterBox& box, int per_axis, const OptimizeSpec& spec,
                     const GridFunction& f, int threads) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<double> x = grid_points(box, per_axis);
  const std::size_t K = box.lower.size();
  const std::size_t n = K ? x.size() / K : 0;
  std::vector<GridValue> values(n);
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t i = next++; i < n; i = next++) values[i] = f(&x[i * K]);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads && static_cast<std::size_t>(t) < n; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();

  GridSummary s;
  s.per_axis = per_axis;
  s.points = n;
  for (std::size_t i = 0; i < n; ++i) {
    const GridValue& v = values[i];
    if (!v.evaluated) {
      if (s.failed++ == 0) s.first_failure = v.reason;
      continue;
    }
    bool meets = true;
    for (std::size_t c = 0; c < spec.subject_to.size(); ++c)
      meets = meets && constraint_met(spec.subject_to[c], v.values[c + 1]) != 0;
    if (!meets) {
      ++s.violating;
      continue;
    }
    if (!s.found || v.values[0] < s.best_values[0]) {
      s.found = true;
      s.best_x.assign(x.begin() + static_cast<std::ptrdiff_t>(i * K),
                      x.begin() + static_cast<std::ptrdiff_t>((i + 1) * K));
      s.best_values = v.values;
    }
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

GridFunction interpolant_function(cadinterp_optimize_problem* problem) {
  return [problem](const double* x) {
    GridValue v;
    v.values.resize(1 + static_cast<std::size_t>(cadinterp_optimize_constraint_count(problem)));
    if (cadinterp_optimize_evaluate(problem, x, v.values.data(), nullptr) == CADINTERP_OK)
      v.evaluated = true;
    else
      v.reason = cadinterp_optimize_error(problem);
    return v;
  };
}

}  // namespace cadinterp::cli
