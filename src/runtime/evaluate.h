// The evaluation bodies of the C ABI's eval, eval_subset, grad, vjp and eval_properties. The
// C ABI layer (cadinterp_runtime.cpp) checks the workspace and output pointers and guards each
// call (capi/capi_guard.h); these check the rest of the arguments, report failures through the
// workspace's message, clear it on success, and may throw (format::FormatError, std::bad_alloc).
#pragma once

#include <cstddef>
#include <cstdint>

#include "runtime/runtime_objects.h"

namespace cadinterp::runtime {

cadinterp_status evaluate_mesh(cadinterp_workspace* ws, const double* x, const int* fields,
                               int field_count, cadinterp_mesh* out);

cadinterp_status evaluate_subset(cadinterp_workspace* ws, const double* x,
                                 const std::uint32_t* vertices, std::size_t vertex_subset_count,
                                 const std::uint32_t* tets, std::size_t tet_subset_count,
                                 const int* fields, int field_count, cadinterp_mesh* out);

// The feasible element holding x (*element), or CADINTERP_E_OUTSIDE_DOMAIN /
// CADINTERP_E_INFEASIBLE with the workspace's message set.
cadinterp_status locate_feasible(cadinterp_workspace* ws, const double* x, int* element);

cadinterp_status evaluate_grad(cadinterp_workspace* ws, const double* x, const int* fields,
                               int field_count, cadinterp_mesh_grad* out);

cadinterp_status evaluate_vjp(cadinterp_workspace* ws, const double* x, const float* dF_dpositions,
                              const int* fields, const float* const* dF_dfields, int field_count,
                              double* dF_dx);

cadinterp_status evaluate_properties(cadinterp_workspace* ws, const double* x, double density,
                                     const double* direction, cadinterp_properties* out,
                                     cadinterp_properties* grad);

// cadinterp_eval_integral: the integral of one component of a field (field -1: of 1) over the
// tets (region -1) or over a region's boundary triangles, and its K derivatives if grad.
cadinterp_status evaluate_integral(cadinterp_workspace* ws, const double* x, int field,
                                   int component, int region, double* value, double* grad);

}  // namespace cadinterp::runtime
