// The problem behind cadinterp_optimize_problem: functions (objective and constraints) as
// weighted sums of terms over one asset, their values and exact gradients at x through the
// runtime's public C ABI, and the parameter ranges. Internal to libcadinterp_optimize.
#pragma once

#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_optimize.h"

namespace cadinterp::optimize {

struct Function {
  double lower = 0, upper = 0;  // bounds of a constraint (unused for the objective)
  std::vector<cadinterp_optimize_term> terms;
};

class Problem {
 public:
  // Throws std::bad_alloc or std::runtime_error (the workspace cannot be created).
  explicit Problem(const cadinterp_asset* asset);
  ~Problem();
  Problem(const Problem&) = delete;
  Problem& operator=(const Problem&) = delete;

  const cadinterp_asset* asset() const { return asset_; }
  int parameter_count() const { return K_; }
  int function_count() const { return static_cast<int>(functions_.size()); }
  const Function& function(int f) const { return functions_[static_cast<std::size_t>(f)]; }
  Function& function(int f) { return functions_[static_cast<std::size_t>(f)]; }
  int add_constraint(double lower, double upper);
  // Empty when `term` is valid for this asset, else why not.
  std::string check(const cadinterp_optimize_term& term) const;

  const std::vector<double>& lower() const { return lower_; }
  const std::vector<double>& upper() const { return upper_; }
  std::vector<double>& lower() { return lower_; }
  std::vector<double>& upper() { return upper_; }
  // The parameters whose range is not a single value, in order.
  std::vector<int> free_parameters() const;

  // values: function_count(); grads: NULL or function_count() rows of K. On failure returns the
  // runtime's status and sets `error` to its message. May throw std::bad_alloc.
  cadinterp_status evaluate(const double* x, double* values, double* grads, std::string* error);

 private:
  cadinterp_status term_value(const cadinterp_optimize_term& t, const double* x, double* value,
                              double* grad);
  cadinterp_status field_max(const cadinterp_optimize_term& t, const double* x, double* value,
                             double* grad);
  cadinterp_status properties(const cadinterp_optimize_term& t, const double* x,
                              cadinterp_properties* p, cadinterp_properties* g);

  const cadinterp_asset* asset_;
  cadinterp_workspace* ws_ = nullptr;
  int K_;
  std::vector<double> lower_, upper_;
  std::vector<Function> functions_;
  // Properties of the current evaluate call, per (density, direction) already computed.
  struct CachedProperties {
    double density, direction[3];
    cadinterp_properties value;
    std::vector<cadinterp_properties> grad;
  };
  std::vector<CachedProperties> props_;
  bool props_with_grad_ = false;
  std::vector<float> adjoint_;
  std::vector<double> rows_;
};

}  // namespace cadinterp::optimize
