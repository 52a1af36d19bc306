// The C ABI of include/cadinterp/cadinterp.h: argument checks, the exception guard, and the
// queries answered from the asset's metadata. The objects behind the handles are in
// runtime_objects.h, the element cache in element_cache.h, the evaluation bodies in evaluate.h.
// Every exported body that can throw runs between CADINTERP_CATCH_BEGIN and _END
// (capi/capi_guard.h), which map exceptions to status codes: nothing crosses the ABI.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <new>
#include <string>

#include "cadinterp/cadinterp.h"
#include "cadinterp_generated.h"
#include "capi/capi_guard.h"
#include "format/asset_reader.h"
#include "format/error_model.h"
#include "runtime/evaluate.h"
#include "runtime/runtime_objects.h"

using cadinterp::runtime::evaluate_grad;
using cadinterp::runtime::evaluate_integral;
using cadinterp::runtime::evaluate_mesh;
using cadinterp::runtime::evaluate_properties;
using cadinterp::runtime::evaluate_subset;
using cadinterp::runtime::evaluate_vjp;
using cadinterp::runtime::fail;
using cadinterp::runtime::FieldSlot;
using cadinterp::runtime::RegionSlot;

#define CADINTERP_STR2(x) #x
#define CADINTERP_STR(x) CADINTERP_STR2(x)
#define CADINTERP_VERSION_TEXT           \
  CADINTERP_STR(CADINTERP_VERSION_MAJOR) \
  "." CADINTERP_STR(CADINTERP_VERSION_MINOR) "." CADINTERP_STR(CADINTERP_VERSION_PATCH)

namespace {

thread_local std::string t_open_error;

// Copies the caller's options into *o by the struct_size rule of cadinterp.h: members beyond
// struct_size keep their zero default; bytes beyond this library's struct must be zero (a newer
// caller's members left at their defaults). Sets t_open_error on failure.
cadinterp_status read_open_options(const cadinterp_open_options* in, cadinterp_open_options* o) {
  *o = cadinterp_open_options{};
  if (!in) return CADINTERP_OK;
  const std::size_t n = in->struct_size;
  if (n < CADINTERP_OPEN_OPTIONS_SIZE_1_0) {
    t_open_error = "options struct_size " + std::to_string(n) + " is below the 1.0 struct's " +
                   std::to_string(CADINTERP_OPEN_OPTIONS_SIZE_1_0) + " bytes";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  std::memcpy(o, in, std::min(n, sizeof(*o)));
  const auto* bytes = reinterpret_cast<const unsigned char*>(in);
  for (std::size_t i = sizeof(*o); i < n; ++i)
    if (bytes[i] != 0) {
      t_open_error = "options byte " + std::to_string(i) +
                     " is set: a member this library (" CADINTERP_VERSION_TEXT
                     ") does not know, so it cannot honour it";
      return CADINTERP_E_INVALID_ARGUMENT;
    }
  if (const std::uint64_t unknown = o->flags & ~std::uint64_t(CADINTERP_OPEN_KNOWN_FLAGS)) {
    char hex[19];
    std::snprintf(hex, sizeof hex, "0x%llx", static_cast<unsigned long long>(unknown));
    t_open_error = std::string("unknown option flag bits ") + hex;
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  return CADINTERP_OK;
}

cadinterp_status open_with(
    const std::function<std::unique_ptr<cadinterp::format::AssetReader>()>& make,
    const cadinterp_open_options* options, cadinterp_asset** out) {
  t_open_error.clear();
  if (!out) {
    t_open_error = "out is NULL";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  // Inside the guard: reading the options builds messages, which allocate.
  CADINTERP_CATCH_BEGIN
  cadinterp_open_options o;
  if (const cadinterp_status s = read_open_options(options, &o)) return s;
  auto asset = cadinterp::runtime::make_asset(make());
  if (o.cache_budget_bytes != 0) asset->cache.set_budget(o.cache_budget_bytes);
  if (o.flags & CADINTERP_OPEN_VERIFY_BLOBS) asset->reader->verify_blobs();
  *out = asset.release();
  return CADINTERP_OK;
  CADINTERP_CATCH_END(&t_open_error)
}

}  // namespace

extern "C" {

const char* cadinterp_version(void) { return CADINTERP_VERSION_TEXT; }

unsigned cadinterp_version_number(void) { return CADINTERP_VERSION_NUMBER; }

void cadinterp_format_version(int* major, int* minor) {
  if (major) *major = cadinterp::format::kFormatMajor;
  if (minor) *minor = cadinterp::format::kFormatMinor;
}

const char* cadinterp_status_string(cadinterp_status status) {
  if (status == CADINTERP_E_NOT_FOUND) return "not found";
  if (status == CADINTERP_E_CANCELLED) return "cancelled";
  if (status == CADINTERP_E_STORE_MISMATCH) return "sample store belongs to another model";
  if (status < CADINTERP_OK || status > CADINTERP_E_INTERNAL) return "unknown status";
  return cadinterp::format::status_name(static_cast<cadinterp::format::Status>(status));
}

void cadinterp_open_options_init(cadinterp_open_options* options) {
  if (options) {
    *options = cadinterp_open_options{};
    options->struct_size = sizeof(*options);
  }
}

cadinterp_status cadinterp_open_with_options(const char* path,
                                             const cadinterp_open_options* options,
                                             cadinterp_asset** out) {
  if (!path) {
    t_open_error = "path is NULL";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  return open_with([&] { return cadinterp::format::AssetReader::open_file(path); }, options, out);
}

cadinterp_status cadinterp_open(const char* path, cadinterp_asset** out) {
  return cadinterp_open_with_options(path, nullptr, out);
}

cadinterp_status cadinterp_open_memory_with_options(const void* data, size_t size, int copy,
                                                    const cadinterp_open_options* options,
                                                    cadinterp_asset** out) {
  if (!data) {
    t_open_error = "data is NULL";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  return open_with(
      [&] { return cadinterp::format::AssetReader::open_memory(data, size, copy != 0); }, options,
      out);
}

cadinterp_status cadinterp_open_memory(const void* data, size_t size, int copy,
                                       cadinterp_asset** out) {
  return cadinterp_open_memory_with_options(data, size, copy, nullptr, out);
}

const char* cadinterp_open_error(void) { return t_open_error.c_str(); }

void cadinterp_close(cadinterp_asset* asset) { delete asset; }

int cadinterp_parameter_count(const cadinterp_asset* a) { return a ? a->reader->basis().dim() : 0; }
int cadinterp_degree(const cadinterp_asset* a) {
  return a ? static_cast<int>(a->reader->basis().degree()) : 0;
}
int cadinterp_element_count(const cadinterp_asset* a) {
  return a ? a->reader->basis().element_count() : 0;
}

cadinterp_status cadinterp_asset_format(const cadinterp_asset* a, int* major, int* minor) {
  if (!a || !major || !minor) return CADINTERP_E_INVALID_ARGUMENT;
  *major = cadinterp::format::kFormatMajor;
  *minor = a->reader->format_minor();
  return CADINTERP_OK;
}

cadinterp_status cadinterp_parameter(const cadinterp_asset* a, int i,
                                     cadinterp_parameter_info* out) {
  if (!a || !out || i < 0 || i >= static_cast<int>(a->names.size()))
    return CADINTERP_E_INVALID_ARGUMENT;
  const auto& p = a->reader->basis().parts();
  out->name = a->names[static_cast<std::size_t>(i)].c_str();
  out->unit = a->units[static_cast<std::size_t>(i)].c_str();
  out->lower = p.lo[static_cast<std::size_t>(i)];
  out->upper = p.hi[static_cast<std::size_t>(i)];
  return CADINTERP_OK;
}

int cadinterp_field_count(const cadinterp_asset* a) {
  return a ? static_cast<int>(a->fields.size()) : 0;
}

cadinterp_status cadinterp_field(const cadinterp_asset* a, int i, cadinterp_field_info* out) {
  if (!a || !out || i < 0 || i >= static_cast<int>(a->fields.size()))
    return CADINTERP_E_INVALID_ARGUMENT;
  const FieldSlot& f = a->fields[static_cast<std::size_t>(i)];
  *out = {f.name.c_str(), f.location, f.components, f.max_abs_error};
  return CADINTERP_OK;
}

cadinterp_status cadinterp_field_unit(const cadinterp_asset* a, int i, const char** unit) {
  if (!a || !unit || i < 0 || i >= static_cast<int>(a->fields.size()))
    return CADINTERP_E_INVALID_ARGUMENT;
  *unit = a->fields[static_cast<std::size_t>(i)].unit.c_str();
  return CADINTERP_OK;
}

cadinterp_status cadinterp_find_field(const cadinterp_asset* a, const char* name, int* index) {
  if (!a || !name || !index) return CADINTERP_E_INVALID_ARGUMENT;
  for (std::size_t i = 0; i < a->fields.size(); ++i)
    if (a->fields[i].name == name) {
      *index = static_cast<int>(i);
      return CADINTERP_OK;
    }
  return CADINTERP_E_NOT_FOUND;
}

int cadinterp_region_count(const cadinterp_asset* a) {
  return a ? static_cast<int>(a->regions.size()) : 0;
}

cadinterp_status cadinterp_region(const cadinterp_asset* a, int i, cadinterp_region_info* out) {
  if (!a || !out || i < 0 || i >= static_cast<int>(a->regions.size()))
    return CADINTERP_E_INVALID_ARGUMENT;
  const RegionSlot& r = a->regions[static_cast<std::size_t>(i)];
  *out = {r.name.c_str(), r.kind.c_str(), r.tags.data(), static_cast<int>(r.tags.size())};
  return CADINTERP_OK;
}

cadinterp_status cadinterp_asset_provenance(const cadinterp_asset* a, cadinterp_provenance* out) {
  if (!a || !out) return CADINTERP_E_INVALID_ARGUMENT;
  *out = {a->builder_version.c_str(), a->host.c_str(), a->options.c_str()};
  return CADINTERP_OK;
}

int cadinterp_infeasible_point_count(const cadinterp_asset* a) {
  return a ? static_cast<int>(a->infeasible_x.size()) : 0;
}

cadinterp_status cadinterp_infeasible_point(const cadinterp_asset* a, int i, double* x,
                                            const char** message) {
  if (!a || i < 0 || i >= static_cast<int>(a->infeasible_x.size()) || !x)
    return CADINTERP_E_INVALID_ARGUMENT;
  const auto& p = a->infeasible_x[static_cast<std::size_t>(i)];
  std::copy(p.begin(), p.end(), x);
  if (message) *message = a->infeasible_message[static_cast<std::size_t>(i)].c_str();
  return CADINTERP_OK;
}

cadinterp_status cadinterp_locate(const cadinterp_asset* a, const double* x, int* element,
                                  int* feasible) {
  if (!a || !x || !element) return CADINTERP_E_INVALID_ARGUMENT;
  const int e = a->reader->basis().locate(x);
  if (e < 0) return CADINTERP_E_OUTSIDE_DOMAIN;
  *element = e;
  if (feasible) *feasible = a->reader->basis().element_feasible(e) ? 1 : 0;
  return CADINTERP_OK;
}

cadinterp_status cadinterp_element_mesh_size(const cadinterp_asset* a, int element,
                                             uint32_t* vertex_count, uint32_t* tet_count,
                                             uint32_t* triangle_count) {
  if (!a || element < 0 || element >= a->reader->basis().element_count())
    return CADINTERP_E_INVALID_ARGUMENT;
  const auto* m = a->reader->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(element));
  const bool meshes = m->vertex_count() > 0;  // an infeasible element has none (reader checks)
  if (vertex_count) *vertex_count = m->vertex_count();
  if (tet_count) *tet_count = meshes ? m->tet_count() : 0;
  if (triangle_count) *triangle_count = meshes ? m->triangle_count() : 0;
  return CADINTERP_OK;
}

cadinterp_status cadinterp_element_term_count(const cadinterp_asset* a, int element, int* terms) {
  if (!a || !terms || element < 0 || element >= a->reader->basis().element_count())
    return CADINTERP_E_INVALID_ARGUMENT;
  int n = 0;
  a->reader->basis().element_samples(element, &n);
  *terms = n;
  return CADINTERP_OK;
}

namespace {

// The estimates of cadinterp_error_estimates at x (element e feasible) into out (1 + #fields
// values): the element's error model shaped at x's place in the element (format/error_model.h),
// times the calibrated safety factor, plus the element's floor for the quantity; -1 everywhere
// without a model.
void estimates_at(const cadinterp_asset* a, int e, const double* x, double* out, int count) {
  const cadinterp::core::CompiledBasis& basis = a->reader->basis();
  const auto* m = a->reader->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
  const auto* model = m->error_model();
  if (!model) {
    std::fill(out, out + count, -1.0);
    return;
  }
  const int K = basis.dim();
  double lo[cadinterp::core::kMaxDim], hi[cadinterp::core::kMaxDim], t[cadinterp::core::kMaxDim];
  basis.element_box(e, lo, hi);
  for (int d = 0; d < K; ++d) t[d] = (x[d] - lo[d]) / (hi[d] - lo[d]);
  // A cubic asset's corner-fallback element interpolates its corners multilinearly, and the
  // builder measured its model as a linear element's: it takes the linear shape and factor.
  const bool cubic = basis.element_cubic(e);
  for (int q = 0; q < count; ++q)
    out[q] = cadinterp::format::error_model_reported(
        cadinterp::format::error_model_estimate(
            model->data() + static_cast<std::size_t>(q) * static_cast<std::size_t>(K + 1), K, cubic,
            t),
        cubic, q == 0, cadinterp::format::element_error_floor(*m, q));
}

}  // namespace

cadinterp_status cadinterp_error_estimate(const cadinterp_asset* a, const double* x,
                                          double* error) {
  if (!a || !x || !error) return CADINTERP_E_INVALID_ARGUMENT;
  const int e = a->reader->basis().locate(x);
  if (e < 0) return CADINTERP_E_OUTSIDE_DOMAIN;
  if (!a->reader->basis().element_feasible(e)) return CADINTERP_E_INFEASIBLE;
  const auto* m = a->reader->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e));
  if (!m->error_model()) {
    *error = m->error_estimate();
    return CADINTERP_OK;
  }
  // Row 0 of the model is the geometry's (the rows after it are the fields').
  estimates_at(a, e, x, error, 1);
  return CADINTERP_OK;
}

cadinterp_status cadinterp_error_estimates(const cadinterp_asset* a, const double* x, double* out,
                                           int capacity, int* count) {
  if (!a || !count) return CADINTERP_E_INVALID_ARGUMENT;
  const auto* fields = a->reader->index().fields();
  *count = 1 + (fields ? static_cast<int>(fields->size()) : 0);
  if (!x || (!out && capacity > 0) || capacity < *count) return CADINTERP_E_INVALID_ARGUMENT;
  const int e = a->reader->basis().locate(x);
  if (e < 0) return CADINTERP_E_OUTSIDE_DOMAIN;
  if (!a->reader->basis().element_feasible(e)) return CADINTERP_E_INFEASIBLE;
  estimates_at(a, e, x, out, *count);
  return CADINTERP_OK;
}

cadinterp_status cadinterp_set_cache_budget(cadinterp_asset* a, size_t bytes) {
  if (!a) return CADINTERP_E_INVALID_ARGUMENT;
  CADINTERP_CATCH_BEGIN
  a->cache.set_budget(bytes);
  return CADINTERP_OK;
  CADINTERP_CATCH_END(nullptr)
}

cadinterp_status cadinterp_workspace_create(const cadinterp_asset* a, cadinterp_workspace** out) {
  if (!a || !out) return CADINTERP_E_INVALID_ARGUMENT;
  CADINTERP_CATCH_BEGIN
  auto ws = std::make_unique<cadinterp_workspace>();
  ws->asset = a;
  ws->basis_ws = a->reader->basis().make_workspace();
  *out = ws.release();
  return CADINTERP_OK;
  CADINTERP_CATCH_END(nullptr)
}

void cadinterp_workspace_destroy(cadinterp_workspace* ws) { delete ws; }

const char* cadinterp_workspace_error(const cadinterp_workspace* ws) {
  return ws ? ws->error.c_str() : "";
}

cadinterp_status cadinterp_eval(cadinterp_workspace* ws, const double* x, const int* fields,
                                int field_count, cadinterp_mesh* out) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!out) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "out is NULL");
  CADINTERP_CATCH_BEGIN
  return evaluate_mesh(ws, x, fields, field_count, out);
  CADINTERP_CATCH_END(&ws->error)
}

cadinterp_status cadinterp_eval_subset(cadinterp_workspace* ws, const double* x,
                                       const uint32_t* vertices, size_t vertex_subset_count,
                                       const uint32_t* tets, size_t tet_subset_count,
                                       const int* fields, int field_count, cadinterp_mesh* out) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!out) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "out is NULL");
  if (!vertices && vertex_subset_count > 0)
    return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "vertices is NULL with a nonzero count");
  if (!tets && tet_subset_count > 0)
    return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "tets is NULL with a nonzero count");
  CADINTERP_CATCH_BEGIN
  return evaluate_subset(ws, x, vertices, vertex_subset_count, tets, tet_subset_count, fields,
                         field_count, out);
  CADINTERP_CATCH_END(&ws->error)
}

cadinterp_status cadinterp_grad(cadinterp_workspace* ws, const double* x, const int* fields,
                                int field_count, cadinterp_mesh_grad* out) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!out) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "out is NULL");
  CADINTERP_CATCH_BEGIN
  return evaluate_grad(ws, x, fields, field_count, out);
  CADINTERP_CATCH_END(&ws->error)
}

cadinterp_status cadinterp_vjp(cadinterp_workspace* ws, const double* x, const float* dF_dpositions,
                               const int* fields, const float* const* dF_dfields, int field_count,
                               double* dF_dx) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!dF_dx) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "dF_dx is NULL");
  CADINTERP_CATCH_BEGIN
  return evaluate_vjp(ws, x, dF_dpositions, fields, dF_dfields, field_count, dF_dx);
  CADINTERP_CATCH_END(&ws->error)
}

cadinterp_status cadinterp_eval_properties(cadinterp_workspace* ws, const double* x, double density,
                                           const double* direction, cadinterp_properties* out,
                                           cadinterp_properties* grad) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!out || !direction) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "out or direction is NULL");
  if (!std::isfinite(density)) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "density not finite");
  // Checked here: a non-finite direction would make the frontal area NaN, which the overflow
  // check would then blame on the asset's values.
  if (!std::isfinite(direction[0]) || !std::isfinite(direction[1]) || !std::isfinite(direction[2]))
    return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "direction not finite");
  CADINTERP_CATCH_BEGIN
  return evaluate_properties(ws, x, density, direction, out, grad);
  CADINTERP_CATCH_END(&ws->error)
}

cadinterp_status cadinterp_eval_integral(cadinterp_workspace* ws, const double* x, int field,
                                         int component, int region, double* value, double* grad) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!value) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "value is NULL");
  CADINTERP_CATCH_BEGIN
  return evaluate_integral(ws, x, field, component, region, value, grad);
  CADINTERP_CATCH_END(&ws->error)
}

int cadinterp_output_count(const cadinterp_asset* a) {
  return a ? static_cast<int>(a->outputs.size()) : 0;
}

cadinterp_status cadinterp_output(const cadinterp_asset* a, int i, const char** name,
                                  const char** unit) {
  if (!a || !name || i < 0 || i >= static_cast<int>(a->outputs.size()))
    return CADINTERP_E_INVALID_ARGUMENT;
  *name = a->outputs[static_cast<std::size_t>(i)].name.c_str();
  if (unit) *unit = a->outputs[static_cast<std::size_t>(i)].unit.c_str();
  return CADINTERP_OK;
}

cadinterp_status cadinterp_find_output(const cadinterp_asset* a, const char* name, int* index) {
  if (!a || !name || !index) return CADINTERP_E_INVALID_ARGUMENT;
  for (std::size_t i = 0; i < a->outputs.size(); ++i)
    if (a->outputs[i].name == name) {
      *index = static_cast<int>(i);
      return CADINTERP_OK;
    }
  return CADINTERP_E_NOT_FOUND;
}

cadinterp_status cadinterp_eval_outputs(cadinterp_workspace* ws, const double* x,
                                        const int* outputs, int output_count, double* values,
                                        double* grad) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!x || !values) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "x or values is NULL");
  if (output_count < 0 || (output_count > 0 && !outputs))
    return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "outputs is NULL or output_count negative");
  const cadinterp_asset& a = *ws->asset;
  for (int i = 0; i < output_count; ++i)
    if (outputs[i] < 0 || outputs[i] >= static_cast<int>(a.outputs.size()))
      return fail(ws, CADINTERP_E_INVALID_ARGUMENT,
                  "output index " + std::to_string(outputs[i]) + " out of range (the asset has " +
                      std::to_string(a.outputs.size()) + ")");
  CADINTERP_CATCH_BEGIN
  const cadinterp::core::CompiledBasis& basis = a.reader->basis();
  int e = -1;
  const cadinterp_status located = cadinterp::runtime::locate_feasible(ws, x, &e);
  if (located != CADINTERP_OK) return located;
  cadinterp::core::BasisWeights w;
  basis.eval_element(e, x, ws->basis_ws, grad != nullptr, &w);
  const int K = basis.dim();
  // Nothing fails past the checks above, so values and grad are written as they are summed.
  for (int i = 0; i < output_count; ++i) {
    const std::vector<double>& o = a.outputs[static_cast<std::size_t>(outputs[i])].values;
    double v = 0.0;
    for (int t = 0; t < w.count; ++t) v += w.psi[t] * o[static_cast<std::size_t>(w.samples[t])];
    values[i] = v;
    if (grad)
      for (int d = 0; d < K; ++d) {
        double g = 0.0;
        for (int t = 0; t < w.count; ++t)
          g += w.dpsi[d * w.count + t] * o[static_cast<std::size_t>(w.samples[t])];
        grad[static_cast<std::size_t>(i) * static_cast<std::size_t>(K) +
             static_cast<std::size_t>(d)] = g;
      }
  }
  ws->error.clear();
  return CADINTERP_OK;
  CADINTERP_CATCH_END(&ws->error)
}

// The deprecated names (cadinterp.h, "Deprecated names"): exported for one release.

int cadinterp_dim(const cadinterp_asset* a) { return cadinterp_parameter_count(a); }

cadinterp_status cadinterp_get_provenance(const cadinterp_asset* a, cadinterp_provenance* out) {
  return cadinterp_asset_provenance(a, out);
}

cadinterp_status cadinterp_properties_eval(cadinterp_workspace* ws, const double* x, double density,
                                           const double* direction, cadinterp_properties* out,
                                           cadinterp_properties* grad) {
  return cadinterp_eval_properties(ws, x, density, direction, out, grad);
}

}  // extern "C"
