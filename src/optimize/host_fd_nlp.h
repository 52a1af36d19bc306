// The benchmark's reference run: the same optimization as on the asset, on the host itself,
// with forward-difference gradients (free parameters + 1 host evaluations per gradient): the
// speed-up the interpolant exists for. Each evaluation runs the host's regenerate,
// references and simulate (cadinterp_host_evaluate_serialized: the host's whole cost) and takes
// the objective and a constraint lower <= g(x) from `outputs`, the closed forms the host writes
// as its per-sample outputs (the sample's bytes are the builder's, not this module's to read).
// Ipopt with the optimizer's settings (limited-memory Hessian, the box as a wall). Benchmark-only:
// not part of any library.
#pragma once

#include <IpIpoptApplication.hpp>
#include <IpTNLP.hpp>

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_builder.h"

namespace cadinterp::optimize::bench {

class HostFdNlp : public Ipopt::TNLP {
 public:
  using Index = Ipopt::Index;
  using Number = Ipopt::Number;
  // `full` holds all K values (fixed ones too); `free` the indices Ipopt moves, in [lo, hi].
  using Outputs = std::function<void(const double* x, double* f, double* g)>;
  HostFdNlp(const cadinterp_host* host, std::vector<double> full, std::vector<int> free,
            Outputs outputs, double lower)
      : host_(host),
        full_(std::move(full)),
        free_(std::move(free)),
        outputs_(std::move(outputs)),
        lower_(lower) {}

  int host_evaluations = 0;
  std::vector<double> x_final;

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac, Index& nnz_h,
                    IndexStyleEnum& style) override {
    n = static_cast<Index>(free_.size());
    m = 1;
    nnz_jac = n;
    nnz_h = 0;
    style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Index n, Number* xl, Number* xu, Index, Number* gl, Number* gu) override {
    for (Index i = 0; i < n; ++i) xl[i] = 0.0, xu[i] = 1.0;
    gl[0] = lower_;
    gu[0] = 2e19;  // Ipopt's +infinity
    return true;
  }
  bool get_starting_point(Index n, bool, Number* x, bool, Number*, Number*, Index, bool,
                          Number*) override {
    for (Index i = 0; i < n; ++i) x[i] = full_[static_cast<std::size_t>(free_[i])];
    return true;
  }
  bool eval_f(Index n, const Number* x, bool, Number& f) override {
    double g = 0;
    return values(n, x, &f, &g);
  }
  bool eval_g(Index n, const Number* x, bool, Index, Number* g) override {
    double f = 0;
    return values(n, x, &f, g);
  }
  bool eval_grad_f(Index n, const Number* x, bool, Number* grad) override {
    return gradients(n, x, grad, nullptr);
  }
  bool eval_jac_g(Index n, const Number* x, bool, Index, Index, Index* row, Index* col,
                  Number* v) override {
    if (!v) {
      for (Index i = 0; i < n; ++i) row[i] = 0, col[i] = i;
      return true;
    }
    return gradients(n, x, nullptr, v);
  }
  void finalize_solution(Ipopt::SolverReturn, Index n, const Number* x, const Number*,
                         const Number*, Index, const Number*, const Number*, Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    x_final = full_;
    for (Index i = 0; i < n; ++i) x_final[static_cast<std::size_t>(free_[i])] = x[i];
  }

 private:
  // The host's two outputs at the free values x (the others from full_).
  bool host_at(const std::vector<double>& full, double* f, double* g) {
    void* bytes = nullptr;
    std::size_t size = 0;
    ++host_evaluations;
    if (cadinterp_host_evaluate_serialized(host_, full.data(), &bytes, &size) != CADINTERP_OK)
      return false;
    cadinterp_bytes_free(bytes);
    outputs_(full.data(), f, g);
    return true;
  }
  std::vector<double> at(Index n, const Number* x) const {
    std::vector<double> full = full_;
    for (Index i = 0; i < n; ++i) full[static_cast<std::size_t>(free_[i])] = x[i];
    return full;
  }
  bool values(Index n, const Number* x, double* f, double* g) {
    const std::vector<double> full = at(n, x);
    if (full != cached_x_) {
      if (!host_at(full, &cached_f_, &cached_g_)) return false;
      cached_x_ = full;
    }
    *f = cached_f_;
    *g = cached_g_;
    return true;
  }
  // Forward differences: one host evaluation per free parameter beyond the value at x.
  bool gradients(Index n, const Number* x, Number* df, Number* dg) {
    double f0 = 0, g0 = 0;
    if (!values(n, x, &f0, &g0)) return false;
    if (at(n, x) != grad_x_) {
      grad_f_.assign(static_cast<std::size_t>(n), 0.0);
      grad_g_.assign(static_cast<std::size_t>(n), 0.0);
      for (Index i = 0; i < n; ++i) {
        std::vector<double> step = at(n, x);
        double& xi = step[static_cast<std::size_t>(free_[i])];
        const double h = xi + 1e-6 <= 1.0 ? 1e-6 : -1e-6;  // stay inside the box
        xi += h;
        double f = 0, g = 0;
        if (!host_at(step, &f, &g)) return false;
        grad_f_[static_cast<std::size_t>(i)] = (f - f0) / h;
        grad_g_[static_cast<std::size_t>(i)] = (g - g0) / h;
      }
      grad_x_ = at(n, x);
    }
    for (Index i = 0; i < n; ++i) {
      if (df) df[i] = grad_f_[static_cast<std::size_t>(i)];
      if (dg) dg[i] = grad_g_[static_cast<std::size_t>(i)];
    }
    return true;
  }

  const cadinterp_host* host_;
  std::vector<double> full_;
  std::vector<int> free_;
  Outputs outputs_;
  double lower_;
  std::vector<double> cached_x_, grad_x_, grad_f_, grad_g_;
  double cached_f_ = 0, cached_g_ = 0;
};

// Runs `nlp` with the optimizer's Ipopt settings; returns Ipopt's status.
inline Ipopt::ApplicationReturnStatus solve_on_host(const Ipopt::SmartPtr<HostFdNlp>& nlp) {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  auto& opt = *app->Options();
  opt.SetStringValue("sb", "yes");
  opt.SetIntegerValue("print_level", 0);
  opt.SetStringValue("hessian_approximation", "limited-memory");
  opt.SetNumericValue("tol", 1e-6);
  opt.SetNumericValue("bound_relax_factor", 0.0);
  opt.SetStringValue("honor_original_bounds", "yes");
  if (app->Initialize() != Ipopt::Solve_Succeeded) throw std::runtime_error("Ipopt init");
  return app->OptimizeTNLP(Ipopt::GetRawPtr(nlp));
}

}  // namespace cadinterp::optimize::bench
