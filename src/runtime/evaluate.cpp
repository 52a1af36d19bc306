// The evaluation bodies behind cadinterp_eval, _eval_subset, _grad, _vjp and _eval_properties
// (evaluate.h): locate x, take the element from the asset's cache, blend its stored samples with
// the basis weights (paper Eq. 3 and 13; kernels in blend_multi.h and mesh_metrics.h) and refuse
// results that overflow single precision.
#include "runtime/evaluate.h"

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "runtime/blend_multi.h"
#include "runtime/mesh_metrics.h"

namespace cadinterp::runtime {

cadinterp_status locate_feasible(cadinterp_workspace* ws, const double* x, int* element) {
  const core::CompiledBasis& basis = ws->asset->reader->basis();
  const int e = basis.locate(x);
  if (e < 0) return fail(ws, CADINTERP_E_OUTSIDE_DOMAIN, "x is outside the parameter box");
  if (!basis.element_feasible(e))
    return fail(
        ws, CADINTERP_E_INFEASIBLE,
        "x lies in element " + std::to_string(e) + ", which depends on an infeasible sample");
  *element = e;
  return CADINTERP_OK;
}

using format::DecodedArray;
using format::DecodedElement;
using format::Topology;

namespace {

// <a, b> over n floats: float products summed in float per block of 256 (vectorizable at -O2:
// compile-time trip count, restrict parameters), blocks summed in double. Relative error about
// 256 * 2^-24 of the block sums' magnitudes: far below the float data's own precision.
template <std::size_t L>
float dot_block(const float* __restrict a, const float* __restrict b) {
  float s[8] = {};
  for (std::size_t k = 0; k < L; k += 8)
    for (std::size_t l = 0; l < 8; ++l) s[l] += a[k + l] * b[k + l];
  return ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]));
}

double dot(const float* a, const float* b, std::size_t n) {
  double sum = 0.0;
  std::size_t i = 0;
  for (; i + 256 <= n; i += 256) sum += dot_block<256>(a + i, b + i);
  for (; i < n; ++i) sum += double(a[i]) * b[i];
  return sum;
}

// Shared front half of eval/grad/vjp/properties: argument checks, locate, basis weights, the
// element's meshes, and its fields if need_fields. Returns OK with ws->element set (and
// ws->fields if need_fields) and w filled; throws FormatError if a decode fails.
cadinterp_status prepare(cadinterp_workspace* ws, const double* x, const int* fields,
                         int field_count, bool want_grad, bool need_fields, core::BasisWeights* w) {
  if (!x) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "x is NULL");
  if (field_count < 0 || (field_count > 0 && !fields))
    return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "fields is NULL or field_count negative");
  const cadinterp_asset& a = *ws->asset;
  for (int i = 0; i < field_count; ++i)
    if (fields[i] < 0 || fields[i] >= static_cast<int>(a.fields.size()))
      return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "field index out of range");
  int e = -1;
  const cadinterp_status located = locate_feasible(ws, x, &e);
  if (located != CADINTERP_OK) return located;
  a.reader->basis().eval_element(e, x, ws->basis_ws, want_grad, w);
  ws->fields = nullptr;
  ws->element = a.cache.get(e, *a.reader);
  if (need_fields) ws->fields = &a.cache.fields(*ws->element, *a.reader);
  return CADINTERP_OK;
}

// Whether n floats are all finite: v * 0 is 0 for finite v and NaN for inf or NaN, so the
// per-lane sums below are NaN exactly when some value is not finite. Lanes are independent
// (a compile-time block, restrict parameters), so GCC vectorizes it at -O2 with SSE2; this
// runs after every blend and must cost a fraction of the blend's memory traffic.
template <std::size_t L>
inline void zero_products(float* __restrict acc, const float* __restrict v) {
  for (std::size_t k = 0; k < L; ++k) acc[k] += v[k] * 0.0f;
}
bool finite_floats(const float* v, std::size_t n) {
  constexpr std::size_t kLanes = 32;
  float acc[kLanes] = {};
  std::size_t i = 0;
  for (; i + kLanes <= n; i += kLanes) zero_products<kLanes>(acc, v + i);
  float sum = 0.0f;
  for (; i < n; ++i) sum += v[i] * 0.0f;
  for (float a : acc) sum += a;
  return sum == 0.0f;
}

// Largest |v| over n floats, in independent lanes so that it vectorizes (see finite_floats).
template <std::size_t L>
inline void max_abs_block(float* __restrict acc, const float* __restrict v) {
  for (std::size_t k = 0; k < L; ++k) acc[k] = std::max(acc[k], std::fabs(v[k]));
}
float max_abs(const float* v, std::size_t n) {
  constexpr std::size_t kLanes = 32;
  float acc[kLanes] = {};
  std::size_t i = 0;
  for (; i + kLanes <= n; i += kLanes) max_abs_block<kLanes>(acc, v + i);
  float m = 0.0f;
  for (; i < n; ++i) m = std::max(m, std::fabs(v[i]));
  for (float a : acc) m = std::max(m, a);
  return m;
}

// Whether a blend of the element's position arrays with these weights cannot overflow: every
// output is at most sum_t |w_t| * max|p| (float rounding adds far less than the factor 4 of
// margin). Costs O(terms) per call once the element's max|p| is known (one pass, on the first
// call after a cell switch), instead of a pass over every output.
bool positions_blend_bounded(const CachedElement& el, const float* weights, int terms) {
  float m = el.positions_max_abs.load(std::memory_order_relaxed);
  if (m < 0.0f) {
    m = 0.0f;
    for (const auto& p : el.mesh.positions) m = std::max(m, max_abs(p.data(), p.size()));
    el.positions_max_abs.store(m, std::memory_order_relaxed);
  }
  double w = 0.0;
  for (int t = 0; t < terms; ++t) w += std::fabs(static_cast<double>(weights[t]));
  return w * static_cast<double>(m) <= 0.25 * static_cast<double>(FLT_MAX);
}

// Every stored value is finite (the reader checks), yet blends of values near the float range,
// or derivatives over a tiny parameter range, can still overflow: such a result is refused
// rather than handed out.
cadinterp_status overflow(cadinterp_workspace* ws) {
  return fail(ws, CADINTERP_E_CORRUPT_BLOB,
              "the result is not finite: the asset's values overflow single precision");
}

// Overflow test of mass properties: volume, mass and areas are sums that only overflow. The
// centroid and inertia divide by the volume and are NaN for a mesh of zero volume, by
// definition (mesh_metrics.h), so they are left to the caller.
bool finite_properties(const cadinterp_properties& p) {
  return std::isfinite(p.volume) && std::isfinite(p.mass) && std::isfinite(p.area) &&
         std::isfinite(p.frontal_area);
}

// Copies the K derivatives to dst when all are finite (clearing the message), else refuses the
// overflow with dst untouched.
cadinterp_status store_derivatives(cadinterp_workspace* ws, const double* out, int K, double* dst) {
  for (int k = 0; k < K; ++k)
    if (!std::isfinite(out[k])) return overflow(ws);
  std::memcpy(dst, out, sizeof(double) * static_cast<std::size_t>(K));
  ws->error.clear();
  return CADINTERP_OK;
}

// out = sum_t weight_t * arrays_t (Eq. 3): the multi-output kernel with one output.
void blend(cadinterp_workspace* ws, const double* weight, std::size_t offset, std::size_t n,
           bool positions, float* out) {
  const auto& arrays = positions ? ws->element->mesh.positions : *ws->fields;
  const std::size_t terms = arrays.size();
  ws->arrays.resize(terms);
  ws->weights.resize(terms);
  for (std::size_t t = 0; t < terms; ++t) {
    ws->arrays[t] = arrays[t].data() + offset;
    ws->weights[t] = static_cast<float>(weight[t]);
  }
  blend_arrays_multi(ws->arrays.data(), ws->weights.data(), static_cast<int>(terms), n, 1, &out);
}

// ws->positions = every vertex position of the element at weights psi (Eq. 3); false when the
// blend overflowed single precision. The O(terms) bound decides first, so the pass over every
// output runs only for blends near the float range.
bool blend_positions(cadinterp_workspace* ws, const core::BasisWeights& w) {
  const std::size_t n = ws->element->mesh.vertex_count * 3;
  ws->positions.resize(n);
  blend(ws, w.psi, 0, n, true, ws->positions.data());
  return positions_blend_bounded(*ws->element, ws->weights.data(), w.count) ||
         finite_floats(ws->positions.data(), n);
}

// One term of a subset blend over rows [r0, r1): out rows (contiguous) = (FIRST ? 0 : out) +
// w * the rows ids[r] of a, C floats each (C = 0: c at run time). Restrict pointers and a
// compile-time C let the compiler keep w in a register and unroll the row.
template <bool FIRST, std::size_t C>
void blend_rows_term(float w, const float* __restrict a, const std::uint32_t* __restrict ids,
                     std::size_t r0, std::size_t r1, std::size_t c_rt, float* __restrict out) {
  const std::size_t c = C ? C : c_rt;
  for (std::size_t r = r0; r < r1; ++r) {
    const float* __restrict src = a + static_cast<std::size_t>(ids[r]) * c;
    float* __restrict o = out + r * c;
    for (std::size_t k = 0; k < c; ++k) {
      if (FIRST)
        o[k] = w * src[k];
      else
        o[k] += w * src[k];
    }
  }
}

template <std::size_t C>
void blend_rows_c(const float* const* a, const float* w, std::size_t terms,
                  const std::uint32_t* ids, std::size_t n, std::size_t c, float* out) {
  // Rows in blocks whose outputs stay in L1 while every term is added to them (term-major
  // inside a block, as blend_arrays_multi): one weight and one array per inner loop instead
  // of reloading both for every multiply-add of a row-major loop, which measured 2.7x slower
  // than the whole-mesh blend on the boundary rows of the 90k-vertex bracket (WebAssembly).
  constexpr std::size_t kRows = 512;
  for (std::size_t r0 = 0; r0 < n; r0 += kRows) {
    const std::size_t r1 = n - r0 < kRows ? n : r0 + kRows;
    blend_rows_term<true, C>(w[0], a[0], ids, r0, r1, c, out);
    for (std::size_t t = 1; t < terms; ++t)
      blend_rows_term<false, C>(w[t], a[t], ids, r0, r1, c, out);
  }
}

// out[i * c + k] = sum_t weight_t * arrays_t[offset + ids[i] * c + k] for the n chosen rows of
// c floats (cadinterp_eval_subset): Eq. 3 on a subset, accumulated in float in the term order
// t = 0, 1, ..., m - 1 of blend_arrays_multi, so that without fused multiply-adds (the portable
// kernel, WebAssembly) each row equals cadinterp_eval's bit for bit.
void blend_rows(cadinterp_workspace* ws, const double* weight, std::size_t offset,
                const std::uint32_t* ids, std::size_t n, std::size_t c, bool positions,
                float* out) {
  const auto& arrays = positions ? ws->element->mesh.positions : *ws->fields;
  const std::size_t terms = arrays.size();
  ws->arrays.resize(terms);
  ws->weights.resize(terms);
  for (std::size_t t = 0; t < terms; ++t) {
    ws->arrays[t] = arrays[t].data() + offset;
    ws->weights[t] = static_cast<float>(weight[t]);
  }
  if (terms == 0 || c == 0) {
    std::fill(out, out + n * c, 0.0f);
    return;
  }
  const float* const* a = ws->arrays.data();
  const float* w = ws->weights.data();
  if (c == 3)
    blend_rows_c<3>(a, w, terms, ids, n, c, out);
  else if (c == 1)
    blend_rows_c<1>(a, w, terms, ids, n, c, out);
  else
    blend_rows_c<0>(a, w, terms, ids, n, c, out);
}

// CADINTERP_OK when every id of ids[0, n) is below `limit` (the element's #V or #T), else
// CADINTERP_E_INVALID_ARGUMENT naming the first that is not (a caller's bad index, like a field
// index out of range; CADINTERP_E_OUT_OF_RANGE names a blob outside the file).
cadinterp_status check_ids(cadinterp_workspace* ws, const std::uint32_t* ids, std::size_t n,
                           std::size_t limit, const char* array, const char* what, int element) {
  for (std::size_t i = 0; i < n; ++i)
    if (ids[i] >= limit)
      return fail(ws, CADINTERP_E_INVALID_ARGUMENT,
                  std::string(array) + "[" + std::to_string(i) + "] = " + std::to_string(ids[i]) +
                      " is not a " + what + " of element " + std::to_string(element) + " (it has " +
                      std::to_string(limit) + ")");
  return CADINTERP_OK;
}

// Points `out` at the workspace's evaluated mesh (positions and field rows already blended into
// ws->positions and ws->field_ptrs) and the current element's topology.
void publish_mesh(cadinterp_workspace* ws, int element, cadinterp_mesh* out) {
  const DecodedElement& d = ws->element->mesh;
  const Topology& topo = *d.topology;
  out->element = element;
  out->vertex_count = d.vertex_count;
  out->tet_count = static_cast<std::uint32_t>(topo.tets.size() / 4);
  out->triangle_count = static_cast<std::uint32_t>(topo.triangles.size() / 3);
  out->tets = topo.tets.data();
  out->triangles = topo.triangles.data();
  out->triangle_tags = topo.triangle_tags.data();
  out->positions = ws->positions.data();
  out->fields = ws->field_ptrs.data();
  ws->error.clear();
}

}  // namespace

cadinterp_status evaluate_mesh(cadinterp_workspace* ws, const double* x, const int* fields,
                               int field_count, cadinterp_mesh* out) {
  core::BasisWeights w;
  const cadinterp_status s = prepare(ws, x, fields, field_count, false, field_count > 0, &w);
  if (s != CADINTERP_OK) return s;
  const DecodedElement& d = ws->element->mesh;
  const Topology& topo = *d.topology;
  const std::size_t nv = d.vertex_count, nt = topo.tets.size() / 4;
  if (!blend_positions(ws, w)) return overflow(ws);
  ws->field_values.resize(static_cast<std::size_t>(field_count));
  ws->field_ptrs.resize(static_cast<std::size_t>(field_count));
  for (int i = 0; i < field_count; ++i) {
    const std::size_t n = field_size(*ws->asset, fields[i], nv, nt);
    auto& dst = ws->field_values[static_cast<std::size_t>(i)];
    dst.resize(n);
    blend(ws, w.psi, field_offset(*ws->asset, fields[i], nv, nt), n, false, dst.data());
    if (!finite_floats(dst.data(), n)) return overflow(ws);
    ws->field_ptrs[static_cast<std::size_t>(i)] = dst.data();
  }
  publish_mesh(ws, w.element, out);
  return CADINTERP_OK;
}

cadinterp_status evaluate_subset(cadinterp_workspace* ws, const double* x,
                                 const std::uint32_t* vertices, std::size_t vertex_subset_count,
                                 const std::uint32_t* tets, std::size_t tet_subset_count,
                                 const int* fields, int field_count, cadinterp_mesh* out) {
  core::BasisWeights w;
  const cadinterp_status s = prepare(ws, x, fields, field_count, false, field_count > 0, &w);
  if (s != CADINTERP_OK) return s;
  const DecodedElement& d = ws->element->mesh;
  const Topology& topo = *d.topology;
  const std::size_t nv = d.vertex_count, nt = topo.tets.size() / 4;
  // Ids are checked before any output is written: `out` stays untouched on failure.
  cadinterp_status ids_ok =
      check_ids(ws, vertices, vertex_subset_count, nv, "vertices", "vertex", w.element);
  if (ids_ok == CADINTERP_OK)
    ids_ok = check_ids(ws, tets, tet_subset_count, nt, "tets", "tet", w.element);
  if (ids_ok != CADINTERP_OK) return ids_ok;
  ws->positions.resize(vertex_subset_count * 3);
  blend_rows(ws, w.psi, 0, vertices, vertex_subset_count, 3, true, ws->positions.data());
  if (!positions_blend_bounded(*ws->element, ws->weights.data(), w.count) &&
      !finite_floats(ws->positions.data(), vertex_subset_count * 3))
    return overflow(ws);
  ws->field_values.resize(static_cast<std::size_t>(field_count));
  ws->field_ptrs.resize(static_cast<std::size_t>(field_count));
  for (int i = 0; i < field_count; ++i) {
    const FieldSlot& f = ws->asset->fields[static_cast<std::size_t>(fields[i])];
    const bool per_vertex = f.location == CADINTERP_PER_VERTEX;
    const std::uint32_t* ids = per_vertex ? vertices : tets;
    const std::size_t rows = per_vertex ? vertex_subset_count : tet_subset_count;
    const std::size_t c = static_cast<std::size_t>(f.components);
    auto& dst = ws->field_values[static_cast<std::size_t>(i)];
    dst.resize(rows * c);
    blend_rows(ws, w.psi, field_offset(*ws->asset, fields[i], nv, nt), ids, rows, c, false,
               dst.data());
    if (!finite_floats(dst.data(), dst.size())) return overflow(ws);
    ws->field_ptrs[static_cast<std::size_t>(i)] = dst.data();
  }
  publish_mesh(ws, w.element, out);
  return CADINTERP_OK;
}

cadinterp_status evaluate_grad(cadinterp_workspace* ws, const double* x, const int* fields,
                               int field_count, cadinterp_mesh_grad* out) {
  core::BasisWeights w;
  const cadinterp_status s = prepare(ws, x, fields, field_count, true, field_count > 0, &w);
  if (s != CADINTERP_OK) return s;
  const DecodedElement& d = ws->element->mesh;
  const std::size_t nv = d.vertex_count, nt = d.topology->tets.size() / 4;
  const int K = ws->asset->reader->basis().dim();
  // One pass per array family: outputs are the value (weights psi) and the K derivatives
  // (weights dpsi/dx_k), so every stored array is read once (blend_multi.h).
  const std::size_t nterm = static_cast<std::size_t>(w.count);
  ws->weights.resize((static_cast<std::size_t>(K) + 1) * nterm);
  for (std::size_t t = 0; t < nterm; ++t) ws->weights[t] = static_cast<float>(w.psi[t]);
  for (std::size_t i = 0; i < static_cast<std::size_t>(K) * nterm; ++i)
    ws->weights[nterm + i] = static_cast<float>(w.dpsi[i]);
  ws->positions.resize(nv * 3);
  ws->dpositions.resize(static_cast<std::size_t>(K) * nv * 3);
  float* outs[core::kMaxDim + 1];
  outs[0] = ws->positions.data();
  for (int k = 0; k < K; ++k)
    outs[k + 1] = ws->dpositions.data() + static_cast<std::size_t>(k) * nv * 3;
  ws->arrays.resize(nterm);
  for (std::size_t t = 0; t < nterm; ++t) ws->arrays[t] = d.positions[t].data();
  blend_arrays_multi(ws->arrays.data(), ws->weights.data(), w.count, nv * 3, K + 1, outs);
  bool bounded = true;
  for (int k = 0; k <= K && bounded; ++k)
    bounded = positions_blend_bounded(*ws->element, ws->weights.data() + k * w.count, w.count);
  if (!bounded && (!finite_floats(ws->positions.data(), nv * 3) ||
                   !finite_floats(ws->dpositions.data(), static_cast<std::size_t>(K) * nv * 3)))
    return overflow(ws);
  ws->field_grads.resize(static_cast<std::size_t>(field_count));
  ws->field_grad_ptrs.resize(static_cast<std::size_t>(field_count));
  for (int i = 0; i < field_count; ++i) {
    const std::size_t n = field_size(*ws->asset, fields[i], nv, nt);
    const std::size_t off = field_offset(*ws->asset, fields[i], nv, nt);
    auto& dst = ws->field_grads[static_cast<std::size_t>(i)];
    dst.resize(static_cast<std::size_t>(K) * n);
    for (int k = 0; k < K; ++k) outs[k] = dst.data() + static_cast<std::size_t>(k) * n;
    for (std::size_t t = 0; t < nterm; ++t) ws->arrays[t] = (*ws->fields)[t].data() + off;
    blend_arrays_multi(ws->arrays.data(), ws->weights.data() + nterm, w.count, n, K, outs);
    if (!finite_floats(dst.data(), static_cast<std::size_t>(K) * n)) return overflow(ws);
    ws->field_grad_ptrs[static_cast<std::size_t>(i)] = dst.data();
  }
  out->element = w.element;
  out->vertex_count = d.vertex_count;
  out->positions = ws->positions.data();
  out->dpositions = ws->dpositions.data();
  out->dfields = ws->field_grad_ptrs.data();
  ws->error.clear();
  return CADINTERP_OK;
}

cadinterp_status evaluate_vjp(cadinterp_workspace* ws, const double* x, const float* dF_dpositions,
                              const int* fields, const float* const* dF_dfields, int field_count,
                              double* dF_dx) {
  core::BasisWeights w;
  // Field arrays are read only for the adjoints given.
  const bool need_fields = field_count > 0 && dF_dfields != nullptr;
  const cadinterp_status s = prepare(ws, x, fields, field_count, true, need_fields, &w);
  if (s != CADINTERP_OK) return s;
  const DecodedElement& d = ws->element->mesh;
  const std::size_t nv = d.vertex_count, nt = d.topology->tets.size() / 4;
  const int K = ws->asset->reader->basis().dim();
  // dF/dx_k = sum_t dpsi_t/dx_k <dF/dP, p_t>: one dot product per term (Eq. 13 contracted).
  double out[core::kMaxDim] = {};
  for (int t = 0; t < w.count; ++t) {
    double dot_t = 0.0;
    if (dF_dpositions)
      dot_t += dot(dF_dpositions, d.positions[static_cast<std::size_t>(t)].data(), nv * 3);
    for (int f = 0; dF_dfields && f < field_count; ++f) {
      const float* g = dF_dfields[f];
      if (!g) continue;
      const float* v = (*ws->fields)[static_cast<std::size_t>(t)].data() +
                       field_offset(*ws->asset, fields[f], nv, nt);
      dot_t += dot(g, v, field_size(*ws->asset, fields[f], nv, nt));
    }
    for (int k = 0; k < K; ++k) out[k] += w.dpsi[k * w.count + t] * dot_t;
  }
  return store_derivatives(ws, out, K, dF_dx);
}

cadinterp_status evaluate_properties(cadinterp_workspace* ws, const double* x, double density,
                                     const double* direction, cadinterp_properties* out,
                                     cadinterp_properties* grad) {
  core::BasisWeights w;
  const cadinterp_status s = prepare(ws, x, nullptr, 0, grad != nullptr, false, &w);
  if (s != CADINTERP_OK) return s;
  const DecodedElement& d = ws->element->mesh;
  const Topology& topo = *d.topology;
  const std::size_t nv = d.vertex_count;
  if (!blend_positions(ws, w)) return overflow(ws);
  const TetMeshView mesh{ws->positions.data(),  nv,
                         topo.tets.data(),      topo.tets.size() / 4,
                         topo.triangles.data(), topo.triangles.size() / 3};
  MassPropertiesOptions opt;
  opt.density = density;
  for (int c = 0; c < 3; ++c) opt.direction[c] = direction[c];
  const MassProperties mp = mass_properties(mesh, opt);
  auto store = [](const MassProperties& m, cadinterp_properties* o) {
    o->volume = m.volume;
    o->mass = m.mass;
    o->area = m.area;
    o->frontal_area = m.frontal_area;
    std::memcpy(o->centroid, m.centroid, sizeof o->centroid);
    std::memcpy(o->inertia, m.inertia, sizeof o->inertia);
  };
  cadinterp_properties result;
  store(mp, &result);
  if (grad) {
    // For each of the 18 outputs: its gradient dO/dV (one reverse pass over the mesh), then
    // dO/dx_k = sum_t dpsi_t/dx_k <dO/dV, p_t> (Eq. 13 contracted).
    const int K = ws->asset->reader->basis().dim();
    std::vector<cadinterp_properties> g(static_cast<std::size_t>(K));
    ws->adjoint.resize(nv * 3);
    for (int o = 0; o < 16; ++o) {
      MassPropertiesBar bar;
      double* slot[16] = {&bar.volume,      &bar.mass,        &bar.area,        &bar.frontal_area,
                          &bar.centroid[0], &bar.centroid[1], &bar.centroid[2], &bar.inertia[0],
                          &bar.inertia[1],  &bar.inertia[2],  &bar.inertia[3],  &bar.inertia[4],
                          &bar.inertia[5],  &bar.inertia[6],  &bar.inertia[7],  &bar.inertia[8]};
      *slot[o] = 1.0;
      std::fill(ws->adjoint.begin(), ws->adjoint.end(), 0.0);
      mass_properties_vjp(mesh, opt, mp, bar, ws->adjoint.data());
      ws->dots.assign(static_cast<std::size_t>(w.count), 0.0);
      for (int t = 0; t < w.count; ++t) {
        const float* p = d.positions[static_cast<std::size_t>(t)].data();
        double dot = 0.0;
        for (std::size_t i = 0; i < nv * 3; ++i) dot += ws->adjoint[i] * p[i];
        ws->dots[static_cast<std::size_t>(t)] = dot;
      }
      for (int k = 0; k < K; ++k) {
        double sum = 0.0;
        for (int t = 0; t < w.count; ++t)
          sum += w.dpsi[k * w.count + t] * ws->dots[static_cast<std::size_t>(t)];
        cadinterp_properties& gk = g[static_cast<std::size_t>(k)];
        double* dst[16] = {&gk.volume,      &gk.mass,        &gk.area,        &gk.frontal_area,
                           &gk.centroid[0], &gk.centroid[1], &gk.centroid[2], &gk.inertia[0],
                           &gk.inertia[1],  &gk.inertia[2],  &gk.inertia[3],  &gk.inertia[4],
                           &gk.inertia[5],  &gk.inertia[6],  &gk.inertia[7],  &gk.inertia[8]};
        *dst[o] = sum;
      }
    }
    for (const cadinterp_properties& gk : g)
      if (!finite_properties(gk)) return overflow(ws);
    if (!finite_properties(result)) return overflow(ws);
    std::memcpy(grad, g.data(), sizeof(cadinterp_properties) * static_cast<std::size_t>(K));
  }
  if (!finite_properties(result)) return overflow(ws);
  *out = result;
  ws->error.clear();
  return CADINTERP_OK;
}

namespace {

struct Vec3 {
  double x, y, z;
};
Vec3 point(const float* p, std::uint32_t v) { return {p[3 * v], p[3 * v + 1], p[3 * v + 2]}; }
Vec3 sub(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double dot3(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
void add_scaled(double* adj, std::uint32_t v, Vec3 g, double s) {
  adj[3 * v] += s * g.x;
  adj[3 * v + 1] += s * g.y;
  adj[3 * v + 2] += s * g.z;
}

// The integrand of an integral: one component of a blended field at vertex or tet i, or 1.
struct Integrand {
  const float* values = nullptr;  // null: the integrand is 1
  std::size_t stride = 1, component = 0;
  bool per_tet = false;
  double* adjoint = nullptr;  // d(integral)/d(value i), per vertex or tet; null without grad
  double at(std::size_t i) const { return values ? values[i * stride + component] : 1.0; }
};

// sum over tets of vol * (mean of the 4 vertex values, or the tet's value): P1 integration of a
// per-vertex field, exact for the piecewise-linear field on the tet mesh. The adjoint of each
// corner position is f_avg * dvol/dp, with dvol/dp1 = (e2 x e3) / 6 and cyclically.
double volume_integral(const float* pos, const Topology& topo, const Integrand& f, double* adj_p) {
  double total = 0.0;
  const std::size_t nt = topo.tets.size() / 4;
  for (std::size_t t = 0; t < nt; ++t) {
    const std::uint32_t* v = &topo.tets[4 * t];
    const Vec3 p0 = point(pos, v[0]);
    const Vec3 e1 = sub(point(pos, v[1]), p0), e2 = sub(point(pos, v[2]), p0),
               e3 = sub(point(pos, v[3]), p0);
    const Vec3 g1 = cross(e2, e3), g2 = cross(e3, e1), g3 = cross(e1, e2);
    const double vol = dot3(e1, g1) / 6.0;
    const double favg =
        f.per_tet ? f.at(t) : 0.25 * (f.at(v[0]) + f.at(v[1]) + f.at(v[2]) + f.at(v[3]));
    total += vol * favg;
    if (!adj_p) continue;
    const double s = favg / 6.0;
    add_scaled(adj_p, v[1], g1, s);
    add_scaled(adj_p, v[2], g2, s);
    add_scaled(adj_p, v[3], g3, s);
    add_scaled(adj_p, v[0], {g1.x + g2.x + g3.x, g1.y + g2.y + g3.y, g1.z + g2.z + g3.z}, -s);
    if (!f.adjoint) continue;
    if (f.per_tet)
      f.adjoint[t] += vol;
    else
      for (int c = 0; c < 4; ++c) f.adjoint[v[c]] += 0.25 * vol;
  }
  return total;
}

// The tet owning each boundary triangle of `tris` (ids into topo.triangles), by its vertex set:
// a per-tet field's value on a boundary triangle is that of the tet it bounds.
bool owning_tets(const Topology& topo, const std::vector<std::size_t>& tris,
                 std::vector<std::size_t>& owner) {
  using Key = std::array<std::uint32_t, 3>;
  auto key = [](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    Key k{a, b, c};
    std::sort(k.begin(), k.end());
    return k;
  };
  std::map<Key, std::size_t> slot;
  for (std::size_t i = 0; i < tris.size(); ++i) {
    const std::uint32_t* v = &topo.triangles[3 * tris[i]];
    slot.emplace(key(v[0], v[1], v[2]), i);
  }
  owner.assign(tris.size(), SIZE_MAX);
  static const int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  for (std::size_t t = 0; t < topo.tets.size() / 4; ++t)
    for (const auto& fc : kFaces) {
      const std::uint32_t* v = &topo.tets[4 * t];
      const auto it = slot.find(key(v[fc[0]], v[fc[1]], v[fc[2]]));
      if (it != slot.end()) owner[it->second] = t;
    }
  return std::find(owner.begin(), owner.end(), SIZE_MAX) == owner.end();
}

// sum over the region's triangles of area * (mean of the 3 vertex values, or the owning tet's
// value). With n = e1 x e2 and area |n| / 2: darea/dp1 = (e2 x n^) / 2, darea/dp2 = (n^ x e1) / 2.
cadinterp_status region_integral(cadinterp_workspace* ws, const float* pos, const Topology& topo,
                                 const RegionSlot& region, const Integrand& f, double* adj_p,
                                 double* total) {
  std::vector<std::size_t> tris, owner;
  for (std::size_t i = 0; i < topo.triangle_tags.size(); ++i)
    if (std::find(region.tags.begin(), region.tags.end(), topo.triangle_tags[i]) !=
        region.tags.end())
      tris.push_back(i);
  if (f.per_tet && !owning_tets(topo, tris, owner))
    return fail(ws, CADINTERP_E_CORRUPT_BLOB,
                "a boundary triangle of region '" + region.name + "' bounds no tet");
  double sum = 0.0;
  for (std::size_t i = 0; i < tris.size(); ++i) {
    const std::uint32_t* v = &topo.triangles[3 * tris[i]];
    const Vec3 p0 = point(pos, v[0]);
    const Vec3 e1 = sub(point(pos, v[1]), p0), e2 = sub(point(pos, v[2]), p0);
    const Vec3 n = cross(e1, e2);
    const double len = std::sqrt(dot3(n, n)), area = 0.5 * len;
    const double favg = f.per_tet ? f.at(owner[i]) : (f.at(v[0]) + f.at(v[1]) + f.at(v[2])) / 3.0;
    sum += area * favg;
    if (!adj_p) continue;
    if (len > 0.0) {
      const Vec3 u{n.x / len, n.y / len, n.z / len};
      const Vec3 g1 = cross(e2, u), g2 = cross(u, e1);
      add_scaled(adj_p, v[1], g1, 0.5 * favg);
      add_scaled(adj_p, v[2], g2, 0.5 * favg);
      add_scaled(adj_p, v[0], {g1.x + g2.x, g1.y + g2.y, g1.z + g2.z}, -0.5 * favg);
    }
    if (!f.adjoint) continue;
    if (f.per_tet)
      f.adjoint[owner[i]] += area;
    else
      for (int c = 0; c < 3; ++c) f.adjoint[v[c]] += area / 3.0;
  }
  *total = sum;
  return CADINTERP_OK;
}

}  // namespace

cadinterp_status evaluate_integral(cadinterp_workspace* ws, const double* x, int field,
                                   int component, int region, double* value, double* grad) {
  const cadinterp_asset& a = *ws->asset;
  if (field < -1 || field >= static_cast<int>(a.fields.size()))
    return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "field index out of range");
  const int components = field < 0 ? 1 : a.fields[static_cast<std::size_t>(field)].components;
  if (component < 0 || component >= components)
    return fail(ws, CADINTERP_E_INVALID_ARGUMENT,
                "component " + std::to_string(component) + " out of range (the field has " +
                    std::to_string(components) + ")");
  if (region < -1 || region >= static_cast<int>(a.regions.size()))
    return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "region index out of range");
  const int nf = field >= 0 ? 1 : 0;
  core::BasisWeights w;
  const cadinterp_status s = prepare(ws, x, &field, nf, grad != nullptr, nf > 0, &w);
  if (s != CADINTERP_OK) return s;
  const DecodedElement& d = ws->element->mesh;
  const Topology& topo = *d.topology;
  const std::size_t nv = d.vertex_count, nt = topo.tets.size() / 4;
  if (!blend_positions(ws, w)) return overflow(ws);
  Integrand f;
  std::size_t n = 0, off = 0;
  if (nf) {
    n = field_size(a, field, nv, nt);
    off = field_offset(a, field, nv, nt);
    ws->field_values.resize(1);
    ws->field_values[0].resize(n);
    blend(ws, w.psi, off, n, false, ws->field_values[0].data());
    if (!finite_floats(ws->field_values[0].data(), n)) return overflow(ws);
    f.values = ws->field_values[0].data();
    f.stride = static_cast<std::size_t>(components);
    f.component = static_cast<std::size_t>(component);
    f.per_tet = a.fields[static_cast<std::size_t>(field)].location == CADINTERP_PER_TET;
  }
  double* adj_p = nullptr;
  if (grad) {
    ws->adjoint.assign(nv * 3, 0.0);
    adj_p = ws->adjoint.data();
    if (nf) {
      ws->field_adjoint.assign(n / static_cast<std::size_t>(components), 0.0);
      f.adjoint = ws->field_adjoint.data();
    }
  }
  double total = 0.0;
  if (region < 0) {
    total = volume_integral(ws->positions.data(), topo, f, adj_p);
  } else {
    const cadinterp_status r =
        region_integral(ws, ws->positions.data(), topo, a.regions[static_cast<std::size_t>(region)],
                        f, adj_p, &total);
    if (r != CADINTERP_OK) return r;
  }
  if (!std::isfinite(total)) return overflow(ws);
  if (grad) {
    // dI/dx_k = sum_t dpsi_t/dx_k (<dI/dP, p_t> + <dI/df, f_t>) (Eq. 13 contracted), in double.
    const int K = a.reader->basis().dim();
    double out[core::kMaxDim] = {};
    for (int t = 0; t < w.count; ++t) {
      const float* p = d.positions[static_cast<std::size_t>(t)].data();
      double dt = 0.0;
      for (std::size_t i = 0; i < nv * 3; ++i) dt += ws->adjoint[i] * p[i];
      if (nf) {
        const float* v = (*ws->fields)[static_cast<std::size_t>(t)].data() + off;
        for (std::size_t i = 0; i < ws->field_adjoint.size(); ++i)
          dt += ws->field_adjoint[i] * v[i * f.stride + f.component];
      }
      for (int k = 0; k < K; ++k) out[k] += w.dpsi[k * w.count + t] * dt;
    }
    const cadinterp_status g = store_derivatives(ws, out, K, grad);
    if (g != CADINTERP_OK) return g;
  }
  *value = total;
  ws->error.clear();
  return CADINTERP_OK;
}

}  // namespace cadinterp::runtime
