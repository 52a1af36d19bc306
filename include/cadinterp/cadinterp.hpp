// Header-only C++17 RAII wrapper over the C ABI of cadinterp.h. Errors become
// cadinterp::Error exceptions carrying the status and the message; everything else is the C
// API's semantics (see cadinterp.h for shapes, lifetimes and thread-safety).
#ifndef CADINTERP_HPP
#define CADINTERP_HPP

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"

namespace cadinterp {

class Error : public std::runtime_error {
 public:
  Error(cadinterp_status status, const std::string& message)
      : std::runtime_error(std::string(cadinterp_status_string(status)) + ": " + message),
        status_(status) {}
  cadinterp_status status() const noexcept { return status_; }

 private:
  cadinterp_status status_;
};

/// An opened asset; shareable across threads (const methods).
class Asset {
 public:
  static Asset open(const std::string& path) {
    cadinterp_asset* a = nullptr;
    const cadinterp_status s = cadinterp_open(path.c_str(), &a);
    if (s != CADINTERP_OK) throw Error(s, cadinterp_open_error());
    return Asset(a);
  }
  /// copy=false: `data` must outlive the Asset.
  static Asset open_memory(const void* data, size_t size, bool copy) {
    cadinterp_asset* a = nullptr;
    const cadinterp_status s = cadinterp_open_memory(data, size, copy ? 1 : 0, &a);
    if (s != CADINTERP_OK) throw Error(s, cadinterp_open_error());
    return Asset(a);
  }
  /// Options with struct_size set (cadinterp_open_options_init), the budget and flags given.
  static cadinterp_open_options options(size_t cache_budget_bytes = 0, uint64_t flags = 0) {
    cadinterp_open_options o;
    cadinterp_open_options_init(&o);
    o.cache_budget_bytes = cache_budget_bytes;
    o.flags = flags;
    return o;
  }
  /// cadinterp_open_with_options.
  static Asset open(const std::string& path, const cadinterp_open_options& options) {
    cadinterp_asset* a = nullptr;
    const cadinterp_status s = cadinterp_open_with_options(path.c_str(), &options, &a);
    if (s != CADINTERP_OK) throw Error(s, cadinterp_open_error());
    return Asset(a);
  }
  /// cadinterp_open_memory_with_options; copy=false: `data` must outlive the Asset.
  static Asset open_memory(const void* data, size_t size, bool copy,
                           const cadinterp_open_options& options) {
    cadinterp_asset* a = nullptr;
    const cadinterp_status s =
        cadinterp_open_memory_with_options(data, size, copy ? 1 : 0, &options, &a);
    if (s != CADINTERP_OK) throw Error(s, cadinterp_open_error());
    return Asset(a);
  }
  int parameter_count() const { return cadinterp_parameter_count(get()); }
  /// Deprecated name of parameter_count(), kept through 1.x.
  [[deprecated("use parameter_count")]] int dim() const { return parameter_count(); }
  int degree() const { return cadinterp_degree(get()); }
  int element_count() const { return cadinterp_element_count(get()); }
  cadinterp_parameter_info parameter(int i) const {
    cadinterp_parameter_info p{};
    check(cadinterp_parameter(get(), i, &p), "parameter index");
    return p;
  }
  int field_count() const { return cadinterp_field_count(get()); }
  cadinterp_field_info field(int i) const {
    cadinterp_field_info f{};
    check(cadinterp_field(get(), i, &f), "field index");
    return f;
  }
  int find_field(const std::string& name) const {
    int i = -1;
    check(cadinterp_find_field(get(), name.c_str(), &i), name);
    return i;
  }
  void set_cache_budget(size_t bytes) { check(cadinterp_set_cache_budget(get(), bytes), "budget"); }
  cadinterp_asset* get() const { return a_.get(); }

 private:
  explicit Asset(cadinterp_asset* a) : a_(a, &cadinterp_close) {}
  static void check(cadinterp_status s, const std::string& what) {
    if (s != CADINTERP_OK) throw Error(s, what);
  }
  std::shared_ptr<cadinterp_asset> a_;
};

/// Per-thread evaluation state; keeps its asset alive.
class Workspace {
 public:
  explicit Workspace(const Asset& asset) : asset_(asset) {
    cadinterp_workspace* ws = nullptr;
    const cadinterp_status s = cadinterp_workspace_create(asset.get(), &ws);
    if (s != CADINTERP_OK) throw Error(s, "workspace");
    ws_.reset(ws);
  }
  /// The mesh at x; its arrays are valid until the next call on this workspace.
  cadinterp_mesh eval(const double* x, const std::vector<int>& fields = {}) {
    cadinterp_mesh m{};
    check(cadinterp_eval(ws_.get(), x, fields.data(), static_cast<int>(fields.size()), &m));
    return m;
  }
  cadinterp_mesh_grad grad(const double* x, const std::vector<int>& fields = {}) {
    cadinterp_mesh_grad g{};
    check(cadinterp_grad(ws_.get(), x, fields.data(), static_cast<int>(fields.size()), &g));
    return g;
  }
  /// dF/dx (K values) from dF/dpositions (#V by 3).
  std::vector<double> vjp(const double* x, const float* dF_dpositions) {
    std::vector<double> out(static_cast<size_t>(asset_.parameter_count()));
    check(cadinterp_vjp(ws_.get(), x, dF_dpositions, nullptr, nullptr, 0, out.data()));
    return out;
  }
  cadinterp_properties properties(const double* x, double density, const double direction[3],
                                  std::vector<cadinterp_properties>* grad = nullptr) {
    cadinterp_properties p{};
    if (grad) grad->resize(static_cast<size_t>(asset_.parameter_count()));
    check(cadinterp_eval_properties(ws_.get(), x, density, direction, &p,
                                    grad ? grad->data() : nullptr));
    return p;
  }

 private:
  struct Destroy {
    void operator()(cadinterp_workspace* ws) const { cadinterp_workspace_destroy(ws); }
  };
  void check(cadinterp_status s) {
    if (s != CADINTERP_OK) throw Error(s, cadinterp_workspace_error(ws_.get()));
  }
  Asset asset_;
  std::unique_ptr<cadinterp_workspace, Destroy> ws_;
};

}  // namespace cadinterp

#endif  // CADINTERP_HPP
