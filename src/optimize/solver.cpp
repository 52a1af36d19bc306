// Ipopt's TNLP over a Problem: the free parameters are Ipopt's variables (fixed ones are left
// out), the constraints its g with dense Jacobian rows, the Hessian a limited-memory quasi-Newton
// approximation (the runtime has no second derivatives). An evaluation the runtime refuses
// (infeasible element, outside the box) returns false, which Ipopt's line search answers by
// cutting its step back: the walls of cadinterp_optimize.h.
#include "optimize/solver.h"

#include <IpIpoptApplication.hpp>
#include <IpTNLP.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace cadinterp::optimize {
namespace {

using Ipopt::Index;
using Ipopt::Number;

const char* status_words(int s) {
  switch (s) {
    case Ipopt::Solve_Succeeded:
      return "optimal (converged to the tolerance)";
    case Ipopt::Solved_To_Acceptable_Level:
      return "acceptable (converged to Ipopt's looser acceptable tolerance)";
    case Ipopt::Infeasible_Problem_Detected:
      return "the constraints appear infeasible";
    case Ipopt::Search_Direction_Becomes_Too_Small:
      return "search direction too small (no further progress)";
    case Ipopt::Diverging_Iterates:
      return "iterates diverging";
    case Ipopt::User_Requested_Stop:
      return "stopped by the caller";
    case Ipopt::Feasible_Point_Found:
      return "feasible point found";
    case Ipopt::Maximum_Iterations_Exceeded:
      return "maximum iterations reached";
    case Ipopt::Restoration_Failed:
      return "restoration phase failed (often a wall or a kink)";
    case Ipopt::Error_In_Step_Computation:
      return "error in step computation (often a wall: no evaluable step)";
    case Ipopt::Maximum_CpuTime_Exceeded:
      return "maximum CPU time reached";
    case Ipopt::Not_Enough_Degrees_Of_Freedom:
      return "not enough degrees of freedom (too many equality constraints)";
    case Ipopt::Invalid_Problem_Definition:
      return "invalid problem definition";
    case Ipopt::Invalid_Option:
      return "invalid option";
    case Ipopt::Invalid_Number_Detected:
      return "invalid number (the runtime could not evaluate the start)";
    default:
      return "Ipopt failed";
  }
}

// Ipopt's "no bound" beyond +-1e19 (nlp_lower_bound_inf, nlp_upper_bound_inf).
double ipopt_bound(double b) { return std::isinf(b) ? std::copysign(2e19, b) : b; }

// Constraint j's scale: its bounds' magnitude (at least 1). Ipopt sees g_j / scale and bounds
// / scale, so that its absolute feasibility tolerance (constr_viol_tol, 1e-4) is relative to
// the constraint's size: a volume of 5e5 mm^3 blended from float meshes carries a noise of
// ~1e-3 mm^3, which an absolute 1e-4 never meets (Ipopt then reports the constraints
// infeasible at a point that meets them).
double constraint_scale(const Problem& p, int j) {
  double s = 1.0;
  for (const double b : {p.function(j).lower, p.function(j).upper})
    if (std::isfinite(b)) s = std::max(s, std::fabs(b));
  return s;
}

// The largest violation of a constraint, in its units (relative: divided by its scale).
double violation(const Problem& p, const std::vector<double>& values, bool relative = false) {
  double v = 0.0;
  for (int j = 1; j < p.function_count(); ++j) {
    const double g = values[static_cast<std::size_t>(j)];
    const double d = std::max(p.function(j).lower - g, g - p.function(j).upper);
    v = std::max(v, relative ? d / constraint_scale(p, j) : d);
  }
  return v;
}

// Whether (objective f, relative violation v) is better than (bf, bv): feasible for the
// constraints first (to Ipopt's constraint tolerance and below), then lowest objective, else
// least violation.
bool better(double f, double v, double bf, double bv) {
  const double tol = 1e-6;
  if ((v <= tol) != (bv <= tol)) return v <= tol;
  return v <= tol ? f < bf : v < bv;
}

class Nlp : public Ipopt::TNLP {
 public:
  Nlp(Problem& p, const cadinterp_optimize_options& o, int start_index, std::vector<double> start)
      : p_(p),
        o_(o),
        start_index_(start_index),
        full_(std::move(start)),
        free_(p.free_parameters()),
        K_(p.parameter_count()),
        m_(p.function_count() - 1) {
    for (int j = 1; j < p.function_count(); ++j) scale_.push_back(constraint_scale(p, j));
  }

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac, Index& nnz_h,
                    IndexStyleEnum& style) override {
    n = static_cast<Index>(free_.size());
    m = m_;
    nnz_jac = n * m;
    nnz_h = 0;
    style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Index n, Number* xl, Number* xu, Index m, Number* gl, Number* gu) override {
    for (Index i = 0; i < n; ++i) {
      xl[i] = p_.lower()[static_cast<std::size_t>(free_[static_cast<std::size_t>(i)])];
      xu[i] = p_.upper()[static_cast<std::size_t>(free_[static_cast<std::size_t>(i)])];
    }
    for (Index j = 0; j < m; ++j) {
      gl[j] = ipopt_bound(p_.function(j + 1).lower / scale_[static_cast<std::size_t>(j)]);
      gu[j] = ipopt_bound(p_.function(j + 1).upper / scale_[static_cast<std::size_t>(j)]);
    }
    return true;
  }
  bool get_starting_point(Index n, bool, Number* x, bool, Number*, Number*, Index, bool,
                          Number*) override {
    for (Index i = 0; i < n; ++i)
      x[i] = full_[static_cast<std::size_t>(free_[static_cast<std::size_t>(i)])];
    return true;
  }
  bool eval_f(Index, const Number* x, bool, Number& f) override {
    if (!at(x, false)) return false;
    f = values_[0];
    return true;
  }
  bool eval_grad_f(Index n, const Number* x, bool, Number* g) override {
    if (!at(x, true)) return false;
    for (Index i = 0; i < n; ++i)
      g[i] = grads_[static_cast<std::size_t>(free_[static_cast<std::size_t>(i)])];
    // Gradients are asked for at accepted iterates only: the path's next point.
    path_x_ = full_;
    path_f_ = values_[0];
    path_v_ = violation(p_, values_, true);
    return true;
  }
  bool eval_g(Index, const Number* x, bool, Index m, Number* g) override {
    if (!at(x, false)) return false;
    for (Index j = 0; j < m; ++j)
      g[j] = values_[static_cast<std::size_t>(j) + 1] / scale_[static_cast<std::size_t>(j)];
    return true;
  }
  bool eval_jac_g(Index n, const Number* x, bool, Index m, Index, Index* row, Index* col,
                  Number* v) override {
    if (!v) {
      for (Index j = 0; j < m; ++j)
        for (Index i = 0; i < n; ++i) row[j * n + i] = j, col[j * n + i] = i;
      return true;
    }
    if (!at(x, true)) return false;
    const std::size_t K = static_cast<std::size_t>(K_);
    for (Index j = 0; j < m; ++j)
      for (Index i = 0; i < n; ++i)
        v[j * n + i] = grads_[(static_cast<std::size_t>(j) + 1) * K +
                              static_cast<std::size_t>(free_[static_cast<std::size_t>(i)])] /
                       scale_[static_cast<std::size_t>(j)];
    return true;
  }
  bool intermediate_callback(Ipopt::AlgorithmMode mode, Index iter, Number, Number inf_pr,
                             Number inf_du, Number, Number, Number, Number, Number, Index,
                             const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    iterations_ = iter;
    optimality_ = inf_du;
    if (mode != Ipopt::RegularMode || path_x_.empty()) return true;
    path.insert(path.end(), path_x_.begin(), path_x_.end());
    path_objective.push_back(path_f_);
    path_violation.push_back(path_v_);
    if (stalling()) {
      stalled = true;
      return false;
    }
    if (o_.progress &&
        o_.progress(o_.progress_user, start_index_, iter, path_x_.data(), path_f_, inf_pr, inf_du))
      return false;
    return true;
  }
  void finalize_solution(Ipopt::SolverReturn, Index n, const Number* x, const Number*,
                         const Number*, Index, const Number*, const Number*, Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    final_x = full_;
    for (Index i = 0; i < n; ++i)
      final_x[static_cast<std::size_t>(free_[static_cast<std::size_t>(i)])] = x[i];
  }

  std::vector<double> path, path_objective, path_violation, final_x;
  bool stalled = false;  // stopped here: no progress in kStallIterations iterations
  int evaluations = 0, refused = 0;
  int iterations() const { return iterations_; }
  double optimality() const { return optimality_; }

 private:
  // Values (and gradients if grad) at Ipopt's x, from the cache when x has not changed. False
  // where the runtime refuses x (or a value is not finite): Ipopt's evaluation error.
  bool at(const Number* x, bool grad) {
    bool same = have_values_;
    for (std::size_t i = 0; i < free_.size() && same; ++i)
      same = full_[static_cast<std::size_t>(free_[i])] == x[i];
    if (same && (!grad || have_grads_)) return ok_;
    if (!same) {
      for (std::size_t i = 0; i < free_.size(); ++i)
        full_[static_cast<std::size_t>(free_[i])] = x[i];
      ++evaluations;
    }
    values_.resize(static_cast<std::size_t>(p_.function_count()));
    grads_.resize(values_.size() * static_cast<std::size_t>(K_));
    std::string error;
    ok_ = p_.evaluate(full_.data(), values_.data(), grad ? grads_.data() : nullptr, &error) ==
          CADINTERP_OK;
    for (double v : values_) ok_ = ok_ && std::isfinite(v);
    if (!ok_ && !same) ++refused;
    have_values_ = true;
    have_grads_ = grad;
    return ok_;
  }

  // Whether the best iterate has not improved for kStallIterations accepted iterates. At a kink
  // of a C0 interpolant (linear assets) or at the float noise floor of the values (~1e-7
  // relative), Ipopt's KKT error stays above tol and it would spend the rest of max_iterations
  // in failing line searches; the best point is then already found.
  static constexpr int kStallIterations = 20;
  bool stalling() {
    const double f = path_objective.back(), v = path_violation.back();
    const bool first = path_objective.size() == 1;
    const bool improved =
        first || (v <= 1e-6 ? best_v_ > 1e-6 || f < best_f_ - 1e-9 * (1.0 + std::fabs(best_f_))
                            : v < best_v_ - 1e-9);
    if (first || better(f, v, best_f_, best_v_)) {
      best_f_ = f;
      best_v_ = v;
    }
    since_improved_ = improved ? 0 : since_improved_ + 1;
    return since_improved_ >= kStallIterations;
  }

  double best_f_ = HUGE_VAL, best_v_ = HUGE_VAL;
  int since_improved_ = 0;
  Problem& p_;
  const cadinterp_optimize_options& o_;
  int start_index_;
  std::vector<double> full_;
  std::vector<int> free_;
  int K_, m_;
  std::vector<double> scale_;  // per constraint: constraint_scale
  std::vector<double> values_, grads_, path_x_;
  double path_f_ = 0, path_v_ = 0;
  bool have_values_ = false, have_grads_ = false, ok_ = false;
  int iterations_ = 0;
  double optimality_ = NAN;
};

// The i-th point of the Halton sequence (bases: the first primes) over the free ranges; fixed
// parameters keep their value.
std::vector<double> halton_point(const Problem& p, int index) {
  static const int kPrimes[8] = {2, 3, 5, 7, 11, 13, 17, 19};
  std::vector<double> x(p.lower());
  int d = 0;
  for (int i : p.free_parameters()) {
    double f = 1.0, r = 0.0;
    for (int n = index; n > 0; n /= kPrimes[d]) {
      f /= kPrimes[d];
      r += f * (n % kPrimes[d]);
    }
    const std::size_t s = static_cast<std::size_t>(i);
    x[s] = p.lower()[s] + r * (p.upper()[s] - p.lower()[s]);
    ++d;
  }
  return x;
}

// One Ipopt run from `start` into `out` (x, values at x, path, counts). False when Ipopt could
// not be set up (error set).
bool run_start(Problem& p, const cadinterp_optimize_options& o, int index,
               const std::vector<double>& start, Outcome* out, std::string* error) {
  Ipopt::SmartPtr<Nlp> nlp = new Nlp(p, o, index, start);
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  auto& opt = *app->Options();
  opt.SetStringValue("sb", "yes");
  opt.SetIntegerValue("print_level", o.print_level);
  opt.SetStringValue("hessian_approximation", "limited-memory");
  opt.SetIntegerValue("max_iter", o.max_iterations);
  opt.SetNumericValue("tol", o.tolerance);
  // The values come from a float mesh (relative rounding ~1e-7): progress below that is noise,
  // so a run that stalls near tol for a few iterations ends as "acceptable".
  opt.SetNumericValue("acceptable_tol", std::max(1e-4, o.tolerance));
  opt.SetIntegerValue("acceptable_iter", 10);
  // Constraints reach Ipopt divided by their scale (constraint_scale): feasible means within
  // 1e-6 of the bound's size, above the float noise of a blended quantity (~1e-7 relative), at
  // termination and at the looser "acceptable" level alike (Ipopt's default there is 1e-2).
  opt.SetNumericValue("constr_viol_tol", 1e-6);
  opt.SetNumericValue("acceptable_constr_viol_tol", 1e-6);
  // The box is a wall: never evaluate outside it.
  opt.SetNumericValue("bound_relax_factor", 0.0);
  opt.SetStringValue("honor_original_bounds", "yes");
  if (app->Initialize() != Ipopt::Solve_Succeeded) {
    *error = "Ipopt cannot be initialized";
    return false;
  }
  const Ipopt::ApplicationReturnStatus s = app->OptimizeTNLP(Ipopt::GetRawPtr(nlp));
  out->ipopt_status = static_cast<int>(s);
  out->status = nlp->stalled ? "stalled: no decrease in 20 iterations (at a wall, a kink of a "
                               "linear asset's C0 interpolant, or the float noise floor)"
                             : status_words(s);
  out->converged = s == Ipopt::Solve_Succeeded || s == Ipopt::Solved_To_Acceptable_Level;
  out->iterations = nlp->iterations();
  out->evaluations = nlp->evaluations;
  out->refused = nlp->refused;
  out->optimality = nlp->optimality();
  out->path = nlp->path;
  out->path_objective = nlp->path_objective;
  // The reported point must be one the runtime evaluates, and the best one seen: Ipopt's final
  // x, or the best accepted iterate (always evaluated; on a linear asset's kinks the filter line
  // search may end above it), or the start.
  std::vector<std::vector<double>> candidates;
  if (!nlp->final_x.empty()) candidates.push_back(nlp->final_x);
  const std::size_t K = static_cast<std::size_t>(p.parameter_count());
  std::size_t best_i = SIZE_MAX;
  for (std::size_t i = 0; i < out->path_objective.size(); ++i)
    if (best_i == SIZE_MAX || better(out->path_objective[i], nlp->path_violation[i],
                                     out->path_objective[best_i], nlp->path_violation[best_i]))
      best_i = i;
  if (best_i != SIZE_MAX)
    candidates.emplace_back(out->path.begin() + static_cast<long>(best_i * K),
                            out->path.begin() + static_cast<long>((best_i + 1) * K));
  candidates.push_back(start);
  std::vector<double> values(static_cast<std::size_t>(p.function_count()));
  std::vector<double> grads(values.size() * K);
  bool found = false;
  double best_v = 0;  // the relative violation at out->x
  for (const auto& x : candidates) {
    std::string ignored;
    if (p.evaluate(x.data(), values.data(), grads.data(), &ignored) != CADINTERP_OK) continue;
    const double v = violation(p, values, true);
    if (found && !better(values[0], v, out->objective, best_v)) continue;
    found = true;
    best_v = v;
    out->x = x;
    out->objective = values[0];
    out->constraints.assign(values.begin() + 1, values.end());
    out->violation = violation(p, values);
    double g2 = 0.0;
    for (int i : p.free_parameters())
      g2 += grads[static_cast<std::size_t>(i)] * grads[static_cast<std::size_t>(i)];
    out->gradient_norm = std::sqrt(g2);
  }
  if (found) return true;
  *error = "no evaluable point";  // unreachable: the start was evaluated before the run
  return false;
}

}  // namespace

cadinterp_status solve(Problem& p, const cadinterp_optimize_options& o, Outcome* out,
                       std::string* error) {
  const std::size_t K = static_cast<std::size_t>(p.parameter_count());
  std::vector<double> values(static_cast<std::size_t>(p.function_count()));
  // Starts: the caller's (or the centre), then Halton points, each one the runtime evaluates.
  std::vector<std::vector<double>> starts;
  std::string first_refusal;
  auto try_start = [&](std::vector<double> x) {
    for (std::size_t i = 0; i < K; ++i)
      if (p.lower()[i] == p.upper()[i]) x[i] = p.lower()[i];
    std::string why;
    if (p.evaluate(x.data(), values.data(), nullptr, &why) == CADINTERP_OK)
      starts.push_back(std::move(x));
    else if (first_refusal.empty())
      first_refusal = why;
  };
  std::vector<double> centre(K);
  for (std::size_t i = 0; i < K; ++i) centre[i] = 0.5 * (p.lower()[i] + p.upper()[i]);
  try_start(o.start ? std::vector<double>(o.start, o.start + K) : centre);
  for (int h = 1;
       o.multistart > 1 && static_cast<int>(starts.size()) < o.multistart && h < 20 * o.multistart;
       ++h)
    try_start(halton_point(p, h));
  if (starts.empty()) {
    *error = "the runtime cannot evaluate the start point: " + first_refusal;
    return CADINTERP_E_INFEASIBLE;
  }
  bool have = false;
  Outcome best;
  double best_v = 0;  // the relative violation at best.x
  int iterations = 0, evaluations = 0, refused = 0;
  for (std::size_t s = 0; s < starts.size(); ++s) {
    Outcome r;
    if (!run_start(p, o, static_cast<int>(s), starts[s], &r, error)) return CADINTERP_E_INTERNAL;
    iterations += r.iterations;
    evaluations += r.evaluations;
    refused += r.refused;
    r.best_start = static_cast<int>(s);
    // Feasible for the constraints first (relative to their scale), then lowest.
    std::vector<double> at = {r.objective};
    at.insert(at.end(), r.constraints.begin(), r.constraints.end());
    const double v = violation(p, at, true);
    if (!have || better(r.objective, v, best.objective, best_v)) {
      best = std::move(r);
      best_v = v;
      have = true;
    }
  }
  best.iterations = iterations;
  best.evaluations = evaluations;
  best.refused = refused;
  best.starts = static_cast<int>(starts.size());
  cadinterp_error_estimate(p.asset(), best.x.data(), &best.error_estimate);
  best.linear = cadinterp_degree(p.asset()) == 1;
  if (best.linear)
    best.note =
        "linear asset: the interpolant is only C0 in x; its gradient jumps at kinks inside and "
        "between elements, which limits Ipopt's convergence (build with degree 3 for a C2 "
        "interpolant)";
  *out = std::move(best);
  return CADINTERP_OK;
}

}  // namespace cadinterp::optimize
