// The C ABI of include/cadinterp/cadinterp.h over the asset reader (src/format), the compiled
// basis (src/core) and the runtime kernels (blend: blend_multi.h, measured against the bandwidth
// probe of bandwidth_probe.h; mass properties: mesh_metrics.h). Every exported body runs inside
// CADINTERP_GUARD, which maps exceptions to status codes: nothing crosses the ABI.
#include "cadinterp/cadinterp.h"

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <unordered_map>
#include <vector>

#include "cadinterp_generated.h"
#include "format/asset_reader.h"
#include "runtime/bandwidth_probe.h"
#include "runtime/blend_multi.h"
#include "runtime/mesh_metrics.h"

using cadinterp::format::AssetReader;
using cadinterp::format::DecodedArray;
using cadinterp::format::DecodedElement;
using cadinterp::format::SpareArrays;
using cadinterp::format::Topology;

namespace {

// Float arrays of released elements, for the next decode to reuse. Memory a decode writes for the
// first time costs a page fault per 4 KiB (measured: about 2,700 faults and as much CPU time as
// the raw decode itself for one 100k-vertex element), and whether freed memory comes back without
// faults is up to malloc's heuristics. Bounded to one element's worth: the largest element
// released so far (positions and fields), outside the cache budget.
class BufferPool {
 public:
  // Moves the arrays of a released element in, as far as the bound allows (the rest are freed).
  void give(DecodedElement& mesh, std::vector<DecodedArray<float>>& fields) noexcept {
    std::size_t element = 0;
    auto count = [&](const DecodedArray<float>& a) { element += a.capacity() * sizeof(float); };
    count(mesh.canonical);
    for (const auto& a : mesh.positions) count(a);
    for (const auto& a : fields) count(a);
    std::lock_guard<std::mutex> lock(mu_);
    cap_ = std::max(cap_, element);
    put(mesh.canonical);
    for (auto& a : mesh.positions) put(a);
    for (auto& a : fields) put(a);
  }
  // Every pooled array, for one decode; what it leaves goes back with give_back.
  SpareArrays take_all() {
    std::lock_guard<std::mutex> lock(mu_);
    bytes_ = 0;
    return std::move(arrays_);
  }
  void give_back(SpareArrays& spare) noexcept {
    std::lock_guard<std::mutex> lock(mu_);
    for (auto& a : spare) put(a);
  }

 private:
  // Under mu_. Runs in destructors: never throws (an array the list has no room for is freed).
  void put(DecodedArray<float>& a) noexcept {
    const std::size_t b = a.capacity() * sizeof(float);
    if (b == 0 || bytes_ + b > cap_) return;
    try {
      arrays_.push_back(std::move(a));
      bytes_ += b;
    } catch (const std::bad_alloc&) {
    }
  }
  std::mutex mu_;
  SpareArrays arrays_;
  std::size_t bytes_ = 0, cap_ = 0;
};

// Returns the arrays a decode did not use to the pool, also when the decode throws.
struct SpareGuard {
  BufferPool& pool;
  SpareArrays spare = pool.take_all();
  ~SpareGuard() { pool.give_back(spare); }
};

// An element as the cache holds it. A cell switch decodes the topology (or shares a neighbour's)
// and the positions; the field arrays, as large again, are decoded by the first call that asks
// for a field, since shape-only calls (eval without fields, mass properties) never read them.
struct CachedElement {
  explicit CachedElement(std::shared_ptr<BufferPool> p) : pool(std::move(p)) {}
  CachedElement(const CachedElement&) = delete;
  CachedElement& operator=(const CachedElement&) = delete;
  // The last holder (cache or workspace) releases the element: its buffers go to the pool.
  ~CachedElement() { pool->give(mesh, fields); }

  std::shared_ptr<BufferPool> pool;
  int index = -1;
  DecodedElement mesh;
  // Filled once under fields_mu; fields_ready (release/acquire) publishes them, so calls after the
  // first read them without locking.
  mutable std::mutex fields_mu;
  mutable std::atomic<bool> fields_ready{false};
  mutable std::vector<DecodedArray<float>> fields;
  // Largest |value| over all position arrays, measured by the first call that needs it (-1:
  // not yet); racing threads store the same value.
  mutable std::atomic<float> positions_max_abs{-1.0f};
};

// Least-recently-used cache of decoded elements under a byte budget. Elements are shared_ptrs:
// a workspace holding one keeps it alive after eviction. The budget counts each element's own
// arrays (positions, and fields once decoded) and each distinct topology once, however many
// cached elements share it.
class ElementCache {
 public:
  std::shared_ptr<const CachedElement> get(int e, const AssetReader& reader) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      auto it = map_.find(e);
      if (it != map_.end()) {
        lru_.splice(lru_.begin(), lru_, it->second.lru);
        return it->second.element;
      }
    }
    // Decode outside the lock: other threads keep evaluating cached elements meanwhile. Two
    // threads missing the same element both decode it; the second insert is dropped.
    auto decoded = std::make_shared<CachedElement>(pool_);
    decoded->index = e;
    {
      SpareGuard g{*pool_};
      decoded->mesh = reader.decode_element(e, &g.spare);
    }
    std::lock_guard<std::mutex> lock(mu_);
    auto it = map_.find(e);
    if (it != map_.end()) return it->second.element;
    lru_.push_front(e);
    const std::size_t own = decoded->mesh.bytes();
    map_.emplace(e, Slot{decoded, lru_.begin(), own});
    bytes_ += own;
    if (const Topology* t = decoded->mesh.topology.get())
      if (topology_users_[t]++ == 0) bytes_ += t->bytes();
    evict();
    return decoded;
  }

  // The field arrays of `el`, decoded on the first call. A failed decode throws its FormatError
  // and keeps nothing, so every call that needs the fields reports it.
  const std::vector<DecodedArray<float>>& fields(const CachedElement& el,
                                                 const AssetReader& reader) {
    if (el.fields_ready.load(std::memory_order_acquire)) return el.fields;
    std::size_t added = 0;
    {
      std::lock_guard<std::mutex> lock(el.fields_mu);
      if (!el.fields_ready.load(std::memory_order_relaxed)) {
        SpareGuard g{*pool_};
        std::vector<DecodedArray<float>> f = reader.decode_fields(el.index, &g.spare);
        for (const auto& a : f) added += a.size() * sizeof(float);
        el.fields = std::move(f);
        el.fields_ready.store(true, std::memory_order_release);
      }
    }
    if (added) {  // charged only while the element is cached (an evicted one is not counted)
      std::lock_guard<std::mutex> lock(mu_);
      auto it = map_.find(el.index);
      if (it != map_.end() && it->second.element.get() == &el) {
        it->second.bytes += added;
        bytes_ += added;
        evict();
      }
    }
    return el.fields;
  }

  void set_budget(std::size_t bytes) {
    std::lock_guard<std::mutex> lock(mu_);
    budget_ = bytes;
    evict();
  }

 private:
  struct Slot {
    std::shared_ptr<CachedElement> element;
    std::list<int>::iterator lru;
    std::size_t bytes;  // what this entry added to bytes_, topology aside
  };
  void evict() {  // keeps at least the most recent element
    while (bytes_ > budget_ && lru_.size() > 1) {
      const int victim = lru_.back();
      lru_.pop_back();
      auto it = map_.find(victim);
      bytes_ -= it->second.bytes;
      // A cached element keeps its topology alive, so the pointer cannot be reused while it is a
      // key here.
      if (const Topology* t = it->second.element->mesh.topology.get()) {
        auto u = topology_users_.find(t);
        if (--u->second == 0) {
          bytes_ -= t->bytes();
          topology_users_.erase(u);
        }
      }
      map_.erase(it);
    }
  }
  const std::shared_ptr<BufferPool> pool_ = std::make_shared<BufferPool>();
  std::mutex mu_;
  std::size_t budget_ = std::size_t(256) << 20, bytes_ = 0;
  std::list<int> lru_;
  std::unordered_map<int, Slot> map_;
  std::unordered_map<const Topology*, std::size_t> topology_users_;  // cached elements per topology
};

struct FieldSlot {
  std::string name;
  cadinterp_field_location location;
  int components;
  double max_abs_error;
  std::string unit;  // "" when the asset gives none (format 1.0, or a field without a unit)
};

struct RegionSlot {
  std::string name, kind;
  std::vector<std::int32_t> tags;
};

thread_local std::string t_open_error;

cadinterp_status to_status(cadinterp::format::Status s) {
  return static_cast<cadinterp_status>(static_cast<int>(s));
}

}  // namespace

struct cadinterp_asset {
  std::unique_ptr<cadinterp::format::AssetReader> reader;
  std::vector<std::string> names, units;
  std::vector<FieldSlot> fields;
  std::vector<RegionSlot> regions;
  std::string builder_version, host, options;
  std::vector<std::vector<double>> infeasible_x;  // host failures recorded by the builder
  std::vector<std::string> infeasible_message;
  mutable ElementCache cache;
};

struct cadinterp_workspace {
  const cadinterp_asset* asset = nullptr;
  cadinterp::core::EvalWorkspace basis_ws;
  std::shared_ptr<const CachedElement> element;  // keeps returned topology alive
  // The element's field arrays when the last call needed them (prepare), else null.
  const std::vector<DecodedArray<float>>* fields = nullptr;
  std::vector<const float*> arrays;
  std::vector<float> weights;
  std::vector<float> positions, dpositions;
  std::vector<std::vector<float>> field_values, field_grads;
  std::vector<const float*> field_ptrs, field_grad_ptrs;
  std::vector<double> adjoint;  // #V by 3 scratch for mass-property gradients
  std::vector<double> dots;     // per term
  std::string error;
};

namespace {

cadinterp_status fail(cadinterp_workspace* ws, cadinterp_status s, const std::string& msg) {
  if (ws) ws->error = msg;
  return s;
}

// Every exported body is wrapped once: exceptions become statuses (CONVENTIONS.md).
#define CADINTERP_GUARD(ws, ...)                                                       \
  try {                                                                                \
    __VA_ARGS__                                                                        \
  } catch (const cadinterp::format::FormatError& e) {                                  \
    return fail(ws, to_status(e.status), e.what());                                    \
  } catch (const std::bad_alloc&) {                                                    \
    return fail(ws, CADINTERP_E_OUT_OF_MEMORY, "out of memory");                       \
  } catch (const std::exception& e) {                                                  \
    return fail(ws, CADINTERP_E_INTERNAL, std::string("internal error: ") + e.what()); \
  } catch (...) {                                                                      \
    return fail(ws, CADINTERP_E_INTERNAL, "internal error: unknown exception");        \
  }

cadinterp_status open_with(
    const std::function<std::unique_ptr<cadinterp::format::AssetReader>()>& make,
    cadinterp_asset** out) {
  t_open_error.clear();
  if (!out) {
    t_open_error = "out is NULL";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  try {
    auto a = std::make_unique<cadinterp_asset>();
    a->reader = make();
    const cadinterp::fb::Asset& idx = a->reader->index();
    for (const auto* p : *idx.parameters()) {
      a->names.push_back(p->name()->str());
      a->units.push_back(p->unit() ? p->unit()->str() : "");
    }
    if (idx.fields())
      for (const auto* f : *idx.fields())
        a->fields.push_back(
            {f->name()->str(),
             f->location() == cadinterp::fb::FieldLocation::Tet ? CADINTERP_PER_TET
                                                                : CADINTERP_PER_VERTEX,
             f->components(), f->max_abs_error(), f->unit() ? f->unit()->str() : std::string()});
    if (idx.regions())
      for (const auto* r : *idx.regions()) {
        RegionSlot s{r->name()->str(), r->kind() ? r->kind()->str() : "", {}};
        if (r->face_tags()) s.tags.assign(r->face_tags()->begin(), r->face_tags()->end());
        a->regions.push_back(std::move(s));
      }
    if (const auto* p = idx.provenance()) {
      a->builder_version = p->builder_version() ? p->builder_version()->str() : "";
      a->host = p->host() ? p->host()->str() : "";
      a->options = p->options() ? p->options()->str() : "";
    }
    if (const auto* inf = idx.infeasible())
      for (const auto* f : *inf) {
        a->infeasible_x.emplace_back(f->x()->begin(), f->x()->end());
        a->infeasible_message.push_back(f->message() ? f->message()->str() : "");
      }
    *out = a.release();
    return CADINTERP_OK;
  } catch (const cadinterp::format::FormatError& e) {
    t_open_error = e.what();
    return to_status(e.status);
  } catch (const std::bad_alloc&) {
    t_open_error = "out of memory";
    return CADINTERP_E_OUT_OF_MEMORY;
  } catch (const std::exception& e) {
    t_open_error = std::string("internal error: ") + e.what();
    return CADINTERP_E_INTERNAL;
  } catch (...) {
    t_open_error = "internal error: unknown exception";
    return CADINTERP_E_INTERNAL;
  }
}

// Offset of field f in an element's concatenated field array (fields in index order).
std::size_t field_offset(const cadinterp_asset& a, int f, std::size_t nv, std::size_t nt) {
  std::size_t off = 0;
  for (int j = 0; j < f; ++j)
    off += (a.fields[static_cast<std::size_t>(j)].location == CADINTERP_PER_VERTEX ? nv : nt) *
           static_cast<std::size_t>(a.fields[static_cast<std::size_t>(j)].components);
  return off;
}

std::size_t field_size(const cadinterp_asset& a, int f, std::size_t nv, std::size_t nt) {
  const FieldSlot& s = a.fields[static_cast<std::size_t>(f)];
  return (s.location == CADINTERP_PER_VERTEX ? nv : nt) * static_cast<std::size_t>(s.components);
}

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
                         int field_count, bool want_grad, bool need_fields,
                         cadinterp::core::BasisWeights* w) {
  if (!x) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "x is NULL");
  if (field_count < 0 || (field_count > 0 && !fields))
    return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "fields is NULL or field_count negative");
  const cadinterp_asset& a = *ws->asset;
  for (int i = 0; i < field_count; ++i)
    if (fields[i] < 0 || fields[i] >= static_cast<int>(a.fields.size()))
      return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "field index out of range");
  const cadinterp::core::CompiledBasis& basis = a.reader->basis();
  const int e = basis.locate(x);
  if (e < 0) return fail(ws, CADINTERP_E_OUTSIDE_DOMAIN, "x is outside the parameter box");
  if (!basis.element_feasible(e))
    return fail(
        ws, CADINTERP_E_INFEASIBLE,
        "x lies in element " + std::to_string(e) + ", which depends on an infeasible sample");
  basis.eval_element(e, x, ws->basis_ws, want_grad, w);
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
  cadinterp::runtime::blend_arrays_multi(ws->arrays.data(), ws->weights.data(),
                                         static_cast<int>(terms), n, 1, &out);
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
// CADINTERP_E_OUT_OF_RANGE naming the first that is not.
cadinterp_status check_ids(cadinterp_workspace* ws, const std::uint32_t* ids, std::size_t n,
                           std::size_t limit, const char* array, const char* what, int element) {
  for (std::size_t i = 0; i < n; ++i)
    if (ids[i] >= limit)
      return fail(ws, CADINTERP_E_OUT_OF_RANGE,
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

extern "C" {

const char* cadinterp_version(void) {
#define CADINTERP_STR2(x) #x
#define CADINTERP_STR(x) CADINTERP_STR2(x)
  return CADINTERP_STR(CADINTERP_VERSION_MAJOR) "." CADINTERP_STR(
      CADINTERP_VERSION_MINOR) "." CADINTERP_STR(CADINTERP_VERSION_PATCH);
}

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

cadinterp_status cadinterp_open(const char* path, cadinterp_asset** out) {
  if (!path) {
    t_open_error = "path is NULL";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  return open_with([&] { return cadinterp::format::AssetReader::open_file(path); }, out);
}

cadinterp_status cadinterp_open_memory(const void* data, size_t size, int copy,
                                       cadinterp_asset** out) {
  if (!data) {
    t_open_error = "data is NULL";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  return open_with(
      [&] { return cadinterp::format::AssetReader::open_memory(data, size, copy != 0); }, out);
}

const char* cadinterp_open_error(void) { return t_open_error.c_str(); }

void cadinterp_close(cadinterp_asset* asset) { delete asset; }

int cadinterp_dim(const cadinterp_asset* a) { return a ? a->reader->basis().dim() : 0; }
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

cadinterp_status cadinterp_get_provenance(const cadinterp_asset* a, cadinterp_provenance* out) {
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

cadinterp_status cadinterp_error_estimate(const cadinterp_asset* a, const double* x,
                                          double* error) {
  if (!a || !x || !error) return CADINTERP_E_INVALID_ARGUMENT;
  const int e = a->reader->basis().locate(x);
  if (e < 0) return CADINTERP_E_OUTSIDE_DOMAIN;
  *error =
      a->reader->index().elements()->Get(static_cast<flatbuffers::uoffset_t>(e))->error_estimate();
  return CADINTERP_OK;
}

cadinterp_status cadinterp_set_cache_budget(cadinterp_asset* a, size_t bytes) {
  if (!a) return CADINTERP_E_INVALID_ARGUMENT;
  CADINTERP_GUARD(nullptr, {
    a->cache.set_budget(bytes);
    return CADINTERP_OK;
  })
}

cadinterp_status cadinterp_workspace_create(const cadinterp_asset* a, cadinterp_workspace** out) {
  if (!a || !out) return CADINTERP_E_INVALID_ARGUMENT;
  CADINTERP_GUARD(nullptr, {
    auto ws = std::make_unique<cadinterp_workspace>();
    ws->asset = a;
    ws->basis_ws = a->reader->basis().make_workspace();
    *out = ws.release();
    return CADINTERP_OK;
  })
}

void cadinterp_workspace_destroy(cadinterp_workspace* ws) { delete ws; }

const char* cadinterp_workspace_error(const cadinterp_workspace* ws) {
  return ws ? ws->error.c_str() : "";
}

cadinterp_status cadinterp_eval(cadinterp_workspace* ws, const double* x, const int* fields,
                                int field_count, cadinterp_mesh* out) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!out) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "out is NULL");
  CADINTERP_GUARD(ws, {
    cadinterp::core::BasisWeights w;
    const cadinterp_status s = prepare(ws, x, fields, field_count, false, field_count > 0, &w);
    if (s != CADINTERP_OK) return s;
    const DecodedElement& d = ws->element->mesh;
    const Topology& topo = *d.topology;
    const std::size_t nv = d.vertex_count, nt = topo.tets.size() / 4;
    ws->positions.resize(nv * 3);
    blend(ws, w.psi, 0, nv * 3, true, ws->positions.data());
    if (!positions_blend_bounded(*ws->element, ws->weights.data(), w.count) &&
        !finite_floats(ws->positions.data(), nv * 3))
      return overflow(ws);
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
  })
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
  CADINTERP_GUARD(ws, {
    cadinterp::core::BasisWeights w;
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
  })
}

cadinterp_status cadinterp_grad(cadinterp_workspace* ws, const double* x, const int* fields,
                                int field_count, cadinterp_mesh_grad* out) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!out) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "out is NULL");
  CADINTERP_GUARD(ws, {
    cadinterp::core::BasisWeights w;
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
    float* outs[cadinterp::core::kMaxDim + 1];
    outs[0] = ws->positions.data();
    for (int k = 0; k < K; ++k)
      outs[k + 1] = ws->dpositions.data() + static_cast<std::size_t>(k) * nv * 3;
    ws->arrays.resize(nterm);
    for (std::size_t t = 0; t < nterm; ++t) ws->arrays[t] = d.positions[t].data();
    cadinterp::runtime::blend_arrays_multi(ws->arrays.data(), ws->weights.data(), w.count, nv * 3,
                                           K + 1, outs);
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
      cadinterp::runtime::blend_arrays_multi(ws->arrays.data(), ws->weights.data() + nterm, w.count,
                                             n, K, outs);
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
  })
}

cadinterp_status cadinterp_vjp(cadinterp_workspace* ws, const double* x, const float* dF_dpositions,
                               const int* fields, const float* const* dF_dfields, int field_count,
                               double* dF_dx) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!dF_dx) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "dF_dx is NULL");
  CADINTERP_GUARD(ws, {
    cadinterp::core::BasisWeights w;
    // Field arrays are read only for the adjoints given.
    const bool need_fields = field_count > 0 && dF_dfields != nullptr;
    const cadinterp_status s = prepare(ws, x, fields, field_count, true, need_fields, &w);
    if (s != CADINTERP_OK) return s;
    const DecodedElement& d = ws->element->mesh;
    const std::size_t nv = d.vertex_count, nt = d.topology->tets.size() / 4;
    const int K = ws->asset->reader->basis().dim();
    // dF/dx_k = sum_t dpsi_t/dx_k <dF/dP, p_t>: one dot product per term (Eq. 13 contracted).
    double out[cadinterp::core::kMaxDim] = {};
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
    for (int k = 0; k < K; ++k)
      if (!std::isfinite(out[k])) return overflow(ws);
    std::memcpy(dF_dx, out, sizeof(double) * static_cast<std::size_t>(K));
    ws->error.clear();
    return CADINTERP_OK;
  })
}

cadinterp_status cadinterp_properties_eval(cadinterp_workspace* ws, const double* x, double density,
                                           const double* direction, cadinterp_properties* out,
                                           cadinterp_properties* grad) {
  if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
  if (!out || !direction) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "out or direction is NULL");
  if (!std::isfinite(density)) return fail(ws, CADINTERP_E_INVALID_ARGUMENT, "density not finite");
  CADINTERP_GUARD(ws, {
    cadinterp::core::BasisWeights w;
    const cadinterp_status s = prepare(ws, x, nullptr, 0, grad != nullptr, false, &w);
    if (s != CADINTERP_OK) return s;
    const DecodedElement& d = ws->element->mesh;
    const Topology& topo = *d.topology;
    const std::size_t nv = d.vertex_count;
    ws->positions.resize(nv * 3);
    blend(ws, w.psi, 0, nv * 3, true, ws->positions.data());
    if (!finite_floats(ws->positions.data(), nv * 3)) return overflow(ws);
    const cadinterp::runtime::TetMeshView mesh{ws->positions.data(),  nv,
                                               topo.tets.data(),      topo.tets.size() / 4,
                                               topo.triangles.data(), topo.triangles.size() / 3};
    cadinterp::runtime::MassPropertiesOptions opt;
    opt.density = density;
    for (int c = 0; c < 3; ++c) opt.direction[c] = direction[c];
    const cadinterp::runtime::MassProperties mp = cadinterp::runtime::mass_properties(mesh, opt);
    auto store = [](const cadinterp::runtime::MassProperties& m, cadinterp_properties* o) {
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
        cadinterp::runtime::MassPropertiesBar bar;
        double* slot[16] = {&bar.volume,      &bar.mass,        &bar.area,        &bar.frontal_area,
                            &bar.centroid[0], &bar.centroid[1], &bar.centroid[2], &bar.inertia[0],
                            &bar.inertia[1],  &bar.inertia[2],  &bar.inertia[3],  &bar.inertia[4],
                            &bar.inertia[5],  &bar.inertia[6],  &bar.inertia[7],  &bar.inertia[8]};
        *slot[o] = 1.0;
        std::fill(ws->adjoint.begin(), ws->adjoint.end(), 0.0);
        cadinterp::runtime::mass_properties_vjp(mesh, opt, mp, bar, ws->adjoint.data());
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
  })
}

}  // extern "C"
