// Values and exact gradients of the problem's functions (problem.h), through the runtime's C ABI:
// cadinterp_eval_properties for mass properties, cadinterp_eval_integral for field integrals,
// cadinterp_eval + cadinterp_vjp for the smooth maxima, whose adjoint is formed here, and
// cadinterp_eval_outputs for per-sample outputs (no mesh at all).
#include "optimize/problem.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace cadinterp::optimize {

Problem::Problem(const cadinterp_asset* asset)
    : asset_(asset), K_(cadinterp_parameter_count(asset)), functions_(1) {
  if (cadinterp_workspace_create(asset, &ws_) != CADINTERP_OK)
    throw std::runtime_error("cannot create a workspace of the asset");
  for (int i = 0; i < K_; ++i) {
    cadinterp_parameter_info p;
    cadinterp_parameter(asset, i, &p);
    lower_.push_back(p.lower);
    upper_.push_back(p.upper);
  }
}

Problem::~Problem() { cadinterp_workspace_destroy(ws_); }

int Problem::add_constraint(double lower, double upper) {
  Function f;
  f.lower = lower;
  f.upper = upper;
  functions_.push_back(f);
  return function_count() - 1;
}

std::vector<int> Problem::free_parameters() const {
  std::vector<int> out;
  for (int i = 0; i < K_; ++i)
    if (lower_[static_cast<std::size_t>(i)] < upper_[static_cast<std::size_t>(i)]) out.push_back(i);
  return out;
}

std::string Problem::check(const cadinterp_optimize_term& t) const {
  if (t.struct_size < sizeof(cadinterp_optimize_term)) return "term struct_size too small";
  if (!std::isfinite(t.weight)) return "weight not finite";
  if (!std::isfinite(t.parameter)) return "parameter not finite";
  for (double d : t.direction)
    if (!std::isfinite(d)) return "direction not finite";
  const int nfields = cadinterp_field_count(asset_);
  switch (t.quantity) {
    case CADINTERP_OPTIMIZE_VOLUME:
    case CADINTERP_OPTIMIZE_MASS:
    case CADINTERP_OPTIMIZE_AREA:
    case CADINTERP_OPTIMIZE_FRONTAL_AREA:
      return "";
    case CADINTERP_OPTIMIZE_CENTROID:
      return t.component >= 0 && t.component < 3 ? "" : "centroid component out of range (0..2)";
    case CADINTERP_OPTIMIZE_INERTIA:
      return t.component >= 0 && t.component < 9 ? "" : "inertia component out of range (0..8)";
    case CADINTERP_OPTIMIZE_OUTPUT:
      return t.field >= 0 && t.field < cadinterp_output_count(asset_) ? ""
                                                                      : "output index out of range";
    case CADINTERP_OPTIMIZE_INTEGRAL:
    case CADINTERP_OPTIMIZE_MAX_PNORM:
    case CADINTERP_OPTIMIZE_MAX_KS:
      break;
    default:
      return "unknown quantity " + std::to_string(static_cast<int>(t.quantity));
  }
  const bool integral = t.quantity == CADINTERP_OPTIMIZE_INTEGRAL;
  if (t.field < (integral ? -1 : 0) || t.field >= nfields) return "field index out of range";
  int components = 1;
  if (t.field >= 0) {
    cadinterp_field_info f;
    cadinterp_field(asset_, t.field, &f);
    components = f.components;
  }
  if (t.component < 0 || t.component >= components) return "field component out of range";
  if (integral && (t.region < -1 || t.region >= cadinterp_region_count(asset_)))
    return "region index out of range";
  if (t.quantity == CADINTERP_OPTIMIZE_MAX_PNORM && !(t.parameter >= 1))
    return "p-norm needs p >= 1";
  if (t.quantity == CADINTERP_OPTIMIZE_MAX_KS && !(t.parameter > 0)) return "KS needs rho > 0";
  return "";
}

cadinterp_status Problem::properties(const cadinterp_optimize_term& t, const double* x,
                                     cadinterp_properties* p, cadinterp_properties* g) {
  // Only mass and inertia depend on the density, only the frontal area on the direction: the
  // others share one call.
  const bool dense =
      t.quantity == CADINTERP_OPTIMIZE_MASS || t.quantity == CADINTERP_OPTIMIZE_INERTIA;
  const double density = dense ? t.parameter : 1.0;
  double dir[3] = {0.0, 0.0, 1.0};
  if (t.quantity == CADINTERP_OPTIMIZE_FRONTAL_AREA) std::memcpy(dir, t.direction, sizeof dir);
  for (const CachedProperties& c : props_)
    if (c.density == density && std::memcmp(c.direction, dir, sizeof dir) == 0) {
      *p = c.value;
      if (g) std::copy(c.grad.begin(), c.grad.end(), g);
      return CADINTERP_OK;
    }
  CachedProperties c;
  c.density = density;
  std::memcpy(c.direction, dir, sizeof dir);
  c.grad.resize(props_with_grad_ ? static_cast<std::size_t>(K_) : 0);
  const cadinterp_status s = cadinterp_eval_properties(ws_, x, density, dir, &c.value,
                                                       props_with_grad_ ? c.grad.data() : nullptr);
  if (s != CADINTERP_OK) return s;
  props_.push_back(c);
  *p = c.value;
  if (g) std::copy(c.grad.begin(), c.grad.end(), g);
  return CADINTERP_OK;
}

// The smooth maximum of a field over its rows and its gradient: the aggregate's derivative with
// respect to each row value is the adjoint handed to cadinterp_vjp.
cadinterp_status Problem::field_max(const cadinterp_optimize_term& t, const double* x,
                                    double* value, double* grad) {
  cadinterp_mesh m;
  cadinterp_status s = cadinterp_eval(ws_, x, &t.field, 1, &m);
  if (s != CADINTERP_OK) return s;
  cadinterp_field_info info;
  cadinterp_field(asset_, t.field, &info);
  const std::size_t c = static_cast<std::size_t>(info.components);
  const std::size_t n = info.location == CADINTERP_PER_VERTEX ? m.vertex_count : m.tet_count;
  rows_.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    rows_[i] = m.fields[0][i * c + static_cast<std::size_t>(t.component)];
  // d aggregate / d f_i, in rows_ once the value is known.
  double result = 0.0;
  if (t.quantity == CADINTERP_OPTIMIZE_MAX_PNORM) {
    // m (sum (|f_i| / m)^p)^(1/p) with m = max |f_i|: no overflow for any p.
    double mx = 0.0;
    for (double f : rows_) mx = std::max(mx, std::fabs(f));
    double sum = 0.0;
    for (double f : rows_) sum += mx > 0 ? std::pow(std::fabs(f) / mx, t.parameter) : 0.0;
    result = mx > 0 ? mx * std::pow(sum, 1.0 / t.parameter) : 0.0;
    const double scale = mx > 0 ? std::pow(sum, 1.0 / t.parameter - 1.0) : 0.0;
    for (double& f : rows_) {
      const double d = mx > 0 ? std::pow(std::fabs(f) / mx, t.parameter - 1.0) * scale : 0.0;
      f = f < 0 ? -d : d;
    }
  } else {
    // max + ln(sum exp(rho (f_i - max))) / rho: every exponent <= 0.
    double mx = -HUGE_VAL;
    for (double f : rows_) mx = std::max(mx, f);
    double sum = 0.0;
    for (double f : rows_) sum += std::exp(t.parameter * (f - mx));
    result = n ? mx + std::log(sum) / t.parameter : 0.0;
    for (double& f : rows_) f = std::exp(t.parameter * (f - mx)) / sum;
  }
  if (grad) {
    adjoint_.assign(n * c, 0.0f);
    for (std::size_t i = 0; i < n; ++i)
      adjoint_[i * c + static_cast<std::size_t>(t.component)] = static_cast<float>(rows_[i]);
    const float* adj = adjoint_.data();
    s = cadinterp_vjp(ws_, x, nullptr, &t.field, &adj, 1, grad);
    if (s != CADINTERP_OK) return s;
  }
  *value = result;
  return CADINTERP_OK;
}

cadinterp_status Problem::term_value(const cadinterp_optimize_term& t, const double* x,
                                     double* value, double* grad) {
  switch (t.quantity) {
    case CADINTERP_OPTIMIZE_INTEGRAL:
      return cadinterp_eval_integral(ws_, x, t.field, t.component, t.region, value, grad);
    case CADINTERP_OPTIMIZE_MAX_PNORM:
    case CADINTERP_OPTIMIZE_MAX_KS:
      return field_max(t, x, value, grad);
    case CADINTERP_OPTIMIZE_OUTPUT:
      return cadinterp_eval_outputs(ws_, x, &t.field, 1, value, grad);
    case CADINTERP_OPTIMIZE_VOLUME:
    case CADINTERP_OPTIMIZE_MASS: {
      // The volume integral (integrand 1) rather than the mass properties: the same signed
      // volume and exact gradient, without the centroid, inertia and frontal area that
      // cadinterp_eval_properties also differentiates (measured ~10x its cost per evaluation,
      // optimize_bench).
      const cadinterp_status s = cadinterp_eval_integral(ws_, x, -1, 0, -1, value, grad);
      if (s != CADINTERP_OK || t.quantity == CADINTERP_OPTIMIZE_VOLUME) return s;
      *value *= t.parameter;
      for (int k = 0; grad && k < K_; ++k) grad[k] *= t.parameter;
      return CADINTERP_OK;
    }
    default:
      break;
  }
  cadinterp_properties p;
  std::vector<cadinterp_properties> g(grad ? static_cast<std::size_t>(K_) : 0);
  const cadinterp_status s = properties(t, x, &p, grad ? g.data() : nullptr);
  if (s != CADINTERP_OK) return s;
  auto pick = [&t](const cadinterp_properties& q) {
    switch (t.quantity) {
      case CADINTERP_OPTIMIZE_VOLUME:
        return q.volume;
      case CADINTERP_OPTIMIZE_MASS:
        return q.mass;
      case CADINTERP_OPTIMIZE_AREA:
        return q.area;
      case CADINTERP_OPTIMIZE_FRONTAL_AREA:
        return q.frontal_area;
      case CADINTERP_OPTIMIZE_CENTROID:
        return q.centroid[t.component];
      default:
        return q.inertia[t.component];
    }
  };
  *value = pick(p);
  for (std::size_t k = 0; grad && k < g.size(); ++k) grad[k] = pick(g[k]);
  return CADINTERP_OK;
}

cadinterp_status Problem::evaluate(const double* x, double* values, double* grads,
                                   std::string* error) {
  props_.clear();
  props_with_grad_ = grads != nullptr;
  const std::size_t K = static_cast<std::size_t>(K_);
  std::vector<double> v(functions_.size(), 0.0), g(grads ? functions_.size() * K : 0, 0.0);
  std::vector<double> tg(K);
  for (std::size_t f = 0; f < functions_.size(); ++f)
    for (const cadinterp_optimize_term& t : functions_[f].terms) {
      double tv = 0.0;
      const cadinterp_status s = term_value(t, x, &tv, grads ? tg.data() : nullptr);
      if (s != CADINTERP_OK) {
        *error = cadinterp_workspace_error(ws_);
        return s;
      }
      v[f] += t.weight * tv;
      for (std::size_t k = 0; grads && k < K; ++k) g[f * K + k] += t.weight * tg[k];
    }
  std::copy(v.begin(), v.end(), values);
  if (grads) std::copy(g.begin(), g.end(), grads);
  return CADINTERP_OK;
}

}  // namespace cadinterp::optimize
